"""One line about any recorded file: what was read, skipped and why, or why it is refused.

:func:`describe_recording` recognises RINEX observation and navigation files (plain,
gzip, Hatanaka), NMEA logs (plain, gpsd's commented logs, GnssLogger's wrapped form) and
the GSDC 2022 CSV files, and reads each with the framework's reader.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import DataFileError

__all__ = ["describe_recording", "recording_kind"]


def _first_line(path: Path) -> str:
    from .observations import _decompress

    name = path.name.lower()
    if name.endswith((".crx", ".crx.gz", ".gz", ".z")) or name[-1:] == "d" and name[-3:-1].isdigit():
        return _decompress(path).split("\n", 1)[0]  # hatanaka undoes the compression
    with open(path, "rb") as fh:
        return fh.readline(4096).decode("ascii", errors="replace").rstrip("\r\n")


def recording_kind(path: str | Path) -> str:
    """``"rinex-obs"``, ``"rinex-nav"``, ``"nmea"``, ``"gsdc-device"`` or ``"gsdc-truth"``.

    Raises
    ------
    DataFileError
        Line 1 of a file that is none of them.
    """
    path = Path(path)
    if not path.is_file():
        raise DataFileError(str(path), None, "no such file")
    first = _first_line(path)
    if "RINEX VERSION / TYPE" in first:
        return "rinex-obs" if first[20:21] == "O" else "rinex-nav" if first[20:21] in "NGL" else "rinex-other"
    if first.startswith("MessageType,") and "WlsPositionXEcefMeters" in first:
        return "gsdc-device"
    if first.startswith("MessageType,") and "LatitudeDegrees" in first:
        return "gsdc-truth"
    with open(path, "rb") as fh:
        head = fh.read(65536).decode("ascii", errors="replace")
    if any(line.lstrip().startswith(("$", "!", "NMEA,$")) for line in head.split("\n")):
        return "nmea"
    raise DataFileError(str(path), 1, f"not a RINEX, NMEA or GSDC 2022 file: first line {first[:40]!r}")


def describe_recording(path: str | Path, select: str = "all") -> str:
    """Read ``path`` with the reader its kind needs and say, in one line, what was read.

    Parameters
    ----------
    select
        Satellites or systems of a RINEX observation file (as ``read_observations``).

    Raises
    ------
    DataFileError
        The file is refused (one line: file, line, reason).
    """
    path = Path(path)
    kind = recording_kind(path)
    if kind == "rinex-obs":
        from .observations import read_observations

        obs = read_observations(path, select)
        systems = {s: int(sum(sv[0] == s for sv in obs.sv)) for s in sorted({sv[0] for sv in obs.sv})}
        flags = int(((obs.lli & 1) != 0)[obs.valid].sum())
        return (
            f"{path.name}: RINEX {obs.version:g} observations, {obs.epoch.size} epochs at {obs.interval_s:g} s, "
            f"satellites {', '.join(f'{s} {n}' for s, n in systems.items())}, {int(obs.valid.sum())} code+carrier "
            f"observations, {flags} loss-of-lock flags; {len(obs.skipped)} skipped"
            + (f" (first at line {obs.skipped[0][0]}: {obs.skipped[0][1]})" if obs.skipped else "")
            + (f"; not read: {len(obs.dropped)} satellites" if obs.dropped else "")
            + (f"; TRUNCATED: {obs.truncated}" if obs.truncated else "")
        )
    if kind == "rinex-nav":
        from ..navigation.ephemeris import read_rinex_nav

        import warnings

        with warnings.catch_warnings(record=True) as caught:  # records georinex misread: said in the line
            warnings.simplefilter("always", UserWarning)
            eph = read_rinex_nav(path, "GEC")  # every system this framework propagates (not GLONASS)
        misread = [str(w.message).split(": ", 1)[1].split(" (")[0] for w in caught if "misread" in str(w.message)]
        letters = eph.sv.astype("U1")
        counts = {s: int((letters == s).sum()) for s in "GEC" if (letters == s).any()}
        what = (
            "GPS ephemeris records"
            if list(counts) == ["G"]
            else f"ephemeris records ({', '.join(f'{s} {n}' for s, n in counts.items())})"
        )
        return (
            f"{path.name}: RINEX navigation, {eph.sv.size} {what} of {np.unique(eph.sv).size} "
            f"satellites, {int((eph.health != 0).sum())} unhealthy"
            + (f"; {', '.join(misread)}, not used" if misread else "")
        )
    if kind == "nmea":
        from .nmea import read_nmea

        fixes = read_nmea(path)
        ignored = ", ".join(f"{n} {k}" for k, n in fixes.ignored.items())
        return (
            f"{path.name}: NMEA, {fixes.time_s.size} fixes over {fixes.time_s[-1]:g} s; not used: "
            f"{ignored or 'nothing'}; {fixes.comments} comment lines; {len(fixes.skipped)} skipped"
            + (f" (first at line {fixes.skipped[0][0]}: {fixes.skipped[0][1]})" if fixes.skipped else "")
        )
    if kind in ("gsdc-device", "gsdc-truth"):
        from .gsdc import read_gsdc_truth, read_gsdc_wls

        fixes = read_gsdc_wls(path) if kind == "gsdc-device" else read_gsdc_truth(path)
        what = "baseline WLS fixes" if kind == "gsdc-device" else "ground-truth positions"
        return (
            f"{path.name}: GSDC 2022, {fixes.utc_ms.size} {what} over {(fixes.utc_ms[-1] - fixes.utc_ms[0]) / 1e3:g} s"
        )
    raise DataFileError(str(path), 1, "a RINEX file of a type this framework does not read (not O or N)")
