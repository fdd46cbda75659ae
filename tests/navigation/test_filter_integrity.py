"""The navigation filter's integrity tests (`navigation.filter_integrity`) checked against
theory, on the ``ekf-pv`` nav filter.

The Monte Carlo runs draw the truth from the filter's own model (initial state from its
prior, white acceleration and clock noise from its ``transition(T)``) on seven satellites
of the nominal constellation seen from one place, moving over the run, and feed the
filter the true ranges and rates plus Gaussian noise of the variances it is told. Then the
innovations are white and ``N(0, S)`` (Bar-Shalom et al. 2001, sec. 5.2.4) up to the
linearisation of ranges 2e7 m long. Each check compares a measured frequency with what
theory gives, inside a binomial interval (or a Dvoretzky-Kiefer-Wolfowitz band for a
whole distribution) of probability ``1 - 1e-4``. The detection theory of the ramp is an
independent Kalman recursion written here (Riccati and the fault's mean through the
gains), not the filter's outputs.
"""

import numpy as np
import pytest
from scipy.stats import chi2, ncx2, norm

from gnssframework import registry
from gnssframework.errors import ConfigError
from gnssframework.navigation.filter_integrity import filter_solution_separation, innovation_test, satellite_modes
from gnssframework.navigation.integrity import covariance_protection_levels

from nav_filter_truth import (  # the truth shared with receiver/test_filter_bank.py
    CH,
    CONF,
    LAT,
    LON,
    P0_DIAG,
    T_S,
    _context,
    _enu,
    _epochs,
    _geometry,
    _inputs,
    _interval,
    _jacobian,
    _upper,
)


def _run(runs: int, epochs: int, fault_m: np.ndarray | None = None, seed: int = 0, estimator: str = "ekf"):
    """Run ``ekf-pv`` (with ``estimator``) over ``runs`` x ``epochs`` with an optional range
    fault ``(epochs, runs, CH)`` added to the measurements; returns the statistics
    ``ν^T S^-1 ν`` ``(epochs, runs)``, the position errors ``(epochs, runs, 3)`` in east,
    north, up and the last step."""
    rng = np.random.default_rng(seed)
    r, pos, vel, sigma = _geometry(epochs)
    nav = registry.create("nav_filter", "ekf-pv", estimator=estimator)
    F, Q = nav.transition(T_S)
    x_hat0, ctx = _context(runs, r)
    nav.reset((runs,), ctx)
    stats, errors = [], []
    for k, x, z in _epochs(rng, runs, epochs, x_hat0, F, Q, pos, vel, sigma, fault_m):
        nav.step(_inputs(pos[k], vel[k], z, sigma, runs))
        u = nav.last_step.update
        stats.append(innovation_test(u.innovation, u.innovation_cov, 1e-2).statistic)
        errors.append(nav.state.mean[:, 0:3] - x[:, 0:3])
    return np.array(stats), np.array(errors) @ _enu(LAT, LON).T, nav.last_step


def test_innovation_test_matches_an_explicit_quadratic_form_and_masks_rows():
    rng = np.random.default_rng(0)
    L = rng.standard_normal((5, 6, 6))
    S = L @ np.swapaxes(L, -1, -2) + np.eye(6)
    nu = rng.standard_normal((5, 6))
    used = np.ones((5, 6), bool)
    used[1, [0, 4]] = False
    t = innovation_test(nu, S, 1e-3, used)
    for b in range(5):
        keep = used[b]
        expect = nu[b, keep] @ np.linalg.inv(S[b][np.ix_(keep, keep)]) @ nu[b, keep]
        assert t.statistic[b] == pytest.approx(expect, rel=1e-10)
        assert t.dof[b] == keep.sum() and t.threshold[b] == pytest.approx(chi2.isf(1e-3, keep.sum()))
    with pytest.raises(ConfigError, match="false_alarm"):
        innovation_test(nu, S, 1.5)


