"""Strapdown inertial navigation, IMU errors and reference trajectories (Cai and Guo 2017).

Batched over Monte Carlo runs: states are ``(..., n)`` arrays with the run axes leading;
time series put time first, ``(T, ..., n)``, as everywhere in the framework.

Modules
-------
earth
    WGS-84 constants, J2 gravity and its gradient.
quaternion
    Batched quaternion helpers for the hot path.
frames
    ENU/NED frames and Euler angles (pymap3d for the geodesy).
mechanisation
    ECEF strapdown mechanisation from angle/velocity increments.
imu
    IMU error model (random constant + Gauss-Markov + white noise, scale factor).
trajectory
    Smooth reference trajectories and their exact increments.
error_model
    15-state error-state model (transition matrix, process noise, closed-loop correction).
calibration
    IMU scale factors and misalignments as 18 more error states (coupling, compensation).
"""

from gnssframework.inertial.earth import STANDARD_GRAVITY_MPS2, WGS84, EarthModel
from gnssframework.inertial.error_model import (
    ERROR_STATE_LABELS,
    apply_navigation_error,
    compensate_increments,
    correct_state,
    error_state_matrices,
    error_state_transition,
    navigation_error,
)
from gnssframework.inertial.imu import ImuErrors, ImuGrade, simulate_imu
from gnssframework.inertial.mechanisation import (
    MechanisationOptions,
    NavSeries,
    NavState,
    integrate,
    kinematic_acceleration_ecef,
    strapdown_step,
)
from gnssframework.inertial.trajectory import (
    AccelerationPulse,
    Trajectory,
    TrajectoryModel,
    TrajectoryProfile,
    constant_velocity_profile,
    paper_profile,
    static_profile,
)

__all__ = [
    "ERROR_STATE_LABELS",
    "apply_navigation_error",
    "compensate_increments",
    "correct_state",
    "error_state_matrices",
    "error_state_transition",
    "navigation_error",
    "ImuErrors",
    "ImuGrade",
    "simulate_imu",
    "STANDARD_GRAVITY_MPS2",
    "WGS84",
    "EarthModel",
    "MechanisationOptions",
    "NavSeries",
    "NavState",
    "integrate",
    "kinematic_acceleration_ecef",
    "strapdown_step",
    "AccelerationPulse",
    "Trajectory",
    "TrajectoryModel",
    "TrajectoryProfile",
    "constant_velocity_profile",
    "paper_profile",
    "static_profile",
]
