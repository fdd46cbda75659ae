"""Satellite position, velocity and clock from GPS broadcast ephemerides (IS-GPS-200).

The one place the framework turns broadcast ephemeris records into satellite states: the
simulation's :class:`~gnssframework.simulation.ephemeris.BroadcastEphemeris` and a
software receiver both call :func:`satellite_state`. Records come from RINEX 2 or 3
navigation files through georinex (:func:`read_rinex_nav`).

Times are GPS seconds of the week (the records' ``Toe`` and ``Toc`` scale);
:func:`gps_seconds_of_week` converts ``datetime64`` epochs.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import DataFileError

__all__ = ["Ephemerides", "SatelliteState", "read_rinex_nav", "satellite_state", "gps_seconds_of_week",
           "GM_GPS_M3_S2", "OMEGA_EARTH_RAD_S", "F_RELATIVISTIC_S_SQRTM", "ORBIT_FIELDS", "CLOCK_FIELDS"]

#: WGS 84 gravitational constant of IS-GPS-200 (Table 20-IV), m^3/s^2.
GM_GPS_M3_S2 = 3.986005e14
#: WGS 84 Earth rotation rate of IS-GPS-200 (Table 20-IV), rad/s.
OMEGA_EARTH_RAD_S = 7.2921151467e-5
#: Relativistic clock constant F = -2 sqrt(mu) / c^2 (IS-GPS-200 20.3.3.3.3.1), s/sqrt(m).
F_RELATIVISTIC_S_SQRTM = -4.442807633e-10
_HALF_WEEK_S = 302_400.0
_GPS_EPOCH = np.datetime64("1980-01-06T00:00:00", "ns")

#: georinex names of the Keplerian elements (IS-GPS-200 Table 20-III).
ORBIT_FIELDS = ("sqrtA", "Eccentricity", "Io", "Omega0", "omega", "M0", "DeltaN", "OmegaDot", "IDOT",
                "Cuc", "Cus", "Crc", "Crs", "Cic", "Cis", "Toe")
#: georinex names of the clock terms af0, af1, af2 (s, s/s, s/s^2) and the group delay T_GD (s).
CLOCK_FIELDS = ("SVclockBias", "SVclockDrift", "SVclockDriftRate", "TGD")


@dataclass(frozen=True)
class Ephemerides:
    """Broadcast ephemeris records, one per entry (batch-first over records).

    Attributes
    ----------
    sv
        ``(N,)`` satellite of each record (``"G08"``).
    toc_s
        ``(N,)`` clock reference time, GPS seconds of week.
    elements
        ``ORBIT_FIELDS`` and ``CLOCK_FIELDS``, each ``(N,)``.
    health
        ``(N,)`` the SV health word (0: healthy).
    iode
        ``(N,)`` issue of data.
    """

    sv: np.ndarray
    toc_s: np.ndarray
    elements: dict[str, np.ndarray]
    health: np.ndarray
    iode: np.ndarray

    def subset(self, index: np.ndarray) -> "Ephemerides":
        return Ephemerides(self.sv[index], self.toc_s[index], {k: v[index] for k, v in self.elements.items()},
                           self.health[index], self.iode[index])

    def select(self, sv: np.ndarray | list[str], t_s: float, healthy_only: bool = True) -> "Ephemerides":
        """For each satellite of ``sv``, the record whose ``Toe`` is nearest ``t_s``
        (across the week crossover); healthy records only unless ``healthy_only`` is False.

        Raises
        ------
        KeyError
            Naming a satellite without a (healthy) record.
        """
        picks = []
        for name in np.atleast_1d(sv):
            ok = (self.sv == name) & ((self.health == 0) | (not healthy_only))
            if not ok.any():
                raise KeyError(f"no {'healthy ' if healthy_only else ''}ephemeris of {name}")
            idx = np.flatnonzero(ok)
            dt = _wrap_week(t_s - self.elements["Toe"][idx])
            picks.append(idx[np.argmin(np.abs(dt))])
        return self.subset(np.array(picks, dtype=int))


@dataclass(frozen=True)
class SatelliteState:
    """Satellite states at transmit times (shapes ``(..., 3)`` and ``(...)``).

    ``clock_s`` is the SV clock offset of IS-GPS-200 20.3.3.3.3.1 including the
    relativistic term (``relativistic_s``), for the ionosphere-free P1/P2 combination;
    ``clock_l1_s`` subtracts T_GD, for an L1 C/A single-frequency user (20.3.3.3.3.2).
    """

    position_m: np.ndarray
    velocity_mps: np.ndarray
    clock_s: np.ndarray
    clock_drift_s_s: np.ndarray
    relativistic_s: np.ndarray
    clock_l1_s: np.ndarray


def _wrap_week(dt_s):
    """Account for the beginning or end of week crossover (IS-GPS-200 20.3.3.4.3)."""
    return (np.asarray(dt_s, float) + _HALF_WEEK_S) % (2 * _HALF_WEEK_S) - _HALF_WEEK_S


def gps_seconds_of_week(epoch: np.ndarray) -> np.ndarray:
    """GPS seconds of week of ``datetime64`` epochs given in GPS time."""
    ns = (np.asarray(epoch, dtype="datetime64[ns]") - _GPS_EPOCH).astype(np.int64)
    return (ns % (604_800 * 10**9)) / 1e9


def satellite_state(eph: Ephemerides, t_s: np.ndarray | float) -> SatelliteState:
    """Position, velocity (ECEF, WGS 84) and clock of each record at GPS time ``t_s``.

    Position follows the user algorithm of IS-GPS-200 Table 20-IV (Kepler's equation by
    Newton's method, second-harmonic corrections, Earth-fixed node longitude); velocity
    is its time derivative (analytic); the clock is af0 + af1 (t - toc) + af2 (t - toc)^2
    plus the relativistic term F e sqrt(A) sin E (IS-GPS-200 20.3.3.3.3.1).

    Parameters
    ----------
    eph
        ``S`` records (one per satellite, :meth:`Ephemerides.select`).
    t_s
        Transmit times, GPS seconds of week, broadcastable to ``(..., S)``: the satellite
        time corrected for the SV clock, as the ICD's ``t``.

    Returns
    -------
    SatelliteState
        Arrays of shape ``(..., S, 3)`` and ``(..., S)``.
    """
    e = eph.elements
    t = np.asarray(t_s, dtype=float)
    A = e["sqrtA"] ** 2
    n0 = np.sqrt(GM_GPS_M3_S2 / A**3)
    n = n0 + e["DeltaN"]
    tk = _wrap_week(t - e["Toe"])
    M = e["M0"] + n * tk
    ecc = e["Eccentricity"]
    E = np.array(M, dtype=float, copy=True)
    for _ in range(10):  # Newton on Kepler's equation; converges in 3-4 steps for e < 0.03
        E = E - (E - ecc * np.sin(E) - M) / (1 - ecc * np.cos(E))
    sinE, cosE = np.sin(E), np.cos(E)
    nu = np.arctan2(np.sqrt(1 - ecc**2) * sinE, cosE - ecc)
    phi = nu + e["omega"]
    s2, c2 = np.sin(2 * phi), np.cos(2 * phi)
    u = phi + e["Cus"] * s2 + e["Cuc"] * c2
    r = A * (1 - ecc * cosE) + e["Crs"] * s2 + e["Crc"] * c2
    i = e["Io"] + e["Cis"] * s2 + e["Cic"] * c2 + e["IDOT"] * tk
    x_orb, y_orb = r * np.cos(u), r * np.sin(u)
    node_rate = e["OmegaDot"] - OMEGA_EARTH_RAD_S
    node = e["Omega0"] + node_rate * tk - OMEGA_EARTH_RAD_S * e["Toe"]
    cn, sn, ci, si = np.cos(node), np.sin(node), np.cos(i), np.sin(i)
    x = x_orb * cn - y_orb * ci * sn
    y = x_orb * sn + y_orb * ci * cn
    z = y_orb * si
    # Time derivatives of the same chain.
    E_dot = n / (1 - ecc * cosE)
    phi_dot = np.sqrt(1 - ecc**2) * E_dot / (1 - ecc * cosE)
    u_dot = phi_dot * (1 + 2 * (e["Cus"] * c2 - e["Cuc"] * s2))
    r_dot = A * ecc * sinE * E_dot + 2 * phi_dot * (e["Crs"] * c2 - e["Crc"] * s2)
    i_dot = e["IDOT"] + 2 * phi_dot * (e["Cis"] * c2 - e["Cic"] * s2)
    xo_dot = r_dot * np.cos(u) - y_orb * u_dot
    yo_dot = r_dot * np.sin(u) + x_orb * u_dot
    vx = xo_dot * cn - yo_dot * ci * sn + y_orb * si * sn * i_dot - y * node_rate
    vy = xo_dot * sn + yo_dot * ci * cn - y_orb * si * cn * i_dot + x * node_rate
    vz = yo_dot * si + y_orb * ci * i_dot
    dtc = _wrap_week(t - eph.toc_s)
    rel = F_RELATIVISTIC_S_SQRTM * ecc * e["sqrtA"] * sinE
    rel_dot = F_RELATIVISTIC_S_SQRTM * ecc * e["sqrtA"] * cosE * E_dot
    clock = e["SVclockBias"] + e["SVclockDrift"] * dtc + e["SVclockDriftRate"] * dtc**2 + rel
    drift = e["SVclockDrift"] + 2 * e["SVclockDriftRate"] * dtc + rel_dot
    return SatelliteState(np.stack([x, y, z], -1), np.stack([vx, vy, vz], -1), clock, drift, rel,
                          clock - e["TGD"])


def read_rinex_nav(path: str | Path) -> Ephemerides:
    """Every complete GPS ephemeris record of a RINEX 2 or 3 navigation file (georinex).

    Raises
    ------
    DataFileError
        If the file is missing, unreadable or holds no complete GPS record (one line,
        naming the file).
    """
    import georinex

    path = Path(path)
    if not path.exists():
        raise DataFileError(str(path), None, "no such file")
    try:
        with warnings.catch_warnings():  # georinex's xarray calls emit FutureWarnings per record
            warnings.simplefilter("ignore", FutureWarning)
            nav = georinex.load(path, use="G")
    except Exception as exc:  # noqa: BLE001 - georinex raises many types
        raise DataFileError(str(path), None, f"georinex could not read it: {type(exc).__name__}: {exc}") from None
    if nav.attrs.get("rinextype") != "nav":
        raise DataFileError(str(path), 1, f"not a navigation file (RINEX type {nav.attrs.get('rinextype')!r})")
    fields = ORBIT_FIELDS + CLOCK_FIELDS + ("health", "IODE")
    missing = [f for f in fields if f not in nav.data_vars]
    if missing:
        raise DataFileError(str(path), None, f"not a GPS navigation file: lacks {', '.join(missing)}")
    values = {f: nav[f].values for f in fields}  # (time, sv)
    ok = np.all([np.isfinite(v) for v in values.values()], axis=0)
    if not ok.any():
        raise DataFileError(str(path), None, "no complete GPS ephemeris record")
    ti, si = np.nonzero(ok)
    toc = gps_seconds_of_week(nav.time.values[ti])  # the record's epoch is its Toc
    return Ephemerides(nav.sv.values[si].astype(str), toc, {f: values[f][ti, si].astype(float)
                                                            for f in ORBIT_FIELDS + CLOCK_FIELDS},
                       values["health"][ti, si].astype(float), values["IODE"][ti, si].astype(float))
