"""``ins-ekf`` with the IMU's scale factors and misalignments as states: its update against
Gaussian conditioning on the 33-state prior written out here, and its refusals."""

from __future__ import annotations

import numpy as np
import pytest

from gnssframework.errors import InvalidInputError
from gnssframework.inertial.calibration import calibration_prior_std
from gnssframework.interfaces import RunContext
from gnssframework.registry import create

PRIOR = {"gyro_scale_factor_ppm": 300.0, "accel_scale_factor_ppm": 200.0, "gyro_misalignment_mrad": 0.5}


@pytest.mark.parametrize("estimator", ["kf", "ekf", "ukf", "ckf", "svd-ckf"])
def test_loose_update_conditions_the_calibration_states_through_the_transition(estimator):
    """One loose update after a transition whose calibration block couples the scale factors
    and misalignments into velocity and position: the 33-state error estimate and the 15-state
    covariance are Gaussian conditioning on the prior [P0, diag(std^2)] propagated by it, with
    every estimator of the registry (the sigma-point ones too, whose factorisation must bear
    the held states' 1e-24 variance beside the position's 1e2)."""
    rng = np.random.default_rng(11)
    runs = 3
    L0 = rng.normal(size=(15, 15))
    P0 = L0 @ L0.T + np.eye(15)
    std = calibration_prior_std(300.0, 200.0, 0.5, 0.0)
    prior = np.zeros((33, 33))
    prior[:15, :15] = P0
    prior[15:, 15:] = np.diag(np.maximum(std, 1e-12) ** 2)
    Phi = np.broadcast_to(np.eye(33), (runs, 33, 33)).copy()
    Phi[:, :15, :15] += rng.normal(size=(runs, 15, 15)) * 0.05
    Phi[:, 0:9, 15:] = rng.normal(size=(runs, 9, 18)) * 2e3  # a 1e-4 scale factor moves metres
    Q = np.zeros((runs, 33, 33))
    Q[:, :15, :15] = 1e-3 * np.eye(15)
    B = rng.normal(size=(runs, 6, 6))
    R = B @ np.swapaxes(B, 1, 2) + np.eye(6)
    z = rng.normal(size=(runs, 6)) * 3.0
    ekf = create("nav_filter", "ins-ekf", estimator=estimator, **PRIOR)
    assert ekf.error_states == 33
    ekf.reset((runs,), RunContext(initial_cov=P0))
    out = ekf.step({"transition": Phi, "process_noise": Q, "position_velocity_error": z, "position_velocity_cov": R})
    P = Phi @ prior @ np.swapaxes(Phi, 1, 2) + Q
    idx = np.r_[6:9, 3:6]  # position then velocity
    S = P[:, idx][:, :, idx] + R
    K = P[:, :, idx] @ np.linalg.inv(S)
    posterior = P - K @ S @ np.swapaxes(K, 1, 2)
    assert out["error_state"].shape == (runs, 33)
    np.testing.assert_allclose(out["error_state"], np.einsum("rij,rj->ri", K, z), rtol=1e-7, atol=1e-12)
    np.testing.assert_allclose(out["cov"], posterior[:, :15, :15], rtol=1e-7, atol=1e-9)
    assert np.abs(out["error_state"][:, 15:24]).max() > 1e-6  # the scale factors learned something
    accel_cross = 24 + np.array([1, 2, 3, 5, 6, 7])  # the accelerometers' off-diagonal elements: prior 0, held
    np.testing.assert_allclose(out["error_state"][:, accel_cross], 0.0, atol=1e-15)
    assert np.all(np.abs(ekf.state.mean[:, :33]) == 0.0)  # closed loop: the INS takes it all


def test_calibration_states_show_in_the_assumptions_and_refuse_a_15_state_model():
    ekf = create("nav_filter", "ins-ekf", **PRIOR)
    ekf.reset((2,), RunContext(initial_cov=np.eye(15)))
    shown = ekf.assumptions(RunContext())
    assert shown["IMU calibration states: gyro, accelerometer scale factor"] == ("300, 200", "ppm")
    with pytest.raises(InvalidInputError, match=r"transition.*\(runs, 33, 33\).*\(2, 15, 15\) at step 0"):
        ekf.propagate(np.zeros((2, 15, 15)), np.zeros((2, 33, 33)))
    plain = create("nav_filter", "ins-ekf")
    assert plain.error_states == 15 and "IMU calibration states: gyro, accelerometer scale factor" not in (
        plain.assumptions(RunContext())
    )


def test_a_33_state_filter_without_its_own_innovation_is_not_gated_on_15_states():
    # The harness's fallback gate knows the 15 INS states only: it refuses in one line
    # rather than gate a 33-state filter on the wrong covariance.
    from gnssframework.errors import ConfigError
    from gnssframework.receiver.deep.ins_navigator import gate_innovation

    plugin_cls = type(create("nav_filter", "ins-ekf"))
    no_own = type("NoOwnInnovation", (plugin_cls,), {"innovation": lambda self, inputs: None})
    other = no_own(**PRIOR)
    other.reset((1,), RunContext(initial_cov=np.eye(15)))
    inputs = {
        "transition": np.eye(33)[None],
        "process_noise": np.zeros((1, 33, 33)),
        "position_velocity_error": np.zeros((1, 6)),
        "position_velocity_cov": np.eye(6)[None],
    }
    with pytest.raises(ConfigError, match="33 INS error states and no innovation of its own"):
        gate_innovation(other, inputs)
