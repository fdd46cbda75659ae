"""The flight of the ``deep-integration`` scenario: its truth kinematics, attitude and IMU increments.

`make_flight` builds reference 002's pull-up, a straight flight or a jerk pulse on
`gnssframework.inertial.trajectory`; `Flight` answers the kinematics at any time.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ...errors import ConfigError

__all__ = ["Flight", "make_flight", "body_to_ned"]


class Flight:
    """Truth of the flight: kinematics at any time and the exact IMU increments."""

    def __init__(self, model: Any) -> None:
        self.model = model

    def kinematics(self, t_s) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """ECEF position, velocity, acceleration, each ``np.shape(t_s) + (3,)``."""
        t = np.asarray(t_s, float)
        tr = self.model.evaluate(t.reshape(-1))
        shape = t.shape + (3,)
        return (
            tr.position_ecef_m.reshape(shape),
            tr.velocity_ecef_mps.reshape(shape),
            tr.acceleration_ecef_mps2.reshape(shape),
        )

    def body_to_ned(self, t_s) -> np.ndarray:
        """Body-to-local-level (NED at the true position) DCM ``(T, 3, 3)``."""
        tr = self.model.evaluate(np.atleast_1d(np.asarray(t_s, float)))
        return body_to_ned(tr.q_b_e, tr.position_ecef_m)

    def truth(self, t_s):
        return self.model.evaluate(np.atleast_1d(np.asarray(t_s, float)))


def body_to_ned(q_b_e: np.ndarray, position_ecef_m: np.ndarray) -> np.ndarray:
    """C_b^n = C_e^n C_b^e with the NED frame at each position (geodetic latitude, pymap3d)."""
    import pymap3d

    from ...inertial.frames import ned_to_ecef_matrix
    from ...inertial.quaternion import quat_to_dcm

    r = np.broadcast_to(position_ecef_m, q_b_e.shape[:-1] + (3,))
    lat, lon, _ = pymap3d.ecef2geodetic(r[..., 0], r[..., 1], r[..., 2])
    return np.swapaxes(ned_to_ecef_matrix(lat, lon), -1, -2) @ quat_to_dcm(q_b_e)


def make_flight(
    profile: str, lat_deg: float, lon_deg: float, height_m: float, duration_s: float, *, pulse: dict | None = None
) -> Flight:
    """Reference 002's pull-up (`inertial.trajectory.paper_profile`, moved to the given start), straight
    flight, or a ``jerk-pulse``: straight flight at (50, 50, 50) m/s ENU with one smooth acceleration
    pulse ``pulse`` = {accel_g, jerk_g_s, start_s, hold_s, direction_enu}, whose rise takes
    ``1.875 * accel / jerk`` so that its peak jerk is ``jerk_g_s`` (`inertial.trajectory`)."""
    from ...inertial.earth import STANDARD_GRAVITY_MPS2
    from ...inertial.trajectory import AccelerationPulse, TrajectoryModel, constant_velocity_profile, paper_profile

    if profile == "pull-up":
        # The whole 50 s flight is defined; a shorter duration_s simulates its first part.
        base = paper_profile()
        prof = base.model_copy(
            update={
                "start_lat_deg": lat_deg,
                "start_lon_deg": lon_deg,
                "start_height_m": height_m,
                "duration_s": max(duration_s, base.duration_s),
            }
        )
    elif profile == "straight":
        prof = constant_velocity_profile(lat_deg, lon_deg, height_m, (50.0, 50.0, 50.0), duration_s)
    elif profile == "jerk-pulse":
        q = pulse or {}
        u = np.asarray(q.get("direction_enu", (0.0, 0.0, 1.0)), float)
        u = u / np.linalg.norm(u)
        accel = q.get("accel_g", 20.0) * STANDARD_GRAVITY_MPS2
        rise = 1.875 * q.get("accel_g", 20.0) / q.get("jerk_g_s", 50.0)
        p = AccelerationPulse(
            start_s=q.get("start_s", 2.0), rise_s=rise, hold_s=q.get("hold_s", 1.0), accel_enu_mps2=tuple(accel * u)
        )
        # As for the pull-up, the whole flight is defined; a shorter duration_s simulates its first part.
        prof = constant_velocity_profile(lat_deg, lon_deg, height_m, (50.0, 50.0, 50.0), max(duration_s, p.end_s))
        prof = prof.model_copy(update={"pulses": (p,)})
    else:
        raise ConfigError("scenario.profile", f"got {profile!r}; allowed: pull-up, straight, jerk-pulse")
    return Flight(TrajectoryModel(prof))
