"""Satellites from GPS broadcast ephemeris (RINEX navigation files read with georinex).

Positions follow the user algorithm of IS-GPS-200 (Table 20-IV), in the one module that
implements it (:mod:`gnssframework.navigation.ephemeris`). Velocity and
acceleration are central differences of that position (velocity error below 1e-5 m/s,
acceleration below 1e-6 m/s²). The time argument is GPS seconds of the week, as the ephemeris' ``Toe``.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import DataFileError
from ..io.text import check_input_file
from ..navigation.ephemeris import ORBIT_FIELDS
from .constellation import SatelliteSet

__all__ = ["BroadcastEphemeris", "load_rinex_nav", "EPHEMERIS_FIELDS"]

#: georinex variable names of the Keplerian elements used.
EPHEMERIS_FIELDS = ORBIT_FIELDS


@dataclass(frozen=True)
class BroadcastEphemeris(SatelliteSet):
    """One broadcast ephemeris per satellite; ``elements[name]`` are arrays over satellites."""

    prn: np.ndarray
    elements: dict[str, np.ndarray]

    def subset(self, index: np.ndarray) -> BroadcastEphemeris:
        return BroadcastEphemeris(self.prn[index], {k: v[index] for k, v in self.elements.items()})

    def position(self, t_s: np.ndarray | float) -> np.ndarray:
        """ECEF position (m), shape ``(*t.shape, S, 3)`` (IS-GPS-200, Table 20-IV), computed
        by :func:`gnssframework.navigation.ephemeris.satellite_state`."""
        from ..navigation.ephemeris import CLOCK_FIELDS, Ephemerides, satellite_state

        n = self.prn.size
        zeros = np.zeros(n)
        sv = np.char.add("G", np.char.zfill(self.prn.astype(int).astype(str), 2))  # GPS records: "G01"
        records = Ephemerides(sv, zeros, {**self.elements, **{f: zeros for f in CLOCK_FIELDS}}, zeros, zeros)
        t = np.asarray(t_s, dtype=float)[..., None]
        return satellite_state(records, t).position_m

    def state(self, t_s):
        # Velocity: 10 ms central difference (truncation and rounding both below 1e-5 m/s).
        # Acceleration: 1 s second difference; a 10 ms one would be rounding-limited.
        t = np.asarray(t_s, dtype=float)
        p = self.position(t)
        v = (self.position(t + 0.01) - self.position(t - 0.01)) / 0.02
        a = self.position(t + 1.0) - 2 * p + self.position(t - 1.0)
        return p, v, a


def load_rinex_nav(path: str | Path, t_s: float | None = None) -> BroadcastEphemeris:
    """GPS ephemerides of a RINEX navigation file (georinex; a RINEX 4 file's LNAV records
    through `navigation.rinex4_nav`), one per satellite.

    With ``t_s`` (GPS seconds of week), each satellite's record whose ``Toe`` is closest
    is used; otherwise its last record.

    Raises
    ------
    DataFileError
        If the file is missing, unreadable or holds no complete GPS ephemeris.
    """
    import georinex

    path = check_input_file(path)
    from ..navigation.ephemeris import read_rinex_nav
    from ..navigation.rinex4_nav import is_rinex4

    if is_rinex4(path):  # georinex reads RINEX 2 and 3: the project's RINEX 4 reader, LNAV records
        return _from_records(read_rinex_nav(path, "G"), t_s)
    try:
        with warnings.catch_warnings():  # georinex's xarray calls emit FutureWarnings per record
            warnings.simplefilter("ignore", FutureWarning)
            nav = georinex.load(path, use="G")
    except Exception as exc:  # noqa: BLE001 - georinex raises many types
        raise DataFileError(str(path), None, f"georinex could not read it: {type(exc).__name__}: {exc}") from None
    missing = [f for f in EPHEMERIS_FIELDS if f not in nav.data_vars]
    if missing:
        raise DataFileError(str(path), None, f"not a GPS navigation file: lacks {', '.join(missing)}")
    prns, rows = [], []
    for sv in nav.sv.values:
        sat = nav.sel(sv=sv)
        toe = sat["Toe"].values
        ok = np.all([np.isfinite(sat[f].values) for f in EPHEMERIS_FIELDS], axis=0)
        if not ok.any():
            continue
        idx = np.flatnonzero(ok)
        pick = idx[np.argmin(np.abs(toe[idx] - t_s))] if t_s is not None else idx[-1]
        prns.append(int(str(sv)[1:]))
        rows.append([float(sat[f].values[pick]) for f in EPHEMERIS_FIELDS])
    if not rows:
        raise DataFileError(str(path), None, "no complete GPS ephemeris")
    table = np.array(rows)
    return BroadcastEphemeris(np.array(prns), {f: table[:, j] for j, f in enumerate(EPHEMERIS_FIELDS)})


def _from_records(records, t_s: float | None) -> BroadcastEphemeris:
    """One LNAV record per satellite of `ephemeris.Ephemerides` (CNAV records left out: their
    Adot and Delta n0 rate are not elements here), chosen as `load_rinex_nav` chooses."""
    lnav = records.subset(np.flatnonzero(records.elements["CNAV"] == 0)) if "CNAV" in records.elements else records
    prns, rows = [], []
    for sv in dict.fromkeys(lnav.sv.tolist()):
        idx = np.flatnonzero(lnav.sv == sv)
        toe = lnav.elements["Toe"][idx]
        pick = idx[np.argmin(np.abs(toe - t_s))] if t_s is not None else idx[-1]
        prns.append(int(str(sv)[1:]))
        rows.append([float(lnav.elements[f][pick]) for f in EPHEMERIS_FIELDS])
    table = np.array(rows)
    return BroadcastEphemeris(np.array(prns), {f: table[:, j] for j, f in enumerate(EPHEMERIS_FIELDS)})
