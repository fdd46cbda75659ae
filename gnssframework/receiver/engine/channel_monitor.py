r"""A vector loop's channel fault monitor: each channel's innovation tested every interval.

In a vector loop each replica runs at the navigation filter's predicted range, so a
channel filter's code error is the innovation of that channel's pseudorange,
:math:`\nu_i = \rho_i - h_i(x^-)` (m). Its variance when the channel is healthy is

.. math:: s_i = R_i + h_i P^- h_i^T,\qquad h_i = [-e_i^T,\ 0_3,\ 1,\ 0]

(``R_i`` the variance the channel filter reports, ``P^-`` the filter's predicted
covariance of its 8 states ``[r, v, b, d]``, ``e_i`` the line of sight), and
:math:`z_i = \nu_i^2 / s_i` is :math:`\chi^2_1` (the normalised innovation squared of one
measurement: Bar-Shalom, Li & Kirubarajan 2001, sec. 5.4.2). The monitor:

- flags channel ``i`` at an interval where :math:`z_i` exceeds the :math:`1 - P_{fa}` quantile;
- excludes it from the navigation update after ``consecutive`` flagged intervals in a row
  (its code and frequency variances set to `IGNORE_VAR`: the filter's gain on it is then
  nil) from the update of the interval that completes the count on: one noisy interval
  does not cost a channel, while a fault pulls at most ``consecutive - 1`` updates before
  it is cut off (the first of them, in the analytic correlator model, sees part of a step
  that starts within or at the end of its interval: docs/estimators/integrity.md);
- readmits it after ``readmit`` unflagged intervals in a row.

An excluded channel is neither re-acquired nor handed to a scalar loop: its replica keeps
being steered by the navigation solution from the other channels (vector tracking's own
coasting), so its innovation stays measured against where the signal should be and the
channel returns as soon as that agrees again (a fault that ends, a multipath that fades).

``P^-`` is the last published covariance carried over one interval by the filter's own
``transition(T)`` (its 8-state block); for a filter without one, the last covariance
itself (the interval's process noise left out: a slightly smaller ``s_i``).
"""

from __future__ import annotations

import numpy as np

from ...errors import ConfigError

__all__ = ["ChannelMonitor", "ExclusionCount", "IGNORE_VAR", "ScheduledExclusion"]

#: Variance (chips², Hz²) given the navigation filter for an excluded channel's outputs.
IGNORE_VAR = 1e8


class ExclusionCount:
    """Exclusion with hysteresis, batch-first: a channel is excluded after ``consecutive``
    flagged tests in a row and readmitted after ``readmit`` clear ones in a row (default
    ``consecutive``). ``fields`` name the two settings in the errors. Shared by
    `ChannelMonitor` (innovation tests) and the C/N0 lock test
    (`gnssframework.receiver.engine.lock_detector.CN0LockDetector`).

    Attributes
    ----------
    flagged_run, clear_run
        Flagged and clear tests in a row so far, per channel.
    excluded
        The current verdict.
    """

    def __init__(
        self, consecutive: int, readmit: int | None, fields: tuple[str, str] = ("consecutive", "readmit")
    ) -> None:
        if consecutive < 1:
            raise ConfigError(fields[0], f"must be at least 1, got {consecutive}")
        readmit = consecutive if readmit is None else readmit
        if readmit < 1:
            raise ConfigError(fields[1], f"must be at least 1, got {readmit}")
        self.consecutive, self.readmit = int(consecutive), int(readmit)
        self.reset((0, 0))

    def reset(self, batch: tuple[int, ...]) -> None:
        """Every channel of ``batch`` admitted, no history."""
        self.flagged_run = np.zeros(batch, int)
        self.clear_run = np.zeros(batch, int)
        self.excluded = np.zeros(batch, bool)

    def update(self, flagged: np.ndarray) -> np.ndarray:
        """One test per channel: the counts, then the verdict (returned)."""
        self.flagged_run = np.where(flagged, self.flagged_run + 1, 0)
        self.clear_run = np.where(flagged, 0, self.clear_run + 1)
        self.excluded = np.where(self.excluded, self.clear_run < self.readmit, self.flagged_run >= self.consecutive)
        return self.excluded


