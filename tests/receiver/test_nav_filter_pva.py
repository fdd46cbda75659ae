"""``ekf-pva``: ekf-pv with acceleration states, checked against closed forms and a hand-written KF."""

import numpy as np
import pytest
import scipy.linalg

import gnssframework as gf
from gnssframework.errors import ConfigError
from gnssframework.receiver.tracking.vector import predicted_range
from gnssframework.signal.constants import CA_CHIP_LENGTH_M, L1_WAVELENGTH_M, SPEED_OF_LIGHT_M_S
from gnssframework.simulation.clock import PRESETS
from gnssframework_plugins.nav_filter_pva import ca_clock_model

X0 = np.array([6_378_137.0, 0.0, 0.0, 0.0, 0.0, 0.0, 100.0, 1.0])
DIRS = np.array([[1, 0, 0], [0.8, 0.6, 0], [0.8, 0, 0.6], [0.7, -0.5, -0.5], [0.6, 0.4, -0.69]], float)
DIRS /= np.linalg.norm(DIRS, axis=1, keepdims=True)
SAT_POS = X0[:3] + 2.0e7 * DIRS
SAT_VEL = np.cross(DIRS, [0.0, 0.0, 1.0]) * 3000.0


def _van_loan(T: float, jerk_psd: float) -> tuple[np.ndarray, np.ndarray]:
    """F and Q of one axis [p, v, a] with white jerk, by Van Loan's matrix exponential (1978)."""
    A = np.array([[0, 1, 0], [0, 0, 1], [0, 0, 0]], float)
    GQG = np.zeros((3, 3))
    GQG[2, 2] = jerk_psd
    M = scipy.linalg.expm(np.block([[-A, GQG], [np.zeros((3, 3)), A.T]]) * T)
    F = M[3:, 3:].T
    return F, F @ M[:3, 3:]


@pytest.mark.parametrize("T", [0.001, 0.1, 1.0])
def test_ca_model_is_the_exact_discretisation_of_white_jerk(T):
    q = 3.7e3
    F, Q = ca_clock_model(T, q, "ocxo")
    F1, Q1 = _van_loan(T, q)
    axis = [0, 3, 8]  # x, vx, ax in ekf-pva's state order
    # expm's rounding is relative to the norm of the block matrix (about q T): a few ulps of it.
    tol = 64 * np.finfo(float).eps * max(1.0, q * T)
    np.testing.assert_allclose(F[np.ix_(axis, axis)], F1, rtol=1e-12, atol=tol)
    np.testing.assert_allclose(Q[np.ix_(axis, axis)], Q1, rtol=1e-9, atol=tol * np.max(Q1))
    # The clock block is ekf-pv's: the preset's two-state process noise in metres.
    np.testing.assert_allclose(Q[6:8, 6:8], SPEED_OF_LIGHT_M_S**2 * PRESETS["ocxo"].process_noise(T), rtol=1e-12)
    assert np.all(Q[6:8, [0, 1, 2, 3, 4, 5, 8, 9, 10]] == 0)
    np.testing.assert_array_equal(F[6:8, 6:8], [[1, T], [0, 1]])


def _inputs(x_true, code_chips=0.0, freq_hz=0.0, code_var=1e-4, freq_var=1e-2):
    rho, rate, _ = predicted_range(x_true, SAT_POS, SAT_VEL)
    ones = np.ones(len(DIRS))
    return {
        "replica_range_m": rho,
        "replica_rate_m_s": rate,
        "code_error_chips": code_chips * ones,
        "code_error_var_chips2": code_var * ones,
        "freq_error_hz": freq_hz * ones,
        "freq_error_var_hz2": freq_var * ones,
        "sat_pos_m": SAT_POS,
        "sat_vel_m_s": SAT_VEL,
        "next_sat_pos_m": SAT_POS,
        "next_sat_vel_m_s": SAT_VEL,
    }


