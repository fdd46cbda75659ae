r"""Receiver autonomous integrity monitoring (RAIM): fault detection and exclusion and
protection levels, batched over epochs.

A snapshot (least-squares) solution of ``n`` ranges with the linearised model
:math:`y = G\,\delta x + \varepsilon`, :math:`\varepsilon \sim N(0, C)`, ``C`` diagonal
(variances :math:`\sigma_i^2`, weights :math:`W = C^{-1}`), ``G`` ``(n, m)`` with the first
three columns east, north, up and the others clocks; :math:`P_0 = (G^T W G)^{-1}`,
:math:`S_0 = P_0 G^T W`, :math:`\hat x_0 = S_0 y`.

Residual (chi-square) test
    :math:`\mathrm{WSSE} = r^T W r`, :math:`r = (I - G S_0) y`, is :math:`\chi^2_{n-m}`
    without a fault and noncentral :math:`\chi^2_{n-m}(\lambda)`,
    :math:`\lambda = b^2 (I - G S_0)_{ii} / \sigma_i^2`, with a bias ``b`` on satellite
    ``i``; a fault is declared above :math:`T = F^{-1}_{\chi^2_{n-m}}(1 - P_{fa})`
    (Parkinson & Axelrad 1988; Walter & Enge 1995 for the weighted form).

Slope protection levels (paired with the residual test)
    The position error per unit of test statistic of a bias on satellite ``i``,
    :math:`\mathrm{Hslope}_i = \sqrt{S_{0,Ei}^2 + S_{0,Ni}^2}\,\sigma_i / \sqrt{(I - G S_0)_{ii}}`
    (vertical with :math:`|S_{0,Ui}|`), times :math:`p_{bias} = \sqrt{\lambda_{det}}`, the
    noncentrality at which the test misses with probability :math:`P_{md}`:
    :math:`F_{\chi^2_{n-m}(\lambda_{det})}(T) = P_{md}`;
    :math:`\mathrm{HPL} = \max_i \mathrm{Hslope}_i\, p_{bias}` (Brown & Chin 1998,
    "Calculating the probability of missed detection given the slope", and Walter & Enge
    1995). It bounds the error a bias causes at the detection limit, without the noise on
    the error: an approximation, not a bound, for small redundancies.

Solution separation (Blanch et al. 2015, "Baseline advanced RAIM user algorithm and
possible improvements", IEEE TAES 51(1), the single-fault modes)
    The subset solution :math:`\hat x_k` leaves out satellite ``k`` (weights :math:`W_k`,
    :math:`P_k = (G^T W_k G)^{-1}`); with optimal weights
    :math:`\mathrm{cov}(\hat x_k - \hat x_0) = P_k - P_0`, so per axis ``q``
    :math:`\sigma_{ss,k,q}^2 = (P_k - P_0)_{qq}`. The test: a fault where any
    :math:`|\hat x_{k,q} - \hat x_{0,q}| > T_{k,q} = K_{fa}\,\sigma_{ss,k,q}`,
    :math:`K_{fa} = Q^{-1}(P_{fa} / (6 N))` (``Q`` the standard normal tail, ``N`` the
    fault modes, 3 axes, two-sided: by the union bound the false-alarm probability is at
    most :math:`P_{fa}`). Protection level per axis

    .. math:: PL_q = \max\big(K_{ff,q}\,\sigma_{0,q},\ \max_k\,(T_{k,q} + K_{md,q}\,\sigma_{k,q})\big)

    with :math:`K_{md,U} = Q^{-1}(P_{md}/2)`, :math:`K_{md,E} = K_{md,N} = Q^{-1}(P_{md}/4)`,
    :math:`K_{ff,U} = Q^{-1}(I_{ff}/2)`, :math:`K_{ff,E} = K_{ff,N} = Q^{-1}(I_{ff}/4)`;
    :math:`\mathrm{VPL} = PL_U`, :math:`\mathrm{HPL} = \sqrt{PL_E^2 + PL_N^2}` (Blanch et al.
    2015). Without a detection under fault ``k``,
    :math:`|e_q| \le |\hat x_{0,q} - \hat x_{k,q}| + |e_{k,q}| \le T_{k,q} + |e_{k,q}|`
    and the fault-free subset's error :math:`e_k` exceeds :math:`K_{md,q}\sigma_{k,q}` on
    an axis with probability at most :math:`P_{md}`: the PL bounds the error of an
    undetected single fault with probability :math:`\ge 1 - P_{md}`, and the fault-free
    error with probability :math:`\ge 1 - I_{ff}`.

Exclusion
    After a detection, the subsets whose own residual test passes (:math:`\chi^2_{n-1-m}`
    at :math:`P_{fa}`) are candidates; the one with the smallest WSSE is taken (none
    passing: an alert, no exclusion).

Covariance protection levels (for navigation filters)
    From a fault-free estimate's covariance alone: :math:`\mathrm{VPL} = Q^{-1}(I/2)\,\sigma_U`
    and :math:`\mathrm{HPL} = \sqrt{-2 \ln I}\,\sqrt{\lambda_{max}(C_{EN})}` (a Gaussian with
    covariance below :math:`\sigma^2 I` puts no more mass outside a disc than the circular
    one, Anderson 1955, whose tail is the Rayleigh :math:`e^{-k^2/2}`). They bound the
    error only as far as the filter's covariance is honest and no fault is undetected.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..errors import ConfigError

__all__ = [
    "IntegrityResult",
    "RaimOptions",
    "raim",
    "detection_noncentrality",
    "covariance_protection_levels",
    "enu_geometry",
    "separation_levels",
    "RAIM_METHODS",
]

#: The detection tests `raim` can apply: ``chi2`` the residual test (with slope PLs),
#: ``ss`` solution separation (with its PLs).
RAIM_METHODS = ("chi2", "ss")


@dataclass(frozen=True)
class IntegrityResult:
    """`raim`'s outputs, each ``(...)`` over the batch (``(..., n)`` per satellite).

    ``wsse`` the weighted sum of squared residuals, ``dof`` its degrees of freedom
    ``n - m``, ``threshold`` its ``1 - P_fa`` quantile, ``chi2_detected`` the residual test;
    ``ss_ratio`` the largest ``|Δx_{k,q}| / T_{k,q}`` over subsets and axes and
    ``ss_detected`` whether it exceeds 1; ``detected`` the test named by ``method``;
    ``excluded`` the satellite left out after a detection (-1: none); ``alert`` a
    detection with no exclusion; ``hpl_m``/``vpl_m`` the protection levels of ``method``
    (slope PLs for ``chi2``, solution separation's for ``ss``; inf where unavailable: fewer
    than ``m + 2`` satellites), ``hpl_slope_m``/``vpl_slope_m``, ``hpl_ss_m``/``vpl_ss_m``
    both kinds; ``error_enu_m`` the full solution's correction ``S_0 y`` (position part).
    """

    wsse: np.ndarray
    dof: np.ndarray
    threshold: np.ndarray
    chi2_detected: np.ndarray
    ss_ratio: np.ndarray
    ss_detected: np.ndarray
    detected: np.ndarray
    excluded: np.ndarray
    alert: np.ndarray
    hpl_m: np.ndarray
    vpl_m: np.ndarray
    hpl_slope_m: np.ndarray
    vpl_slope_m: np.ndarray
    hpl_ss_m: np.ndarray
    vpl_ss_m: np.ndarray
    error_enu_m: np.ndarray


def enu_geometry(unit_enu: np.ndarray, clocks: int = 1) -> np.ndarray:
    """The design matrix ``(..., n, 3 + clocks)`` of line-of-sight unit vectors ``(..., n, 3)``
    (east, north, up, receiver to satellite): rows ``[-u, 1]`` (one clock; more clocks need
    their own columns, given directly to `raim`)."""
    u = np.asarray(unit_enu, float)
    return np.concatenate([-u, np.ones(u.shape[:-1] + (clocks,))], axis=-1)


def _q_inv(p: np.ndarray | float) -> np.ndarray:
    """``Q^{-1}(p)``: the standard normal quantile ``1 - p`` (`scipy.stats.norm.isf`)."""
    from scipy.stats import norm

    q: np.ndarray = np.asarray(norm.isf(p), float)
    return q


@lru_cache(maxsize=256)
def detection_noncentrality(dof: int, false_alarm: float, missed_detection: float) -> float:
    """The noncentrality ``λ`` at which a ``χ²_dof`` test at ``false_alarm`` misses with
    probability ``missed_detection``: ``ncx2.cdf(chi2.isf(false_alarm, dof), dof, λ) = missed_detection``
    (Brown & Chin 1998's ``p_bias² ``; NaN for ``dof < 1``)."""
    from scipy.optimize import brentq
    from scipy.stats import chi2, ncx2

    if dof < 1:
        return float("nan")
    t = chi2.isf(false_alarm, dof)
    hi = 1.0
    while ncx2.cdf(t, dof, hi) > missed_detection:
        hi *= 2.0
    return float(brentq(lambda lam: ncx2.cdf(t, dof, lam) - missed_detection, 0.0, hi, xtol=1e-10, rtol=1e-12))


def _check_probability(name: str, p: float) -> None:
    if not 0.0 < p < 1.0:
        raise ConfigError(name, f"must be a probability in (0, 1), got {p}")


def _chi2_isf(p: float, dof: np.ndarray) -> np.ndarray:
    """``chi2.isf(p, dof)`` per element (NaN for ``dof < 1``), evaluated once per distinct ``dof``."""
    from scipy.stats import chi2

    dofs, inverse = np.unique(np.asarray(dof), return_inverse=True)
    values = np.array([chi2.isf(p, d) if d >= 1 else np.nan for d in dofs])
    return values[inverse].reshape(np.shape(dof))


def _safe_inv(N: np.ndarray, ok: np.ndarray) -> np.ndarray:
    """Inverses of ``N`` ``(..., m, m)`` where ``ok`` (identity elsewhere: unavailable)."""
    eye = np.eye(N.shape[-1])
    return np.linalg.inv(np.where(ok[..., None, None], N, eye))


def raim(
    geometry: np.ndarray,
    sigma_m: np.ndarray,
    residual_m: np.ndarray,
    used: np.ndarray | None = None,
    *,
    false_alarm: float = 1e-5,
    missed_detection: float = 1e-3,
    integrity_risk: float = 1e-7,
    method: str = "chi2",
) -> IntegrityResult:
    """Fault detection and exclusion and protection levels of weighted least-squares
    solutions (see the module text for the equations and sources).

    Parameters
    ----------
    geometry
        ``(..., n, m)`` design matrices, columns east, north, up (m) then clocks
        (`enu_geometry`); broadcast against the others.
    sigma_m
        ``(..., n)`` standard deviations of the ranges (weights ``1/σ²``).
    residual_m
        ``(..., n)`` measurement minus model at the linearisation point (a converged
        solution's post-fit residuals give the same statistics: the tests are linear).
    used
        ``(..., n)`` the satellites in the solution (default all).
    false_alarm, missed_detection, integrity_risk
        ``P_fa`` of each test, ``P_md`` of the protection levels, and the fault-free share
        ``I_ff`` of the integrity risk.
    method
        One of `RAIM_METHODS`: the test behind ``detected`` and the PLs in ``hpl_m``.

    Returns
    -------
    IntegrityResult
    """
    for name, p in (
        ("false_alarm", false_alarm),
        ("missed_detection", missed_detection),
        ("integrity_risk", integrity_risk),
    ):
        _check_probability(name, p)
    if method not in RAIM_METHODS:
        raise ConfigError("method", f"one of {', '.join(RAIM_METHODS)}, got {method!r}")
    G = np.asarray(geometry, float)
    y = np.asarray(residual_m, float)
    sig = np.asarray(sigma_m, float)
    n, m = G.shape[-2:]
    if used is None:
        used = np.ones(y.shape, bool)
    shape = np.broadcast_shapes(G.shape[:-2], y.shape[:-1], sig.shape[:-1], np.shape(used)[:-1])
    G = np.broadcast_to(G, shape + (n, m))
    use = np.broadcast_to(np.asarray(used, bool), shape + (n,)) & np.isfinite(np.broadcast_to(y, shape + (n,)))
    use = use & np.isfinite(np.broadcast_to(sig, shape + (n,)))
    w = np.where(use, 1.0 / np.where(use, np.broadcast_to(sig, shape + (n,)), 1.0) ** 2, 0.0)
    y = np.where(use, np.broadcast_to(y, shape + (n,)), 0.0)
    n_used = use.sum(-1)
    dof = n_used - m
    ok0 = dof >= 0
    # Full solution.
    GtW = np.swapaxes(G, -1, -2) * w[..., None, :]
    P0 = _safe_inv(GtW @ G, ok0)
    S0 = P0 @ GtW
    x0 = np.einsum("...mn,...n->...m", S0, y)
    r = y - np.einsum("...nm,...m->...n", G, x0)
    wsse = np.sum(w * r**2, axis=-1)
    threshold = _chi2_isf(false_alarm, dof)
    chi2_detected = (dof >= 1) & (wsse > threshold)
    # Subsets leaving out each used satellite k: batch axis -3 is k.
    keep_k = use[..., None, :] & ~np.eye(n, dtype=bool)
    wk = np.where(keep_k, w[..., None, :], 0.0)
    valid_k = use & (dof >= 1)[..., None]  # (..., n): subset k exists and is solvable
    GtWk = np.swapaxes(G, -1, -2)[..., None, :, :] * wk[..., :, None, :]
    Pk = _safe_inv(GtWk @ G[..., None, :, :], valid_k)
    Sk = Pk @ GtWk
    xk = np.einsum("...kmn,...n->...km", Sk, y)
    rk = y[..., None, :] - np.einsum("...nm,...km->...kn", G, xk)
    wsse_k = np.sum(wk * rk**2, axis=-1)
    dxk = (xk - x0[..., None, :])[..., :3]
    var_ss = np.diagonal(Pk - P0[..., None, :, :], axis1=-2, axis2=-1)[..., :3]
    sig_ss = np.sqrt(np.maximum(var_ss, 0.0))
    sig_k = np.sqrt(np.diagonal(Pk, axis1=-2, axis2=-1)[..., :3])
    sig_0 = np.sqrt(np.diagonal(P0, axis1=-2, axis2=-1)[..., :3])
    ss_ratio, pl = separation_levels(dxk, sig_ss, sig_k, sig_0, valid_k, false_alarm, missed_detection, integrity_risk)
    ss_detected = ss_ratio > 1.0
    detected = chi2_detected if method == "chi2" else ss_detected
    # Exclusion: subsets whose own residual test passes; the smallest WSSE among them.
    dof_k = dof - 1
    thr_k = np.where(dof_k >= 1, _chi2_isf(false_alarm, dof_k), np.inf)
    passes = valid_k & (dof_k >= 1)[..., None] & (wsse_k <= thr_k[..., None])
    best = np.argmin(np.where(passes, wsse_k, np.inf), axis=-1) if n else np.zeros(shape, int)
    can = passes.any(-1)
    excluded = np.where(detected & can, best, -1)
    alert = detected & ~can
    # Slope PLs.
    proj = 1.0 - np.einsum("...nm,...mn->...n", G, S0)  # (I - G S0)_ii
    sig_b = np.broadcast_to(sig, shape + (n,))
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = np.where(use & (proj > 1e-12), sig_b / np.sqrt(np.maximum(proj, 1e-300)), 0.0)
    hslope = np.hypot(S0[..., 0, :], S0[..., 1, :]) * scale
    vslope = np.abs(S0[..., 2, :]) * scale
    dofs, inverse = np.unique(dof, return_inverse=True)
    lam = np.array([detection_noncentrality(int(d), false_alarm, missed_detection) for d in dofs])[inverse]
    lam = lam.reshape(shape)
    pbias = np.sqrt(lam)
    enough = dof >= 2
    hpl_slope = np.where(enough, hslope.max(-1, initial=0.0) * pbias, np.inf)
    vpl_slope = np.where(enough, vslope.max(-1, initial=0.0) * pbias, np.inf)
    # Solution-separation PLs (per axis in `pl`).
    hpl_ss = np.where(enough, np.hypot(pl[..., 0], pl[..., 1]), np.inf)
    vpl_ss = np.where(enough, pl[..., 2], np.inf)
    hpl, vpl = (hpl_slope, vpl_slope) if method == "chi2" else (hpl_ss, vpl_ss)
    return IntegrityResult(
        wsse,
        dof,
        threshold,
        chi2_detected,
        ss_ratio,
        ss_detected,
        detected,
        excluded,
        alert,
        hpl,
        vpl,
        hpl_slope,
        vpl_slope,
        hpl_ss,
        vpl_ss,
        x0[..., :3],
    )


def separation_levels(
    separation: np.ndarray,
    sigma_ss: np.ndarray,
    sigma_subset: np.ndarray,
    sigma_full: np.ndarray,
    valid: np.ndarray,
    false_alarm: float,
    missed_detection: float,
    integrity_risk: float,
) -> tuple[np.ndarray, np.ndarray]:
    r"""Solution separation's test and per-axis protection levels (Blanch et al. 2015; the
    module text), shared by `raim` and `navigation.filter_integrity`.

    Parameters
    ----------
    separation
        ``(..., N, 3)`` :math:`\hat x_{k,q} - \hat x_{0,q}` of the ``N`` fault modes, east, north, up.
    sigma_ss, sigma_subset
        ``(..., N, 3)`` :math:`\sigma_{ss,k,q}` and :math:`\sigma_{k,q}`.
    sigma_full
        ``(..., 3)`` :math:`\sigma_{0,q}`.
    valid
        ``(..., N)`` the modes that exist (the others neither test nor bound).

    Returns
    -------
    The largest :math:`|\hat x_{k,q} - \hat x_{0,q}| / T_{k,q}` ``(...)`` (a fault above 1),
    :math:`T_{k,q} = K_{fa}\sigma_{ss,k,q}`, :math:`K_{fa} = Q^{-1}(P_{fa} / (6 N_{valid}))`, and
    :math:`PL_q = \max(K_{ff,q}\sigma_{0,q}, \max_k (T_{k,q} + K_{md,q}\sigma_{k,q}))` ``(..., 3)``.
    """
    sig_ss, sig_k, sig_0 = sigma_ss, sigma_subset, sigma_full
    shape, n = np.shape(valid)[:-1], np.shape(valid)[-1]
    modes = np.maximum(valid.sum(-1), 1)
    k_fa = _q_inv(false_alarm / (6.0 * modes))[..., None, None]
    t_k = k_fa * sig_ss
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(valid[..., None] & (sig_ss > 0), np.abs(separation) / t_k, 0.0)
    ss_ratio = ratio.max(axis=(-1, -2)) if n else np.zeros(shape)
    k_md = np.array([_q_inv(missed_detection / 4), _q_inv(missed_detection / 4), _q_inv(missed_detection / 2)])
    k_ff = np.array([_q_inv(integrity_risk / 4), _q_inv(integrity_risk / 4), _q_inv(integrity_risk / 2)])
    fault_terms = np.where(valid[..., None], t_k + k_md * sig_k, 0.0).max(axis=-2) if n else np.zeros(shape + (3,))
    return ss_ratio, np.maximum(k_ff * sig_0, fault_terms)


def covariance_protection_levels(cov_enu_m2: np.ndarray, integrity_risk: float = 1e-7) -> tuple[np.ndarray, np.ndarray]:
    """HPL and VPL ``(...)`` (m) of position covariances ``(..., 3, 3)`` in east, north, up:
    ``VPL = Q⁻¹(I/2) σ_U``, ``HPL = sqrt(-2 ln I) sqrt(λ_max(C_EN))`` (see the module text):
    each exceeded by a fault-free Gaussian error with probability at most ``integrity_risk``."""
    _check_probability("integrity_risk", integrity_risk)
    C = np.asarray(cov_enu_m2, float)
    vpl = _q_inv(integrity_risk / 2) * np.sqrt(np.maximum(C[..., 2, 2], 0.0))
    a, b, d = C[..., 0, 0], C[..., 0, 1], C[..., 1, 1]
    lam_max = 0.5 * (a + d) + np.sqrt(0.25 * (a - d) ** 2 + b**2)
    hpl = np.sqrt(-2.0 * np.log(integrity_risk)) * np.sqrt(np.maximum(lam_max, 0.0))
    return hpl, vpl


@dataclass(frozen=True)
class RaimOptions:
    """Integrity monitoring of a receiver's fixes: ``method`` (one of `RAIM_METHODS`) at
    ``false_alarm`` (also the nav filters' innovation test), ``missed_detection`` and the
    fault-free ``integrity_risk`` of the protection levels.

    Raises
    ------
    ConfigError
        For an unknown method or a probability outside (0, 1).
    """

    method: str = "chi2"
    false_alarm: float = 1e-5
    missed_detection: float = 1e-3
    integrity_risk: float = 1e-7

    def __post_init__(self) -> None:
        if self.method not in RAIM_METHODS:
            raise ConfigError("raim", f"one of {', '.join(RAIM_METHODS)}, got {self.method!r}")
        for name, p in (
            ("raim_false_alarm", self.false_alarm),
            ("raim_missed_detection", self.missed_detection),
            ("integrity_risk", self.integrity_risk),
        ):
            _check_probability(name, p)
