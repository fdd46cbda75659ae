"""A navigation filter's bank of sub-filters (`receiver.engine.filter_bank`) checked against
theory on the ``ekf-pv`` nav filter, on the truth of `navigation/test_filter_integrity.py` (`nav_filter_truth`) (the filter's
own model, seven satellites of the nominal constellation, measurements of the variances it
is told).

- A sub-filter that weighs a channel at `EXCLUDED_VAR` is the filter without that channel.
- Fault-free, the separation of each sub-filter from the full filter is N(0, P_k - P_0)
  (Brenner 1996): per axis the fraction of runs beyond one sigma is 2 Q(1), and the test's
  false alarms are at most the stated probability.
- A slow range ramp on one satellite, which the full filter absorbs as it grows, is found by
  the bank at least as early as the separation of its mean predicts (an independent
  Riccati recursion of the full filter and of the sub-filter without that satellite), and
  sooner than by the separation of one update (`filter_solution_separation`), paired on
  the same runs.
"""

import numpy as np
import pytest
from scipy.stats import norm

from gnssframework import registry
from gnssframework.errors import ConfigError
from gnssframework.interfaces import RunContext
from gnssframework.receiver.engine.filter_bank import SubFilterBank
from gnssframework.navigation.filter_integrity import filter_solution_separation, innovation_test, satellite_modes
from gnssframework.signal.gps_l1ca import GPS_L1CA
from nav_filter_truth import (
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
    _h,
    _inputs,
    _interval,
    _jacobian,
    _upper,
)

CHIP, LAM = GPS_L1CA.chip_length_m, GPS_L1CA.wavelength_m


def _run_bank(runs, epochs, fault_m=None, seed=0, p_fa=1e-2):
    """The bank (and, on the same runs, the full filter's one-update separation and
    innovation test) over ``runs`` x ``epochs``: each test's verdicts ``(epochs, runs)``,
    the bank's last `BankStep` and the true position errors (ENU) ``(epochs, runs, 3)``."""
    rng = np.random.default_rng(seed)
    r, pos, vel, sigma = _geometry(epochs)
    nav = registry.create("nav_filter", "ekf-pv")
    F, Q = nav.transition(T_S)
    bank = SubFilterBank(nav, CH, false_alarm=p_fa, missed_detection=1e-2, integrity_risk=1e-2)
    x_hat0, ctx = _context(runs, r)
    bank.reset((runs,), ctx)
    A = _enu(LAT, LON) @ np.eye(3, 8)
    bank_fault, one_fault, nis_fault, excluded, errors = [], [], [], [], []
    for k, x, z in _epochs(rng, runs, epochs, x_hat0, F, Q, pos, vel, sigma, fault_m):
        step = bank.step(_inputs(pos[k], vel[k], z, sigma, runs))
        last = nav.last_step
        u, prior = last.update, last.prior
        one = filter_solution_separation(
            prior.cov[:runs],
            u.innovation[:runs],
            u.innovation_cov[:runs],
            u.cross_cov[:runs],
            satellite_modes(CH),
            A,
            false_alarm=p_fa,
        )
        bank_fault.append(step.fault)
        excluded.append(step.excluded)
        one_fault.append(one.detected)
        nis_fault.append(innovation_test(u.innovation[:runs], u.innovation_cov[:runs], p_fa).detected)
        errors.append(step.outputs["position_m"] - x[:, 0:3])
    return {
        "bank": np.array(bank_fault),
        "one_update": np.array(one_fault),
        "innovation": np.array(nis_fault),
        "excluded": np.array(excluded),
        "last": step,
        "errors_enu_m": np.array(errors) @ _enu(LAT, LON).T,
    }


@pytest.mark.parametrize("estimator, atol_m", [("ekf", 1e-6), ("ckf", 1e-6), ("ukf", 2e-2)])
def test_a_sub_filter_is_the_filter_without_its_channel(estimator, atol_m):
    # Measured 9e-9 m (ekf), 1e-8 m (ckf) and 5e-3 m (ukf: its update's S holds the
    # 8.6e12 m² row beside 9-300 m² ones, and its sigma-point sums lose digits to it).
    runs, epochs, left_out = 3, 6, 4
    rng = np.random.default_rng(1)
    r, pos, vel, sigma = _geometry(epochs)
    bank_nav = registry.create("nav_filter", "ekf-pv", estimator=estimator)
    bank = SubFilterBank(bank_nav, CH)
    x_hat0, ctx = _context(runs, r)
    bank.reset((runs,), ctx)
    alone = registry.create("nav_filter", "ekf-pv", estimator=estimator)
    alone.reset((runs,), ctx)
    keep = np.arange(CH) != left_out
    x = x_hat0 + rng.standard_normal((runs, 8)) * np.sqrt(P0_DIAG)
    for k in range(epochs):
        z = _h(x, pos[k], vel[k]) + rng.standard_normal((runs, 2 * CH)) * sigma
        bank.step(_inputs(pos[k], vel[k], z, sigma, runs))
        sub = {
            key: (v[:, keep] if np.ndim(v) == 2 and np.shape(v) == (runs, CH) else v[keep] if np.ndim(v) == 2 else v)
            for key, v in _inputs(pos[k], vel[k], z, sigma, runs).items()
        }
        out = alone.checked_step(sub)
    got = bank_nav.state.mean.reshape(CH + 1, runs, 8)[1 + left_out]
    # EXCLUDED_VAR (1e8 chips², 8.6e12 m²) against ranges of σ 3-17 m: a left-out row
    # weighs at most ~3.5e-11 of a kept one; from innovations of tens of metres, µm pulls.
    np.testing.assert_allclose(got[:, :3], out["position_m"], rtol=0, atol=atol_m)


