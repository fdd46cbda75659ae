"""Range-bias states of ``ekf-pv``/``ekf-pva`` (`plugins/range_bias.py`): the filter's
position covariance against Monte Carlo truth drawn from the error budget it is told, the
least-squares prior against sampled fixes, and the refusals.

The truth here is written apart from the filter: satellites of the nominal constellation
seen from one place (elevations by pymap3d), a static receiver, pseudoranges carrying a
vertical ionospheric residual mapped by the Klobuchar obliquity factor, a zenith
tropospheric residual mapped by DO-229's function, and a SISRE bias per satellite, drawn per
run and constant; the first fix is a least-squares solution of the biased ranges, solved
by Gauss-Newton on the full nonlinear ranges.
"""

import numpy as np
import pymap3d
import pytest
from scipy.stats import chi2

import gnssframework as gf
from gnssframework.errors import ConfigError
from gnssframework.receiver.navigation.vector_config import vector_config
from gnssframework.signal.gps_l1ca import GPS_L1CA
from gnssframework.simulation.constellation import nominal_constellation
from gnssframework.simulation.propagation import klobuchar_obliquity, least_squares_fix_error, tropo_mapping
from gnssframework_plugins.range_bias import RangeBiasBudget, RangeBiasParams, least_squares_prior

LAT, LON, H = 45.0, 7.0, 300.0
T_S, STEPS, RUNS = 1.0, 40, 300
SISRE, IONO, TROPO = 0.6, 2.0, 0.05
SIGMA_RANGE_M, SIGMA_RATE_M_S = 0.3, 0.05
P0 = np.diag([3.0, 3.0, 3.0, 0.3, 0.3, 0.3, 3.0, 0.3]) ** 2
CONF = 1e-4  # probability of a correct implementation failing one interval


def _sky():
    """Receiver ECEF position, satellites above 10 deg (ECEF, velocity zero: a frozen sky),
    their elevations (pymap3d)."""
    rx = np.array(pymap3d.geodetic2ecef(LAT, LON, H))
    sats = nominal_constellation().state(37800.0)[0]
    az, el, _ = pymap3d.ecef2aer(sats[:, 0], sats[:, 1], sats[:, 2], LAT, LON, H)
    keep = el > 10.0
    return rx, sats[keep], np.asarray(el)[keep]


def _gauss_newton_fix(rho, sats, start):
    """Position and clock bias solving the pseudoranges ``rho (runs, ch)`` by Gauss-Newton."""
    x = np.broadcast_to(np.append(start, 0.0), rho.shape[:1] + (4,)).copy()
    for _ in range(8):
        los = sats - x[:, None, :3]
        dist = np.linalg.norm(los, axis=-1)
        G = np.concatenate([-los / dist[..., None], np.ones(dist.shape + (1,))], axis=-1)
        res = rho - dist - x[:, 3:4]
        dx = np.stack([np.linalg.lstsq(G[i], res[i], rcond=None)[0] for i in range(len(x))])
        x += dx
    return x


def test_least_squares_fix_error_is_the_fix_of_the_biased_ranges():
    rx, sats, _ = _sky()
    rng = np.random.default_rng(1)
    bias = rng.normal(0.0, 3.0, (5, len(sats)))
    clock = 100.0
    rho = np.linalg.norm(sats - rx, axis=-1) + clock + bias
    fix = _gauss_newton_fix(rho, sats, rx + 50.0)
    dx = least_squares_fix_error(bias, sats, np.broadcast_to(rx, (5, 3)))
    # Linearised at the truth: the nonlinear fix differs by second-order terms, |dx|^2 / range
    # per range (about 6 um here), which the geometry amplifies by at most its GDOP (< 10).
    tol = 10 * np.max(np.linalg.norm(dx, axis=-1)) ** 2 / np.min(np.linalg.norm(sats - rx, axis=-1))
    np.testing.assert_allclose(fix[:, :3] - rx, dx[:, :3], atol=tol)
    np.testing.assert_allclose(fix[:, 3] - clock, dx[:, 3], atol=tol)
    assert np.max(np.abs(dx)) > 1e4 * tol  # the errors compared are metres


