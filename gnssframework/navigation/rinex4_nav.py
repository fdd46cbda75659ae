r"""RINEX 4 navigation files, parsed: their records as written and their ``EPH`` records'
fields by name, which `ephemeris.read_rinex_nav` makes `ephemeris.Ephemerides` and
`rinex_nav_header.read_nav_file_info` a `rinex_nav_header.NavFileInfo` (with the first ``ION``
and ``STO`` records).

RINEX 4.00 (IGS/RTCM-SC104, 2021; 4.01 and 4.02 keep the layouts read here) gives every
record a line of its own before it, ``> EPH G01 LNAV``: the record type (``EPH``, ``ION``,
``STO``, ``EOP``), the satellite that sent it and the message it came from. An ``EPH``
record's lines are then those of RINEX 3 (a first line ``A3,1X,I4,5(1X,I2.2),3D19.12``,
orbit lines ``4X,4D19.12``), one layout per message:

======================== =============================================================
message                  record
======================== =============================================================
GPS/QZSS ``LNAV``        RINEX 3's GPS record (IODE ... fit interval), tables A32/A38
Galileo ``INAV``/``FNAV`` RINEX 3's Galileo record (IODnav ... BGDs, data sources), A35
BeiDou ``D1``/``D2``     RINEX 3's BDS record (AODE ... TGD1, TGD2, AODC), A36
GPS/QZSS ``CNAV``        ``Adot, Crs, Δn0, M0 / Cuc, e, Cus, √A / t_op, Cic, Ω0, Cis /
                         i0, Crc, ω, Ω̇ / IDOT, Δṅ0, URAI_NED0, URAI_NED1 / URAI_ED,
                         health, T_GD, URAI_NED2 / ISC_L1CA, ISC_L2C, ISC_L5I5,
                         ISC_L5Q5 / t_tm, WN_op``, A33 (t_oe is the record's epoch t_oc)
GPS/QZSS ``CNV2``        CNAV's, with ``ISC_L1Cd, ISC_L1Cp`` on a line before t_tm, A34
BeiDou ``CNV1``/``CNV2`` ``Adot, Crs, Δn0, M0 / Cuc, e, Cus, √A / t_oe, Cic, Ω0, Cis /
                         i0, Crc, ω, Ω̇ / IDOT, Δṅ0, satellite type, t_op / SISAI_oe,
                         SISAI_ocb, SISAI_oc1, SISAI_oc2 / ISC_B1Cd (CNV2: ISC_B2ad second),
                         T_GD,B1Cp, T_GD,B2ap / SISMAI, health, integrity flags, IODC / t_tm,
                         IODE (fourth)``, A37 (B-CNAV1 from B1C, B-CNAV2 from B2a)
BeiDou ``CNV3``          the same six orbit lines, then ``SISMAI, health, integrity flags,
                         T_GD,B2bI / t_tm`` (B-CNAV3 from B2b)
======================== =============================================================

A CNAV record's √A is that of :math:`A_{REF} + \Delta A` and its Ω̇ the full rate, as
`cnav_records` assembles a decoded one; its health is the 3-bit L1/L2/L5 word (L1 the high
bit: IS-GPS-200 30.3.3.1.1.2), of which a record read here keeps the bit of the band its user
tracks (``cnav_band``: ``"L2"`` or ``"L5"``; the L1 bit for ``"L1"``); its accuracy the
URA_ED index's metres and its issue of data :math:`t_{oe}/300`, as `cnav_records`. A BeiDou
``CNV1``-``CNV3`` record's orbit is propagated as a CNAV one (:math:`A_0` the written √A's
square, its rates Ȧ and Δṅ0; BDS-SIS-ICD-B1C 7.8) and its clock (referred to B3I, as D1's)
keeps its own group delays apart from D1's: `ephemeris.single_frequency_clock_s` gives a
B1C user ``Δt_SV - T_GD,B1Cp`` and a B2a user ``Δt_SV - T_GD,B2ap`` from these records only,
and a B1I user ``Δt_SV - T_GD1`` from D1/D2 records only. Records of other systems or
messages (GLONASS ``FDMA``, SBAS, NavIC) are counted and left out.

An ``ION`` record holds the coefficients the satellite broadcast at its epoch: GPS/QZSS
``LNAV`` and BeiDou ``D1D2`` Klobuchar's α0-α3, β0-β3; Galileo ``IFNV`` NeQuick's ai0-ai2.
An ``STO`` record a time offset ``A0, A1, A2`` at the reference time of its epoch (its
second line ``t_tm, A0, A1, A2``), named as RINEX 3's ``TIME SYSTEM CORR`` (``GPUT``,
``GAGP``, ``GAUT``, ``BDUT``). What a RINEX 3 header held once, the first of these records
holds here (`rinex_nav_header.read_nav_file_info`): the models a receiver would use at the
file's start.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import DataFileError

__all__ = [
    "Rinex4Record",
    "EPH_LAYOUTS",
    "CNAV_HEALTH_BITS",
    "ISC_ABSENT_S",
    "is_rinex4",
    "scan_rinex4_nav",
    "eph_tables",
    "klobuchar_of",
    "time_offset_of",
]

_LNAV = (
    ("IODE", "Crs", "DeltaN", "M0"),
    ("Cuc", "Eccentricity", "Cus", "sqrtA"),
    ("Toe", "Cic", "Omega0", "Cis"),
    ("Io", "Crc", "omega", "OmegaDot"),
    ("IDOT", "CodesL2", "GPSWeek", "L2Pflag"),
    ("SVacc", "health", "TGD", "IODC"),
    ("TransTime", "FitIntvl"),
)
_GALILEO = (
    ("IODnav", "Crs", "DeltaN", "M0"),
    ("Cuc", "Eccentricity", "Cus", "sqrtA"),
    ("Toe", "Cic", "Omega0", "Cis"),
    ("Io", "Crc", "omega", "OmegaDot"),
    ("IDOT", "DataSrc", "GALWeek", ""),
    ("SISA", "health", "BGDe5a", "BGDe5b"),
    ("TransTime",),
)
_BEIDOU = (
    ("AODE", "Crs", "DeltaN", "M0"),
    ("Cuc", "Eccentricity", "Cus", "sqrtA"),
    ("Toe", "Cic", "Omega0", "Cis"),
    ("Io", "Crc", "omega", "OmegaDot"),
    ("IDOT", "", "BDTWeek", ""),
    ("SVacc", "SatH1", "TGD1", "TGD2"),
    ("TransTime", "AODC"),
)
_CNAV = (
    ("Adot", "Crs", "DeltaN", "M0"),
    ("Cuc", "Eccentricity", "Cus", "sqrtA"),
    ("Top", "Cic", "Omega0", "Cis"),
    ("Io", "Crc", "omega", "OmegaDot"),
    ("IDOT", "DeltaN0dot", "URAI_NED0", "URAI_NED1"),
    ("URAI_ED", "health", "TGD", "URAI_NED2"),
    ("ISC_L1CA", "ISC_L2C", "ISC_L5I5", "ISC_L5Q5"),
    ("TransTime", "WNop"),
)
_CNV2 = _CNAV[:7] + (("ISC_L1Cd", "ISC_L1Cp"), _CNAV[7])
_BDS_CNAV = (
    ("Adot", "Crs", "DeltaN", "M0"),
    ("Cuc", "Eccentricity", "Cus", "sqrtA"),
    ("Toe", "Cic", "Omega0", "Cis"),
    ("Io", "Crc", "omega", "OmegaDot"),
    ("IDOT", "DeltaN0dot", "SatType", "Top"),
    ("SISAI_oe", "SISAI_ocb", "SISAI_oc1", "SISAI_oc2"),
)
_BDS_CNV1 = _BDS_CNAV + (
    ("ISC_B1Cd", "", "TGD_B1Cp", "TGD_B2ap"),
    ("SISMAI", "health", "IntegrityFlags", "IODC"),
    ("TransTime", "", "", "IODE"),
)
_BDS_CNV2 = _BDS_CNAV + (
    ("", "ISC_B2ad", "TGD_B1Cp", "TGD_B2ap"),
    ("SISMAI", "health", "IntegrityFlags", "IODC"),
    ("TransTime", "", "", "IODE"),
)
_BDS_CNV3 = _BDS_CNAV + (("SISMAI", "health", "IntegrityFlags", "TGD_B2bI"), ("TransTime",))

#: (system letter, message) -> the names of a record's orbit lines' fields, line by line
#: ("" a spare), as the module text's table.
EPH_LAYOUTS: dict[tuple[str, str], tuple[tuple[str, ...], ...]] = {
    ("G", "LNAV"): _LNAV,
    ("J", "LNAV"): _LNAV,
    ("E", "INAV"): _GALILEO,
    ("E", "FNAV"): _GALILEO,
    ("C", "D1"): _BEIDOU,
    ("C", "D2"): _BEIDOU,
    ("G", "CNAV"): _CNAV,
    ("J", "CNAV"): _CNAV,
    ("G", "CNV2"): _CNV2,
    ("J", "CNV2"): _CNV2,
    ("C", "CNV1"): _BDS_CNV1,
    ("C", "CNV2"): _BDS_CNV2,
    ("C", "CNV3"): _BDS_CNV3,
}
#: The health word's bit of each band in a CNAV record (L1 the high bit).
CNAV_HEALTH_BITS = {"L1": 2, "L2": 1, "L5": 0}
#: A broadcast ISC's "not available" value (13-bit field 1000000000000 x 2^-35 s,
#: IS-GPS-200 30.3.3.3.1.1): read as NaN.
ISC_ABSENT_S = -4096 * 2.0**-35


@dataclass(frozen=True)
class Rinex4Record:
    """One record of a RINEX 4 navigation file as written: its type (``"EPH"``, ``"ION"``,
    ``"STO"``, ``"EOP"``), satellite (``"G01"``; ``"E"`` where only the system is named),
    message (``"LNAV"``), epoch (calendar, in the record's system time), the numbers of its
    lines in order (NaN for a blank field), the text field of an ``STO`` record's first line
    (``"GAGP"``) and the file line of its ``>`` line."""

    kind: str
    sv: str
    message: str
    epoch: np.datetime64
    values: tuple[float, ...]
    label: str
    line: int


def _open_text(path: Path):
    """The file as text, gunzipped where it is gzip (IGS distributes ``BRD400DLR...rnx.gz``)."""
    import gzip

    with path.open("rb") as fh:
        gzipped = fh.read(2) == b"\x1f\x8b"
    return gzip.open(path, "rt", errors="replace") if gzipped else path.open(errors="replace")


def is_rinex4(path: str | Path) -> bool:
    """Whether the file's first line (gzip or plain) gives RINEX version 4 or later."""
    try:
        with _open_text(Path(path)) as fh:
            first = fh.readline()
    except OSError:  # a corrupt gzip stream: not read here
        return False
    try:
        return float(first[:9]) >= 4.0
    except ValueError:
        return False


def _number(text: str, where: tuple[str, int], what: str) -> float:
    text = text.strip()
    if not text:
        return float("nan")
    try:
        return float(text.replace("D", "E").replace("d", "e"))
    except ValueError:
        raise DataFileError(where[0], where[1], f"{what}: {text!r} is not a number") from None


def _epoch(text: str, where: tuple[str, int], what: str) -> np.datetime64:
    parts = text.split()
    try:
        y, mo, d, h, mi = (int(p) for p in parts[:5])
        s = float(parts[5])
        return np.datetime64(f"{y:04d}-{mo:02d}-{d:02d}T{h:02d}:{mi:02d}", "ns") + np.timedelta64(
            int(round(s * 1e9)), "ns"
        )
    except (ValueError, IndexError):
        raise DataFileError(
            where[0], where[1], f"{what}: epoch {text.strip()!r} is not 'yyyy mm dd hh mm ss'"
        ) from None


def _fields(line: str, start: int, count: int, where: tuple[str, int], what: str) -> list[float]:
    return [_number(line[start + 19 * k : start + 19 * (k + 1)], where, what) for k in range(count)]


def _record(path: str, head: int, kind: str, sv: str, message: str, lines: list[str]) -> Rinex4Record:
    what = f"{kind} {sv} {message}"
    first = lines[0]
    where = (path, head + 1)
    epoch = _epoch(first[4:23], where, what)
    # STO: the offset's type after the epoch; EPH, ION, EOP: three numbers.
    label = first[24:42].strip() if kind == "STO" else ""
    values = [] if kind == "STO" else _fields(first, 23, 3, where, what)
    for k, line in enumerate(lines[1:], 2):
        values += _fields(line.rstrip("\n").ljust(80), 4, 4, (path, head + k), what)
    return Rinex4Record(kind, sv, message, epoch, tuple(values), label, head)


def scan_rinex4_nav(path: str | Path) -> tuple[dict[str, str], list[Rinex4Record]]:
    """The header lines (label -> the content of its last line) and every record of a
    RINEX 4 navigation file, in file order.

    Raises
    ------
    DataFileError
        If the file is missing, not RINEX 4, without END OF HEADER, or a record's line is
        malformed (naming its line).
    """
    path = Path(path)
    if not path.exists():
        raise DataFileError(str(path), None, "no such file")
    with _open_text(path) as fh:
        lines = fh.read().splitlines()
    if not lines or not is_rinex4(path):
        raise DataFileError(str(path), 1, f"RINEX version {lines[0][:9].strip() if lines else ''!r}: not RINEX 4")
    if "NAV" not in lines[0][20:40].upper() and lines[0][20:21] != "N":
        raise DataFileError(str(path), 1, f"not a navigation file (type {lines[0][20:40].strip()!r})")
    header: dict[str, str] = {}
    end = None
    for i, line in enumerate(lines):
        label = line[60:].strip()
        header[label] = line[:60]
        if label == "END OF HEADER":
            end = i
            break
    if end is None:
        raise DataFileError(str(path), None, "no END OF HEADER line")
    heads = [i for i in range(end + 1, len(lines)) if lines[i].startswith(">")]
    records = []
    for n, i in enumerate(heads):
        stop = heads[n + 1] if n + 1 < len(heads) else len(lines)
        parts = lines[i][1:].split()
        if len(parts) < 3:
            raise DataFileError(str(path), i + 1, f"record line {lines[i].strip()!r}: expected '> TYPE SV MESSAGE'")
        kind, sv, message = parts[:3]
        body = [line for line in lines[i + 1 : stop] if line.strip()]
        if not body:
            raise DataFileError(str(path), i + 1, f"{kind} {sv} {message}: the record has no lines")
        records.append(_record(str(path), i + 1, kind, sv, message, body))
    return header, records


def _column(records: list[Rinex4Record], layout: tuple[tuple[str, ...], ...]) -> dict[str, np.ndarray]:
    """The records' fields by name (the clock first, then the orbit lines)."""
    names = ["SVclockBias", "SVclockDrift", "SVclockDriftRate"]
    for row in layout:
        names += list(row) + [""] * (4 - len(row))
    table = np.full((len(records), len(names)), np.nan)
    for r, rec in enumerate(records):
        n = min(len(rec.values), len(names))
        table[r, :n] = rec.values[:n]
    return {name: table[:, k] for k, name in enumerate(names) if name}


def eph_tables(
    records: list[Rinex4Record],
) -> list[tuple[np.ndarray, str, str, list[Rinex4Record], dict[str, np.ndarray]]]:
    """The ``EPH`` records among ``records`` of the messages `EPH_LAYOUTS` reads, grouped by
    (system, message): each group's positions in ``records``, system letter, message, its
    records and their fields by name (the clock's ``SVclockBias``, ``SVclockDrift``,
    ``SVclockDriftRate``, then the layout's; NaN where blank). `ephemeris.read_rinex_nav`
    makes them `ephemeris.Ephemerides`."""
    out = []
    for (letter, message), layout in EPH_LAYOUTS.items():
        index = [k for k, r in enumerate(records) if r.kind == "EPH" and (r.sv[:1], r.message) == (letter, message)]
        if index:
            group = [records[k] for k in index]
            out.append((np.asarray(index), letter, message, group, _column(group, layout)))
    return out


def klobuchar_of(records: list[Rinex4Record], system: str, message: str) -> tuple[tuple, tuple] | None:
    """α0-α3 and β0-β3 of the first ``ION`` record of ``system`` and ``message``."""
    for r in records:
        if r.kind == "ION" and r.sv[:1] == system and r.message == message and len(r.values) >= 8:
            return tuple(r.values[:4]), tuple(r.values[4:8])
    return None


def time_offset_of(records: list[Rinex4Record], label: str) -> tuple[float, float, np.datetime64] | None:
    """``(A0 s, A1 s/s, reference epoch)`` of the first ``STO`` record named ``label``
    (``"GAGP"``)."""
    for r in records:
        if r.kind == "STO" and r.label == label and len(r.values) >= 3:
            return float(r.values[1]), float(r.values[2]), r.epoch
    return None