class ChannelMonitor:
    """The per-channel innovation test and exclusion of a vector loop (see the module text).

    Parameters
    ----------
    false_alarm
        Probability that a healthy channel's interval is flagged.
    consecutive
        Flagged intervals in a row that exclude a channel.
    readmit
        Unflagged intervals in a row that readmit it (default ``consecutive``).
    """

    def __init__(self, false_alarm: float = 1e-3, consecutive: int = 3, readmit: int | None = None) -> None:
        if not 0.0 < false_alarm < 1.0:
            raise ConfigError("channel_monitor.false_alarm", f"must be a probability in (0, 1), got {false_alarm}")
        self.count = ExclusionCount(consecutive, readmit, ("channel_monitor.consecutive", "channel_monitor.readmit"))
        from scipy.special import chdtri

        self.false_alarm, self.consecutive, self.readmit = false_alarm, self.count.consecutive, self.count.readmit
        self.threshold = float(chdtri(1, false_alarm))  # chi2.isf(false_alarm, 1)
        self.reset((0, 0))

    def reset(self, batch: tuple[int, int]) -> None:
        """Every channel of ``batch`` ``(runs, channels)`` admitted, no history."""
        self.count.reset(batch)
        self.excluded = self.count.excluded
        self.returned = np.zeros(batch, bool)  # never: no channel filter is restarted
        self.statistic = np.zeros(batch)

    def observe(self, correlators) -> None:
        """Each interval's correlators, before `screen` (not read: the test is on the innovations)."""

    def screen(
        self, innovation_m: np.ndarray, variance_m2: np.ndarray, unit_los: np.ndarray, predicted_cov: np.ndarray
    ) -> np.ndarray:
        """One interval: update the counts and return the channels excluded ``(runs, channels)``.

        Parameters
        ----------
        innovation_m, variance_m2
            ``(runs, channels)`` range innovations and their measurement variances.
        unit_los
            ``(runs, channels, 3)`` or ``(channels, 3)`` lines of sight (receiver to satellite).
        predicted_cov
            ``(runs, 8, 8)`` or ``(8, 8)`` predicted covariance of ``[r, v, b, d]``.
        """
        e = np.asarray(unit_los, float)
        P = np.asarray(predicted_cov, float)[..., :8, :8]
        if P.ndim == 2:
            P = P[None]
        if e.ndim == 2:
            e = e[None]
        # h P h^T with h = [-e, 0, 0, 0, 1, 0]: the position block, the bias and their cross terms.
        Ppp, Ppb, Pbb = P[:, None, 0:3, 0:3], P[:, None, 0:3, 6], P[:, None, 6, 6]
        hph = np.einsum("...i,...ij,...j->...", e, Ppp, e) - 2 * np.einsum("...i,...i->...", e, Ppb) + Pbb
        s = np.asarray(variance_m2, float) + hph
        z = np.asarray(innovation_m, float) ** 2 / s
        self.statistic = z
        self.excluded = self.count.update(~(z <= self.threshold))  # NaN flags
        return self.excluded


class ScheduledExclusion:
    """The channels a vector loop leaves out at each interval, known beforehand: an ideal lock
    detector for a scenario whose truth blocks channels (a satellite outage), with the
    `ChannelMonitor` interface `VectorCloser` calls (``reset``, then ``observe`` and ``screen``
    once per interval, in order). A lock test on the correlators themselves is
    `gnssframework.receiver.engine.lock_detector.CN0LockDetector`.

    Parameters
    ----------
    usable_at
        ``k -> (runs, channels)`` bool: the channels the update of interval ``k`` (from 0)
        may use.
    """

    def __init__(self, usable_at) -> None:
        self.usable_at = usable_at
        self.reset((0, 0))

    def reset(self, batch: tuple[int, int]) -> None:
        """Every channel of ``batch`` admitted; the next interval is the first."""
        self.excluded = np.zeros(batch, bool)
        self.returned = np.zeros(batch, bool)  # never: no channel filter is restarted
        self.statistic = np.zeros(batch)
        self.interval = 0

    def observe(self, correlators) -> None:
        """Each interval's correlators, before `screen` (not read: the schedule is known beforehand)."""

    def screen(
        self, innovation_m: np.ndarray, variance_m2: np.ndarray, unit_los: np.ndarray, predicted_cov: np.ndarray
    ) -> np.ndarray:
        """This interval's exclusions ``(runs, channels)`` (the innovations are not read)."""
        usable = np.asarray(self.usable_at(self.interval), bool)
        self.excluded = np.broadcast_to(~usable, np.shape(innovation_m)).copy()
        self.interval += 1
        return self.excluded
