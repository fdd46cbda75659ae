"""NMEA position logs (GGA and RMC sentences), parsed with pynmea2."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import DataFileError

__all__ = ["NmeaFixes", "read_nmea"]


@dataclass
class NmeaFixes:
    """Position fixes of an NMEA log, one per epoch (GGA preferred over RMC).

    Attributes
    ----------
    time_s
        Seconds since the first fix (UTC time of day, wrapped across midnight).
    lat_deg, lon_deg, height_m
        Fixes; ``height_m`` is NaN for epochs seen only in RMC.
    line
        Line number of the sentence each fix came from.
    skipped
        ``(line, reason)`` of every sentence that was corrupted (bad checksum, truncated,
        unparseable) or not a valid fix.
    """

    time_s: np.ndarray
    lat_deg: np.ndarray
    lon_deg: np.ndarray
    height_m: np.ndarray
    line: np.ndarray
    skipped: list[tuple[int, str]] = field(default_factory=list)


def _seconds(t) -> float:
    return t.hour * 3600 + t.minute * 60 + t.second + t.microsecond * 1e-6


def read_nmea(path: str | Path) -> NmeaFixes:
    """Read GGA and RMC fixes from an NMEA log.

    Corrupted sentences (bad or missing checksum, truncated, unparseable) and sentences
    that are not a valid fix (GGA quality 0, RMC status V) are skipped and listed with
    their line numbers in ``skipped``. Other sentence types are ignored silently.

    Raises
    ------
    DataFileError
        If the file cannot be read or holds no valid fix.
    """
    import pynmea2

    path = Path(path)
    try:
        text = path.read_text(errors="replace")
    except OSError as exc:
        raise DataFileError(str(path), None, f"cannot read: {exc.strerror}") from None
    fixes: dict[float, tuple] = {}
    skipped: list[tuple[int, str]] = []
    for no, raw in enumerate(text.splitlines(), 1):
        line = raw.strip()
        if not line:
            continue
        if "*" not in line:
            skipped.append((no, "truncated (no checksum)"))
            continue
        try:
            msg = pynmea2.parse(line, check=True)
        except pynmea2.ChecksumError:
            skipped.append((no, "bad checksum"))
            continue
        except (pynmea2.ParseError, ValueError, AttributeError) as exc:
            reason = "missing checksum (truncated?)" if "checksum" in str(exc).lower() else f"unparseable: {exc}"
            skipped.append((no, reason))
            continue
        kind = getattr(msg, "sentence_type", "")
        if kind not in ("GGA", "RMC"):
            continue
        try:
            if kind == "GGA":
                if not msg.gps_qual or int(msg.gps_qual) == 0:
                    skipped.append((no, "GGA without a fix (quality 0)"))
                    continue
                t = _seconds(msg.timestamp)
                fixes[t] = (msg.latitude, msg.longitude, float(msg.altitude), no)
            else:
                if msg.status != "A":
                    skipped.append((no, "RMC status V (no fix)"))
                    continue
                t = _seconds(msg.timestamp)
                fixes.setdefault(t, (msg.latitude, msg.longitude, np.nan, no))
        except (TypeError, ValueError, AttributeError) as exc:
            skipped.append((no, f"incomplete {kind}: {exc}"))
    if not fixes:
        raise DataFileError(str(path), None, f"no valid GGA or RMC fix ({len(skipped)} sentences skipped)")
    times = np.array(sorted(fixes))
    rows = np.array([fixes[t] for t in times], dtype=float)
    t_rel = np.unwrap(times - times[0], period=86400.0)  # a log may run past midnight
    return NmeaFixes(t_rel, rows[:, 0], rows[:, 1], rows[:, 2], rows[:, 3].astype(int), skipped)
