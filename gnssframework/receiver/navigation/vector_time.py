r"""The start time of an assisted vector start, checked and corrected in the loop.

An assisted start (`vector_handover.try_assisted_handover`) resolves each code phase's whole
periods from the approximate position and the start time it is given. A start time off by
:math:`\delta` puts the same whole number of periods, :math:`m \approx \delta / T`, into
every channel's transmit time: the pseudoranges keep only a common error (the receiver
clock's), but every satellite is placed :math:`mT` away along its orbit, and the fix goes
kilometres off while passing every test (issue 40: 375 m at 0.5 s, 1.8 km at 1.6 s). The
coarse-time fix of the pull-in pseudoranges (`coarse_time`) sees errors above four of its
sigmas only (`vector_handover.pull_in_code_sigma_m`: 0.5-0.75 s with five satellites at
32 dB-Hz), its code phases being tens of metres apart from the truth.

Once the navigation filter tracks the code, the error shows in every epoch's code errors:
the measured pseudorange :math:`z_i` (the replica's range plus its code error) less the
range the state predicts at the labelled transmit time is
:math:`r_i = \dot\rho_i\, mT - u_i^T \Delta r + \Delta b + \varepsilon_i`, with
:math:`\dot\rho_i = u_i\cdot v_i - c\,\Delta\dot t_{SV,i}` the satellite's range rate
(van Diggelen 2009, ch. 4: coarse-time navigation, here in the loop). Whatever the filter
has absorbed of it lies in the span of the geometry :math:`[-u_i, 1]`; per epoch both
:math:`r` and :math:`\dot\rho` are projected off that span (weights :math:`1/\sigma_i^2`
from the channels' code-error variances) and the projections are pooled over a window
(Frisch-Waugh-Lovell, as `coarse_time` does for one epoch):

.. math::

    \hat\delta = \frac{\sum_e \dot\rho_{\perp,e}^T W_e r_{\perp,e}}
                      {\sum_e \dot\rho_{\perp,e}^T W_e \dot\rho_{\perp,e}}.

The loop's code errors are correlated from epoch to epoch (the filter steers the replicas
on them), so the epochs are not independent and the least-squares variance would be too
small (by about half, measured). :math:`\sigma_{\hat\delta}` comes from batch means
instead: the window is cut into `BATCHES` equal batches, each gives its own
:math:`\hat\delta_b` with its information :math:`D_b = \sum_{e \in b}
\dot\rho_{\perp,e}^T W_e \dot\rho_{\perp,e}`, and
:math:`\sigma_{\hat\delta}^2 = \sum_b D_b (\hat\delta_b - \hat\delta)^2 / ((B - 1)
\sum_b D_b)`, which holds for any correlation shorter than a batch and scales out a
channel filter's mis-stated variances. Five channels an epoch are needed (one degree of
freedom each). When :math:`|\hat\delta| / \sigma_{\hat\delta}` exceeds Student's t for
:math:`B' - 1` degrees of freedom (:math:`B'` the batches with at least `MIN_BATCH_SHARE` of
the largest batch's information: a window whose information sits in one batch has a
variance near zero and no degree of freedom) at ``time_false_alarm`` (`VectorConfig`; 6.6 at 1e-4),
every transmit-time label moves by :math:`\hat\delta` in whole code periods (the true
error is whole periods; the code phases give the rest) and the receiver time with it, so
that the pseudoranges are unchanged and only the satellites move to where they were. The
first window whose estimate is within that, with most of its batches informed (`FULL_DOF`),
ends the check (the start time is right to about its sigma, milliseconds), so that no later
window can move a right time.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import special  # not scipy.stats: its import costs a second of every run's start-up

from ...navigation.coarse_time import off_geometry

__all__ = ["TimeOffsetEstimator", "TimeOffset", "BATCHES", "FULL_DOF", "MIN_BATCH_SHARE", "RELAXATION"]

#: Batches of a window for the batch-means variance (module text).
BATCHES = 10
#: Each correction is this many times the estimate. The code errors read the offset through
#: the discriminator, whose gain behind a band-limited front end is below one (measured on
#: the 2.6 MHz test file: 0.45 of 150 m of offset, 0.7 of 40 m), so the plain estimate
#: undershoots and the corrections converge slowly; 1.5 times it converges for any gain
#: below 1.33 (the error after a step is 1 - 1.5 g of the one before), faster for these.
RELAXATION = 1.5
#: The degrees of freedom of a window that ends the check when its estimate is within the
#: threshold: most of its batches with information (a window of a few usable epochs moves
#: nothing, and ends nothing either).
FULL_DOF = BATCHES - 3
#: A batch counts as a degree of freedom with at least this share of the window's largest
#: batch's information (module text). Kish's effective number of batches, tried first, also
#: refuses a window of one informed batch, but it took a degree of freedom or more from
#: windows whose channels were losing the code (information 1, 0.9, 0.7, 0.4, 0.3, 0.2 over
#: six batches: 3.8 instead of 5), and a start time 0.5 s off was then not corrected before
#: they had lost it.
MIN_BATCH_SHARE = 0.1


@dataclass(frozen=True)
class TimeOffset:
    """One window's estimate: ``offset_s`` :math:`\\hat\\delta` (add it to every transmit-time
    label), ``sigma_s`` its standard deviation, ``epochs`` the epochs pooled, ``dof`` the
    degrees of freedom of ``sigma_s`` (the batches with information, `MIN_BATCH_SHARE` of the largest's, less one)."""

    offset_s: float
    sigma_s: float
    epochs: int
    dof: int = 0

    def significant(self, false_alarm: float) -> bool:
        """Whether ``offset_s`` is off zero beyond Student's t at ``false_alarm`` (two-sided)
        for ``dof``: the batch means' variance is itself an estimate."""
        if not (self.dof >= 1 and np.isfinite(self.sigma_s)):
            return False
        return abs(self.offset_s) > float(special.stdtrit(self.dof, 1.0 - false_alarm / 2)) * self.sigma_s


class TimeOffsetEstimator:
    """Pools epochs in batches of ``window_s / BATCHES`` and, at the end of every window,
    estimates the common transmit-time offset over all batches since the last `restart`
    (module text). ``window_s`` the window (s of recording time)."""

    def __init__(self, window_s: float) -> None:
        self.window_s = float(window_s)
        self.restart(None)

    def restart(self, t0_s: float | None) -> None:
        """Forget what was pooled (after a correction, the residuals are another time's)."""
        self._t0 = self._window_t0 = t0_s
        self._num: list[float] = []
        self._den: list[float] = []
        self._epochs = 0

    def add(
        self,
        t_s: float,
        residual_m: np.ndarray,
        var_m2: np.ndarray,
        los: np.ndarray,
        rate_mps: np.ndarray,
        use: np.ndarray,
    ) -> TimeOffset | None:
        """Pool one epoch at recording time ``t_s``: each channel's residual (m), its
        variance (m²), line of sight ``(n, 3)`` and range rate (m/s), ``use`` the channels
        read. Returns the estimate over every batch since `restart` when a window ends,
        else None; with fewer than two batches of information (five channels an epoch) a NaN
        offset of infinite sigma: not checked."""
        if self._t0 is None:
            self._t0 = self._window_t0 = t_s
        b = int((t_s - self._t0) / (self.window_s / BATCHES))
        while len(self._num) <= b:
            self._num.append(0.0)
            self._den.append(0.0)
        use = np.asarray(use, bool) & np.isfinite(residual_m) & (np.asarray(var_m2) > 0)
        if use.sum() >= 5:
            w = 1.0 / np.asarray(var_m2, float)[use]
            y = np.column_stack([np.asarray(rate_mps, float)[use], np.asarray(residual_m, float)[use]])
            perp = off_geometry(y, w, np.asarray(los, float)[use])
            rate, resid = perp[:, 0], perp[:, 1]
            self._num[b] += float(np.sum(w * rate * resid))
            self._den[b] += float(np.sum(w * rate * rate))
            self._epochs += 1
        if self._window_t0 is None or t_s - self._window_t0 < self.window_s:
            return None
        self._window_t0 = t_s
        num, den = np.asarray(self._num), np.asarray(self._den)
        full = den > 0
        if full.sum() < 2:
            return TimeOffset(float("nan"), float("inf"), self._epochs)
        den, num = den[full], num[full]
        d = float(num.sum() / den.sum())
        var = float(np.sum(den * (num / den - d) ** 2) / ((full.sum() - 1) * den.sum()))
        # Degrees of freedom from the batches that carry information (`MIN_BATCH_SHARE` of the
        # largest batch's), not from every batch with some: a window whose information is
        # nearly all in one batch has a batch-means variance near zero and no degree of
        # freedom to trust it with.
        informed = int(np.sum(den >= MIN_BATCH_SHARE * den.max()))
        return TimeOffset(d, float(np.sqrt(var)), self._epochs, informed - 1)
