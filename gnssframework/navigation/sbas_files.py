"""SBAS message files, for corrections gathered elsewhere than in the recording: RTKLIB's
SBAS log (``.sbs``, written by ``convbin`` and ``str2str`` from a receiver's raw messages)
and ESA's EGNOS Message Server files (``.ems``), read as RTKLIB 2.4.3's ``sbas.c`` reads
them (learned from, not copied), and RTKLIB's log written.

=========== ==================================================================================
format      one line per message
=========== ==================================================================================
RTKLIB      ``week tow prn type : hex`` — GPS week, seconds of week, GEO PRN, message type, then
            29 bytes: the message's first 226 bits (preamble, type, data) padded with zeros;
            the CRC-24Q is not kept and is computed again here
EMS         ``prn yy mm dd hh mm ss type hex`` — the time GPS time as RTKLIB takes it (two-digit
            year: 19xx from 70), then the 250-bit message with its CRC (64 hex digits)
=========== ==================================================================================

A line of neither form is refused in one line naming the file and the line, as is a message
of the EMS form whose CRC does not hold. Each record is a `SbasRecord`; its ``bits`` are the
250 bits `sbas_content.decode_content` reads.
"""

from __future__ import annotations

import datetime as _dt
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import DataFileError
from . import fec
from .sbas_content import SbasCorrections, decode_content
from .sbas_message import MESSAGE_BITS, parse_message
from .weeks import gps_week_tow

__all__ = ["SbasRecord", "read_sbas_messages", "write_rtklib_sbs", "busiest_prn", "SbasReplay"]

_CRC_BITS = 226


@dataclass(frozen=True)
class SbasRecord:
    """One message of a file: GPS ``week``, ``tow_s`` (seconds of week), the GEO's ``prn``,
    its message ``type`` and its 250 ``bits`` (0/1, CRC included)."""

    week: int
    tow_s: float
    prn: int
    type: int
    bits: np.ndarray = field(repr=False)


def _with_crc(head: np.ndarray) -> np.ndarray:
    crc = int(fec.crc24q_bits(head[:_CRC_BITS]))
    return np.r_[head[:_CRC_BITS], (crc >> np.arange(23, -1, -1)) & 1].astype(np.uint8)


def _bits(text: str) -> np.ndarray:
    return np.unpackbits(np.frombuffer(bytes.fromhex(text), np.uint8))


def _rtklib(parts: list[str], rest: str) -> tuple[int, float, int, np.ndarray]:
    week, tow, prn = int(parts[0]), float(parts[1]), int(parts[2])
    bits = _bits(rest.strip())
    if bits.size < _CRC_BITS:
        raise ValueError(f"{bits.size} bits, a message's first 226 are needed")
    return week, tow, prn, _with_crc(bits)


def _ems(parts: list[str]) -> tuple[int, float, int, np.ndarray]:
    prn = int(parts[0])
    yy, mo, dd, hh, mi = (int(p) for p in parts[1:6])
    sec = float(parts[6])
    year = yy + (2000 if yy < 70 else 1900)
    t = _dt.datetime(year, mo, dd, hh, mi) + _dt.timedelta(seconds=sec)
    week, tow_s = gps_week_tow(t)
    bits = _bits(parts[8])
    if bits.size < MESSAGE_BITS:
        raise ValueError(f"{bits.size} bits, an EMS message holds all 250")
    bits = bits[:MESSAGE_BITS].astype(np.uint8)
    if not parse_message(bits)[2]:
        raise ValueError("its CRC-24Q does not hold")
    return week, tow_s, prn, bits