def test_filter_separation_matches_explicit_subset_updates():
    rng = np.random.default_rng(1)
    n, sats = 8, 6
    m = 2 * sats
    L = rng.standard_normal((n, n))
    P = L @ L.T + np.eye(n)
    Hm = rng.standard_normal((m, n))
    R = np.diag(rng.uniform(0.5, 2.0, m))
    nu = rng.standard_normal(m) * 3
    S, C = Hm @ P @ Hm.T + R, P @ Hm.T
    A = np.linalg.qr(rng.standard_normal((3, 3)))[0] @ np.eye(3, n)
    out = filter_solution_separation(P, nu, S, C, satellite_modes(sats), A, false_alarm=1e-3)

    def update(rows):  # the information form: independent of the module's gain algebra
        Wr = np.linalg.inv(R[np.ix_(rows, rows)])
        Pk = np.linalg.inv(np.linalg.inv(P) + Hm[rows].T @ Wr @ Hm[rows])
        return Pk @ Hm[rows].T @ Wr @ nu[rows], Pk

    dx0, P0 = update(np.arange(m))
    for k in range(sats):
        dxk, Pk = update(np.flatnonzero(~satellite_modes(sats)[k]))
        assert out.separation_enu_m[k] == pytest.approx(A @ (dxk - dx0), rel=1e-9, abs=1e-12)
        assert out.sigma_ss_m[k] ** 2 == pytest.approx(np.diag(A @ (Pk - P0) @ A.T), rel=1e-8)
    assert out.error_sigma_enu_m**2 == pytest.approx(np.diag(A @ P0 @ A.T), rel=1e-9)
    with pytest.raises(ConfigError, match="modes"):
        filter_solution_separation(P, nu, S, C, satellite_modes(sats + 1), A)


@pytest.mark.parametrize("estimator", ["ekf", pytest.param("ckf", marks=pytest.mark.slow)])  # ckf: ~15 s
def test_fault_free_innovation_test_false_alarm_rate_is_the_stated_one(estimator):
    runs, epochs, p_fa = 2_000, 12, 1e-2
    stats, _, _ = _run(runs, epochs, seed=2, estimator=estimator)
    threshold = chi2.isf(p_fa, 2 * CH)
    lo, hi = _interval(stats.size, p_fa)  # 24 000 independent epoch-runs: the innovations are white
    assert lo <= (stats > threshold).mean() <= hi
    # The whole distribution: chi-square with 2 CH = 14 degrees of freedom, inside the DKW band.
    grid = chi2.ppf(np.linspace(0.01, 0.99, 99), 2 * CH)
    empirical = (stats.ravel()[:, None] <= grid).mean(0)
    assert np.max(np.abs(empirical - chi2.cdf(grid, 2 * CH))) < np.sqrt(np.log(2 / CONF) / (2 * stats.size))


def _ramp_theory(epochs: int, onset: int, slope_m: float, sat: int, p_fa: float) -> np.ndarray:
    """Per epoch the probability the innovation test detects a range ramp ``slope (t - onset
    + 1)`` on ``sat`` from ``onset``: the fault's mean innovation through an independent
    Kalman recursion (the Riccati's gains; the mean error the fault leaves in the state,
    carried by F), its noncentrality, and ``ncx2.sf``."""
    r, pos, vel, sigma = _geometry(epochs)
    F, Q = registry.create("nav_filter", "ekf-pv").transition(T_S)
    P, mean_err = np.diag(P0_DIAG), np.zeros(8)
    threshold = chi2.isf(p_fa, 2 * CH)
    p_det = np.empty(epochs)
    for k in range(epochs):
        if k:
            P, mean_err = F @ P @ F.T + Q, F @ mean_err
        H = _jacobian(r, pos[k])
        S = H @ P @ H.T + np.diag(sigma**2)
        K = P @ H.T @ np.linalg.inv(S)
        b = np.zeros(2 * CH)
        b[sat] = slope_m * (k - onset + 1) if k >= onset else 0.0
        mu = b - H @ mean_err  # ν = -H δ⁻ + v + b
        lam = float(mu @ np.linalg.solve(S, mu))
        p_det[k] = ncx2.sf(threshold, 2 * CH, lam) if lam > 0 else p_fa
        mean_err = mean_err + K @ mu
        P = P - K @ S @ K.T
    return p_det


