"""RAIM (`navigation.integrity`) checked by Monte Carlo against the distributions it claims.

Each test draws thousands of epochs of Gaussian range noise on a fixed eight-satellite
geometry (vectorised, no receiver) and compares a measured frequency with the probability
theory gives, inside a binomial interval of probability ``1 - 1e-4`` (or a DKW band for
a whole distribution), so a wrong statistic, threshold or protection level fails.
"""

import numpy as np
import pytest
from scipy.stats import binom, chi2, ncx2

from gnssframework.errors import ConfigError
from gnssframework.navigation.integrity import covariance_protection_levels, enu_geometry, raim

AZ = np.radians([0, 50, 100, 160, 210, 260, 300, 330])
EL = np.radians([70, 20, 45, 15, 35, 60, 10, 25])
U = np.stack([np.cos(EL) * np.sin(AZ), np.cos(EL) * np.cos(AZ), np.sin(EL)], axis=-1)
G = enu_geometry(U)
SIGMA = 0.5 / np.sin(EL)
CONF = 1e-4  # probability of a correct implementation failing one check


def _interval(n: int, p: float) -> tuple[float, float]:
    lo, hi = binom.interval(1 - CONF, n, p)
    return lo / n, hi / n


def _upper(n: int, p: float) -> float:
    return binom.ppf(1 - CONF, n, p) / n


def _projection_diag() -> np.ndarray:
    """``(I - G S)_ii`` from an explicit weighted least squares (not the module's algebra)."""
    A = G / SIGMA[:, None]
    hat = A @ np.linalg.pinv(A)
    return 1.0 - np.diag(hat)


def test_statistics_match_explicit_subset_solutions():
    rng = np.random.default_rng(0)
    y = rng.standard_normal(8) * SIGMA
    r = raim(G, SIGMA, y)
    A, b = G / SIGMA[:, None], y / SIGMA
    x0, res, *_ = np.linalg.lstsq(A, b, rcond=None)
    assert r.wsse == pytest.approx(float(res[0]), rel=1e-10)
    assert r.error_enu_m == pytest.approx(x0[:3], abs=1e-12)
    assert int(r.dof) == 4
    # Solution separation: each subset solved on its own, its separation over its threshold.
    ratios = []
    from scipy.stats import norm

    k_fa = norm.isf(1e-5 / (6 * 8))
    P0 = np.linalg.inv(A.T @ A)
    for k in range(8):
        keep = np.arange(8) != k
        xk = np.linalg.lstsq(A[keep], b[keep], rcond=None)[0]
        Pk = np.linalg.inv(A[keep].T @ A[keep])
        ratios.append(np.abs(xk - x0)[:3] / (k_fa * np.sqrt(np.diag(Pk - P0)[:3])))
    assert r.ss_ratio == pytest.approx(np.max(ratios), rel=1e-9)


def test_false_alarm_rate_matches_the_stated_probability():
    rng = np.random.default_rng(1)
    E, p_fa = 20_000, 1e-2
    y = rng.standard_normal((E, 8)) * SIGMA
    r = raim(G, SIGMA, y, false_alarm=p_fa)
    lo, hi = _interval(E, p_fa)
    assert lo <= r.chi2_detected.mean() <= hi
    assert r.ss_detected.mean() <= _upper(E, p_fa)  # a union bound: at most p_fa
    # A detection's exclusion never leaves fewer than m + 1 satellites.
    assert np.all(r.excluded[~r.detected] == -1)


@pytest.mark.parametrize("sat", [2, 6])
def test_step_fault_detected_with_the_noncentral_chi2_power_and_excluded(sat):
    rng = np.random.default_rng(2 + sat)
    E, p_fa = 10_000, 1e-2
    proj = _projection_diag()[sat]
    bias = 5.0 * SIGMA[sat] / np.sqrt(proj)  # noncentrality 25
    y = rng.standard_normal((E, 8)) * SIGMA
    y[:, sat] += bias
    r = raim(G, SIGMA, y, false_alarm=p_fa)
    power = ncx2.sf(chi2.isf(p_fa, 4), 4, bias**2 * proj / SIGMA[sat] ** 2)
    lo, hi = _interval(E, power)
    assert lo <= r.chi2_detected.mean() <= hi
    # A larger fault: detected and the faulty satellite the one excluded.
    y[:, sat] += 2 * bias
    r = raim(G, SIGMA, y, false_alarm=p_fa)
    assert r.detected.mean() > 0.999
    assert (r.excluded == sat).mean() > 0.97


