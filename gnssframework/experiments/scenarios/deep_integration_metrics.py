"""Navigation errors of the deep-integration experiment in local axes (its post-settle RMSE and maximum
reduce them with the shared helpers of `gnssframework.experiments.metrics`).

Reference 002 reports its errors as horizontal position, height, horizontal and vertical
velocity and roll/pitch/yaw. They are formed here from ECEF errors rotated into the
east-north-up frame at the *true* position (pymap3d, WGS-84), and from the Euler angles
of the body-to-local-level rotation (scipy; yaw-pitch-roll, Groves 2013 section 2.2.2).
"""

from __future__ import annotations

import numpy as np
import pymap3d
from scipy.spatial.transform import Rotation

__all__ = ["enu_errors", "attitude_errors_deg"]


def enu_errors(
    est_pos_m: np.ndarray, true_pos_m: np.ndarray, est_vel_m_s: np.ndarray, true_vel_m_s: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Position and velocity errors (estimate minus truth) in ENU at the true position.

    All inputs ``(..., 3)`` ECEF. Returns ``(pos_err_enu_m, vel_err_enu_m_s)``, each ``(..., 3)``.
    """
    lat, lon, _ = pymap3d.ecef2geodetic(true_pos_m[..., 0], true_pos_m[..., 1], true_pos_m[..., 2])
    dp = np.asarray(est_pos_m) - true_pos_m
    dv = np.asarray(est_vel_m_s) - true_vel_m_s
    pos = np.stack(pymap3d.ecef2enuv(dp[..., 0], dp[..., 1], dp[..., 2], lat, lon), -1)
    vel = np.stack(pymap3d.ecef2enuv(dv[..., 0], dv[..., 1], dv[..., 2], lat, lon), -1)
    return pos, vel


def attitude_errors_deg(est_body_to_nav: np.ndarray, true_body_to_nav: np.ndarray) -> np.ndarray:
    """Roll, pitch and yaw errors (deg, wrapped to [-180, 180)) of two body-to-local-level DCMs.

    Inputs ``(..., 3, 3)`` (the same local-level axes for both); returns ``(..., 3)``
    ordered roll, pitch, yaw.
    """
    shape = np.shape(est_body_to_nav)[:-2]
    e = Rotation.from_matrix(np.reshape(est_body_to_nav, (-1, 3, 3))).as_euler("ZYX", degrees=True)
    t = Rotation.from_matrix(np.reshape(true_body_to_nav, (-1, 3, 3))).as_euler("ZYX", degrees=True)
    d = (e - t + 180.0) % 360.0 - 180.0
    return d[:, ::-1].reshape(*shape, 3)