def test_ramp_fault_is_detected_at_the_epochs_the_noncentral_chi2_predicts():
    runs, epochs, onset, sat, p_fa, slope = 3_000, 22, 4, 2, 1e-2, 2.0
    p_det = _ramp_theory(epochs, onset, slope, sat, p_fa)
    t = np.arange(epochs)
    fault = np.zeros((epochs, runs, CH))
    fault[:, :, sat] = (slope * np.maximum(t - onset + 1, 0))[:, None]
    stats, _, _ = _run(runs, epochs, fault, seed=3)
    detected = stats > chi2.isf(p_fa, 2 * CH)
    after = detected[onset:]
    first = np.where(after.any(0), after.argmax(0), epochs - onset)  # epochs after the onset
    cdf = 1.0 - np.cumprod(1.0 - p_det[onset:])  # P(first detection <= onset + s)
    assert cdf[-1] > 0.999 and cdf[0] < 0.1  # the ramp is caught within the run, not at once
    empirical = (first[:, None] <= np.arange(epochs - onset)).mean(0)
    assert np.max(np.abs(empirical - cdf)) < np.sqrt(np.log(2 / CONF) / (2 * runs))
    # The expected detection epoch (after the onset), against the runs' mean within 4 standard errors.
    expected = np.sum(1.0 - cdf[:-1])
    assert abs(first.mean() - expected) < 4 * first.std() / np.sqrt(runs)
    # Before the onset only false alarms.
    lo, hi = _interval(detected[:onset].size, p_fa)
    assert lo <= detected[:onset].mean() <= hi


def test_filter_protection_levels_bound_the_fault_free_error_at_the_stated_risk():
    runs, epochs, risk, p_fa, p_md = 20_000, 6, 1e-2, 1e-2, 5e-2
    _, err, last = _run(runs, epochs, seed=4)
    e = err[-1]  # the last epoch: runs independent (epochs of one run are not)
    P = last.posterior.cov[:, 0:3, 0:3]
    Renu = _enu(LAT, LON)
    hpl, vpl = covariance_protection_levels(Renu @ P @ Renu.T, risk)
    lo, hi = _interval(runs, risk)
    assert lo <= (np.abs(e[:, 2]) > vpl).mean() <= hi  # exact for the vertical
    assert (np.hypot(e[:, 0], e[:, 1]) > hpl).mean() <= _upper(runs, risk)
    u = last.update
    A = Renu @ np.eye(3, 8)
    ss = filter_solution_separation(
        last.prior.cov,
        u.innovation,
        u.innovation_cov,
        u.cross_cov,
        satellite_modes(CH),
        A,
        false_alarm=p_fa,
        missed_detection=p_md,
        integrity_risk=risk,
    )
    assert ss.detected.mean() <= _upper(runs, p_fa)  # union bound: at most P_fa
    assert (np.hypot(e[:, 0], e[:, 1]) > ss.hpl_m).mean() <= _upper(runs, risk)
    assert (np.abs(e[:, 2]) > ss.vpl_m).mean() <= _upper(runs, risk)
    # The separation has the covariance the test assumes: per axis, separation / σ_ss is N(0, 1)
    # (mode 0; the modes of one run are correlated, the runs are not).
    z = ss.separation_enu_m[:, 0] / ss.sigma_ss_m[:, 0]
    lo, hi = _interval(runs, 2 * norm.sf(1.0))
    for q in range(3):
        assert lo <= (np.abs(z[:, q]) > 1).mean() <= hi, q


def test_filter_separation_bounds_an_undetected_step_at_the_missed_detection_risk():
    per, epochs, p_fa, p_md, risk = 400, 5, 1e-2, 5e-2, 1e-2
    sizes = (3.0, 6.0, 9.0)  # in units of the range's σ
    runs = per * CH * len(sizes)
    _, _, sigma = _geometry(1)[1:]
    cases = np.stack(np.meshgrid(np.arange(CH), np.arange(len(sizes)), indexing="ij"), -1).reshape(-1, 2)
    sat, size = np.repeat(cases[:, 0], per), np.repeat(np.array(sizes)[cases[:, 1]], per)
    fault = np.zeros((epochs, runs, CH))
    fault[-1, np.arange(runs), sat] = size * sigma[sat]  # a step at the last epoch: the prior is fault-free
    _, err, last = _run(runs, epochs, fault, seed=5)
    u = last.update
    ss = filter_solution_separation(
        last.prior.cov,
        u.innovation,
        u.innovation_cov,
        u.cross_cov,
        satellite_modes(CH),
        _enu(LAT, LON) @ np.eye(3, 8),
        false_alarm=p_fa,
        missed_detection=p_md,
        integrity_risk=risk,
    )
    e = err[-1]
    hmi = ((np.hypot(e[:, 0], e[:, 1]) > ss.hpl_m) | (np.abs(e[:, 2]) > ss.vpl_m)) & ~ss.detected
    for c in range(len(cases)):
        assert hmi[c * per : (c + 1) * per].mean() <= _upper(per, p_md), cases[c]
    assert ss.detected[size == 9.0].mean() > 0.5  # the large steps are seen at all
