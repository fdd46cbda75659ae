"""The deep-integration scenario's lock detector: the ideal one of a satellite outage, or a C/N0 test.

By default (``lock_detector = "ideal"``) a candidate drops a blocked channel from the first
update whose measurements reach into the outage and never takes it back: the receiver is
told the outage's schedule (`deep_integration_runs.ChannelOutage`). With the name of a
``cn0_estimator`` plugin instead, every candidate decides from its own prompt correlators
(`gnssframework.receiver.engine.lock_detector.CN0LockDetector`): an estimate per
``lock_window_s``, a channel excluded after ``lock_consecutive`` windows below
``lock_cn0_threshold_dbhz`` and readmitted after ``lock_readmit`` windows at or above it,
whether or not the case has an outage (the control case then measures the false
exclusions). Its threshold must sit above the estimator's noise floor on its window. A
channel whose signal comes back has its channel filter restarted from its correlators at
its first window back (``lock_restart``; `ChannelFilter.restart`), so the filter has
``lock_readmit - 1`` windows to converge before the navigation filter reads it again.

With a detector the scenario adds three metrics (`LOCK_METRICS`), over the updates from
``settle_s``, each channel of an update scored against the truth of the update interval
that ends there (the signal present in all of it, or absent in all of it):

- ``false_exclusion_fraction``: channels left out while their signal was there (false
  alarms, and the delay to readmit a channel when its signal returns);
- ``missed_exclusion_fraction``: channels used while their signal was gone;
- ``channels_used``: the number of channels the update used.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import BaseModel, Field

from ... import registry
from ...errors import ConfigError
from ...receiver.engine.lock_detector import CN0LockDetector, check_above_floor
from ...suggest import did_you_mean
from ..metric_components import Mean

__all__ = [
    "LockDetectorParams",
    "LOCK_METRICS",
    "lock_estimator",
    "check_lock",
    "make_lock",
    "lock_series",
    "whole_multiple",
]

#: The metrics the scenario adds when its lock detector is a C/N0 test.
LOCK_METRICS = (
    Mean(
        "false_exclusion_fraction",
        "-",
        of="false_exclusion",
        settle="settle_s",
        description="fraction of channel-updates left out of the update while the signal was there",
    ),
    Mean(
        "missed_exclusion_fraction",
        "-",
        of="missed_exclusion",
        settle="settle_s",
        description="fraction of channel-updates used while the signal was gone",
    ),
    Mean(
        "channels_used",
        "-",
        of="channels_in_update",
        settle="settle_s",
        description="channels the navigation update used, mean over updates",
    ),
)


class LockDetectorParams(BaseModel):
    """Scenario fields of the lock detector (module text)."""

    lock_detector: str = Field(
        "ideal",
        description="ideal: the receiver knows an outage's schedule (drops a blocked channel from the first update "
        "reaching into it, never takes it back). Otherwise the name of a cn0_estimator plugin that reads the prompt "
        "only (e.g. narrow-wide, m2m4): every candidate tests each channel's C/N0 on its own prompts",
    )
    lock_cn0_threshold_dbhz: float = Field(
        25.0, description="C/N0 test: a window whose estimate is below this counts against the channel"
    )
    lock_window_s: float | None = Field(
        None,
        gt=0,
        description="C/N0 test: window of each estimate (s), whole coherent intervals; null: update_interval_s",
    )
    lock_consecutive: int = Field(1, ge=1, description="C/N0 test: windows in a row below the threshold that exclude")
    lock_readmit: int = Field(3, ge=1, description="C/N0 test: windows in a row at or above it that readmit")
    lock_restart: bool = Field(
        True,
        description="C/N0 test: restart a returning channel's filter from its correlators at its first window back "
        "(ChannelFilter.restart; filters that cannot keep their state). false: readmit it with the state it kept "
        "through the loss (a control)",
    )


def lock_estimator(params: LockDetectorParams):
    """The ``cn0_estimator`` plugin the detector uses (default parameters); `ConfigError`
    naming ``scenario.lock_detector`` for an unknown name (one that needs a noise correlator
    is refused by `CN0LockDetector`)."""
    name = params.lock_detector
    names = registry.names("cn0_estimator")
    if name not in names:
        raise ConfigError(
            "scenario.lock_detector",
            f"got {name!r}; allowed: ideal, {', '.join(names)}{did_you_mean(name, ['ideal', *names])}",
        )
    return registry.create("cn0_estimator", name)


def whole_multiple(field: str, big_s: float, small_s: float, small: str) -> int:
    """``big_s`` / ``small_s`` when it is a whole number of at least 1; else a `ConfigError`
    naming ``scenario.<field>`` and ``small`` (how the message names the smaller interval)."""
    n = big_s / small_s
    if abs(n - round(n)) > 1e-6 or round(n) < 1:
        raise ConfigError(f"scenario.{field}", f"must be a whole multiple of {small} (got {big_s})")
    return int(round(n))


def _window(params: Any) -> int:
    window_s = params.update_interval_s if params.lock_window_s is None else params.lock_window_s
    return whole_multiple(
        "lock_window_s", window_s, params.coherent_time_s, f"coherent_time_s = {params.coherent_time_s} s"
    )


def check_lock(params: Any) -> None:
    """The detector's fields: a known estimator, a window of whole intervals that it accepts,
    a threshold above its noise floor on that window (`check_above_floor`)."""
    if params.lock_detector == "ideal":
        for f in ("lock_cn0_threshold_dbhz", "lock_window_s", "lock_consecutive", "lock_readmit", "lock_restart"):
            if f in params.model_fields_set:
                raise ConfigError(f"scenario.{f}", "has no effect with lock_detector = 'ideal': name a cn0_estimator")
        return
    detector = make_lock(params, None)  # its own checks, under the scenario's field names
    check_above_floor(
        detector.estimator, detector.T, detector.window, detector.threshold_dbhz, "scenario.lock_cn0_threshold_dbhz"
    )


def make_lock(params: Any, outage: Any):
    """The receiver's lock verdicts for one batch: ``outage`` itself with the ideal detector
    (None without an outage), else a fresh `CN0LockDetector`."""
    if params.lock_detector == "ideal":
        return outage
    return CN0LockDetector(
        lock_estimator(params),
        params.coherent_time_s,
        _window(params),
        params.lock_cn0_threshold_dbhz,
        params.lock_consecutive,
        params.lock_readmit,
        params.lock_restart,
        ("scenario.lock_detector", "scenario.lock_window_s", "scenario.lock_consecutive", "scenario.lock_readmit"),
    )


def lock_series(
    lock: CN0LockDetector, t_u: np.ndarray, signal_gain: np.ndarray | None, n_upd: int, batch: tuple[int, int]
) -> dict[str, np.ndarray]:
    """The per-update series of `LOCK_METRICS` ``(U, runs)``: the detector's verdict at each
    update time against the truth's signal over the update interval ending there
    (``signal_gain`` ``(K, runs, ch)``, None: always there)."""
    excluded = np.stack([lock.excluded_at(t) for t in t_u]) if len(t_u) else np.zeros((0,) + batch, bool)
    U = len(t_u)
    if signal_gain is None:
        present = np.ones((U,) + batch, bool)
        absent = np.zeros((U,) + batch, bool)
    else:
        gain = np.asarray(signal_gain)[: U * n_upd].reshape((U, n_upd) + batch)
        present, absent = np.all(gain > 0, axis=1), np.all(gain == 0, axis=1)
    return {
        "false_exclusion": np.mean(excluded & present, axis=-1),
        "missed_exclusion": np.mean(~excluded & absent, axis=-1),
        "channels_in_update": np.sum(~excluded, axis=-1).astype(float),
    }