def test_the_fault_free_separation_has_the_covariance_the_test_assumes():
    runs, epochs, p_fa = 4_000, 12, 1e-2
    out = _run_bank(runs, epochs, seed=7, p_fa=p_fa)
    bank_fault, step, err = out["bank"], out["last"], out["errors_enu_m"]
    # Last epoch (runs independent): separation / σ_ss per mode and axis is N(0, 1).
    z = step.separation / step.sigma_ss
    lo, hi = _interval(runs, 2 * norm.sf(1.0))
    for k in range(CH):
        for q in range(3):
            assert lo <= (np.abs(z[:, k, q]) > 1).mean() <= hi, (k, q)
    assert bank_fault[-1].mean() <= _upper(runs, p_fa)  # union bound over modes and axes
    # The levels bound the fault-free error at the stated risk (1e-2 here).
    assert (np.hypot(err[-1, :, 0], err[-1, :, 1]) > step.hpl_m).mean() <= _upper(runs, 1e-2)
    assert (np.abs(err[-1, :, 2]) > step.vpl_m).mean() <= _upper(runs, 1e-2)


def _ramp_separation_theory(epochs, onset, slope_m_s, sat):
    """Per epoch the mean and the standard deviation (east, north, up) of sub-filter
    ``sat``'s separation from the full filter under the ramp: an independent Riccati
    recursion of each (the full filter's gains carry the fault's mean into its state; the
    sub-filter never sees it), ``σ_ss² = diag A (P_k - P_0) A^T``."""
    r, pos, vel, sigma = _geometry(epochs)
    F, Q = registry.create("nav_filter", "ekf-pv").transition(T_S)
    A = _enu(LAT, LON) @ np.eye(3, 8)
    keep = np.r_[np.arange(CH) != sat, np.arange(CH) != sat]
    P0, Pk, m0 = np.diag(P0_DIAG), np.diag(P0_DIAG), np.zeros(8)
    mean, sd = np.zeros((epochs, 3)), np.zeros((epochs, 3))
    for k in range(epochs):
        if k:
            P0, Pk, m0 = F @ P0 @ F.T + Q, F @ Pk @ F.T + Q, F @ m0
        H = _jacobian(r, pos[k])
        b = np.zeros(2 * CH)
        b[sat] = slope_m_s * T_S * (k - onset + 1) if k >= onset else 0.0
        S0 = H @ P0 @ H.T + np.diag(sigma**2)
        K0 = P0 @ H.T @ np.linalg.inv(S0)
        m0 = m0 + K0 @ (b - H @ m0)
        P0 = P0 - K0 @ S0 @ K0.T
        Hk, Rk = H[keep], np.diag(sigma[keep] ** 2)
        Sk = Hk @ Pk @ Hk.T + Rk
        Kk = Pk @ Hk.T @ np.linalg.inv(Sk)
        Pk = Pk - Kk @ Sk @ Kk.T
        mean[k] = -A @ m0
        sd[k] = np.sqrt(np.diag(A @ (Pk - P0) @ A.T))
    return mean, sd


def test_a_slow_ramp_is_found_by_the_bank_as_its_mean_separation_predicts_and_sooner_than_by_one_update():
    runs, epochs, onset, sat, slope, p_fa = 2_000, 60, 5, 2, 0.5, 1e-2
    t = np.arange(epochs)
    fault = np.zeros((epochs, runs, CH))
    fault[:, :, sat] = (slope * T_S * np.maximum(t - onset + 1, 0))[:, None]
    out = _run_bank(runs, epochs, fault, seed=8, p_fa=p_fa)
    bank_fault, one_fault = out["bank"], out["one_update"]
    mean, sd = _ramp_separation_theory(epochs, onset, slope, sat)
    # The test's threshold: K_fa σ_ss with K_fa = Q^-1(P_fa / (6 N)) (separation_levels).
    k_fa = norm.isf(p_fa / (6 * CH))
    # Mode `sat` alone detects at epoch t with probability max_q P(|N(μ_q, σ_q)| > K_fa σ_q)
    # or more: a lower bound on the bank's detection, and on its first detection by t.
    p_axis = norm.sf(k_fa - mean / sd) + norm.cdf(-k_fa - mean / sd)
    bound = np.maximum.accumulate(p_axis.max(axis=1))
    first = np.where(bank_fault.any(0), bank_fault.argmax(0), epochs)
    empirical = (first[:, None] <= t).mean(0)
    band = np.sqrt(np.log(2 / CONF) / (2 * runs))
    assert np.all(empirical >= bound - band)
    assert bound[-1] > 0.99  # the ramp is caught within the run ...
    assert empirical[onset + 5] < 0.5  # ... not at once
    # At its first detection the bank excludes the faulty satellite in most runs (measured
    # 94 % of 2,000; a binomial standard error of 0.5 %).
    caught = bank_fault.any(0) & (first >= onset)
    at_first = out["excluded"][first[caught], np.flatnonzero(caught)]
    assert caught.mean() > 0.95 and (at_first == sat).mean() > 0.9
    # Paired on the same runs: the bank's first detection comes sooner than one update's.
    first_one = np.where(one_fault.any(0), one_fault.argmax(0), epochs)
    d = first_one - first
    assert d.mean() > 4 * d.std(ddof=1) / np.sqrt(runs)


def test_bad_bank_settings_are_refused_in_one_line():
    nav = registry.create("nav_filter", "ekf-pv")
    with pytest.raises(ConfigError, match="channels"):
        SubFilterBank(nav, 1)
    with pytest.raises(ConfigError, match="false_alarm"):
        SubFilterBank(nav, 5, false_alarm=0.0)
    with pytest.raises(ConfigError, match="batch"):
        SubFilterBank(nav, 5).reset((2, 3), RunContext(coherent_time_s=1.0))
