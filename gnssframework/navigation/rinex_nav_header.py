"""What a RINEX navigation file says besides its records: the Klobuchar coefficients of its
header and the dates its records span.

The header's ionosphere lines are RINEX 2's ``ION ALPHA`` / ``ION BETA`` (``2X,4D12.4``,
RINEX 2.11 table A4) or RINEX 3's ``IONOSPHERIC CORR`` with ``GPSA`` / ``GPSB``
(``A4,1X,4D12.4``, RINEX 3.04 table A5), in the units of the broadcast page 18 (s,
s/semicircle, ...; IS-GPS-200 20.3.3.5.1.7), and BeiDou's ``BDSA`` / ``BDSB`` (the same
layout; BeiDou's model, `bds_iono`); ``LEAP SECONDS`` (``I6``) the current
GPS - UTC. RINEX 3's ``TIME SYSTEM CORR`` line ``GPGA`` (3.00-3.03) or ``GAGP`` (3.04,
``A4,1X,D17.10,D16.9,1X,I6,1X,I4``) carries Galileo's broadcast GPS-Galileo time offset
``A0G, A1G, t0G, WN0G`` (Galileo OS SIS ICD 5.1.8: ``GGTO = GST - GPST = A0G + A1G (t - t0G
+ 604800 (WN - WN0G))``, the week continuous with GPS's), `NavFileInfo.ggto_s`. The records' epochs (their Toc, georinex's ``gettime``) give the GPS time
span a receiver can use them over: a record's fit interval reaches 2 h either side of
its Toe (IS-GPS-200 20.3.4.4), so a recording is covered from 2 h before the first
record to 2 h after the last (`NavFileInfo.covers`), and its full GPS week is the one
that puts a time of week nearest that span (`NavFileInfo.week_at`), as RTKLIB and
GNSS-SDR take the week from the ephemeris when the LNAV week has not been decoded.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import DataFileError
from .bds_iono import BdsKlobuchar
from .ephemeris import _GPS_EPOCH
from .lnav import WEEK_S, IonoUtc

__all__ = ["NavFileInfo", "read_nav_file_info", "FIT_MARGIN_S", "WEEK_S"]

#: Half a record's fit interval (s): a record serves from 2 h before its Toe to 2 h after.
FIT_MARGIN_S = 7200.0


@dataclass(frozen=True)
class NavFileInfo:
    """A navigation file's header Klobuchar model (None when absent) and its records'
    first and last epochs in GPS seconds since 1980-01-06 (GPS time, no leap seconds), and
    the header's GGTO polynomial ``(A0G s, A1G s/s, t0G s of week, WN0G)`` (None when absent)."""

    path: Path
    iono: IonoUtc | None
    first_s: float
    last_s: float
    ggto: tuple[float, float, float, int] | None = None
    #: The header's ``BDSA`` / ``BDSB`` (RINEX 3): BeiDou's coefficients (`bds_iono`).
    bds_iono: BdsKlobuchar | None = None

    def iono_for(self, systems: str) -> IonoUtc | BdsKlobuchar | None:
        """The header's model for a fix of ``systems`` (RINEX letters): for BeiDou satellites
        alone BeiDou's (its own model, `bds_iono`), else GPS's; for any other set GPS's (for
        every system, as RTKLIB); None without."""
        if set(systems) == {"C"} and self.bds_iono is not None:
            return self.bds_iono
        return self.iono

    def ggto_s(self, week: int, tow_s: float) -> float:
        """GST - GPST (s) at GPS time ``(week, tow_s)`` from the header's polynomial (NaN
        without one): the ``time_offsets_s["E"]`` of `pvt.solve_position`."""
        if self.ggto is None:
            return float("nan")
        a0, a1, t0, w0 = self.ggto
        return a0 + a1 * (tow_s - t0 + WEEK_S * (week - w0))

    def week_at(self, tow_s: float) -> int:
        """The full GPS week that puts ``tow_s`` (s of week) nearest the middle of the records."""
        middle = 0.5 * (self.first_s + self.last_s)
        return int(np.round((middle - tow_s) / WEEK_S))

    def covers(self, week: int, tow_s: float) -> bool:
        """Whether GPS time ``(week, tow_s)`` is within the records' fit intervals' span."""
        t = week * WEEK_S + tow_s
        return self.first_s - FIT_MARGIN_S <= t <= self.last_s + FIT_MARGIN_S

    def dates(self) -> str:
        """The records' span, e.g. ``2005-04-01 23:59:44 to 2005-04-03 00:00:00 GPS``."""
        return f"{_calendar(self.first_s)} to {_calendar(self.last_s)} GPS"


def _calendar(gps_s: float) -> str:
    t = _GPS_EPOCH + np.timedelta64(int(round(gps_s)), "s")
    return str(t.astype("datetime64[s]")).replace("T", " ")


def _numbers(line: str, start: int) -> list[float]:
    return [float(line[start + 12 * k : start + 12 * k + 12].replace("D", "E").replace("d", "e")) for k in range(4)]


