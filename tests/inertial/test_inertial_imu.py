"""IMU error model: Gauss-Markov autocovariance, exact discretisation, Allan-variance laws."""

from __future__ import annotations

import allantools
import numpy as np
import pytest

from gnssframework.errors import ConfigError
from gnssframework.inertial.imu import ImuGrade, gauss_markov, simulate_imu


def test_gauss_markov_autocovariance_and_exact_discretisation():
    """Per-run autocovariance at several lags against sigma^2 exp(-lag dt / tau), with the
    run-to-run spread as standard error. dt = 60 s against tau = 300 s makes the exact
    factor exp(-0.2) = 0.8187 distinguishable from Euler's 1 - 0.2 = 0.8."""
    rng = np.random.default_rng(1)
    sigma, tau, dt, runs, n = 2.0, 300.0, 60.0, 400, 500
    x = gauss_markov(rng, (n, runs), sigma, tau, dt)
    # stationary start: the first sample already has variance sigma^2
    assert abs(np.var(x[0]) / sigma**2 - 1) < 4 * np.sqrt(2 / runs)
    for lag in (0, 1, 5, 10):
        per_run = np.mean(x[: n - lag] * x[lag:], axis=0)
        mean, se = per_run.mean(), per_run.std(ddof=1) / np.sqrt(runs)
        expected = sigma**2 * np.exp(-lag * dt / tau)
        assert abs(mean - expected) < 4 * se, (lag, mean, expected, se)
    # lag-1 regression coefficient: exact discretisation, not Euler's
    phi = np.sum(x[:-1] * x[1:]) / np.sum(x[:-1] ** 2)
    se_phi = np.sqrt((1 - phi**2) / x[:-1].size)
    assert abs(phi - np.exp(-dt / tau)) < 4 * se_phi
    assert abs(phi - (1 - dt / tau)) > 8 * se_phi


def _adev_runs(rate, fs, taus):
    """Overlapping Allan variance of each run's rate series (axis 0 time), run mean and SE."""
    avar = []
    for r in range(rate.shape[1]):
        t, dev, *_ = allantools.oadev(rate[:, r], rate=fs, data_type="freq", taus=taus)
        np.testing.assert_allclose(t, taus)
        avar.append(dev**2)
    avar = np.array(avar)
    return avar.mean(axis=0), avar.std(axis=0, ddof=1) / np.sqrt(avar.shape[0])


def test_white_noise_follows_the_random_walk_allan_law():
    """Rates from the simulated increments: AVAR(tau) = N^2 / tau with N the ARW / VRW
    (0.01 deg/sqrt(h) = 0.01 pi/180/60 rad/sqrt(s); 0.01 mg/sqrt(Hz) = 0.01e-3 * 9.80665 m/s^2/sqrt(Hz))."""
    grade = ImuGrade(gyro_bias_deg_per_h=0, gyro_markov_sigma_deg_per_h=0, accel_bias_mg=0, accel_markov_sigma_mg=0)
    dt, n, runs = 0.01, 20000, 8
    dth, dv, _ = simulate_imu(np.zeros((n, 3)), np.zeros((n, 3)), dt, grade, np.random.default_rng(2), (runs,))
    taus = np.array([0.1, 1.0, 10.0])
    for inc, density in ((dth, 0.01 * np.pi / 180 / 60), (dv, 0.01e-3 * 9.80665)):
        for axis in range(3):
            avar, se = _adev_runs(inc[:, :, axis] / dt, 1 / dt, taus)
            expected = density**2 / taus
            assert np.all(np.abs(avar - expected) < 4 * se + 1e-3 * expected), (avar, expected, se)


def test_gauss_markov_follows_its_allan_law():
    """AVAR of a first-order Gauss-Markov rate (sigma, T): (2 sigma^2 T / tau) [1 - (T / 2 tau)
    (3 - 4 e^{-tau/T} + e^{-2 tau/T})]: rate random walk (2/3) sigma^2 tau / T for tau << T,
    white 2 sigma^2 T / tau for tau >> T (IEEE Std 952 / El-Sheimy et al. 2008)."""
    grade = ImuGrade(
        gyro_bias_deg_per_h=0,
        gyro_arw_deg_per_sqrt_h=0,
        accel_bias_mg=0,
        accel_vrw_mg_per_sqrt_hz=0,
        gyro_markov_sigma_deg_per_h=0.1,
        gyro_markov_tau_s=300.0,
    )
    dt, n, runs = 1.0, 30000, 40
    dth, _, errors = simulate_imu(np.zeros((n, 3)), np.zeros((n, 3)), dt, grade, np.random.default_rng(3), (runs,))
    sigma, T = 0.1 * np.pi / 180 / 3600, 300.0
    taus = np.array([10.0, 100.0, 300.0, 1000.0, 3000.0])
    avar, se = _adev_runs(dth[:, :, 0] / dt, 1 / dt, taus)
    x = taus / T
    expected = 2 * sigma**2 * T / taus * (1 - (3 - 4 * np.exp(-x) + np.exp(-2 * x)) / (2 * x))
    assert np.all(np.abs(avar - expected) < 4 * se), (avar / expected, se / expected)
    # the realisation handed back is the process that was added
    np.testing.assert_allclose(errors.gyro_bias_rad_s * dt, dth)


def test_random_constants_and_scale_factor_per_run():
    grade = ImuGrade(
        gyro_markov_sigma_deg_per_h=0,
        gyro_arw_deg_per_sqrt_h=0,
        accel_markov_sigma_mg=0,
        accel_vrw_mg_per_sqrt_hz=0,
        gyro_scale_factor_ppm=100.0,
    )
    runs, dt = 4000, 0.005
    true_dth = np.tile([[0.01, -0.02, 0.03]], (3, 1))
    dth, dv, e = simulate_imu(true_dth, np.zeros((3, 3)), dt, grade, np.random.default_rng(4), (runs,))
    # constant over time within a run, independent across runs with the grade's deviation
    np.testing.assert_allclose(dth[0], dth[2])
    bias = (dth[0] - (1 + e.gyro_scale_factor) * true_dth[0]) / dt
    np.testing.assert_allclose(bias, e.gyro_bias_rad_s[0], rtol=1e-9, atol=1e-15)
    assert abs(bias.std() / grade.gyro_bias_rad_s - 1) < 4 / np.sqrt(2 * bias.size)
    assert abs(e.gyro_scale_factor.std() / 100e-6 - 1) < 4 / np.sqrt(2 * e.gyro_scale_factor.size)
    assert abs((dv[0] / dt).std() / grade.accel_bias_mps2 - 1) < 4 / np.sqrt(2 * runs * 3)
    # common random numbers: same generator state, same draws
    again = simulate_imu(true_dth, np.zeros((3, 3)), dt, grade, np.random.default_rng(4), (runs,))
    np.testing.assert_array_equal(again[0], dth)


def test_grade_validation_names_the_field():
    with pytest.raises(Exception, match="gyro_markov_tau_s"):
        ImuGrade(gyro_markov_tau_s=0.0)
    with pytest.raises(ConfigError, match="dt_s"):
        simulate_imu(np.zeros((2, 3)), np.zeros((2, 3)), -1.0, ImuGrade(), np.random.default_rng(0))