def test_the_least_squares_prior_is_the_covariance_of_sampled_fixes():
    rx, sats, el = _sky()
    budget = RangeBiasBudget(SISRE, IONO, TROPO, None, len(sats))
    rows = budget.rows(el)
    P_b = np.diag(budget.std_m() ** 2)
    los = (sats - rx) / np.linalg.norm(sats - rx, axis=-1, keepdims=True)
    prior = least_squares_prior(np.zeros((8, 8)), P_b, rows, los, 8)
    rng = np.random.default_rng(2)
    n = 200_000
    b = rng.normal(size=(n, budget.size)) * budget.std_m()
    fix = least_squares_fix_error(b @ rows.T, sats, np.broadcast_to(rx, (n, 3)))
    err = np.zeros((n, 8 + budget.size))
    err[:, 0:3], err[:, 6], err[:, 8:] = fix[:, :3], fix[:, 3], -b  # the bias estimate starts at 0
    sample = err.T @ err / n
    # Each sampled covariance entry's standard error is at most sqrt(2 / n) of sqrt(P_ii P_jj).
    scale = np.sqrt(np.outer(np.diag(prior), np.diag(prior)))
    assert np.all(np.abs(sample - prior) <= 6 * np.sqrt(2 / n) * scale + 1e-12)


def _run(nav_params: dict, fix_from_ranges: bool, seed: int = 3, name: str = "ekf-pv") -> float:
    """Mean position NEES over the runs at the last step of a filter told ``nav_params``."""
    rx, sats, el = _sky()
    ch = len(sats)
    rng = np.random.default_rng(seed)
    iono = rng.normal(0.0, IONO, (RUNS, 1))
    tropo = rng.normal(0.0, TROPO, (RUNS, 1))
    sisre = rng.normal(0.0, SISRE, (RUNS, ch))
    bias = iono * klobuchar_obliquity(el) + tropo * tropo_mapping(el) + sisre  # (runs, ch)
    clock = np.array([30.0, 0.2])
    truth = np.concatenate([rx, np.zeros(3), clock])
    x0 = truth + rng.normal(size=(RUNS, 8)) @ np.sqrt(P0)
    if fix_from_ranges:
        dx = least_squares_fix_error(bias, sats, np.broadcast_to(rx, (RUNS, 3)))
        x0[:, 0:3] += dx[:, :3]
        x0[:, 6] += dx[:, 3]
    dynamics = {"accel_psd": 1e-6} if name == "ekf-pv" else {"jerk_psd": 1e-8, "initial_accel_std_m_s2": 0.01}
    nav = gf.registry.create("nav_filter", name, clock="ocxo", **dynamics, **nav_params)
    nav.reset((RUNS,), gf.RunContext(coherent_time_s=T_S, initial_state=x0, initial_cov=P0))
    chip_m, lam = GPS_L1CA.chip_length_m, GPS_L1CA.wavelength_m
    geo = np.linalg.norm(sats - rx, axis=-1)
    for k in range(STEPS):
        t = (k + 0.5) * T_S
        true_clock = clock[0] + clock[1] * t
        replica = np.broadcast_to(geo + true_clock, (RUNS, ch))  # what the NCO would have replicated
        code = (bias + rng.normal(0.0, SIGMA_RANGE_M, (RUNS, ch))) / chip_m
        freq = -rng.normal(0.0, SIGMA_RATE_M_S, (RUNS, ch)) / lam
        out = nav.step(
            {
                "replica_range_m": replica,
                "replica_rate_m_s": np.full((RUNS, ch), clock[1]),
                "code_error_chips": code,
                "code_error_var_chips2": np.full((RUNS, ch), (SIGMA_RANGE_M / chip_m) ** 2),
                "freq_error_hz": freq,
                "freq_error_var_hz2": np.full((RUNS, ch), (SIGMA_RATE_M_S / lam) ** 2),
                "sat_pos_m": sats,
                "sat_vel_m_s": np.zeros_like(sats),
                "next_sat_pos_m": sats,
                "next_sat_vel_m_s": np.zeros_like(sats),
            }
        )
    err = out["position_m"] - rx
    cov = out["cov"][..., 0:3, 0:3]
    assert cov.shape == (RUNS, 3, 3)  # the outputs stay the eight states' marginal
    return float(np.mean(np.einsum("ri,rij,rj->r", err, np.linalg.inv(cov), err)))


def _band(states: int = 3) -> tuple[float, float]:
    dof = RUNS * states
    return chi2.ppf(CONF / 2, dof) / RUNS, chi2.ppf(1 - CONF / 2, dof) / RUNS


BUDGET = {"sisre_std_m": SISRE, "iono_vertical_std_m": IONO, "tropo_zenith_std_m": TROPO}


