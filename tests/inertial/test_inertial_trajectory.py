"""Trajectory generator: coordinated-flight attitude, static and straight profiles, input errors."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from gnssframework.errors import ConfigError
from gnssframework.inertial import (
    AccelerationPulse,
    MechanisationOptions,
    NavState,
    TrajectoryModel,
    TrajectoryProfile,
    constant_velocity_profile,
    integrate,
    paper_profile,
    static_profile,
)
from gnssframework.inertial.error_model import navigation_error
from gnssframework.inertial.frames import enu_to_ecef_matrix, euler_ned_deg


def test_coordinated_flight_attitude():
    """Body x along the velocity; no lateral apparent force (a + g0 up0 in the body x-z
    plane); body z has a downward component (upright flight)."""
    prof = paper_profile()
    model = TrajectoryModel(prof)
    tr = model.evaluate(np.linspace(0.0, 50.0, 501))
    c_b_e = Rotation.from_quat(tr.q_b_e, scalar_first=True).as_matrix()
    x_e, y_e, z_e = c_b_e[..., 0], c_b_e[..., 1], c_b_e[..., 2]
    v_hat = tr.velocity_ecef_mps / np.linalg.norm(tr.velocity_ecef_mps, axis=-1, keepdims=True)
    np.testing.assert_allclose(np.sum(x_e * v_hat, -1), 1.0, atol=1e-12)
    up0 = enu_to_ecef_matrix(prof.start_lat_deg, prof.start_lon_deg)[:, 2]
    apparent = tr.acceleration_ecef_mps2 + 9.80665 * up0
    np.testing.assert_allclose(np.sum(y_e * apparent, -1), 0.0, atol=1e-9)
    assert np.all(np.sum(z_e * up0, -1) < 0)
    # the start attitude: heading 45 deg, pitch = flight-path angle 35.26 deg, wings level
    np.testing.assert_allclose(
        euler_ned_deg(tr.q_b_e[0], tr.position_ecef_m[0]),
        [0.0, np.degrees(np.arctan(50 / np.hypot(50, 50))), 45.0],
        atol=1e-9,
    )


@pytest.mark.parametrize(
    "profile, dt, tol_m",
    [
        # one hour at rest on the rotating Earth at 10 Hz: only the Earth rate and gravity act
        (static_profile(34.23, 108.3576, 590.6, 3600.0, (5.0, -3.0, 120.0)), 0.1, 0.01),  # measured 1.3 mm
        # straight flight at 300 m/s for 60 s at 100 Hz
        (constant_velocity_profile(-20.0, 10.0, 1000.0, (150.0, -250.0, 20.0), 60.0), 0.01, 2e-5),  # measured 2e-6 m
    ],
)
def test_round_trip_static_and_straight(profile, dt, tol_m):
    model = TrajectoryModel(profile)
    n = int(round(profile.duration_s / dt))
    truth = model.evaluate(dt * np.arange(n + 1))
    dth, dv = model.increments(dt, n)
    prev = model.increments(dt, 1, start_s=-dt)
    s = integrate(truth.nav_state(0), dth, dv, dt, MechanisationOptions(), prev[0][0], prev[1][0])
    err = navigation_error(
        NavState(s.q_b_e, s.velocity_ecef_mps, s.position_ecef_m),
        NavState(truth.q_b_e, truth.velocity_ecef_mps, truth.position_ecef_m),
    )
    assert np.linalg.norm(err[:, 6:9], axis=-1).max() < tol_m
    assert np.linalg.norm(err[:, 0:3], axis=-1).max() < 1e-9
    if profile.attitude == "fixed":
        # at rest: the truth does not move, the gyros sense the Earth rate, the accelerometers -g
        np.testing.assert_allclose(truth.position_ecef_m - truth.position_ecef_m[0], 0.0, atol=1e-6)
        np.testing.assert_allclose(np.linalg.norm(dth, axis=-1) / dt, 7.292115e-5, rtol=1e-9)
        np.testing.assert_allclose(
            euler_ned_deg(truth.q_b_e[0], truth.position_ecef_m[0]), (5.0, -3.0, 120.0), atol=1e-9
        )


def test_profile_errors_name_the_field():
    with pytest.raises(ConfigError, match=r"pulses\[0\]"):
        TrajectoryProfile(
            start_lat_deg=0,
            start_lon_deg=0,
            duration_s=5.0,
            initial_velocity_enu_mps=(10, 0, 0),
            pulses=(AccelerationPulse(start_s=4.0, rise_s=1.0, hold_s=0.0, accel_enu_mps2=(1, 0, 0)),),
        )
    with pytest.raises(ConfigError, match="attitude"):
        TrajectoryModel(TrajectoryProfile(start_lat_deg=0, start_lon_deg=0, duration_s=5.0))
    with pytest.raises(Exception, match="rise_s"):
        AccelerationPulse(start_s=0.0, rise_s=0.0, hold_s=0.0, accel_enu_mps2=(1, 0, 0))


def test_kinematic_acceleration_for_nco_aiding():
    """C f + g - 2 Omega v from the truth's attitude, specific force and velocity is the
    truth's ECEF acceleration (30 g pull-up included)."""
    from gnssframework.inertial import kinematic_acceleration_ecef

    tr = TrajectoryModel(paper_profile()).evaluate(np.array([5.0, 12.0, 17.3, 40.0]))
    state = NavState(tr.q_b_e, tr.velocity_ecef_mps, tr.position_ecef_m)
    np.testing.assert_allclose(
        kinematic_acceleration_ecef(state, tr.specific_force_b_mps2), tr.acceleration_ecef_mps2, atol=1e-9
    )
