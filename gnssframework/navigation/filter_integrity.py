r"""Fault detection and protection levels of a navigation filter's measurement update,
batched over runs (and epochs).

The snapshot tests of `navigation.integrity` (`raim`) use a least-squares solution's
residuals; a filter has, at each update, a prior :math:`N(x^-, P^-)`, the innovation
:math:`\nu = z - \hat z` ``(m,)``, its covariance :math:`S` (``R`` included) and the
state-measurement cross covariance :math:`C` (:math:`P^- H^T` for a linear or extended
update, the sigma points' for UKF/CKF): the engines' `estimation.Update` holds all three,
so everything here works for every engine.

Innovation (NIS) test
    Without a fault and with an honest model, :math:`\nu \sim N(0, S)` and the normalised
    innovation squared :math:`\epsilon_\nu = \nu^T S^{-1} \nu` is :math:`\chi^2_m`
    (Bar-Shalom, Li & Kirubarajan 2001, sec. 5.4.2); a fault is declared above
    :math:`T = F^{-1}_{\chi^2_m}(1 - P_{fa})`. The innovations of a Kalman filter are white
    (ibid., sec. 5.2.4), so the epochs' tests are independent. A bias :math:`\mu` in the
    innovation (a fault, and what the filter has already absorbed of it) makes
    :math:`\epsilon_\nu` noncentral :math:`\chi^2_m(\mu^T S^{-1} \mu)`: a test at epoch ``t``
    detects with probability :math:`1 - F_{\chi^2_m(\lambda_t)}(T)` (the same relation as the
    snapshot residual test's; Brenner 1996 for the filter).

Solution separation of one update
    The full update :math:`\hat x_0 = x^- + K\nu`, :math:`K = C S^{-1}`,
    :math:`P_0 = P^- - C S^{-1} C^T`, against fault mode ``k`` updating with the rows
    :math:`J_k` it keeps (one satellite's range and rate left out):
    :math:`\hat x_k = x^- + C_{J_k} S_{J_k J_k}^{-1} \nu_{J_k}`,
    :math:`P_k = P^- - C_{J_k} S_{J_k J_k}^{-1} C_{J_k}^T`. Both start from the same prior,
    and :math:`\hat x_0` is the minimum-variance linear estimate from the prior and all
    rows, so :math:`\hat x_k - \hat x_0` is uncorrelated with :math:`\hat x_0`'s error and
    :math:`\mathrm{cov}(\hat x_k - \hat x_0) = P_k - P_0` (as for least squares; Brenner 1996,
    the separation of a full filter and its sub-filters). With ``A`` ``(3, n)`` mapping the
    state to east, north, up position, the test, its threshold
    :math:`T_{k,q} = K_{fa}\sigma_{ss,k,q}`, :math:`\sigma_{ss,k,q}^2 = (A (P_k - P_0) A^T)_{qq}`,
    and the protection levels
    :math:`PL_q = \max(K_{ff,q}\sigma_{0,q}, \max_k (T_{k,q} + K_{md,q}\sigma_{k,q}))` are
    those of Blanch et al. (2015), `integrity.separation_levels`, as in `raim`.

    The prior is shared: this separates a fault that enters at this update. A fault that
    has already pulled the prior (a slow ramp) is in :math:`x^-` of both solutions; a
    bank of sub-filters, each never given satellite ``k`` (Brenner 1996; Joerger & Pervan
    2013), separates that too, at ``N`` filters' cost. The levels are as honest as
    :math:`P^-` and ``S``.

References
----------
Bar-Shalom Y., Li X. R., Kirubarajan T. (2001), *Estimation with Applications to Tracking
and Navigation*, Wiley. Brenner M. (1996), Integrated GPS/inertial fault detection
availability, *Navigation* 43(2), 111-130. Blanch J. et al. (2015), Baseline advanced RAIM
user algorithm and possible improvements, *IEEE TAES* 51(1), 713-732. Joerger M., Pervan B.
(2013), Kalman filter-based integrity monitoring against sensor faults, *J. Guidance,
Control, and Dynamics* 36(2), 349-361.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError
from .integrity import _check_probability, _chi2_isf, separation_levels

__all__ = [
    "InnovationTest",
    "FilterSeparation",
    "innovation_test",
    "normalised_innovation_squared",
    "filter_solution_separation",
    "satellite_modes",
]


@dataclass(frozen=True)
class InnovationTest:
    """`innovation_test`'s outputs ``(...)``: the statistic :math:`\\nu^T S^{-1} \\nu`, its
    degrees of freedom (the rows used), the threshold :math:`F^{-1}_{\\chi^2_{dof}}(1 - P_{fa})`
    and ``detected`` (statistic above it; False where no row is used)."""

    statistic: np.ndarray
    dof: np.ndarray
    threshold: np.ndarray
    detected: np.ndarray


@dataclass(frozen=True)
class FilterSeparation:
    """`filter_solution_separation`'s outputs over the batch ``(...)``.

    ``separation_enu_m`` ``(..., N, 3)`` :math:`A(\\hat x_k - \\hat x_0)`, ``sigma_ss_m``
    ``(..., N, 3)`` its standard deviations, ``ratio`` the largest separation over its
    threshold and ``detected`` whether it exceeds 1; ``pl_enu_m`` ``(..., 3)`` the per-axis
    levels, ``hpl_m`` :math:`\\sqrt{PL_E^2 + PL_N^2}`, ``vpl_m`` :math:`PL_U`;
    ``error_sigma_enu_m`` ``(..., 3)`` the full update's :math:`\\sigma_{0,q}`.
    """

    separation_enu_m: np.ndarray
    sigma_ss_m: np.ndarray
    ratio: np.ndarray
    detected: np.ndarray
    pl_enu_m: np.ndarray
    hpl_m: np.ndarray
    vpl_m: np.ndarray
    error_sigma_enu_m: np.ndarray


def _masked(innovation: np.ndarray, innovation_cov: np.ndarray, keep: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``ν`` and ``S`` with the rows not in ``keep`` removed in place: ``ν`` 0 there, ``S`` those
    rows and columns the identity's (an equal-size system whose solution ignores them)."""
    k = keep.astype(float)
    S = innovation_cov * (k[..., :, None] * k[..., None, :]) + np.eye(keep.shape[-1]) * (1.0 - k)[..., None, :]
    return innovation * k, S


