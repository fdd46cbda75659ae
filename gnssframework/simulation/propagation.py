"""Signal realism a scenario can add to its truth: C/N0 from elevation, and range errors
the receiver's model does not have.

Everything here is batched (any leading axes) and draws only through
`gnssframework.random_streams`, naming the axis that holds the runs, so a run's numbers
do not depend on how runs are batched.

* :func:`antenna_attenuation_db` / :func:`cn0_from_elevation`: the receiver antenna's
  gain pattern of gps-sdr-sim (T. Ebinuma, ``gpssim.c``, ``ant_pat_db``: attenuation every
  5 deg of boresight angle, 0 dB at zenith, 7.56 dB at 10 deg elevation), linearly
  interpolated; a channel's C/N0 is the zenith C/N0 minus that attenuation.
* :func:`klobuchar_obliquity`: the ionospheric obliquity factor of the Klobuchar model,
  ``F = 1 + 16 (0.53 - E)^3`` with E the elevation in semicircles (Klobuchar 1987;
  IS-GPS-200, 20.3.3.5.2.5).
* :func:`tropo_mapping`: the tropospheric mapping function of RTCA DO-229 (Appendix A,
  used with the UNB3 zenith delays of Collins 1999),
  ``m(E) = 1.001 / sqrt(0.002001 + sin^2 E)``.
* :func:`elevation_deg`: elevation of ECEF satellite positions seen from ECEF receiver
  positions, on the ellipsoid's local vertical at a given geodetic latitude/longitude.
* :class:`RangeErrors`: per-run residuals of the ionosphere, troposphere and broadcast
  orbit/clock, added to the true code (and carrier) ranges.
* :func:`least_squares_fix_error`: the position and clock error those residuals make in a
  least-squares fix, the error a receiver's first fix starts its filter with.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any
from collections.abc import Callable

import numpy as np

from .. import random_streams as draw

__all__ = [
    "ANTENNA_ATTENUATION_DB",
    "antenna_attenuation_db",
    "cn0_from_elevation",
    "klobuchar_obliquity",
    "tropo_mapping",
    "elevation_deg",
    "RangeErrors",
    "draw_range_errors",
    "range_error_function",
    "least_squares_gain",
    "least_squares_fix_error",
]

#: Receiver antenna attenuation (dB) at boresight angles 0, 5, ..., 180 deg (boresight angle =
#: 90 deg minus elevation): gps-sdr-sim's ``ant_pat_db`` (T. Ebinuma, gpssim.c, 2015).
ANTENNA_ATTENUATION_DB = np.array(
    [
        0.00,
        0.00,
        0.22,
        0.44,
        0.67,
        1.11,
        1.56,
        2.00,
        2.44,
        2.89,
        3.56,
        4.22,
        4.89,
        5.56,
        6.22,
        6.89,
        7.56,
        8.22,
        8.89,
        9.78,
        10.67,
        11.56,
        12.44,
        13.33,
        14.44,
        15.56,
        16.67,
        17.78,
        18.89,
        20.00,
        21.33,
        22.67,
        24.00,
        25.56,
        27.33,
        29.33,
        31.56,
    ]
)
_BORESIGHT_DEG = np.arange(37) * 5.0


def antenna_attenuation_db(elevation_deg: np.ndarray) -> np.ndarray:
    """Attenuation (dB, >= 0) of the receiver antenna towards ``elevation_deg`` (any shape).

    The gain pattern of gps-sdr-sim (Ebinuma 2015, ``ant_pat_db``), tabulated every 5 deg
    of boresight angle ``90 - elevation`` and interpolated linearly: 0 dB at zenith, 2.44 dB
    at 50 deg, 7.56 dB at 10 deg and 9.78 dB at the horizon.
    """
    return np.interp(90.0 - np.asarray(elevation_deg, float), _BORESIGHT_DEG, ANTENNA_ATTENUATION_DB)


def cn0_from_elevation(cn0_zenith_dbhz: float | np.ndarray, elevation_deg: np.ndarray) -> np.ndarray:
    """C/N0 (dB-Hz) of satellites at ``elevation_deg``: the zenith C/N0 minus the antenna
    attenuation of `antenna_attenuation_db` (gps-sdr-sim's pattern)."""
    return np.asarray(cn0_zenith_dbhz, float) - antenna_attenuation_db(elevation_deg)


def klobuchar_obliquity(elevation_deg: np.ndarray) -> np.ndarray:
    """Ionospheric obliquity factor of the Klobuchar model (IS-GPS-200, 20.3.3.5.2.5).

    $F = 1 + 16\\,(0.53 - E)^3$ with $E$ the elevation in semicircles: 1.0004 at zenith,
    2.71 at 10 deg. A vertical ionospheric delay times F is the slant delay.
    """
    e_sc = np.asarray(elevation_deg, float) / 180.0
    return 1.0 + 16.0 * (0.53 - e_sc) ** 3


def tropo_mapping(elevation_deg: np.ndarray) -> np.ndarray:
    """Tropospheric mapping function of RTCA DO-229 (the one UNB3, Collins 1999, uses).

    $m(E) = 1.001 / \\sqrt{0.002001 + \\sin^2 E}$: 1.0000 at zenith, 5.58 at 10 deg.
    A zenith delay times m is the slant delay.
    """
    s = np.sin(np.radians(np.asarray(elevation_deg, float)))
    return 1.001 / np.sqrt(0.002001 + s * s)


def elevation_deg(sat_pos_m: np.ndarray, receiver_pos_m: np.ndarray, lat_deg: float, lon_deg: float) -> np.ndarray:
    """Elevation (deg) of satellites ``(..., ch, 3)`` seen from receivers ``(..., 3)`` (ECEF),
    above the plane normal to the ellipsoid's vertical at ``lat_deg``, ``lon_deg``."""
    lat, lon = np.radians(lat_deg), np.radians(lon_deg)
    up = np.array([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)])
    los = np.asarray(sat_pos_m) - np.asarray(receiver_pos_m)[..., None, :]
    return np.degrees(np.arcsin(np.clip((los @ up) / np.linalg.norm(los, axis=-1), -1.0, 1.0)))


