"""RINEX observation files: read with georinex, and a minimal RINEX 3.04 writer.

The writer exists so the project can generate its own small test file (a simulated GPS
pass); reading goes through georinex, which handles the real-world variety of files.
"""

from __future__ import annotations

import datetime as dt
import re
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import DataFileError
from ..signal.constants import L1_WAVELENGTH_M

__all__ = ["CodeCarrier", "read_code_carrier", "write_rinex3_obs", "write_rinex3_nav", "check_rinex3_obs"]


@dataclass
class CodeCarrier:
    """L1 pseudorange and carrier phase of one satellite, epochs where both exist."""

    time_s: np.ndarray  # seconds since the first epoch
    epoch: np.ndarray  # numpy datetime64
    pseudorange_m: np.ndarray
    carrier_m: np.ndarray  # carrier phase times the L1 wavelength


def write_rinex3_obs(path: str | Path, start: dt.datetime, interval_s: float,
                     observations: dict[str, tuple[np.ndarray, np.ndarray]],
                     approx_position_m: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> None:
    """Write a RINEX 3.04 GPS observation file with C1C (m) and L1C (cycles).

    ``observations`` maps a satellite (``"G08"``) to its pseudorange (m) and carrier phase
    (cycles) arrays, NaN where there is no observation.
    """
    sats = sorted(observations)
    n = len(next(iter(observations.values()))[0])

    def hdr(text: str, label: str) -> str:
        return f"{text:<60}{label:<20}"

    lines = [
        hdr("     3.04           OBSERVATION DATA    G (GPS)", "RINEX VERSION / TYPE"),
        hdr(f"{'gnssframework':<20}{'gnssframework':<20}{start:%Y%m%d %H%M%S} UTC", "PGM / RUN BY / DATE"),
        hdr("SIMULATED", "MARKER NAME"),
        hdr(f"{'gnssframework':<20}{'':<40}", "OBSERVER / AGENCY"),
        hdr(f"{'0':<20}{'SIMULATOR':<20}{'1':<20}", "REC # / TYPE / VERS"),
        hdr(f"{'0':<20}{'NONE':<20}", "ANT # / TYPE"),
        hdr("".join(f"{c:14.4f}" for c in approx_position_m), "APPROX POSITION XYZ"),
        hdr("".join(f"{c:14.4f}" for c in (0.0, 0.0, 0.0)), "ANTENNA: DELTA H/E/N"),
        hdr("G    2 C1C L1C", "SYS / # / OBS TYPES"),
        hdr(f"{interval_s:10.3f}", "INTERVAL"),
        hdr(f"{start:  %Y    %m    %d    %H    %M}   {start.second:10.7f}     GPS", "TIME OF FIRST OBS"),
        hdr("", "END OF HEADER"),
    ]
    for k in range(n):
        t = start + dt.timedelta(seconds=k * interval_s)
        present = [s for s in sats if np.isfinite(observations[s][0][k]) and np.isfinite(observations[s][1][k])]
        sec = t.second + t.microsecond * 1e-6
        lines.append(f"> {t:%Y %m %d %H %M}{sec:11.7f}  0{len(present):3d}")
        for s in present:
            code, phase = observations[s][0][k], observations[s][1][k]
            lines.append(f"{s:<3}{code:14.3f}  {phase:14.3f}  ")
    Path(path).write_text("\n".join(lines) + "\n")


_EPOCH = re.compile(r"^> \d{4} [ \d]\d [ \d]\d [ \d]\d [ \d]\d [ \d]\d\.\d{7}  \d[ \d]{2}\d")
_OBS = re.compile(r"^[GRECJIS][ \d]\d")


def check_rinex3_obs(path: str | Path) -> None:
    """Find the first malformed line of a RINEX 3 observation file.

    georinex reports parse failures without a line number; this pass does, for the
    header (labels, END OF HEADER), epoch lines and observation lines.

    Raises
    ------
    DataFileError
        Naming the file and the line.
    """
    path = Path(path)
    lines = path.read_text(errors="replace").splitlines()
    if not lines or "RINEX VERSION / TYPE" not in lines[0]:
        raise DataFileError(str(path), 1, "not a RINEX file: first line lacks 'RINEX VERSION / TYPE'")
    if not lines[0][:9].strip().startswith("3"):
        raise DataFileError(str(path), 1, f"RINEX version {lines[0][:9].strip()!r}: this reader checks version 3")
    try:
        end = next(i for i, line in enumerate(lines) if "END OF HEADER" in line)
    except StopIteration:
        raise DataFileError(str(path), len(lines), "no END OF HEADER line") from None
    n_obs = None
    for i, line in enumerate(lines[1:end], 2):
        if "SYS / # / OBS TYPES" in line and line.startswith("G"):
            try:
                n_obs = int(line[3:6])
            except ValueError:
                raise DataFileError(str(path), i, "bad number of observation types") from None
    expected = 0
    for i in range(end + 1, len(lines)):
        line, no = lines[i], i + 1
        if not line.strip():
            continue
        if line.startswith(">"):
            if not _EPOCH.match(line):
                raise DataFileError(str(path), no, f"malformed epoch line {line!r}")
            expected = int(line[32:35])
            continue
        if expected <= 0:
            raise DataFileError(str(path), no, "observation line outside an epoch (or more than its count)")
        if not _OBS.match(line):
            raise DataFileError(str(path), no, f"bad satellite id {line[:3]!r}")
        if line.startswith("G") and n_obs:
            for j in range(n_obs):
                field = line[3 + 16 * j: 3 + 16 * j + 14]
                if field.strip():
                    try:
                        float(field)
                    except ValueError:
                        raise DataFileError(str(path), no, f"observation {j + 1} is not a number: {field!r}") \
                            from None
        expected -= 1


def read_code_carrier(path: str | Path, prn: str) -> CodeCarrier:
    """L1 C/A pseudorange and carrier (metres) of satellite ``prn`` (``"G08"``), via georinex.

    Raises
    ------
    DataFileError
        For a malformed file (naming the line), or when ``prn`` has no C1C/L1C data.
    """
    import georinex

    path = Path(path)
    if not path.exists():
        raise DataFileError(str(path), None, "no such file")
    check_rinex3_obs(path)
    try:
        with warnings.catch_warnings():  # georinex's xarray calls emit FutureWarnings
            warnings.simplefilter("ignore", FutureWarning)
            obs = georinex.load(path, use="G", meas=["C1C", "L1C"])
    except Exception as exc:  # noqa: BLE001 - georinex raises many types; report them as file errors
        raise DataFileError(str(path), None, f"georinex could not read it: {type(exc).__name__}: {exc}") from None
    if prn not in obs.sv.values:
        raise DataFileError(str(path), None, f"no observations of {prn}; satellites: {', '.join(obs.sv.values)}")
    sat = obs.sel(sv=prn)
    code = sat["C1C"].values.astype(float)
    phase = sat["L1C"].values.astype(float)
    ok = np.isfinite(code) & np.isfinite(phase)
    if not ok.any():
        raise DataFileError(str(path), None, f"{prn} has no epoch with both C1C and L1C")
    times = sat.time.values[ok]
    t = (times - times[0]) / np.timedelta64(1, "s")
    return CodeCarrier(t.astype(float), times, code[ok], phase[ok] * L1_WAVELENGTH_M)


def _d19(x: float) -> str:
    return f"{x:19.12E}".replace("E", "D")


def write_rinex3_nav(path: str | Path, epoch: dt.datetime, ephemerides: dict[int, dict[str, float]],
                     gps_week: int = 2103) -> None:
    """Write a RINEX 3.04 GPS navigation file (one record per satellite, clock terms zero).

    ``ephemerides`` maps a PRN to the IS-GPS-200 elements under georinex's names
    (``sqrtA``, ``Eccentricity``, ``Io``, ``Omega0``, ``omega``, ``M0``, ``Toe`` and,
    optionally, ``DeltaN``, ``OmegaDot``, ``IDOT`` and the six harmonic corrections).
    """

    def hdr(text: str, label: str) -> str:
        return f"{text:<60}{label:<20}"

    lines = [hdr("     3.04           N: GNSS NAV DATA    G: GPS", "RINEX VERSION / TYPE"),
             hdr(f"{'gnssframework':<20}{'gnssframework':<20}{epoch:%Y%m%d %H%M%S} UTC", "PGM / RUN BY / DATE"),
             hdr("", "END OF HEADER")]
    for prn in sorted(ephemerides):
        e = {k: 0.0 for k in ("DeltaN", "OmegaDot", "IDOT", "Cuc", "Cus", "Crc", "Crs", "Cic", "Cis")}
        e.update(ephemerides[prn])
        lines.append(f"G{prn:02d} {epoch:%Y %m %d %H %M %S}" + _d19(0.0) * 3)
        for row in ([1.0, e["Crs"], e["DeltaN"], e["M0"]], [e["Cuc"], e["Eccentricity"], e["Cus"], e["sqrtA"]],
                    [e["Toe"], e["Cic"], e["Omega0"], e["Cis"]], [e["Io"], e["Crc"], e["omega"], e["OmegaDot"]],
                    [e["IDOT"], 0.0, float(gps_week), 0.0], [2.0, 0.0, 0.0, 1.0], [e["Toe"], 4.0]):
            lines.append("    " + "".join(_d19(v) for v in row))
    Path(path).write_text("\n".join(lines) + "\n")
