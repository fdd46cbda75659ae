"""Local-level frames at a geodetic point and attitude angles (pymap3d for the geodesy)."""

from __future__ import annotations

import numpy as np
import pymap3d
from scipy.spatial.transform import Rotation

__all__ = ["enu_to_ecef_matrix", "ned_to_ecef_matrix", "euler_ned_deg", "ecef_to_enu_offset"]

#: ENU <-> NED axis swap (its own inverse).
NED_FROM_ENU = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])


def enu_to_ecef_matrix(lat_deg: np.ndarray, lon_deg: np.ndarray) -> np.ndarray:
    """``C_enu^e`` (columns: east, north, up in ECEF), shape ``(..., 3, 3)``; built with pymap3d.enu2uvw."""
    lat = np.asarray(lat_deg, dtype=float)
    lon = np.asarray(lon_deg, dtype=float)
    cols = [np.stack(pymap3d.enu2uvw(*unit, lat, lon), axis=-1) for unit in np.eye(3)]
    return np.stack(cols, axis=-1)


def ned_to_ecef_matrix(lat_deg: np.ndarray, lon_deg: np.ndarray) -> np.ndarray:
    """``C_n^e`` for the north-east-down frame."""
    return enu_to_ecef_matrix(lat_deg, lon_deg) @ NED_FROM_ENU


def euler_ned_deg(q_b_e: np.ndarray, position_ecef_m: np.ndarray) -> np.ndarray:
    """Roll, pitch, yaw (deg) of the body (x forward, y right, z down) w.r.t. local NED.

    ``C_b^n = R_z(yaw) R_y(pitch) R_x(roll)`` (Groves sec. 2.2); ``(..., 3)``.
    """
    r = np.asarray(position_ecef_m, dtype=float)
    lat, lon, _ = pymap3d.ecef2geodetic(r[..., 0], r[..., 1], r[..., 2])
    c_n_e = ned_to_ecef_matrix(lat, lon)
    q = np.asarray(q_b_e, dtype=float)
    c_b_e = Rotation.from_quat(q.reshape(-1, 4), scalar_first=True).as_matrix().reshape(q.shape[:-1] + (3, 3))
    c_b_n = np.swapaxes(c_n_e, -1, -2) @ c_b_e
    ypr = Rotation.from_matrix(c_b_n.reshape(-1, 3, 3)).as_euler("ZYX", degrees=True)
    return ypr[:, ::-1].reshape(q.shape[:-1] + (3,))


def ecef_to_enu_offset(position_ecef_m: np.ndarray, reference_ecef_m: np.ndarray) -> np.ndarray:
    """ENU coordinates (m) of ``position`` about ``reference`` (pymap3d.ecef2enu), ``(..., 3)``."""
    p = np.asarray(position_ecef_m, dtype=float)
    ref = np.asarray(reference_ecef_m, dtype=float)
    lat, lon, h = pymap3d.ecef2geodetic(ref[..., 0], ref[..., 1], ref[..., 2])
    e, n, u = pymap3d.ecef2enu(p[..., 0], p[..., 1], p[..., 2], lat, lon, h)
    return np.stack([e, n, u], axis=-1)
