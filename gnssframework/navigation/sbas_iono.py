r"""SBAS's ionospheric and tropospheric corrections for an L1 user (RTCA DO-229 Appendix A,
A.4.4.10 and A.4.2.4).

**Pierce point** (A.4.4.10.1): on a shell :math:`h_I = 350` km over a sphere of
:math:`R_e = 6378.1363` km, the Earth's central angle
:math:`\psi = \pi/2 - E - \arcsin(\frac{R_e}{R_e + h_I}\cos E)`, the latitude
:math:`\phi_{pp} = \arcsin(\sin\phi_u\cos\psi + \cos\phi_u\sin\psi\cos A)` and the longitude
:math:`\lambda_{pp} = \lambda_u + \arcsin(\sin\psi\sin A / \cos\phi_{pp})`, or
:math:`\lambda_u + \pi - \arcsin(\dots)` where the ray passes over the pole
(:math:`\phi_u > 70°` and :math:`\tan\psi\cos A > \tan(\pi/2 - \phi_u)`, or the southern
mirror). The slant factor is :math:`F_{pp} = [1 - (\frac{R_e\cos E}{R_e + h_I})^2]^{-1/2}`.

**The grid** (A.4.4.10.2-3): between ±55° the IPP's 5° × 5° cell, between 55° and 75° its
10° × 10° cell (corners at 55°, 65°, 75° and every 10° of longitude). With its four IGPs
monitored the vertical delay is the bilinear interpolation
:math:`\tau = \sum_i W_i \tau_i`, :math:`W = xy, (1-x)y, (1-x)(1-y), x(1-y)` for the
north-east, north-west, south-west and south-east corners, :math:`x` and :math:`y` the IPP's
fractions of the cell from its west and south sides; with three monitored, the linear
interpolation on their triangle if the IPP lies inside it (weights of the triangle's
barycentric coordinates, DO-229's triangular formula); otherwise no correction. The
vertical variance is :math:`\sigma^2_{UIVE} = \sum_i W_i \sigma^2_{GIVE,i}` (DO-229's
degradation terms of type 10 are not applied: `sbas_content` does not read type 10), and the
slant delay and variance are :math:`F_{pp}\tau` and :math:`F_{pp}^2\sigma^2_{UIVE}`. The IPP's
cells beyond 75° of latitude (bands 9 and 10's caps) and the 10° × 10° fallback of a 5° cell
without three IGPs are not implemented: such a ray has no correction.

**GIVE and UDRE** (Tables A-16 and A-6): the variances of the indicators, in m².

**Troposphere** (A.4.2.4): the MOPS model, zenith hydrostatic and wet delays from five
latitude bands' mean and seasonal meteorology (15° to 75°, interpolated in latitude, the
season's cosine from day 28 in the north and 211 in the south) at the user's height, mapped by
:math:`m(E) = 1.001 / \sqrt{0.002001 + \sin^2 E}`, with variance :math:`(0.12\,m(E))^2` m².
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

__all__ = [
    "SBAS_SHELL_HEIGHT_M",
    "SBAS_EARTH_RADIUS_M",
    "GIVE_VARIANCE_M2",
    "UDRE_VARIANCE_M2",
    "sbas_pierce_point",
    "shell_pierce_point",
    "grid_vertical_delay",
    "mops_troposphere",
]

#: The shell's height and the sphere's radius of A.4.4.10.1 (m).
SBAS_SHELL_HEIGHT_M = 350e3
SBAS_EARTH_RADIUS_M = 6378.1363e3

#: σ²_GIVE (m²) of GIVEI 0-14 (DO-229 Table A-17); GIVEI 15 is "not monitored".
GIVE_VARIANCE_M2 = np.array(
    [
        0.0084,
        0.0333,
        0.0749,
        0.1331,
        0.2079,
        0.2994,
        0.4075,
        0.5322,
        0.6735,
        0.8315,
        1.1974,
        1.8709,
        3.3260,
        20.787,
        187.0826,
    ]
)
#: σ²_UDRE (m²) of UDREI 0-13 (DO-229 Table A-6); 14 is "not monitored", 15 "do not use".
UDRE_VARIANCE_M2 = np.array(
    [
        0.0520,
        0.0924,
        0.1444,
        0.2830,
        0.4678,
        0.8315,
        1.2992,
        1.8709,
        2.5465,
        3.3260,
        5.1968,
        20.7870,
        230.9661,
        2078.695,
    ]
)

# MOPS meteorology (A.4.2.4 Table A-2): latitude (deg); mean and seasonal variation of
# pressure (hPa), temperature (K), water-vapour pressure (hPa), temperature lapse (K/m),
# water-vapour lapse (dimensionless).
_MET_LAT_DEG = np.array([15.0, 30.0, 45.0, 60.0, 75.0])
_MET_MEAN = np.array(
    [
        [1013.25, 299.65, 26.31, 6.30e-3, 2.77],
        [1017.25, 294.15, 21.79, 6.05e-3, 3.15],
        [1015.75, 283.15, 11.66, 5.58e-3, 2.57],
        [1011.75, 272.15, 6.78, 5.39e-3, 1.81],
        [1013.00, 263.65, 4.11, 4.53e-3, 1.55],
    ]
)
_MET_SEASON = np.array(
    [
        [0.00, 0.00, 0.00, 0.00e-3, 0.00],
        [-3.75, 7.00, 8.85, 0.25e-3, 0.33],
        [-2.25, 11.00, 7.24, 0.32e-3, 0.46],
        [-1.75, 15.00, 5.36, 0.81e-3, 0.74],
        [-0.50, 14.50, 3.39, 0.62e-3, 0.30],
    ]
)


def shell_pierce_point(
    lat_deg: float,
    lon_deg: float,
    azimuth_deg: np.ndarray,
    elevation_deg: np.ndarray,
    earth_radius_m: float,
    shell_height_m: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Latitude and longitude (deg, longitude in [-180, 180)) where each ray from a user on a
    sphere of ``earth_radius_m`` meets a shell ``shell_height_m`` above it, and the slant
    factor there (module text's formulas, over the pole too)."""
    E = np.radians(np.asarray(elevation_deg, float))
    A = np.radians(np.asarray(azimuth_deg, float))
    phi_u, lam_u = np.radians(lat_deg), np.radians(lon_deg)
    ratio = earth_radius_m / (earth_radius_m + shell_height_m) * np.cos(E)
    psi = np.pi / 2 - E - np.arcsin(ratio)
    phi = np.arcsin(np.sin(phi_u) * np.cos(psi) + np.cos(phi_u) * np.sin(psi) * np.cos(A))
    turn = np.arcsin(np.clip(np.sin(psi) * np.sin(A) / np.cos(phi), -1.0, 1.0))
    over = np.tan(psi) * np.cos(A)
    over_pole = ((lat_deg > 70.0) & (over > np.tan(np.pi / 2 - phi_u))) | (
        (lat_deg < -70.0) & (-over > np.tan(np.pi / 2 + phi_u))
    )
    lam = np.where(over_pole, lam_u + np.pi - turn, lam_u + turn)
    lon = (np.degrees(lam) + 180.0) % 360.0 - 180.0
    return np.degrees(phi), lon, 1.0 / np.sqrt(1.0 - ratio**2)


