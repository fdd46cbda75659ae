"""Free-inertial errors: closed-form Schuler loop, nonlinear vs linear 15-state propagation."""

from __future__ import annotations

import numpy as np
import pytest

from gnssframework.errors import ConfigError
from gnssframework.inertial import EarthModel, MechanisationOptions, NavState, TrajectoryModel, integrate, paper_profile
from gnssframework.inertial.error_model import (
    apply_navigation_error,
    correct_state,
    error_state_transition,
    navigation_error,
)
from gnssframework.inertial.frames import ecef_to_enu_offset
from gnssframework.inertial.imu import ImuGrade
from gnssframework.inertial.trajectory import static_profile


def test_stationary_ins_follows_the_schuler_loop():
    """Non-rotating Earth, body x north / y east / z down, one Schuler period at 2 s steps.
    Run 0: north accelerometer bias b -> dN = b / ws^2 (1 - cos ws t).
    Run 1: east gyro bias b -> tilt b t about east -> dN = -R b (t - sin(ws t) / ws).
    (Flat-Earth Schuler equations dN'' = -g psi_E + b_a - ws^2 dN, ws^2 = g / R; Titterton &
    Weston 2nd ed. sec. 12.3, Groves 2nd ed. sec. 5.7.)"""
    earth = EarthModel(rate_rad_s=0.0)
    model = TrajectoryModel(static_profile(34.23, 108.3576, 590.6, 6000.0), earth=earth)
    dt = 2.0
    r = np.linalg.norm(model.evaluate(np.array([0.0])).position_ecef_m)
    g = np.linalg.norm(earth.gravity_ecef(model.evaluate(np.array([0.0])).position_ecef_m))
    ws = np.sqrt(g / r)
    n = int(np.ceil(2 * np.pi / ws / dt))
    truth = model.evaluate(dt * np.arange(n + 1))
    dth, dv = model.increments(dt, n)
    b_a, b_g = 1e-3, 0.1 * np.pi / 180 / 3600
    bias_th = np.array([[0, 0, 0], [0, b_g, 0]]) * dt
    bias_dv = np.array([[b_a, 0, 0], [0, 0, 0]]) * dt
    series = integrate(
        truth.nav_state(0), dth[:, None] + bias_th, dv[:, None] + bias_dv, dt, MechanisationOptions(earth=earth)
    )
    enu = ecef_to_enu_offset(series.position_ecef_m, truth.position_ecef_m[:, None])
    t = truth.time_s
    expected_n = np.stack([b_a / ws**2 * (1 - np.cos(ws * t)), -r * b_g * (t - np.sin(ws * t) / ws)], axis=-1)
    for run in range(2):
        scale = np.abs(expected_n[:, run]).max()
        assert np.abs(enu[:, run, 1] - expected_n[:, run]).max() < 0.01 * scale, run
        assert np.abs(enu[:, run, 0]).max() < 0.01 * scale  # nothing east
    # sanity of the regime: an oscillation (accel bias returns to ~0 after one period)
    assert abs(enu[-1, 0, 1]) < 0.02 * np.abs(enu[:, 0, 1]).max()


@pytest.fixture(scope="module")
def manoeuvre():
    model = TrajectoryModel(paper_profile())
    dt = 0.005
    k0, n = 1600, 3000  # 8-23 s: boost and 30 g pull-up
    truth = model.evaluate(dt * np.arange(k0, k0 + n + 1))
    dth, dv = model.increments(dt, n, start_s=k0 * dt)
    prev = model.increments(dt, 1, start_s=(k0 - 1) * dt)
    return model, dt, truth, dth, dv, prev


def test_nonlinear_mechanisation_matches_linear_error_propagation(manoeuvre):
    """Four runs with small random initial errors and constant biases through the boost and
    the 30 g pull-up: the nonlinear errors and Phi-propagated errors agree to 1 % of their size."""
    model, dt, truth, dth, dv, (pth, pdv) = manoeuvre
    rng = np.random.default_rng(5)
    runs = 4
    dx0 = np.concatenate(
        [
            rng.normal(0, 1e-3, (runs, 3)),
            rng.normal(0, 0.1, (runs, 3)),
            rng.normal(0, 5.0, (runs, 3)),
            rng.normal(0, 10 * np.pi / 180 / 3600, (runs, 3)),
            rng.normal(0, 1e-2, (runs, 3)),
        ],
        axis=-1,
    )
    start = apply_navigation_error(truth.nav_state(0), dx0)
    n = dth.shape[0]
    series = integrate(
        start,
        dth[:, None] + dx0[:, 9:12] * dt,
        dv[:, None] + dx0[:, 12:15] * dt,
        dt,
        MechanisationOptions(),
        pth[0] + dx0[:, 9:12] * dt,
        pdv[0] + dx0[:, 12:15] * dt,
    )
    tstates = NavState(truth.q_b_e[:-1], truth.velocity_ecef_mps[:-1], truth.position_ecef_m[:-1])
    phi, _ = error_state_transition(
        tstates, dv / dt, dt, ImuGrade.perfect(), bias_model="constant", method="second-order"
    )
    lin = np.empty((n + 1, runs, 15))
    lin[0] = dx0
    for k in range(n):
        lin[k + 1] = lin[k] @ phi[k].T
    nonlin = navigation_error(
        NavState(series.q_b_e, series.velocity_ecef_mps, series.position_ecef_m),
        NavState(truth.q_b_e[:, None], truth.velocity_ecef_mps[:, None], truth.position_ecef_m[:, None]),
    )
    for block in (slice(0, 3), slice(3, 6), slice(6, 9)):
        size = np.abs(nonlin[..., block]).max()
        assert np.abs(nonlin[..., block] - lin[..., block]).max() < 0.01 * size, block
    # the comparison has teeth: with the attitude-velocity coupling's sign flipped it fails
    bad = phi.copy()
    bad[:, 3:6, 0:3] *= -1
    lin_bad = dx0.copy()
    for k in range(n):
        lin_bad = lin_bad @ bad[k].T
    assert np.abs(nonlin[-1, :, 3:6] - lin_bad[:, 3:6]).max() > 0.1 * np.abs(nonlin[..., 3:6]).max()