def test_one_step_is_the_kalman_update_linearised_at_the_prediction():
    # An independent peer: predict with the white-jerk F, Q, then the textbook EKF update
    # with H the Jacobian at the prediction (Groves 2013, eqs. 3.24-3.30), written here.
    T, q, sa = 0.001, 2.0e3, 3.0
    P0 = np.diag([4.0] * 3 + [0.09] * 3 + [9.0, 0.09])
    nav = gf.registry.create("nav_filter", "ekf-pva", clock="ocxo", jerk_psd=q, initial_accel_std_m_s2=sa)
    nav.reset((), gf.RunContext(coherent_time_s=T, initial_state=X0, initial_cov=P0))
    x_first = X0 + np.array([0.5, -0.3, 0.2, 0.01, 0.02, -0.01, 0.4, 0.05])
    nav.step(_inputs(x_first, code_chips=0.002, freq_hz=0.3))  # the first step updates without predicting
    x_prev, P_prev = nav.state.mean.copy(), nav.state.cov.copy()
    inputs = _inputs(X0, code_chips=-0.001, freq_hz=0.5, code_var=2e-4, freq_var=3e-2)
    out = nav.step(inputs)

    F, Q = ca_clock_model(T, q, "ocxo")
    x_pred, P_pred = F @ x_prev, F @ P_prev @ F.T + Q
    rho, rate, e = predicted_range(x_pred, SAT_POS, SAT_VEL)
    n = len(DIRS)
    H = np.zeros((2 * n, 11))
    H[:n, 0:3], H[:n, 6], H[n:, 3:6], H[n:, 7] = -e, 1.0, -e, 1.0
    z = np.concatenate(
        [
            inputs["replica_range_m"] + CA_CHIP_LENGTH_M * inputs["code_error_chips"],
            inputs["replica_rate_m_s"] - L1_WAVELENGTH_M * inputs["freq_error_hz"],
        ]
    )
    R = np.diag(
        np.concatenate(
            [inputs["code_error_var_chips2"] * CA_CHIP_LENGTH_M**2, inputs["freq_error_var_hz2"] * L1_WAVELENGTH_M**2]
        )
    )
    K = P_pred @ H.T @ np.linalg.inv(H @ P_pred @ H.T + R)
    x_post = x_pred + K @ (z - np.concatenate([rho, rate]))
    P_post = (np.eye(11) - K @ H) @ P_pred
    np.testing.assert_allclose(nav.state.mean, x_post, rtol=0, atol=1e-7)
    np.testing.assert_allclose(out["position_m"], x_post[0:3], rtol=0, atol=1e-7)
    np.testing.assert_allclose(out["cov"], P_post[:8, :8], rtol=1e-6, atol=1e-12)
    assert out["cov"].shape == (8, 8)


ACC = np.array([30.0, -20.0, 10.0]) / np.sqrt(1400.0) * 30.0  # |a| = 30 m/s^2


def _track_constant_acceleration(name: str, x0: np.ndarray, P0: np.ndarray, **params) -> np.ndarray:
    """Velocity error (m/s) after 2 s of noise-free range/rate under the constant acceleration ACC."""
    T, steps = 0.001, 2000
    nav = gf.registry.create("nav_filter", name, clock="ocxo", **params)
    nav.reset((), gf.RunContext(coherent_time_s=T, initial_state=x0, initial_cov=P0))
    for k in range(steps):
        t = k * T
        x = X0.copy()
        x[0:3] += ACC * t**2 / 2
        x[3:6] = ACC * t
        x[6] += X0[7] * t
        out = nav.step(_inputs(x, freq_var=1.0))
    return out["velocity_m_s"] - x[3:6]


def test_a_known_acceleration_is_followed_where_the_constant_velocity_model_lags():
    # Both filters start at the true state (ekf-pva with the true acceleration, variance
    # 1e-6 m²/s⁴) and see noise-free range and rate. The constant-velocity model takes the
    # acceleration as noise and lags; the constant-acceleration model's prediction
    # F x carries it (F's acceleration columns), so its error stays at rounding level.
    P8 = np.diag([1.0] * 3 + [0.01] * 3 + [1.0, 0.01])
    P11 = np.zeros((11, 11))
    P11[:8, :8], P11[8:, 8:] = P8, 1e-6 * np.eye(3)
    cv = np.linalg.norm(_track_constant_acceleration("ekf-pv", X0, P8, accel_psd=1e3))
    ca = np.linalg.norm(_track_constant_acceleration("ekf-pva", np.concatenate([X0, ACC]), P11, jerk_psd=1e3))
    assert cv > 1e-4  # the lag this test is about exists (measured: 1.0e-3 m/s)
    assert ca < 1e-3 * cv


def test_an_initial_state_of_the_wrong_size_is_refused_naming_the_filter():
    nav = gf.registry.create("nav_filter", "ekf-pva")
    with pytest.raises(ConfigError, match="ekf-pva.*8 or 11 states"):
        nav.reset((), gf.RunContext(coherent_time_s=0.001, initial_state=X0[:6], initial_cov=np.eye(6)))


def test_a_non_positive_jerk_psd_is_a_config_error():
    with pytest.raises(ConfigError, match="jerk_psd"):
        gf.registry.create("nav_filter", "ekf-pva", jerk_psd=0.0)