def _header_iono(path: Path) -> IonoUtc | None:
    alpha = beta = None
    leap = None
    with path.open(errors="replace") as fh:
        for number, line in enumerate(fh, 1):
            label = line[60:].strip()
            try:
                if label == "ION ALPHA":
                    alpha = _numbers(line, 2)
                elif label == "ION BETA":
                    beta = _numbers(line, 2)
                elif label == "IONOSPHERIC CORR" and line[:4] == "GPSA":
                    alpha = _numbers(line, 5)
                elif label == "IONOSPHERIC CORR" and line[:4] == "GPSB":
                    beta = _numbers(line, 5)
                elif label == "LEAP SECONDS":
                    leap = int(line[:6])
            except ValueError:
                raise DataFileError(str(path), number, f"{label}: not four numbers") from None
            if label == "END OF HEADER" or number > 500:
                break
    if alpha is None or beta is None:
        return None
    # Without LEAP SECONDS, GPS - UTC since 2017-01-01 (18 s), as the receiver assumes elsewhere.
    return IonoUtc(tuple(alpha), tuple(beta), dt_ls_s=18 if leap is None else leap)


def _header_bds_iono(path: Path) -> BdsKlobuchar | None:
    parts: dict[str, list[float]] = {}
    with path.open(errors="replace") as fh:
        for number, line in enumerate(fh, 1):
            label = line[60:].strip()
            if label == "IONOSPHERIC CORR" and line[:4] in ("BDSA", "BDSB"):
                try:
                    parts[line[:4]] = _numbers(line, 5)
                except ValueError:
                    raise DataFileError(str(path), number, f"{label} {line[:4]}: not four numbers") from None
            if label == "END OF HEADER" or number > 500:
                break
    if len(parts) < 2:
        return None
    return BdsKlobuchar(tuple(parts["BDSA"]), tuple(parts["BDSB"]))  # type: ignore[arg-type]


def _header_ggto(path: Path) -> tuple[float, float, float, int] | None:
    with path.open(errors="replace") as fh:
        for number, line in enumerate(fh, 1):
            label = line[60:].strip()
            if label == "TIME SYSTEM CORR" and line[:4] in ("GPGA", "GAGP"):
                try:
                    return (
                        float(line[5:22].replace("D", "E")),
                        float(line[22:38].replace("D", "E")),
                        float(line[38:45]),
                        int(line[45:50]),
                    )
                except ValueError:
                    raise DataFileError(
                        str(path), number, f"TIME SYSTEM CORR {line[:4]}: expected a0, a1, T, W"
                    ) from None
            if label == "END OF HEADER" or number > 500:
                break
    return None


def read_nav_file_info(path: str | Path) -> NavFileInfo:
    """`NavFileInfo` of a RINEX 2 or 3 navigation file, or of a RINEX 4 one: GPS's Klobuchar
    model from its first ``ION G LNAV`` record (QZSS's where none) with ``LEAP SECONDS``,
    BeiDou's from its first ``ION C D1D2``, the GGTO from its first ``STO GAGP`` and the span
    of its ``EPH`` records' epochs (`rinex4_nav`).

    Raises
    ------
    DataFileError
        If the file is missing, its ionosphere lines are malformed or it holds no record.
    """
    import georinex

    path = Path(path)
    if not path.exists():
        raise DataFileError(str(path), None, "no such file")
    from .rinex4_nav import is_rinex4

    if is_rinex4(path):  # its ionosphere and time offsets are records, not header lines
        return _rinex4_info(path)
    iono = _header_iono(path)
    try:
        times = np.asarray(georinex.gettime(path), dtype="datetime64[ns]")
    except Exception as exc:  # noqa: BLE001 - georinex raises many types
        raise DataFileError(
            str(path), None, f"georinex could not read its epochs: {type(exc).__name__}: {exc}"
        ) from None
    if times.size == 0:
        raise DataFileError(str(path), None, "no ephemeris record")
    seconds = (times - _GPS_EPOCH) / np.timedelta64(1, "s")
    return NavFileInfo(
        path, iono, float(np.min(seconds)), float(np.max(seconds)), _header_ggto(path), _header_bds_iono(path)
    )


def _rinex4_info(path: Path) -> NavFileInfo:
    """`read_nav_file_info` of a RINEX 4 file (its docstring)."""
    from .rinex4_nav import klobuchar_of, scan_rinex4_nav, time_offset_of

    header, records = scan_rinex4_nav(path)
    epochs = np.array([r.epoch for r in records if r.kind == "EPH"], dtype="datetime64[ns]")
    if epochs.size == 0:
        raise DataFileError(str(path), None, "no ephemeris record")
    seconds = (epochs - _GPS_EPOCH) / np.timedelta64(1, "s")
    try:
        leap = int(header.get("LEAP SECONDS", "")[:6])
    except ValueError:
        leap = 18  # as a RINEX 3 header without LEAP SECONDS (`_header_iono`)
    gps = klobuchar_of(records, "G", "LNAV") or klobuchar_of(records, "J", "LNAV")
    bds = klobuchar_of(records, "C", "D1D2")
    offset = time_offset_of(records, "GAGP")
    ggto = None
    if offset is not None:  # the reference epoch as GPS seconds of week and week (GST's week is GPS's)
        t0 = (offset[2] - _GPS_EPOCH) / np.timedelta64(1, "s")
        week = int(t0 // WEEK_S)
        ggto = (offset[0], offset[1], float(t0 - week * WEEK_S), week)
    return NavFileInfo(
        path,
        None if gps is None else IonoUtc(gps[0], gps[1], dt_ls_s=leap),  # type: ignore[arg-type]
        float(np.min(seconds)),
        float(np.max(seconds)),
        ggto,
        None if bds is None else BdsKlobuchar(bds[0], bds[1]),  # type: ignore[arg-type]
    )
