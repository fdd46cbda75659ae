r"""A C/N0 lock detector on the prompt correlators: each window's estimate against a threshold.

A receiver does not know when a satellite's signal goes (a building, a wing, a jammer): it
learns it from its own correlators. The textbook test (Kaplan & Hegarty, 3rd ed., sec.
8.10; GNSS-SDR's ``cn0_min`` and ``max_lock_fail``) estimates C/N0 on a window of
prompts and declares the channel out of lock when the estimate stays below a threshold:

- every ``window`` coherent intervals the estimator (a ``cn0_estimator`` plugin that reads
  the prompt only) gives :math:`\widehat{C/N_0}` per channel;
- a channel is **excluded** after ``consecutive`` windows in a row below
  ``threshold_dbhz`` (a reading of no signal, NaN, counts as below) and **readmitted** after
  ``readmit`` windows in a row at or above it.

A threshold at or below the estimator's noise floor on the window lets pure noise pass
the test (docs/receiver/cn0-estimators.md, "the rule"): `check_above_floor` refuses it.

The detector never looks ahead: its verdict at time t is that of the last window complete
at t. A signal lost in the middle of a window is seen at the end of the next full window
of noise at the earliest; with ``consecutive`` > 1 the measurements of the windows before
the verdict still reach the navigation filter, which is the price a real detector pays and
an ideal one (a schedule known beforehand) does not.

When a lost signal comes back (a replica held by vector or deep aiding), the channel
filter's state has been spent on noise (an amplitude estimate fallen to the noise's, a
code and frequency error wandered off): readmitted as it is, it hands the navigation
filter confident, wrong measurements. The detector marks those channels at their first
window back (`CN0LockDetector.returned`) so the harness restarts their filters
(`gnssframework.interfaces.ChannelFilter.restart`): a reacquisition with the replica
already in place.

Interfaces: `observe` takes each interval's correlators (or prompts); `usable` ``(t_s,
reach_s)`` answers as a satellite outage's ideal detector does (``reach_s`` is ignored: the
detector cannot see the future); `reset`/`screen` are the `ChannelMonitor` interface a
`VectorCloser` calls.
"""

from __future__ import annotations

import numpy as np

from ...errors import ConfigError
from ...signal.cn0_estimator import CN0Estimator, noise_floor_dbhz
from .channel_monitor import ExclusionCount

__all__ = ["CN0LockDetector", "check_above_floor"]


def check_above_floor(
    estimator: CN0Estimator, coherent_time_s: float, window: int, threshold_dbhz: float, field: str
) -> float:
    """The estimator's noise floor (dB-Hz) on ``window`` intervals of ``coherent_time_s``
    (`noise_floor_dbhz`, its 95th percentile on pure noise); `ConfigError` naming ``field``
    when ``threshold_dbhz`` is not above it (noise would then pass the lock test in more
    than 5 % of windows)."""
    floor = noise_floor_dbhz(estimator, coherent_time_s, window)
    if not threshold_dbhz > floor:
        raise ConfigError(
            field,
            f"{threshold_dbhz} dB-Hz is not above the noise floor of {estimator.name} on {window} intervals of "
            f"{coherent_time_s} s ({floor:.1f} dB-Hz, 95th percentile on pure noise): noise would pass the lock "
            "test; raise it or lengthen the window",
        )
    return floor