@dataclass(frozen=True)
class RangeErrors:
    """Per-run range errors of the truth that the receiver's model lacks.

    Attributes
    ----------
    iono_vertical_m
        ``(runs, 1)`` vertical ionospheric residual at L1 (m), common to a run's channels
        and constant over the run; its slant value is ``F(E)`` times it (Klobuchar
        obliquity factor). It delays the code and advances the carrier (Kaplan and
        Hegarty 2017, section 10.2.4: code-carrier divergence).
    tropo_zenith_m
        ``(runs, 1)`` zenith (wet) tropospheric residual (m), mapped by the DO-229
        mapping function; delays code and carrier alike.
    orbit_clock_m
        ``(runs, ch)`` broadcast orbit and clock residual along each line of sight (m),
        constant over the run; delays code and carrier alike.
    """

    iono_vertical_m: np.ndarray
    tropo_zenith_m: np.ndarray
    orbit_clock_m: np.ndarray

    def code_and_carrier_m(self, elevation: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Code and carrier range errors (m) at elevations ``(..., runs, ch)`` (deg)."""
        iono = self.iono_vertical_m * klobuchar_obliquity(elevation)
        common = self.tropo_zenith_m * tropo_mapping(elevation) + self.orbit_clock_m
        return common + iono, common - iono


def draw_range_errors(
    rng: Any,
    runs: int,
    channels: int,
    *,
    iono_vertical_std_m: float = 0.0,
    tropo_zenith_std_m: float = 0.0,
    sisre_m: float = 0.0,
) -> RangeErrors:
    """Draw each run's residuals: zero-mean Gaussians of the given standard deviations (m).

    Each error source draws from its own child stream (``rng.child("iono-residual")``...)
    when ``rng`` is a `RunStreams`, so one option's draws never shift another's, and a
    run's values do not depend on its batch. A zero standard deviation draws nothing.
    """

    def gauss(purpose: str, std: float, shape: tuple[int, ...]) -> np.ndarray:
        if std == 0.0:
            return np.zeros(shape)
        src = rng.child(purpose) if isinstance(rng, draw.RunStreams) else rng
        return std * draw.standard_normal(src, shape, 0)

    return RangeErrors(
        gauss("iono-residual", iono_vertical_std_m, (runs, 1)),
        gauss("tropo-residual", tropo_zenith_std_m, (runs, 1)),
        gauss("orbit-clock-residual", sisre_m, (runs, channels)),
    )


def range_error_function(
    errors: RangeErrors, sat_state: Callable, receiver_state: Callable, lat_deg: float, lon_deg: float
) -> Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """``f(t) -> (code_m, carrier_m)``, each ``(*t.shape, runs, ch)``: the errors at the
    satellites' elevations at times ``t`` (``sat_state(t)[0]`` ``(*t, [runs,] ch, 3)``,
    ``receiver_state(t)[0]`` ``(*t, runs, 3)``)."""

    def f(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        s = np.asarray(sat_state(t)[0])
        r = np.asarray(receiver_state(t)[0])
        if s.ndim == r.ndim:  # satellites shared by the runs: add the run axis
            s = s[..., None, :, :]
        return errors.code_and_carrier_m(elevation_deg(s, r, lat_deg, lon_deg))

    return f


def least_squares_gain(unit_los: np.ndarray) -> np.ndarray:
    """$(G^T G)^{-1} G^T$ ``(..., 4, ch)`` with rows $G_i = [-e_i^T, 1]$, ``unit_los``
    ``(..., ch, 3)`` the unit vectors $e_i$ to the satellites: how range errors move a
    least-squares fix's position and clock (Kaplan and Hegarty 2017, section 11.2)."""
    e = np.asarray(unit_los, float)
    G = np.concatenate([-e, np.ones(e.shape[:-1] + (1,))], axis=-1)
    Gt = np.swapaxes(G, -1, -2)
    return np.linalg.solve(Gt @ G, Gt)


def least_squares_fix_error(code_m: np.ndarray, sat_pos_m: np.ndarray, receiver_pos_m: np.ndarray) -> np.ndarray:
    """Position and clock error ``(..., 4)`` (m: x, y, z, clock bias) of a least-squares fix
    whose pseudoranges carry the errors ``code_m`` ``(..., ch)``.

    Linearised at the true position, a pseudorange error $\\delta\\rho$ moves the fix by
    $\\delta x = (G^T G)^{-1} G^T \\delta\\rho$ (`least_squares_gain`): the error a receiver's
    first fix hands its navigation filter when the ranges are biased. Satellites ``(ch, 3)``
    or ``(..., ch, 3)``, receivers ``(..., 3)``, ECEF metres.
    """
    los = np.asarray(sat_pos_m, float) - np.asarray(receiver_pos_m, float)[..., None, :]
    gain = least_squares_gain(los / np.linalg.norm(los, axis=-1, keepdims=True))
    return (gain @ np.asarray(code_m, float)[..., None])[..., 0]
