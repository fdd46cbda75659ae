"""NMEA position logs (GGA and RMC sentences), parsed with pynmea2.

Logs as receivers and loggers write them: ``#`` comment lines (gpsd's regression logs),
Android GnssLogger's wrapped form ``NMEA,<sentence>,<unix ms>``, any talker (GP, GN, GL,
GA, BD, GB, ...) and binary data (a u-blox UBX stream) between the sentences.
"""

from __future__ import annotations

import datetime as dt
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import ConfigError, DataFileError
from .skipped import refuse_or_keep
from .text import read_input_text

__all__ = ["NmeaFixes", "read_nmea", "MAX_SPEED_MPS", "MAX_ABS_HEIGHT_M"]

#: Default speed threshold of the jump check: faster than any airliner, yet a longitude
#: jump of 0.01 deg in 1 s (about 1 km at mid latitudes) already exceeds it.
MAX_SPEED_MPS = 1000.0
#: Default bound of a GGA altitude above mean sea level: no land receiver or aircraft is
#: near 100 km (the Karman line); the Dead Sea shore is at -430 m. A receiver in orbit needs
#: another bound.
MAX_ABS_HEIGHT_M = 1.0e5
_EARTH_RADIUS_M = 6_371_008.8  # mean radius: the jump check needs metres, not millimetres


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
        unparseable), not a valid fix, or refused by the plausibility and time-order
        checks of :func:`read_nmea`; in line order. A run of consecutive lines of binary
        data or other non-NMEA text is one entry (its first line, its extent).
    ignored
        Count of the valid sentences of each type the reader does not use (``"GSV"``,
        ``"GSA"``, a proprietary ``"PUBX"``...): read, checksum-checked, not positions.
    comments
        Number of ``#`` comment lines.
    """

    time_s: np.ndarray
    lat_deg: np.ndarray
    lon_deg: np.ndarray
    height_m: np.ndarray
    line: np.ndarray
    skipped: list[tuple[int, str]] = field(default_factory=list)
    ignored: dict[str, int] = field(default_factory=dict)
    comments: int = 0


def _seconds(t) -> float:
    return t.hour * 3600 + t.minute * 60 + t.second + t.microsecond * 1e-6


def _clock(t_s: float) -> str:
    t = t_s % 86400.0
    return f"{int(t // 3600):02d}:{int(t % 3600 // 60):02d}:{t % 60:06.3f}"


def _coordinate(msg, kind: str) -> tuple[float, float] | str:
    """``(lat_deg, lon_deg)`` of a GGA/RMC sentence, or the reason it is not a position."""
    for name, value, hemi, allowed, width in (
        ("latitude", msg.lat, msg.lat_dir, "NS", 2),
        ("longitude", msg.lon, msg.lon_dir, "EW", 3),
    ):
        if not value.strip():
            return f"{kind} with an empty {name}"
        if hemi not in tuple(allowed):  # pynmea2 reads any other letter as 0 deg
            return f"{kind} {name} hemisphere {hemi!r} is not {' or '.join(allowed)}"
        try:
            minutes = float(value[width:])
        except ValueError:
            return f"{kind} {name} {value!r} is not ddmm.mmmm"
        if not 0.0 <= minutes < 60.0:
            return f"{kind} {name} {value!r}: minutes {minutes:g} outside [0, 60)"
    lat, lon = float(msg.latitude), float(msg.longitude)
    if not -90.0 <= lat <= 90.0:
        return f"latitude {lat:.6f} deg outside +-90 deg"
    if not -180.0 <= lon <= 180.0:
        return f"longitude {lon:.6f} deg outside +-180 deg"
    return lat, lon


def _distance_m(lat0: float, lon0: float, lat1: float, lon1: float) -> float:
    """Great-circle distance (haversine on the mean sphere; the jump test is coarse)."""
    p0, p1, dl = np.radians(lat0), np.radians(lat1), np.radians(lon1 - lon0)
    h = np.sin((p1 - p0) / 2) ** 2 + np.cos(p0) * np.cos(p1) * np.sin(dl / 2) ** 2
    return float(2 * _EARTH_RADIUS_M * np.arcsin(min(1.0, np.sqrt(h))))


def read_nmea(
    path: str | Path,
    max_speed_mps: float = MAX_SPEED_MPS,
    strict: bool = False,
    max_abs_height_m: float = MAX_ABS_HEIGHT_M,
) -> NmeaFixes:
    """Read GGA and RMC fixes from an NMEA log, with integrity checks.

    A sentence is skipped, and listed with its line number and the reason in ``skipped``,
    when it is

    - corrupted: bad or missing checksum, truncated, unparseable (pynmea2 decides);
    - not a valid fix: GGA quality 0, RMC status V;
    - not a position: an empty latitude or longitude field (even under a valid checksum),
      a hemisphere other than N/S or E/W, minutes outside [0, 60), a latitude outside
      +-90 deg or a longitude outside +-180 deg, a GGA altitude that is not a number or
      outside +-``max_abs_height_m``; a timestamp that is not a time of day;
    - out of time order: a timestamp already seen for that sentence type (duplicate), or
      earlier than the last accepted epoch (backwards). A GGA and an RMC with the same
      timestamp are one epoch (GGA preferred). A step back of more than 12 h is read as
      the UTC day rolling over midnight, not as going backwards;
    - an implausible jump: the great-circle distance to the last accepted epoch divided by
      the time between them exceeds ``max_speed_mps``. The first fix is trusted, so a
      wrong first fix shows as every later fix skipped.

    Other sentence types (GSV, GSA, proprietary ones...) are checked, not used, and
    counted by type in ``ignored``. Lines starting with ``#`` are comments (counted),
    empty lines are passed over, GnssLogger's wrapped sentences are unwrapped, and bytes
    that are no NMEA sentence (a binary protocol on the same port) are listed once per
    run of consecutive lines.

    Parameters
    ----------
    path
        The log.
    max_speed_mps
        Threshold of the jump check (m/s), default :data:`MAX_SPEED_MPS`.
    strict
        Refuse the file at the first problem instead of skipping.
    max_abs_height_m
        Plausibility bound of the GGA altitude (m), default :data:`MAX_ABS_HEIGHT_M`.

    Raises
    ------
    DataFileError
        If the file cannot be read or holds no valid fix; with ``strict``, at the first
        line that would be skipped (naming the line and the reason).
    """
    import pynmea2

    if not 0 < max_speed_mps < np.inf:
        raise ConfigError("max_speed_mps", f"must be a positive number of m/s, got {max_speed_mps!r}")
    if not 0 < max_abs_height_m < np.inf:
        raise ConfigError("max_abs_height_m", f"must be a positive number of m, got {max_abs_height_m!r}")
    path = Path(path)
    text = read_input_text(path, errors="replace", encoding="ascii")
    # epochs: absolute time (s since 00:00 of the first day) -> {kind: (lat, lon, h, line)}
    epochs: dict[float, dict[str, tuple[float, float, float, int]]] = {}
    skipped: list[tuple[int, str]] = []
    ignored: dict[str, int] = {}
    noise = _NoiseRuns(skipped)
    comments = 0
    day, last_t = 0, None
    # Lines end at "\n" alone, as editors and grep count them (binary bytes hold other separators).
    for no, raw in enumerate(text.split("\n"), 1):
        line = raw.strip()
        if not line:
            continue
        if line.startswith("#"):
            comments += 1
            continue
        line, junk = _sentence_of(line)
        if junk:
            noise.add(no)
        if not line:
            continue
        noise.end()
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
        kind = _sentence_type(msg)
        if kind not in ("GGA", "RMC"):
            ignored[kind] = ignored.get(kind, 0) + 1
            continue
        try:
            if kind == "GGA" and (not msg.gps_qual or int(msg.gps_qual) == 0):
                skipped.append((no, "GGA without a fix (quality 0)"))
                continue
            if kind == "RMC" and msg.status != "A":
                skipped.append((no, "RMC status V (no fix)"))
                continue
            if msg.timestamp is None:
                skipped.append((no, f"{kind} without a timestamp"))
                continue
            if not isinstance(msg.timestamp, dt.time):  # pynmea2 hands back the text it cannot read
                skipped.append((no, f"{kind} timestamp {msg.timestamp!r} is not a time hhmmss.ss"))
                continue
            pos = _coordinate(msg, kind)
            if isinstance(pos, str):
                skipped.append((no, pos))
                continue
            height = float(msg.altitude) if kind == "GGA" else np.nan
            if kind == "GGA" and not abs(height) <= max_abs_height_m:  # also NaN
                skipped.append((no, f"GGA altitude {height:g} m outside +-{max_abs_height_m:g} m (max_abs_height_m)"))
                continue
            tod = _seconds(msg.timestamp)
        except (TypeError, ValueError, AttributeError) as exc:
            skipped.append((no, f"incomplete {kind}: {exc}"))
            continue
        t = day * 86400.0 + tod
        if last_t is not None and t < last_t - 43200.0:  # midnight rollover
            day += 1
            t += 86400.0
        if t in epochs and kind in epochs[t]:
            first = epochs[t][kind][3]
            skipped.append((no, f"duplicate {kind} timestamp {_clock(t)} (first at line {first})"))
            continue
        if last_t is not None and t < last_t:
            skipped.append((no, f"timestamp {_clock(t)} goes backwards (after {_clock(last_t)})"))
            continue
        epochs.setdefault(t, {})[kind] = (*pos, height, no)
        last_t = t
    noise.end()
    # Jump check, epoch by epoch against the last accepted one.
    rows, prev = [], None
    for t, sentences in epochs.items():  # insertion order is time order
        lat, lon, h, no = sentences.get("GGA", sentences.get("RMC"))
        if prev is not None:
            dist = _distance_m(prev[1], prev[2], lat, lon)
            speed = dist / (t - prev[0])
            if speed > max_speed_mps:
                for k, s in sentences.items():
                    skipped.append(
                        (
                            s[3],
                            f"{k} position jumps {dist / 1e3:.3f} km in {t - prev[0]:g} s "
                            f"({speed:.0f} m/s > max_speed_mps {max_speed_mps:g})",
                        )
                    )
                continue
        prev = (t, lat, lon)
        rows.append((t, lat, lon, h, no))
    skipped.sort()
    refuse_or_keep(path, skipped, strict)
    if not rows:
        first = f", the first at line {skipped[0][0]}: {skipped[0][1]}" if skipped else ""
        raise DataFileError(str(path), None, f"no valid GGA or RMC fix ({len(skipped)} sentences skipped{first})")
    arr = np.array(rows, dtype=float)
    return NmeaFixes(
        arr[:, 0] - arr[0, 0],
        arr[:, 1],
        arr[:, 2],
        arr[:, 3],
        arr[:, 4].astype(int),
        skipped,
        dict(sorted(ignored.items())),
        comments,
    )


_GNSSLOGGER = re.compile(r"^NMEA,(?P<sentence>[$!].*\*[0-9A-Fa-f]{2}),\d+$")


def _sentence_of(line: str) -> tuple[str, bool]:
    """``(sentence, junk_before_it)`` of a log line.

    GnssLogger's ``NMEA,<sentence>,<unix ms>`` is unwrapped. Otherwise the sentence starts
    at the first ``$`` or ``!``: bytes before it (a binary stream sharing the port) are
    junk, and a line with no sentence start is junk as a whole (``("", True)``).
    """
    wrapped = _GNSSLOGGER.match(line)
    if wrapped:
        return wrapped["sentence"], False
    starts = [i for i in (line.find("$"), line.find("!")) if i >= 0]
    if not starts:
        return "", True
    start = min(starts)
    return line[start:], start > 0


def _sentence_type(msg) -> str:
    """``"GGA"`` for any talker's GGA; a proprietary sentence as ``"P"`` + its maker (``"PUBX"``)."""
    import pynmea2

    if isinstance(msg, pynmea2.ProprietarySentence):
        return "P" + msg.manufacturer
    return getattr(msg, "sentence_type", "") or type(msg).__name__


class _NoiseRuns:
    """Collect runs of consecutive lines holding non-NMEA bytes into one skipped entry each."""

    def __init__(self, skipped: list[tuple[int, str]]) -> None:
        self.skipped, self.first, self.last = skipped, None, None

    def add(self, no: int) -> None:
        if self.first is None:
            self.first = no
        self.last = no

    def end(self) -> None:
        if self.first is not None:
            n = self.last - self.first + 1
            self.skipped.append(
                (self.first, f"binary or non-NMEA data: {n} line{'s' if n > 1 else ''} ({self.first}-{self.last})")
            )
        self.first = self.last = None