class CN0LockDetector:
    """The C/N0 lock test of the module text, batch-first over ``(runs, channels)``.

    Parameters
    ----------
    estimator
        A ``cn0_estimator`` that reads the prompt only (``needs == ("prompt",)``).
    coherent_time_s
        T of the prompts.
    window
        Intervals per estimate (at least the estimator's `CN0Estimator.required_intervals`).
    threshold_dbhz
        A channel is below when its estimate is under this.
    consecutive
        Windows in a row below that exclude a channel.
    readmit
        Windows in a row at or above that readmit it (default ``consecutive``).
    restart
        Mark a returning channel for a filter restart (`returned`); False: never (the
        filter is readmitted with the state it kept through the loss, a control).
    fields
        The names its errors give the estimator, the window, ``consecutive`` and ``readmit``
        (a scenario's own field names).

    Attributes
    ----------
    excluded
        ``(runs, channels)`` the current verdict.
    returned
        ``(runs, channels)`` excluded channels whose window just read at or above the
        threshold again, after the last `observe` (else all False): the harness restarts
        their channel filters (`ChannelFilter.restart`), which then have ``readmit - 1``
        windows to converge before the navigation filter uses them.
    verdicts, readings_dbhz
        One ``(runs, channels)`` array per completed window: the verdict after it and its
        estimate.
    """

    def __init__(
        self,
        estimator: CN0Estimator,
        coherent_time_s: float,
        window: int,
        threshold_dbhz: float,
        consecutive: int = 1,
        readmit: int | None = None,
        restart: bool = True,
        fields: tuple[str, str, str, str] = ("lock_cn0_estimator", "lock_window", "lock_consecutive", "lock_readmit"),
    ) -> None:
        if tuple(estimator.needs) != ("prompt",):
            raise ConfigError(
                fields[0], f"{estimator.name} needs {estimator.needs}; the lock test reads the prompt only"
            )
        if window < estimator.required_intervals():
            raise ConfigError(
                fields[1],
                f"{estimator.name} needs at least {estimator.required_intervals()} intervals of {coherent_time_s} s, "
                f"got {window}",
            )
        self.count = ExclusionCount(consecutive, readmit, fields[2:])
        self.estimator, self.T, self.window = estimator, float(coherent_time_s), int(window)
        self.threshold_dbhz, self.restart = float(threshold_dbhz), bool(restart)
        self.reset((0, 0))

    def reset(self, batch: tuple[int, ...]) -> None:
        """Every channel of ``batch`` admitted, no window begun."""
        self.batch = tuple(batch)
        self._buffer = np.zeros(self.batch + (self.window,), complex)
        self._filled = 0
        self.count.reset(self.batch)
        self.excluded = self.count.excluded
        self._none_returned = np.zeros(self.batch, bool)
        self._none_returned.flags.writeable = False  # handed out every interval: read only
        self.returned = self._none_returned
        self.verdicts: list[np.ndarray] = []
        self.readings_dbhz: list[np.ndarray] = []

    def observe(self, correlators) -> None:
        """One interval's prompts (a `Correlators` or the complex prompts ``(runs, channels)``);
        at a window's end, the window's estimate and the new verdict."""
        prompt = np.asarray(getattr(correlators, "prompt", correlators))
        if self._buffer.shape[:-1] != prompt.shape:
            if self._filled or self.verdicts:
                raise ConfigError("prompt", f"shape {prompt.shape} differs from the detector's batch {self.batch}")
            self.reset(prompt.shape)  # the first interval sets the batch
        self._buffer[..., self._filled] = prompt
        self._filled += 1
        self.returned = self._none_returned
        if self._filled < self.window:
            return
        self._filled = 0
        reading = self.estimator.estimate_dbhz(self._buffer, self.T)
        was_excluded = self.excluded
        self.excluded = self.count.update(~(reading >= self.threshold_dbhz))  # NaN counts as below
        if self.restart:  # the first window back: restart its filter
            self.returned = was_excluded & (self.count.clear_run == 1)
        self.verdicts.append(self.excluded.copy())
        self.readings_dbhz.append(reading)

    def excluded_at(self, t_s: float) -> np.ndarray:
        """The verdict after the last window complete at ``t_s`` (none: every channel admitted)."""
        n = int(np.floor(t_s / (self.window * self.T) + 1e-9))
        n = min(n, len(self.verdicts))
        return self.verdicts[n - 1] if n > 0 else np.zeros(self.batch, bool)

    def usable(self, t_s: float, reach_s: float = 0.0) -> np.ndarray:
        """Channels an update at ``t_s`` may use, ``(runs, channels)`` (``reach_s`` ignored)."""
        return ~self.excluded_at(t_s)

    def screen(
        self, innovation_m: np.ndarray, variance_m2: np.ndarray, unit_los: np.ndarray, predicted_cov: np.ndarray
    ) -> np.ndarray:
        """The `ChannelMonitor` interface: this interval's exclusions (the innovations are not read)."""
        return np.broadcast_to(self.excluded, np.shape(innovation_m)).copy()