def test_process_noise_matches_monte_carlo_of_the_mechanisation(manoeuvre):
    """White gyro/accelerometer noise (100x the paper's ARW/VRW, so that it dominates the
    mechanisation's own truncation) through the pull-up: the sample covariance of the
    attitude and velocity errors over 300 runs matches the sum of Phi-propagated Van Loan Qd."""
    model, dt, truth, dth, dv, (pth, pdv) = manoeuvre
    k1 = 800  # 4 s, through the pull-up onset
    grade = ImuGrade(
        gyro_bias_deg_per_h=0,
        gyro_markov_sigma_deg_per_h=0,
        accel_bias_mg=0,
        accel_markov_sigma_mg=0,
        gyro_arw_deg_per_sqrt_h=1.0,
        accel_vrw_mg_per_sqrt_hz=1.0,
    )
    from gnssframework.inertial.imu import simulate_imu

    runs = 300
    rng = np.random.default_rng(6)
    mth, mdv, _ = simulate_imu(dth[:k1], dv[:k1], dt, grade, rng, (runs,))
    series = integrate(truth.nav_state(0), mth, mdv, dt, MechanisationOptions(), pth[0], pdv[0])
    err = navigation_error(
        NavState(series.q_b_e[-1], series.velocity_ecef_mps[-1], series.position_ecef_m[-1]), truth.nav_state(k1)
    )
    tstates = NavState(truth.q_b_e[:k1], truth.velocity_ecef_mps[:k1], truth.position_ecef_m[:k1])
    phi, qd = error_state_transition(tstates, dv[:k1] / dt, dt, grade, bias_model="constant")
    P = np.zeros((15, 15))
    for k in range(k1):
        P = phi[k] @ P @ phi[k].T + qd[k]
    sample = np.cov(err[:, :6].T)
    for i in range(6):
        # variance of a sample variance of a Gaussian: 2 s^4 / (runs - 1)
        assert abs(sample[i, i] - P[i, i]) < 4 * P[i, i] * np.sqrt(2 / (runs - 1)), (i, sample[i, i], P[i, i])


def test_second_order_discretisation_converges_to_van_loan(manoeuvre):
    _, _, truth, _, dv, _ = manoeuvre
    state = truth.nav_state(1000)
    f = dv[1000] / 0.005
    diffs = []
    for dt in (0.1, 0.05, 0.025):
        p1, q1 = error_state_transition(state, f, dt, ImuGrade())
        p2, q2 = error_state_transition(state, f, dt, ImuGrade(), method="second-order")
        diffs.append((np.abs(p1 - p2).max(), np.abs(q1 - q2).max() / np.abs(q1).max()))
    d = np.array(diffs)
    # truncation after the second-order term: Phi error O(dt^3), relative Qd error O(dt^2)
    np.testing.assert_allclose(np.diff(np.log(d[:, 0])) / np.log(0.5), 3.0, atol=0.2)
    np.testing.assert_allclose(np.diff(np.log(d[:, 1])) / np.log(0.5), 2.0, atol=0.3)


def test_closed_loop_correction_removes_the_error():
    model = TrajectoryModel(paper_profile())
    truth = model.evaluate(np.array([12.0])).nav_state(0)
    dx = np.concatenate([[2e-3, -1e-3, 3e-3], [0.5, -0.2, 0.1], [10.0, -3.0, 4.0], [1e-5, 0, 0], [0, 1e-3, 0]])
    est = apply_navigation_error(truth, dx)
    np.testing.assert_allclose(navigation_error(est, truth), dx[:9], rtol=1e-9, atol=1e-12)
    corrected, bg, ba = correct_state(est, dx, np.zeros(3), np.ones(3))
    np.testing.assert_allclose(navigation_error(corrected, truth), 0.0, atol=1e-9)
    np.testing.assert_allclose(bg, dx[9:12])
    np.testing.assert_allclose(ba, 1 + dx[12:15])


def test_bad_options_raise_library_errors():
    state = NavState(np.array([1.0, 0, 0, 0]), np.zeros(3), np.array([6378137.0, 0, 0]))
    with pytest.raises(ConfigError, match="method"):
        error_state_transition(state, np.zeros(3), 0.1, ImuGrade(), method="euler")
    with pytest.raises(ConfigError, match="bias_model"):
        error_state_transition(state, np.zeros(3), 0.1, ImuGrade(), bias_model="walk")
    with pytest.raises(ConfigError, match="gravity_gradient"):
        error_state_transition(state, np.zeros(3), 0.1, ImuGrade(), gravity_gradient="j4")


def test_batched_matrix_exponential_equals_scipy():
    from scipy.linalg import expm

    from gnssframework.inertial.error_model import _expm

    rng = np.random.default_rng(8)
    for scale in (1e-4, 0.1, 1.0, 20.0):
        M = rng.normal(size=(3, 30, 30)) * scale / 5
        ref = np.stack([expm(m) for m in M])
        np.testing.assert_allclose(_expm(M), ref, rtol=0, atol=1e-12 * np.abs(ref).max())