def innovation_test(
    innovation: np.ndarray, innovation_cov: np.ndarray, false_alarm: float = 1e-3, used: np.ndarray | None = None
) -> InnovationTest:
    """The chi-square test of the normalised innovation squared (see the module text).

    Parameters
    ----------
    innovation
        ``(..., m)`` :math:`\\nu = z - \\hat z` (`estimation.Update.innovation`).
    innovation_cov
        ``(..., m, m)`` :math:`S` (`estimation.Update.innovation_cov`); broadcast.
    false_alarm
        :math:`P_{fa}` of one test.
    used
        ``(..., m)`` the rows tested (default every finite one).

    Raises
    ------
    ConfigError
        For ``false_alarm`` outside (0, 1).
    """
    _check_probability("false_alarm", false_alarm)
    statistic, dof = normalised_innovation_squared(innovation, innovation_cov, used)
    threshold = _chi2_isf(false_alarm, dof)
    return InnovationTest(statistic, dof, threshold, (dof >= 1) & (statistic > threshold))


def normalised_innovation_squared(
    innovation: np.ndarray, innovation_cov: np.ndarray, used: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """:math:`\nu^T S^{-1} \nu` over the rows ``used`` (default every finite one) and their
    count, each ``(...)``, from ``(..., m)`` innovations and ``(..., m, m)`` covariances."""
    nu = np.asarray(innovation, float)
    S = np.asarray(innovation_cov, float)
    shape = np.broadcast_shapes(nu.shape, S.shape[:-1])
    nu = np.broadcast_to(nu, shape)
    keep = np.isfinite(nu) & (True if used is None else np.asarray(used, bool))
    if not keep.all():  # every row kept: no masked copies (the common case, a third of the time)
        nu, S = _masked(np.where(keep, nu, 0.0), S, keep)
    statistic = np.einsum("...i,...i->...", nu, np.linalg.solve(S, nu[..., None])[..., 0])
    return statistic, keep.sum(-1)


def satellite_modes(satellites: int, blocks: int = 2) -> np.ndarray:
    """Fault modes ``(S, blocks S)`` of measurements stacked block by block (``ekf-pv``'s
    ranges then rates: ``blocks=2``): mode ``k`` leaves out rows ``k, S + k, ...``."""
    if satellites < 1 or blocks < 1:
        raise ConfigError("satellite_modes", f"needs at least one satellite and block, got {satellites}, {blocks}")
    return np.tile(np.eye(satellites, dtype=bool), (1, blocks))


def filter_solution_separation(
    prior_cov: np.ndarray,
    innovation: np.ndarray,
    innovation_cov: np.ndarray,
    cross_cov: np.ndarray,
    modes: np.ndarray,
    position_enu: np.ndarray,
    *,
    used: np.ndarray | None = None,
    false_alarm: float = 1e-3,
    missed_detection: float = 1e-3,
    integrity_risk: float = 1e-7,
) -> FilterSeparation:
    """Solution separation of one filter update and its protection levels (see the module text).

    Parameters
    ----------
    prior_cov
        ``(..., n, n)`` :math:`P^-`.
    innovation, innovation_cov, cross_cov
        ``(..., m)``, ``(..., m, m)``, ``(..., n, m)``: the update's :math:`\\nu`, :math:`S`
        and :math:`C` (`estimation.Update`'s ``innovation``, ``innovation_cov``, ``cross_cov``).
    modes
        ``(N, m)`` booleans: row ``k`` marks the measurements fault mode ``k`` leaves out
        (`satellite_modes`).
    position_enu
        ``(..., 3, n)`` the map :math:`A` from the state to east, north, up position (m),
        e.g. an ECEF-to-ENU rotation times ``[I_3, 0]``.
    used
        ``(..., m)`` the rows in the update (default every finite one); a mode none of
        whose rows is used does not exist.
    false_alarm, missed_detection, integrity_risk
        :math:`P_{fa}` of the test (over every mode and axis), :math:`P_{md}` and the
        fault-free :math:`I_{ff}` of the levels.

    Raises
    ------
    ConfigError
        For a probability outside (0, 1) or ``modes`` of the wrong width.
    """
    for name, p in (
        ("false_alarm", false_alarm),
        ("missed_detection", missed_detection),
        ("integrity_risk", integrity_risk),
    ):
        _check_probability(name, p)
    nu = np.asarray(innovation, float)
    m = nu.shape[-1]
    mode = np.asarray(modes, bool)
    if mode.ndim != 2 or mode.shape[-1] != m:
        raise ConfigError("modes", f"must be (N, {m}) booleans, one row per fault mode, got shape {mode.shape}")
    P = np.asarray(prior_cov, float)
    C = np.asarray(cross_cov, float)
    A = np.asarray(position_enu, float)
    keep = np.isfinite(nu) & (True if used is None else np.asarray(used, bool))
    keep_k = keep[..., None, :] & ~mode  # (..., N, m)
    valid = (keep[..., None, :] & mode).any(-1)
    nu0, S0 = _masked(np.where(keep, nu, 0.0), np.asarray(innovation_cov, float), keep)
    nuk, Sk = _masked(nu0[..., None, :], S0[..., None, :, :], keep_k)
    C0 = C * keep[..., None, :]
    Ck = C0[..., None, :, :] * keep_k[..., None, :]
    AC0, ACk = A @ C0, A[..., None, :, :] @ Ck  # (..., 3, m), (..., N, 3, m)
    # x_k - x^- = C_k S_k^-1 ν_k and A P_k A^T = A P A^T - (A C_k) S_k^-1 (A C_k)^T, from one solve each.
    sol0 = np.linalg.solve(S0, np.concatenate([nu0[..., :, None], np.swapaxes(AC0, -1, -2)], -1))
    solk = np.linalg.solve(Sk, np.concatenate([nuk[..., :, None], np.swapaxes(ACk, -1, -2)], -1))
    dx0, dxk = (AC0 @ sol0[..., :1])[..., 0], (ACk @ solk[..., :1])[..., 0]
    gain0 = np.diagonal(AC0 @ sol0[..., 1:], axis1=-2, axis2=-1)  # diag(A C S^-1 C^T A^T)
    gaink = np.diagonal(ACk @ solk[..., 1:], axis1=-2, axis2=-1)
    apa = np.diagonal(A @ P @ np.swapaxes(A, -1, -2), axis1=-2, axis2=-1)
    var0 = apa - gain0
    vark = apa[..., None, :] - gaink
    sig_0 = np.sqrt(np.maximum(var0, 0.0))
    sig_k = np.sqrt(np.maximum(vark, 0.0))
    sig_ss = np.sqrt(np.maximum(gain0[..., None, :] - gaink, 0.0))  # diag A (P_k - P_0) A^T
    separation = dxk - dx0[..., None, :]
    ratio, pl = separation_levels(
        separation, sig_ss, sig_k, sig_0, valid, false_alarm, missed_detection, integrity_risk
    )
    return FilterSeparation(
        separation, sig_ss, ratio, ratio > 1.0, pl, np.hypot(pl[..., 0], pl[..., 1]), pl[..., 2], sig_0
    )