def read_sbas_messages(path: str | Path) -> list[SbasRecord]:
    """Every message of an RTKLIB ``.sbs`` log or an EMS file (module text), in file order."""
    p = Path(path)
    try:
        lines = p.read_text().splitlines()
    except OSError as exc:
        raise DataFileError(str(p), None, f"cannot be read: {exc.strerror}") from None
    out = []
    for number, line in enumerate(lines, start=1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        head, colon, rest = line.partition(":")
        parts = head.split() if colon else line.split()
        try:
            if colon and len(parts) == 4:
                week, tow, prn, bits = _rtklib(parts, rest)
            elif not colon and len(parts) == 9:
                week, tow, prn, bits = _ems(parts)
            else:
                raise ValueError(
                    "neither 'week tow prn type : hex' (RTKLIB) nor 'prn yy mm dd hh mm ss type hex' (EMS)"
                )
        except ValueError as exc:
            raise DataFileError(str(p), number, f"not an SBAS message: {exc}") from None
        out.append(SbasRecord(week, tow, prn, parse_message(bits)[1], bits))
    return out


def write_rtklib_sbs(path: str | Path, records: list[SbasRecord]) -> Path:
    """Write ``records`` as RTKLIB's SBAS log (``week tow prn type : hex``, the message's
    first 226 bits in 29 bytes), which RTKLIB's ``rnx2rtkp`` reads."""
    p = Path(path)
    rows = []
    for r in records:
        head = np.r_[np.asarray(r.bits[:_CRC_BITS], np.uint8), np.zeros(6, np.uint8)]
        rows.append(
            f"{r.week:4d} {int(round(r.tow_s)):6d} {r.prn:3d} {r.type:2d} : {np.packbits(head).tobytes().hex().upper()}"
        )
    p.write_text("\n".join(rows) + "\n")
    return p


def busiest_prn(records: list[SbasRecord]) -> int:
    """The GEO PRN with the most messages in ``records`` (the lowest on a tie)."""
    if not records:
        raise ValueError("no SBAS messages")
    prns, counts = np.unique([r.prn for r in records], return_counts=True)
    return int(prns[np.argmax(counts)])


class SbasReplay:
    """One GEO's messages replayed in time order: `at` gives what they add up to at an epoch,
    decoding each message once (epochs must not go back in time).

    Parameters
    ----------
    records
        Messages of any GEOs (`read_sbas_messages`); only ``prn``'s are used.
    prn
        The GEO followed (default `busiest_prn`).
    history_s
        Messages more than this before the first epoch asked for are skipped (1800 s, the
        age RTKLIB gives long-term corrections; masks and the IGP grid come more often).
    """

    def __init__(self, records: list[SbasRecord], prn: int | None = None, history_s: float = 1800.0) -> None:
        self.prn = busiest_prn(records) if prn is None else int(prn)
        mine = [r for r in records if r.prn == self.prn]
        if not mine:
            raise ValueError(f"no message of SBAS PRN {self.prn}")
        mine.sort(key=lambda r: 604_800.0 * r.week + r.tow_s)
        self._records = mine
        self._next = 0
        self._history_s = history_s
        self._last = -np.inf
        self.corrections = SbasCorrections()

    def week_of(self, tow_s: float) -> int:
        """The week of the message nearest ``tow_s`` seconds into its week (for observables
        whose week was not decoded)."""
        gaps = [abs((r.tow_s - tow_s + 302_400.0) % 604_800.0 - 302_400.0) for r in self._records]
        return self._records[int(np.argmin(gaps))].week

    def at(self, week: int, tow_s: float) -> SbasCorrections:
        """The corrections of the messages sent at or before ``week``, ``tow_s`` (their times
        in seconds of ``week``, as `sbas_pvt.solve_position_sbas` compares them)."""
        now = 604_800.0 * week + tow_s
        if now < self._last:
            raise ValueError(f"SBAS replay asked for {tow_s:.3f} s after {self._last - 604_800.0 * week:.3f} s")
        if self._next == 0:  # the first epoch: skip what is too old to matter
            while (
                self._next < len(self._records)
                and 604_800.0 * self._records[self._next].week + (self._records[self._next].tow_s)
                < now - self._history_s
            ):
                self._next += 1
        while self._next < len(self._records):
            r = self._records[self._next]
            t = 604_800.0 * r.week + r.tow_s
            if t > now:
                break
            self.corrections.add(t - 604_800.0 * week, r.prn, decode_content(r.bits))
            self._next += 1
        self._last = now
        return self.corrections
