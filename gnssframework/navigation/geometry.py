r"""Receiver-satellite geometry: range, line of sight, range rate and acceleration, and the Sagnac correction.

The one implementation the receiver harnesses, the simulation's truth, the navigation
filters and the scenarios call (ECEF metres; arrays broadcast, batch first). With $s$,
$\dot s$ the satellite's and $r$, $\dot r$ the receiver's position and velocity
(Groves 2013, *Principles of GNSS, Inertial, and Multisensor Integrated Navigation
Systems*, 2nd ed., sections 8.5.3 and 9.4.1):

$$
\rho_g = \lVert s - r \rVert, \qquad e = \frac{s - r}{\rho_g}, \qquad
\dot\rho_g = e \cdot (\dot s - \dot r), \qquad
\ddot\rho_g = e \cdot (\ddot s - \ddot r)
  + \frac{\lVert \dot s - \dot r \rVert^2 - \dot\rho_g^2}{\rho_g}.
$$

The second term of $\ddot\rho_g$ is the turning of the line of sight (the exact second
derivative of the norm; Groves 2013, section 16.2.2, for its use in NCO aiding).

The Sagnac correction adds the Earth's rotation during the signal's transit when both
positions are in the ECEF frame of reception (IS-GPS-200, 20.3.3.4.3.3.2; Groves 2013,
eq. 8.41): $\delta\rho_{ie} = \frac{\omega_{ie}}{c}(s_x r_y - s_y r_x)$. The project's
simulated truth leaves it out, so the harnesses do too; a receiver working on recorded
data adds it to $\rho_g$.
"""

from __future__ import annotations

import numpy as np
import pymap3d

from ..signal.spec import SPEED_OF_LIGHT_M_S
from .ephemeris import OMEGA_EARTH_RAD_S

__all__ = [
    "enu_rotation",
    "geometric_range",
    "line_of_sight",
    "range_rate",
    "range_acceleration",
    "ranges_from_receivers",
    "sagnac_m",
]


def geometric_range(sat_pos_m: np.ndarray, receiver_pos_m: np.ndarray) -> np.ndarray:
    """Distance $\\lVert s - r \\rVert$ (m) of positions ``(..., 3)`` that broadcast; returns ``(...)``.

    Examples
    --------
    >>> float(geometric_range(np.array([3.0, 4.0, 12.0]), np.zeros(3)))
    13.0
    """
    return np.linalg.norm(np.asarray(sat_pos_m) - np.asarray(receiver_pos_m), axis=-1)


def line_of_sight(sat_pos_m: np.ndarray, receiver_pos_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Geometric range ``(...)`` and unit line of sight ``(..., 3)`` from receiver to satellite.

    Examples
    --------
    >>> rho, e = line_of_sight(np.array([0.0, 0.0, 5.0]), np.zeros(3))
    >>> float(rho), e.tolist()
    (5.0, [0.0, 0.0, 1.0])
    """
    d = np.asarray(sat_pos_m) - np.asarray(receiver_pos_m)
    rho = np.linalg.norm(d, axis=-1)
    return rho, d / rho[..., None]


def range_rate(sat_vel_m_s: np.ndarray, receiver_vel_m_s: np.ndarray, los: np.ndarray) -> np.ndarray:
    """Geometric range rate $e \\cdot (\\dot s - \\dot r)$ (m/s) along the unit line of sight ``los`` ``(..., 3)``."""
    return np.sum((np.asarray(sat_vel_m_s) - np.asarray(receiver_vel_m_s)) * los, axis=-1)


def range_acceleration(
    sat_acc_m_s2: np.ndarray,
    receiver_acc_m_s2: np.ndarray,
    sat_vel_m_s: np.ndarray,
    receiver_vel_m_s: np.ndarray,
    los: np.ndarray,
    range_m: np.ndarray,
) -> np.ndarray:
    r"""Geometric range acceleration (m/s²): $e \cdot (\ddot s - \ddot r) + (\lVert \dot s -
    \dot r \rVert^2 - \dot\rho_g^2) / \rho_g$, the second derivative of $\lVert s - r \rVert$.

    ``los`` ``(..., 3)`` and ``range_m`` ``(...)`` are `line_of_sight`'s; kinematics ``(..., 3)``
    broadcast against them.

    Examples
    --------
    A satellite circling the receiver keeps its range: the turning cancels the acceleration.

    >>> los, rho = np.array([1.0, 0.0, 0.0]), np.array(2.0)
    >>> float(range_acceleration(np.array([-0.5, 0.0, 0.0]), np.zeros(3), np.array([0.0, 1.0, 0.0]),
    ...                          np.zeros(3), los, rho))
    0.0
    """
    dv = np.asarray(sat_vel_m_s) - np.asarray(receiver_vel_m_s)
    rate = np.sum(los * dv, axis=-1)
    return range_rate(sat_acc_m_s2, receiver_acc_m_s2, los) + (np.sum(dv * dv, axis=-1) - rate**2) / range_m


def ranges_from_receivers(sat_pos_m: np.ndarray, receiver_pos_m: np.ndarray) -> np.ndarray:
    """Distances ``(..., runs, ch)`` from receivers ``(..., runs, 3)`` to satellites shared by
    the runs ``(..., ch, 3)`` or one geometry per run ``(..., runs, ch, 3)``."""
    s = np.asarray(sat_pos_m)
    if s.ndim == np.ndim(receiver_pos_m):  # shared by the runs
        s = s[..., None, :, :]
    return geometric_range(s, np.asarray(receiver_pos_m)[..., None, :])


def sagnac_m(
    sat_pos_m: np.ndarray, receiver_pos_m: np.ndarray, omega_earth_rad_s: float = OMEGA_EARTH_RAD_S
) -> np.ndarray:
    """Sagnac correction (m) to add to the geometric range of ECEF positions ``(..., 3)``:
    $\\frac{\\omega_{ie}}{c}(s_x r_y - s_y r_x)$ (IS-GPS-200, 20.3.3.4.3.3.2; at most about 40 m)."""
    s, r = np.asarray(sat_pos_m), np.asarray(receiver_pos_m)
    return omega_earth_rad_s / SPEED_OF_LIGHT_M_S * (s[..., 0] * r[..., 1] - s[..., 1] * r[..., 0])


def enu_rotation(position_ecef_m: np.ndarray) -> np.ndarray:
    """Rotations ``(..., 3, 3)`` from ECEF to east, north, up at ECEF positions ``(..., 3)``
    (geodetic latitude on WGS-84, `pymap3d.ecef2geodetic`): rows east, north, up."""
    r = np.asarray(position_ecef_m, float)
    lat_deg = np.asarray(pymap3d.ecef2geodetic(r[..., 0], r[..., 1], r[..., 2])[0], float)
    lat, lon = np.radians(lat_deg), np.arctan2(r[..., 1], r[..., 0])
    sl, cl, so, co = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
    zero = np.zeros_like(lat)
    return np.stack(
        [np.stack([-so, co, zero], -1), np.stack([-sl * co, -sl * so, cl], -1), np.stack([cl * co, cl * so, sl], -1)],
        -2,
    )
