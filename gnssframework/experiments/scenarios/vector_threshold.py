r"""Scenario ``vector-threshold``: where a vector tracking loop lets go, one C/N0 per case.

The ``vector-tracking`` scenario (`gnssframework.experiments.scenarios.vector_tracking`:
N channels of the nominal constellation, one navigation filter steering every channel's
NCOs by range and rate) scored by a lock test, so that a ``[[sweeps]]`` over
``cases.cn0_dbhz`` with a ``threshold`` table gives its threshold C/N0 as the
``tracking-threshold`` scenario gives a scalar loop's.

A vector loop of this kind is a delay and *frequency* lock loop: the carrier NCO follows
the navigation filter's range rate, its phase is not locked. It is therefore judged by
the code-and-frequency lock test of `tracking_threshold.code_freq_lock_loss`, the one the
``tracking-threshold`` scenario reports beside its phase-lock test as
``loss_of_code_freq_lock``: after ``settle_s``, a channel is out of lock at the end of the
first ``lock_window_s`` block whose mean :math:`|\delta f|` exceeds ``freq_lock_hz``
(default :math:`1/(4T)`) or whose mean :math:`|\delta\tau|` exceeds half the early-late
spacing, the errors being the replica's true ones (truth minus replica). Absorbing: the
channel is not re-acquired.

Metrics (besides every metric of ``vector-tracking``)
    ``loss_of_code_freq_lock``: the fraction of a run's channels that lost lock (its mean
    over runs is the probability that a channel loses lock within the case: one channel
    of a scalar loop's run compares with it). ``loss_of_code_freq_lock_any``: 1 if any
    channel did (the fix then rests on fewer satellites). ``time_to_code_freq_loss_s``:
    time after ``settle_s`` to the first channel's loss, or the observed span (censored).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field

from ..metric_components import SeriesMetric, evaluate, units
from ..metrics import MetricValue
from . import BatchResult, register_scenario
from .tracking_threshold import code_freq_lock_scores
from .vector_tracking import METRICS as VECTOR_METRICS
from .vector_tracking import VectorTrackingCase, VectorTrackingParams, VectorTrackingScenario

__all__ = ["VectorThresholdScenario", "METRICS", "channel_lock_series"]


class VectorThresholdParams(VectorTrackingParams):
    lock_window_s: float = Field(0.1, gt=0, description="block length of the lock test (s)")
    freq_lock_hz: float | None = Field(
        None,
        gt=0,
        description="a block whose mean |frequency error| exceeds it "
        "is out of lock (Hz); null: 1/(4T), a two-quadrant arctangent FLL's "
        "pull-in range",
    )


class VectorThresholdCase(VectorTrackingCase):
    cn0_dbhz: float = Field(
        ...,
        ge=5,
        le=60,
        description="C/N0 of every channel (dB-Hz; down to 5, below the "
        "vector-tracking scenario's 15, for the threshold's grid)",
    )


def channel_lock_series(freq_err: np.ndarray, code_err: np.ndarray, T: float, p: Any) -> np.ndarray:
    """The fraction of each run's channels out of code or frequency lock by every interval,
    ``(K, runs)``, from the replicas' true errors ``(K, runs, channels)`` (a channel counts
    from the last interval of its first out-of-lock block on; `code_freq_lock_scores`)."""
    K = freq_err.shape[0]
    first = int(np.ceil(p.settle_s / T - 1e-9))
    scores = code_freq_lock_scores(freq_err, code_err, T, p)
    lost = scores["loss_of_code_freq_lock"] > 0  # (runs, channels)
    at = first + np.rint(scores["time_to_code_freq_loss_s"] / T).astype(int) - 1  # interval of the loss
    out = (np.arange(K)[:, None, None] >= at[None]) & lost[None]
    return out.mean(axis=-1)


class _LockFraction(SeriesMetric):
    """A per-run value of the ``channels_out_of_lock`` series: its last value (the fraction
    of channels lost), whether it is above 0 at the end, or the time to its first rise."""

    def __init__(self, name: str, unit: str, output: str, *, description: str = "") -> None:
        super().__init__(name, unit, of="channels_out_of_lock", description=description)
        self.output = output

    def compute(self, series: dict[str, np.ndarray], time_s: np.ndarray | None, scenario: Any) -> MetricValue:
        x = series["channels_out_of_lock"]
        if self.output == "fraction":
            return MetricValue(x[-1])
        if self.output == "any":
            return MetricValue((x[-1] > 0).astype(float))
        if time_s is None:
            raise ValueError(f"metric {self.name!r} needs the series' times")
        T = float(time_s[1] - time_s[0]) if len(time_s) > 1 else 2 * float(time_s[0])
        first = int(np.ceil(scenario.params.settle_s / T - 1e-9))
        lost = x[-1] > 0
        k = np.argmax(x > 0, axis=0)
        return MetricValue(np.where(lost, k + 1 - first, x.shape[0] - first) * T)


LOCK_METRICS = (
    _LockFraction(
        "loss_of_code_freq_lock",
        "",
        "fraction",
        description="fraction of the run's channels that lost "
        "code or frequency lock after settle_s (a lock_window_s block with mean |frequency error| above "
        "freq_lock_hz, default 1/(4T), or mean |code error| above d/2); its mean is the probability that "
        "a channel loses lock within the case",
    ),
    _LockFraction(
        "loss_of_code_freq_lock_any",
        "",
        "any",
        description="1 if any channel of the run lost code or frequency lock, else 0",
    ),
    _LockFraction(
        "time_to_code_freq_loss_s",
        "s",
        "time",
        description="time after settle_s to the first channel's "
        "loss of code or frequency lock, or the observed span (censored)",
    ),
)
METRICS = VECTOR_METRICS + LOCK_METRICS


@register_scenario
class VectorThresholdScenario(VectorTrackingScenario):
    """Vector tracking scored by a code-and-frequency lock test per channel (see the module)."""

    kind = "vector-threshold"
    Params = VectorThresholdParams
    params: VectorThresholdParams  # self.params, as validated
    CaseParams = VectorThresholdCase
    metrics = units(METRICS)

    def run_batch(self, case, plugins, runs, rng) -> BatchResult:
        series, rec = self.vector_series(case, plugins, runs, rng)
        series["channels_out_of_lock"] = channel_lock_series(
            rec.freq_error_hz, rec.code_error_chips, self.params.coherent_time_s, self.params
        )
        return evaluate(METRICS, series, rec.time_s, self)


# The vector-tracking scenario's raw series (inherited), and the lock series.
VectorThresholdScenario.outputs = {**VectorThresholdScenario.outputs, "channels_out_of_lock": "-"}