def sbas_pierce_point(
    lat_deg: float, lon_deg: float, azimuth_deg: np.ndarray, elevation_deg: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Latitude and longitude (deg, longitude in [-180, 180)) of each ray's pierce point
    through DO-229's shell, and the slant factor :math:`F_{pp}` (module text)."""
    return shell_pierce_point(lat_deg, lon_deg, azimuth_deg, elevation_deg, SBAS_EARTH_RADIUS_M, SBAS_SHELL_HEIGHT_M)


def _cell(lat_deg: float, lon_deg: float) -> tuple[float, float, float] | None:
    """South-west corner (deg) and side (deg) of the IPP's cell, None beyond 75°."""
    if abs(lat_deg) < 55.0:
        step, south = 5.0, 5.0 * np.floor(lat_deg / 5.0)
    elif abs(lat_deg) < 75.0:
        step, south = 10.0, 10.0 * np.floor((lat_deg - 5.0) / 10.0) + 5.0
    else:
        return None
    return float(south), float(step * np.floor(lon_deg / step)), step


def _wrap(lon_deg: float) -> float:
    return float((lon_deg + 180.0) % 360.0 - 180.0)


def grid_vertical_delay(
    lat_deg: np.ndarray, lon_deg: np.ndarray, igps: Mapping[tuple[float, float], tuple[float, float]]
) -> tuple[np.ndarray, np.ndarray]:
    """Vertical delay (m at L1) and variance (m²) at pierce points from the monitored IGPs.

    Parameters
    ----------
    lat_deg, lon_deg
        ``(S,)`` pierce points (`sbas_pierce_point`).
    igps
        ``(latitude, longitude)`` in degrees (longitude in [-180, 180)) of each monitored IGP
        to its vertical delay (m) and σ²_GIVE (m²).

    Returns
    -------
    ``(S,)`` delays and variances, NaN where the IPP's cell has fewer than three monitored
    corners or three that do not surround it (module text).
    """
    lats, lons = np.atleast_1d(np.asarray(lat_deg, float)), np.atleast_1d(np.asarray(lon_deg, float))
    delay, var = np.full(lats.shape, np.nan), np.full(lats.shape, np.nan)
    for i, (la, lo) in enumerate(zip(lats, lons)):
        cell = _cell(float(la), float(lo))
        if cell is None:
            continue
        south, west, step = cell
        x, y = (lo - west) / step, (la - south) / step
        # North-east, north-west, south-west, south-east corners; their (x, y).
        corners = [(south + step, west + step), (south + step, west), (south, west), (south, west + step)]
        unit = np.array([[1.0, 1.0], [0.0, 1.0], [0.0, 0.0], [1.0, 0.0]])
        have = [igps.get((c[0], _wrap(c[1]))) for c in corners]
        known = [k for k in range(4) if have[k] is not None]
        if len(known) == 4:
            w = np.array([x * y, (1 - x) * y, (1 - x) * (1 - y), x * (1 - y)])
        elif len(known) == 3:
            # Barycentric weights of (x, y) in the triangle of the three monitored corners.
            a, b, c = unit[known]
            T = np.column_stack([a - c, b - c])
            l1, l2 = np.linalg.solve(T, np.array([x, y]) - c)
            w = np.zeros(4)
            w[known] = (l1, l2, 1.0 - l1 - l2)
            if np.any(w[known] < -1e-12):
                continue
        else:
            continue
        values = np.array([have[k] if have[k] is not None else (0.0, 0.0) for k in range(4)], float)
        delay[i], var[i] = w @ values[:, 0], w @ values[:, 1]
    return delay, var


def mops_troposphere(
    lat_deg: float, height_m: float, elevation_deg: np.ndarray, day_of_year: float
) -> tuple[np.ndarray, np.ndarray]:
    """Slant tropospheric delay (m) and its variance (m²) of the MOPS model (module text;
    DO-229 A.4.2.4), for a user at ``height_m`` above the ellipsoid (0-10 km, taken as the
    height above mean sea level) on ``day_of_year`` (1-366)."""
    k1, k2, rd, gm, g = 77.604, 382000.0, 287.054, 9.784, 9.80665
    a = abs(lat_deg)
    mean = np.array([np.interp(a, _MET_LAT_DEG, _MET_MEAN[:, j]) for j in range(5)])
    season = np.array([np.interp(a, _MET_LAT_DEG, _MET_SEASON[:, j]) for j in range(5)])
    d_min = 28.0 if lat_deg >= 0 else 211.0
    p, t, e, beta, lam = mean - season * np.cos(2 * np.pi * (day_of_year - d_min) / 365.25)
    z_hyd = 1e-6 * k1 * rd * p / gm
    z_wet = 1e-6 * k2 * rd / (gm * (lam + 1.0) - beta * rd) * e / t
    h = float(np.clip(height_m, 0.0, 10_000.0))
    base = 1.0 - beta * h / t
    z_hyd *= base ** (g / (rd * beta))
    z_wet *= base ** ((lam + 1.0) * g / (rd * beta) - 1.0)
    sin_e = np.sin(np.radians(np.asarray(elevation_deg, float)))
    m = 1.001 / np.sqrt(0.002001 + sin_e**2)
    return (z_hyd + z_wet) * m, (0.12 * m) ** 2