def test_ramp_detected_within_the_expected_epochs():
    rng = np.random.default_rng(3)
    runs, epochs, p_fa, sat = 1_000, 24, 1e-2, 2
    proj = _projection_diag()[sat]
    slope = 0.25 * SIGMA[sat] / np.sqrt(proj)  # noncentrality (0.25 t)² at epoch t
    t = np.arange(1, epochs + 1)
    y = rng.standard_normal((runs, epochs, 8)) * SIGMA
    y[..., sat] += slope * t
    r = raim(G, SIGMA, y, false_alarm=p_fa)
    first = np.where(r.chi2_detected.any(-1), r.chi2_detected.argmax(-1) + 1, epochs + 1)
    p_det = ncx2.sf(chi2.isf(p_fa, 4), 4, (slope * t) ** 2 * proj / SIGMA[sat] ** 2)
    cdf = 1.0 - np.cumprod(1.0 - p_det)  # P(first detection <= t), epochs independent
    empirical = (first[:, None] <= t).mean(0)
    dkw = np.sqrt(np.log(2 / CONF) / (2 * runs))  # Dvoretzky-Kiefer-Wolfowitz band
    assert np.max(np.abs(empirical - cdf)) < dkw
    assert cdf[-1] > 0.999 and (first <= epochs).mean() > 0.99


def test_slope_protection_level_is_the_bias_detected_with_one_minus_pmd():
    rng = np.random.default_rng(4)
    E, p_fa, p_md = 20_000, 1e-2, 1e-2
    r0 = raim(G, SIGMA, np.zeros(8), false_alarm=p_fa, missed_detection=p_md)
    proj = _projection_diag()
    A = G / SIGMA[:, None]
    S = np.linalg.pinv(A) / SIGMA[None, :]
    slope = np.hypot(S[0], S[1]) * SIGMA / np.sqrt(proj)
    worst = int(np.argmax(slope))
    bias = float(r0.hpl_slope_m) / np.hypot(S[0, worst], S[1, worst])  # its error at the detection limit is the HPL
    y = rng.standard_normal((E, 8)) * SIGMA
    y[:, worst] += bias
    r = raim(G, SIGMA, y, false_alarm=p_fa, missed_detection=p_md)
    lo, hi = _interval(E, p_md)
    assert lo <= 1.0 - r.chi2_detected.mean() <= hi


def test_solution_separation_pl_bounds_the_error_at_the_stated_risks():
    rng = np.random.default_rng(5)
    p_fa, p_md, risk = 1e-2, 5e-2, 1e-2
    E = 20_000
    y = rng.standard_normal((E, 8)) * SIGMA
    r = raim(G, SIGMA, y, false_alarm=p_fa, missed_detection=p_md, integrity_risk=risk, method="ss")
    e = r.error_enu_m
    assert (np.hypot(e[:, 0], e[:, 1]) > r.hpl_m).mean() <= _upper(E, risk)
    assert (np.abs(e[:, 2]) > r.vpl_m).mean() <= _upper(E, risk)
    # Faults near the detection limit on every satellite: error above the PL undetected at most p_md.
    per = 1_000
    for sat in range(8):
        for size in (2.0, 4.0, 6.0):
            yf = rng.standard_normal((per, 8)) * SIGMA
            yf[:, sat] += size * SIGMA[sat] / np.sqrt(_projection_diag()[sat])
            rf = raim(G, SIGMA, yf, false_alarm=p_fa, missed_detection=p_md, integrity_risk=risk, method="ss")
            e = rf.error_enu_m
            hmi = ((np.hypot(e[:, 0], e[:, 1]) > rf.hpl_m) | (np.abs(e[:, 2]) > rf.vpl_m)) & ~rf.ss_detected
            assert hmi.mean() <= _upper(per, p_md), (sat, size)


def test_covariance_protection_levels_bound_a_gaussian_error():
    rng = np.random.default_rng(6)
    L = np.array([[2.0, 0.0, 0.0], [1.5, 0.7, 0.0], [0.3, -0.4, 3.0]])
    C = L @ L.T
    E, risk = 40_000, 1e-2
    e = rng.standard_normal((E, 3)) @ L.T
    hpl, vpl = covariance_protection_levels(C, risk)
    lo, hi = _interval(E, risk)
    assert lo <= (np.abs(e[:, 2]) > vpl).mean() <= hi  # exact for the vertical
    assert (np.hypot(e[:, 0], e[:, 1]) > hpl).mean() <= _upper(E, risk)


def test_too_few_satellites_give_infinite_levels_and_bad_input_is_refused():
    r = raim(G[:5], SIGMA[:5], np.zeros(5))
    assert np.isinf(r.hpl_m) and np.isinf(r.vpl_m) and int(r.dof) == 1
    with pytest.raises(ConfigError, match="false_alarm"):
        raim(G, SIGMA, np.zeros(8), false_alarm=0.0)
    with pytest.raises(ConfigError, match="method"):
        raim(G, SIGMA, np.zeros(8), method="ssx")