@pytest.mark.parametrize("name", ["ekf-pv", "ekf-pva"])
def test_with_its_budget_the_filter_is_consistent_and_without_it_is_not(name):
    lo, hi = _band()
    # The budget's states: the position NEES of 300 runs x 3 states inside the chi-square band.
    # The truth's clock and position have no process noise, which the filter allows a little of:
    # that can only lower the NEES, by far less than the band's width.
    assert lo <= _run(BUDGET, False, name=name) <= hi
    # The same filter on the same draws with no budget: metres of bias it calls centimetres.
    assert _run({}, False, name=name) > 10 * hi


def test_a_first_fix_from_the_biased_ranges_needs_the_least_squares_prior():
    lo, hi = _band()
    assert lo <= _run({**BUDGET, "initial_fix_from_ranges": True}, True) <= hi
    # The prior that takes the fix's error as independent of the biases is overconfident.
    assert _run(BUDGET, True) > hi


def test_gauss_markov_bias_states_keep_their_stationary_variance():
    budget = RangeBiasBudget.of(RangeBiasParams(sisre_std_m=0.6, iono_vertical_std_m=2.0, range_bias_time_s=300.0), 5)
    psi, q = budget.transition(7.0)
    var = budget.std_m() ** 2
    np.testing.assert_allclose(psi**2 * var + q, var, rtol=1e-12)
    assert np.all(psi < 1.0)
    psi, q = RangeBiasBudget.of(RangeBiasParams(sisre_std_m=0.6), 5).transition(7.0)
    assert np.all(psi == 1.0) and np.all(q == 0.0)  # None: random constants


def _still_inputs(rx: np.ndarray, sats: np.ndarray) -> dict:
    """One step's inputs for a receiver at ``rx`` whose replica is right (clock 30 m, 0.2 m/s)."""
    z = np.zeros(len(sats))
    return {
        "replica_range_m": np.linalg.norm(sats - rx, axis=-1) + 30.0,
        "replica_rate_m_s": z + 0.2,
        "code_error_chips": z,
        "code_error_var_chips2": z + 1e-3,
        "freq_error_hz": z,
        "freq_error_var_hz2": z + 1e-2,
        "sat_pos_m": sats,
        "sat_vel_m_s": np.zeros_like(sats),
        "next_sat_pos_m": sats,
        "next_sat_vel_m_s": np.zeros_like(sats),
    }


def _started(**params) -> tuple:
    rx, sats, _ = _sky()
    nav = gf.registry.create("nav_filter", "ekf-pv", clock="ocxo", **params)
    x0 = np.concatenate([rx, np.zeros(3), [30.0, 0.2]])
    nav.reset((), gf.RunContext(coherent_time_s=T_S, initial_state=x0, initial_cov=P0))
    return nav, rx, sats


def test_no_budget_adds_no_state():
    nav, rx, sats = _started()
    nav.step(_still_inputs(rx, sats))
    assert nav.state.mean.shape == (8,) and not nav.fixed_channel_set()
    assert _started(iono_vertical_std_m=2.0)[0].fixed_channel_set()


def test_a_changing_channel_set_is_refused_naming_the_step():
    nav, rx, sats = _started(sisre_std_m=0.6)
    nav.step(_still_inputs(rx, sats))
    assert nav.fixed_channel_set() and nav.state.mean.shape == (8 + len(sats),)
    with pytest.raises(ConfigError) as info:
        nav.step(_still_inputs(rx, sats[:-1]))
    assert info.value.field == "nav_filter 'ekf-pv'.sisre_std_m"
    assert f"step 1 has {len(sats) - 1} channels, the first had {len(sats)}" in str(info.value)


@pytest.mark.parametrize("budget", [{"sisre_std_m": 0.6}, {"iono_vertical_std_m": 2.0}])
def test_the_receiver_refuses_range_bias_states_in_one_line(budget):
    with pytest.raises(ConfigError) as info:
        vector_config(nav_params=budget)
    assert info.value.field == "vector.nav_params"
    assert "satellites come and go" in str(info.value) and "\n" not in str(info.value)
    vector_config(nav_params={"sisre_std_m": 0.0})  # no budget: accepted


def test_the_filtered_positions_refuse_range_bias_states_before_any_epoch():
    from gnssframework.receiver.navigation.filtered import filter_epochs

    with pytest.raises(ConfigError) as info:
        filter_epochs(None, [None], "ekf-pv", {"tropo_zenith_std_m": 0.05})
    assert info.value.field == "nav_filter.params"
