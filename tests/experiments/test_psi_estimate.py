"""Reference 004 with psi estimated: the AR(1) estimators against their theory, and the
multipath scenario's training record behind colored-ar1's psi_estimator."""

import numpy as np
import pytest

from gnssframework import random_streams as draw
from gnssframework.estimation.ar1_estimate import ar1_coefficient, lag1_mean_theory
from gnssframework.experiments import get_scenario
from gnssframework.simulation.impairments import ar1_noise


def _ar1(psi, n, m, seed, white_std=0.0):
    rng = np.random.default_rng(seed)
    x = ar1_noise(psi, np.sqrt(1 - psi**2), n, rng, batch_shape=(m,))  # unit stationary variance
    return x + white_std * rng.standard_normal((n, m))


def test_lag1_autocorrelation_mean_and_variance_follow_marriott_pope_and_bartlett():
    psi, n, m = 0.9, 2000, 4000
    r1 = ar1_coefficient(_ar1(psi, n, m, 1))
    se = np.sqrt((1 - psi**2) / n / m)  # Bartlett's variance over m independent records
    # The O(1/n) bias (1 + 4 psi)/n = 0.0023 is 15 standard errors: the test sees it.
    assert abs(np.mean(r1) - lag1_mean_theory(psi, n)) < 4 * se
    assert abs(np.mean(r1) - psi) > 8 * se
    # Sample variance of m estimates (relative SE sqrt(2/m) = 2 %; Bartlett's is a
    # large-n approximation, measured 5 % low here).
    assert np.var(r1, ddof=1) == pytest.approx((1 - psi**2) / n, rel=0.15)


def test_added_white_noise_biases_lag1_by_its_share_and_not_the_lag_ratio():
    psi, n, m, white_std = 0.95, 20000, 200, 0.5  # AR(1) of unit variance + 0.5 white: share 0.2
    z = _ar1(psi, n, m, 2, white_std)
    share = white_std**2 / (1 + white_std**2)
    r1 = ar1_coefficient(z, "lag1")
    assert abs(np.mean(r1) - lag1_mean_theory(psi, n, share)) < 4 * np.std(r1, ddof=1) / np.sqrt(m)
    ratio = ar1_coefficient(z, "lag-ratio")
    assert abs(np.mean(ratio) - psi) < 4 * np.std(ratio, ddof=1) / np.sqrt(m)
    assert np.mean(r1) < psi - 0.1  # lag1 alone is far off


def test_estimator_takes_the_time_axis_and_refuses_short_records():
    z = _ar1(0.5, 300, 4, 3)
    np.testing.assert_allclose(ar1_coefficient(z.T, axis=1), ar1_coefficient(z), rtol=1e-14)
    with pytest.raises(Exception, match="z"):
        ar1_coefficient(z[:2])


BASE = {
    "nav_filter": {"name": "position-ca", "params": {"q0": [1.0, 0.1, 0.01], "r0": 1.0}},
    "estimator": {"name": "ukf", "params": {"alpha": 0.01, "beta": 2.0, "kappa": 0.0}},
    "augmentation": {"name": "colored-ar1", "params": {"cross_covariance": "paper"}},
}


def test_scenario_hands_the_filter_the_training_records_estimate():
    scen = get_scenario({"kind": "multipath", "epochs": 200, "psi": 0.9, "multipath_std_m": 3.0, "white_std_m": 0.5})
    rng = draw.run_streams(4, (), range(2))
    case = {"psi": 0.8, "psi_training_epochs": 4000}
    assert scen.filter_psi(case, rng) == 0.8  # the default: the true psi
    est = scen.filter_psi(case, rng, "lag1")
    train = scen.simulate(1, rng.shared("psi-training"), 0.8, epochs=4000)[:, 0]
    assert est == np.mean(ar1_coefficient(train, "lag1"))
    # Theory for this record (two coordinates of 4000 epochs): rho_1 = 0.8 * 9 / 9.25,
    # SD sqrt((1 - rho^2) / 8000) = 0.0069.
    rho = lag1_mean_theory(0.8, 4000, 0.25 / 9.25)
    assert abs(est - rho) < 4 * np.sqrt((1 - rho**2) / 8000)
    assert abs(est - 0.8) > 0.01  # the white share's bias, 0.022, is visible
    # Same case, another batch of runs: the same estimate (the record is the case's).
    assert scen.filter_psi(case, draw.run_streams(4, (), [1]), "lag1") == est


def _candidate(estimator):
    return {
        **BASE,
        "augmentation": {"name": "colored-ar1", "params": {"cross_covariance": "paper", "psi_estimator": estimator}},
    }


def test_estimated_psi_runs_do_not_depend_on_their_batch_and_differ_from_the_true_psi_runs():
    scen = get_scenario({"kind": "multipath", "epochs": 120, "psi": 0.9})
    case = {"psi": 0.9, "psi_training_epochs": 100}
    est = scen.build(_candidate("lag1"))
    three = scen.run_batch(case, est, 3, draw.run_streams(6, (), range(3))).metrics
    one = scen.run_batch(case, est, 1, draw.run_streams(6, (), [2])).metrics
    assert three["horizontal_error_rmse"][2] == pytest.approx(one["horizontal_error_rmse"][0], rel=1e-12)
    true = scen.run_batch(case, scen.build(_candidate("truth")), 3, draw.run_streams(6, (), range(3))).metrics
    assert not np.allclose(true["horizontal_error_rmse"], three["horizontal_error_rmse"])


def test_a_given_psi_ignores_the_estimator():
    scen = get_scenario({"kind": "multipath", "epochs": 120, "psi": 0.9})
    given = {**BASE, "augmentation": {"name": "colored-ar1", "params": {"psi": 0.7, "psi_estimator": "lag1"}}}
    plain = {**BASE, "augmentation": {"name": "colored-ar1", "params": {"psi": 0.7}}}
    a = scen.run_batch({}, scen.build(given), 2, draw.run_streams(1, (), range(2))).metrics
    b = scen.run_batch({}, scen.build(plain), 2, draw.run_streams(1, (), range(2))).metrics
    np.testing.assert_array_equal(a["horizontal_error_rmse"], b["horizontal_error_rmse"])
