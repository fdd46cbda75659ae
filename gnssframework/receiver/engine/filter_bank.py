r"""A navigation filter and its bank of sub-filters: solution separation that sees a slow ramp.

`gnssframework.navigation.filter_integrity.filter_solution_separation` separates one update: the full
and the fault-mode solutions share the prior :math:`x^-`, so a fault that has already
pulled the prior (a slow ramp the filter absorbs as it grows) is in both and hardly
separates. The remedy (Brenner 1996; Joerger and Pervan 2013) runs, beside the full filter
(estimate :math:`\hat x_0`, covariance :math:`P_0`), one sub-filter per fault mode ``k``
that is *never* given satellite ``k``'s range and rate (:math:`\hat x_k`, :math:`P_k`). A
fault on satellite ``k`` then pulls :math:`\hat x_0` but not :math:`\hat x_k`, however slowly
it grows.

For a Kalman filter whose model is the truth's, the full filter's error is orthogonal to
every measurement it was given, the sub-filter's among them, so (Brenner 1996, eq. 10)

.. math::

    \mathrm{cov}(\hat x_k - \hat x_0) = P_k - P_0 ,

and the separation test and the protection levels are those of a snapshot solution
separation (`gnssframework.navigation.integrity.separation_levels`, Blanch et al. 2015): per east, north, up axis
``q``, :math:`|A(\hat x_k - \hat x_0)|_q > K_{fa}\sigma_{ss,k,q}`,
:math:`\sigma^2_{ss,k,q} = (A(P_k - P_0)A^T)_{qq}`, with ``A`` the rotation of the
position to east, north, up at the full filter's position. For an extended or sigma-point
filter the relation holds to the linearisation. After a detection the mode whose
separation is largest against its threshold is excluded (a single fault), and its
sub-filter's position is the solution without the faulty satellite.

`SubFilterBank` runs the ``N + 1`` filters as ONE batched navigation filter (any
``nav_filter`` plugin): batch ``(N + 1) runs``, sub-filter ``k``'s inputs those of the full
filter with satellite ``k``'s code and frequency variances raised to `EXCLUDED_VAR` (its
range then weighs about :math:`10^{-12}` of a 3 m range's, its rate :math:`3 \times 10^{-9}`
of a 0.1 m/s rate's, on L1), so the bank costs one
filter step on ``N + 1`` times the batch, not ``N + 1`` Python loops.

References
----------
Brenner M. (1996), Integrated GPS/inertial fault detection availability, *Navigation*
43(2), 111-130. Joerger M., Pervan B. (2013), Kalman filter-based integrity monitoring
against sensor faults, *J. Guidance, Control, and Dynamics* 36(2), 349-361. Blanch J. et
al. (2015), Baseline advanced RAIM user algorithm and possible improvements, *IEEE TAES*
51(1), 713-732.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np

from ... import names
from ...errors import ConfigError
from ...interfaces import NavFilter, RunContext
from ...navigation.geometry import enu_rotation
from ...navigation.integrity import separation_levels

__all__ = ["EXCLUDED_VAR", "BankStep", "SubFilterBank"]

#: Code (chips²) and frequency (Hz²) variance that leaves a channel out of a sub-filter.
EXCLUDED_VAR = 1e8
#: The inputs that carry a channel's weight.
_VARIANCES = (names.CODE_ERROR_VAR_CHIPS2, names.FREQ_ERROR_VAR_HZ2)


@dataclass(frozen=True)
class BankStep:
    """One epoch of a `SubFilterBank`, batch ``(runs,)`` first.

    Attributes
    ----------
    outputs
        The full filter's outputs (the nav filter's, batch ``(runs, ...)``).
    separation, sigma_ss
        ``(runs, N, 3)`` :math:`A(\\hat x_k - \\hat x_0)` east, north, up (m) and
        :math:`\\sigma_{ss,k,q}`.
    ratio, fault
        ``(runs,)`` the largest separation over its threshold, and whether it exceeds 1.
    pl_m, hpl_m, vpl_m
        ``(runs, 3)`` per-axis protection levels, ``(runs,)`` horizontal and vertical.
    excluded, excluded_position_m
        ``(runs,)`` where ``fault``: the mode (channel) whose separation is largest against
        its threshold, the single fault's most likely source, and ``(runs, 3)`` the ECEF
        position of its sub-filter, the solution without it; elsewhere -1 and the full
        filter's position.
    """

    outputs: dict[str, np.ndarray]
    separation: np.ndarray
    sigma_ss: np.ndarray
    ratio: np.ndarray
    fault: np.ndarray
    pl_m: np.ndarray
    hpl_m: np.ndarray
    vpl_m: np.ndarray
    excluded: np.ndarray
    excluded_position_m: np.ndarray


class SubFilterBank:
    """A navigation filter and its ``channels`` sub-filters, each never given one channel
    (see the module text), stepped as one batched filter.

    Parameters
    ----------
    nav_filter
        A ``nav_filter`` plugin instance providing ``position_m`` and ``cov`` (its first
        three states the ECEF position); the bank resets and steps it on the whole bank.
    channels
        ``N``, the channels of its inputs' last batch axis (a fault mode per channel).
    false_alarm, missed_detection, integrity_risk
        :math:`P_{fa}` of the separation test (over every mode and axis), :math:`P_{md}`
        and the fault-free :math:`I_{ff}` of the protection levels.
    """

    def __init__(
        self,
        nav_filter: NavFilter,
        channels: int,
        *,
        false_alarm: float = 1e-3,
        missed_detection: float = 1e-3,
        integrity_risk: float = 1e-7,
    ) -> None:
        if channels < 2:
            raise ConfigError(
                "channels", f"a bank needs at least 2 channels (a sub-filter leaves one out), got {channels}"
            )
        for name, p in (
            ("false_alarm", false_alarm),
            ("missed_detection", missed_detection),
            ("integrity_risk", integrity_risk),
        ):
            if not 0 < p < 1:
                raise ConfigError(name, f"must be a probability in (0, 1), got {p}")
        self.nav, self.channels = nav_filter, int(channels)
        self.false_alarm, self.missed_detection, self.integrity_risk = false_alarm, missed_detection, integrity_risk

    def reset(self, batch: tuple[int, ...], context: RunContext) -> None:
        """Start the full filter and every sub-filter of ``batch = (runs,)`` from ``context``'s
        initial estimate (each run's, shared by its bank)."""
        if len(batch) != 1:
            raise ConfigError("batch", f"a bank runs over (runs,), got {batch}")
        self.runs = int(batch[0])
        # Per-run fields (their per-run rank) are repeated for the bank; shared ones kept.
        tiled: dict[str, Any] = {}
        for name, rank in (("initial_state", 2), ("initial_cov", 3), ("cn0_dbhz", 2), ("doppler_hz", 2)):
            value = getattr(context, name)
            if value is not None and np.ndim(value) == rank:
                tiled[name] = self._tile(value)
        self.nav.reset(((self.channels + 1) * self.runs,), dataclasses.replace(context, **tiled))
        # Sub-filter k (block k + 1) weighs channel k at EXCLUDED_VAR.
        self._excluded = np.zeros((self.channels + 1, 1, self.channels), bool)
        self._excluded[np.arange(1, self.channels + 1), 0, np.arange(self.channels)] = True

    def _tile(self, a: np.ndarray) -> np.ndarray:
        """A per-run array ``(runs, ...)`` repeated for every filter of the bank ``((N+1) runs, ...)``;
        anything else (shared by the runs) as it is."""
        a = np.asarray(a)
        if a.ndim == 0 or a.shape[0] != self.runs:
            return a
        return np.broadcast_to(a, (self.channels + 1,) + a.shape).reshape((-1,) + a.shape[1:])

    def step(self, inputs: dict[str, np.ndarray]) -> BankStep:
        """One epoch: the nav filter's ``inputs`` (channel arrays ``(runs, N, ...)``,
        satellite arrays ``(N, 3)`` or ``(runs, N, 3)``), the bank's separation test and levels."""
        runs, n = self.runs, self.channels
        bank_in: dict[str, np.ndarray] = {}
        for key, value in inputs.items():
            a = np.asarray(value)
            if key in _VARIANCES:
                a = np.broadcast_to(a, (runs, n))
                a = np.where(self._excluded, EXCLUDED_VAR, a[None]).reshape(-1, n)
            elif a.ndim >= 2 and a.shape[:2] == (runs, n):
                a = self._tile(a)
            bank_in[key] = a
        out = self.nav.checked_step(bank_in)
        pos = np.asarray(out[names.POSITION_M], float).reshape(n + 1, runs, 3)
        cov = np.asarray(out[names.COV], float).reshape(n + 1, runs, *np.shape(out[names.COV])[-2:])[..., :3, :3]
        A = enu_rotation(pos[0])  # (runs, 3, 3) at the full filter's position
        sep = np.einsum("rij,krj->rki", A, pos[1:] - pos[0])  # (runs, N, 3)
        acov = A[None] @ cov @ np.swapaxes(A, -1, -2)[None]  # (N+1, runs, 3, 3): each filter in ENU
        var = np.diagonal(acov, axis1=-2, axis2=-1)  # (N+1, runs, 3)
        sig_0 = np.sqrt(np.maximum(var[0], 0.0))
        sig_k = np.sqrt(np.maximum(np.moveaxis(var[1:], 0, 1), 0.0))  # (runs, N, 3)
        sig_ss = np.sqrt(np.maximum(sig_k**2 - sig_0[:, None] ** 2, 0.0))
        valid = np.ones((runs, n), bool)
        ratio, pl = separation_levels(
            sep, sig_ss, sig_k, sig_0, valid, self.false_alarm, self.missed_detection, self.integrity_risk
        )
        # Exclusion: the mode whose separation is least likely fault-free, by its chi-square
        # statistic Δ^T (A (P_k - P_0) A^T)^-1 Δ (3 degrees of freedom without a fault).
        d_cov = np.moveaxis(acov[1:] - acov[0], 0, 1)  # (runs, N, 3, 3)
        d_cov = d_cov + 1e-12 * np.eye(3) * np.trace(d_cov, axis1=-2, axis2=-1)[..., None, None]
        per_mode = np.einsum("rki,rki->rk", sep, np.linalg.solve(d_cov, sep[..., None])[..., 0])
        mode = per_mode.argmax(axis=-1)
        fault = ratio > 1.0
        excluded = np.where(fault, mode, -1)
        out_pos = np.where(fault[:, None], pos[1 + mode, np.arange(runs)], pos[0])
        full = {
            k: (np.asarray(v)[:runs] if np.ndim(v) >= 1 and np.shape(v)[0] == (n + 1) * runs else v)
            for k, v in out.items()
        }
        return BankStep(full, sep, sig_ss, ratio, fault, pl, np.hypot(pl[:, 0], pl[:, 1]), pl[:, 2], excluded, out_pos)
