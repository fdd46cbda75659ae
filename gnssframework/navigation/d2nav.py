"""BeiDou D2 navigation message (BDS-SIS-ICD-B1I 3.0, sec. 5.3): the ephemeris pages of
subframe 1, from the bits of GEO satellites' B1I and back.

D2 is sent at 500 bit/s by the GEO satellites (no overlay, `signal.beidou_b1i`). Its
subframes are D1's: 300 bits, word 1 the preamble, 4 reserved bits and a BCH(15,11,1)
codeword (FraID, the SOW's high bits), words 2-10 two interleaved BCH(15,11,1) codewords
each (:mod:`~gnssframework.navigation.d1nav`, whose decoding serves). A subframe lasts
0.6 s and a frame of five 3 s; every subframe of a frame carries the frame's SOW (BDT, a
multiple of 3 s), so subframe ``k`` starts at ``SOW + 0.6 (k - 1)``. Subframe 1 is paged:
page ``Pnum`` (1-10) is sent in the frame whose ``SOW / 3 mod 10 = Pnum - 1``, and the ten
pages (30 s) hold one ephemeris (sec. 5.3.3.1): page 1 SatH1, AODC, URAI, the BDT week,
toc, T_GD1 and T_GD2; page 2 the Klobuchar coefficients; page 3 a0 and a1's high bits; page
4 a1's low bits, a2, AODE, Delta-n and Cuc's high bits; pages 5-10 the rest of the orbit,
several elements split between two pages (high bits signed, low bits not). Fields lie on
the 224 information bits, as D1's (`d1nav`). Subframes 2-5 (integrity, differential
corrections, almanacs) are read to their header.

Validity: a subframe is kept when its preamble, FraID and SOW agree (SOW a multiple of 3,
and for subframe 1 ``Pnum = SOW / 3 mod 10 + 1``); an ephemeris when pages 1 and 3-10 of one
30 s cycle are kept and toc equals toe (RTKLIB's check).

Truth (tests/navigation/test_d2nav.py): the ten subframe-1 pages of C01 (BDT week 810) and
the values GNSSTk decodes from them (its test data).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import ConfigError
from .bds_iono import FIELD_NAMES, BdsKlobuchar
from .bit_fields import Layout, decode_fields, encode_fields, field_integer
from .d1nav import (
    INFO_BITS,
    SUBFRAME_BITS,
    SUBFRAME_LAYOUTS,
    beidou_record,
    gps_time_of,
    info_bits,
    record_values,
    sent_bits,
    subframe_grid,
)
from .ephemeris import KEPLER_TO_RINEX, Ephemerides

__all__ = [
    "SUBFRAME_S",
    "FRAME_S",
    "SYMBOL_RATE_HZ",
    "PAGE_LAYOUTS",
    "D2Subframe",
    "D2Message",
    "encode_subframe",
    "decode_subframe_bits",
    "find_d2_subframes",
    "pages_to_ephemeris",
    "decode_d2",
    "ephemeris_to_pages",
    "encode_d2",
    "d2_symbols",
]

SUBFRAME_S = 0.6
FRAME_S = 3.0
#: D2 at 500 bit/s, uncoded: one symbol a bit.
SYMBOL_RATE_HZ = 500.0
_WEEK_S = 604_800
_HEADER: Layout = {"preamble": (1, 11, 1, False), "rev": (12, 4, 1, False), "fraid": (16, 3, 1, False)}
_SOW: Layout = {"sow": (19, 20, 1, False), "pnum": (39, 4, 1, False)}
#: Subframe 1 page -> name -> (first information bit, 1-based; length; scale; signed).
#: ``*_msb`` / ``*_lsb``: the high (signed) and low (unsigned) bits of one element.
PAGE_LAYOUTS: dict[int, Layout] = {
    1: {
        "sath1": (43, 1, 1, False),
        "aodc": (44, 5, 1, False),
        "urai": (49, 4, 1, False),
        "wn": (53, 13, 1, False),
        "toc_s": (66, 17, 8, False),
        "tgd1_s": (83, 10, 1e-10, True),
        "tgd2_s": (93, 10, 1e-10, True),
    },
    # Klobuchar's coefficients: D1 subframe 1's fields, 56 information bits earlier.
    2: {k: (SUBFRAME_LAYOUTS[1][k][0] - 56, *SUBFRAME_LAYOUTS[1][k][1:]) for k in FIELD_NAMES},
    3: {"af0_s": (81, 24, 2.0**-33, True), "af1_msb": (105, 4, 1, True)},
    4: {
        "af1_lsb": (43, 18, 1, False),
        "af2_s_s2": (61, 11, 2.0**-66, True),
        "aode": (72, 5, 1, False),
        "delta_n_sc_s": (77, 16, 2.0**-43, True),
        "cuc_msb": (93, 14, 1, True),
    },
    5: {
        "cuc_lsb": (43, 4, 1, False),
        "m0_sc": (47, 32, 2.0**-31, True),
        "cus_rad": (79, 18, 2.0**-31, True),
        "e_msb": (97, 10, 1, False),
    },
    6: {"e_lsb": (43, 22, 1, False), "sqrt_a_sqrtm": (65, 32, 2.0**-19, False), "cic_msb": (97, 10, 1, True)},
    7: {
        "cic_lsb": (43, 8, 1, False),
        "cis_rad": (51, 18, 2.0**-31, True),
        "toe_s": (69, 17, 8, False),
        "i0_msb": (86, 21, 1, True),
    },
    8: {
        "i0_lsb": (43, 11, 1, False),
        "crc_m": (54, 18, 2.0**-6, True),
        "crs_m": (72, 18, 2.0**-6, True),
        "omega_dot_msb": (90, 19, 1, True),
    },
    9: {"omega_dot_lsb": (43, 5, 1, False), "omega0_sc": (48, 32, 2.0**-31, True), "omega_msb": (80, 27, 1, True)},
    10: {"omega_lsb": (43, 5, 1, False), "idot_sc_s": (48, 14, 2.0**-43, True)},
}
#: Split elements: name -> (high part, low part, low bits, scale).
_SPLIT = {
    "af1_s_s": ("af1_msb", "af1_lsb", 18, 2.0**-50),
    "cuc_rad": ("cuc_msb", "cuc_lsb", 4, 2.0**-31),
    "e": ("e_msb", "e_lsb", 22, 2.0**-33),
    "cic_rad": ("cic_msb", "cic_lsb", 8, 2.0**-31),
    "i0_sc": ("i0_msb", "i0_lsb", 11, 2.0**-31),
    "omega_dot_sc_s": ("omega_dot_msb", "omega_dot_lsb", 5, 2.0**-43),
    "omega_sc": ("omega_msb", "omega_lsb", 5, 2.0**-31),
}
#: The pages an ephemeris takes (page 2 holds the ionosphere only).
EPHEMERIS_PAGES = (1, 3, 4, 5, 6, 7, 8, 9, 10)
_TO_RINEX = {**KEPLER_TO_RINEX, "tgd1_s": "TGD"}


@dataclass(frozen=True)
class D2Subframe:
    """One decoded subframe: ``start`` its first bit's index in the stream, ``inverted`` the
    stream's polarity there, ``fraid``, ``sow`` (the frame's BDT s of week), ``pnum`` (the
    page of subframe 1; 0 for the others), ``fields`` (physical units) and the codewords
    BCH ``corrected``."""

    start: int
    inverted: bool
    fraid: int
    sow: int
    pnum: int
    fields: dict[str, float] = field(repr=False)
    corrected: int = 0

    @property
    def word_type(self) -> int:
        """The subframe ID (the receiver's reports read I/NAV's word types under this name)."""
        return self.fraid

    @property
    def start_sow_s(self) -> float:
        """BDT (s of week) at this subframe's first bit: the frame's SOW + 0.6 s a subframe."""
        return self.sow + SUBFRAME_S * (self.fraid - 1)


@dataclass(frozen=True)
class D2Message:
    """What one GEO satellite's D2 bits decoded to: the subframes kept, the record of the
    last complete page cycle (None without), ``bdt`` ``(bit index, BDT week, BDT s)`` of
    the last subframe kept (its own start; the week of the last page 1 before it), the
    last fields of each page of subframe 1 (``page_fields``), and one line per grid
    subframe not kept. ``iono_time`` is None (I/NAV's NeQuick and time parameters have no D2
    counterpart here); ``iono`` page 2's Klobuchar coefficients (`bds_iono.BdsKlobuchar`)."""

    subframes: list[D2Subframe]
    ephemeris: Ephemerides | None
    bdt: tuple[int, int | None, float] | None
    page_fields: dict[int, dict[str, float]]
    failures: list[str]
    iono_time: None = None

    @property
    def pages(self) -> list[D2Subframe]:
        """The subframes, under the name I/NAV's and F/NAV's messages give their pages."""
        return self.subframes

    @property
    def gst(self) -> tuple[int, int | None, float] | None:
        """``bdt`` in GPS time (BDT + 14 s; BDT week + 1356), as the receiver dates rows."""
        return None if self.bdt is None else gps_time_of(*self.bdt)

    @property
    def iono(self) -> BdsKlobuchar | None:
        """The last page 2's Klobuchar coefficients (None without a page 2)."""
        return BdsKlobuchar.from_fields(self.page_fields[2]) if 2 in self.page_fields else None


def _consistent(fraid: int, sow: int, pnum: int) -> bool:
    if not (1 <= fraid <= 5 and sow % 3 == 0 and sow < _WEEK_S):
        return False
    return fraid != 1 or pnum == (sow // 3) % 10 + 1


def encode_subframe(fraid: int, sow: int, values: dict[str, float]) -> np.ndarray:
    """The 300 bits (0/1) as sent of one subframe of the frame at BDT ``sow`` (a multiple of
    3 s): subframe 1 carries its page (``(sow / 3) mod 10 + 1``) with ``values`` quantised
    with the ICD's scale factors (fields not given are 0); subframes 2-5 their header only."""
    if fraid not in (1, 2, 3, 4, 5):
        raise ConfigError("fraid", f"a D2 subframe ID is 1-5, got {fraid}")
    if sow % 3 or not 0 <= sow < _WEEK_S:
        raise ConfigError("sow", f"a D2 frame starts on a multiple of 3 s of BDT, got {sow}")
    pnum = (sow // 3) % 10 + 1 if fraid == 1 else 0
    layout = {**_HEADER, **_SOW, **(PAGE_LAYOUTS[pnum] if fraid == 1 else {})}
    values = {**values, "preamble": int("11100010010", 2), "rev": 0, "fraid": fraid, "sow": sow, "pnum": pnum}
    info = encode_fields(INFO_BITS, layout, values, f"d2.subframe{fraid}.page{pnum}", "BDS-SIS-ICD-B1I 3.0 5.3")
    return sent_bits(info)


def decode_subframe_bits(sent: np.ndarray) -> tuple[int, int, int, dict[str, float], int]:
    """FraID, SOW, page number (subframe 1; else 0), scaled fields of the page and the
    codewords corrected, of 300 bits as sent."""
    b = np.asarray(sent, dtype=np.uint8)
    if b.shape != (SUBFRAME_BITS,):
        raise ConfigError("bits", f"a D2 subframe is {SUBFRAME_BITS} bits, got shape {b.shape}")
    info, corrected = info_bits(b)
    fraid, sow = field_integer(info, 16, 3), field_integer(info, 19, 20)
    pnum = field_integer(info, 39, 4) if fraid == 1 else 0
    return fraid, sow, pnum, decode_fields(info, PAGE_LAYOUTS.get(pnum, {})), int(corrected)


def _d2_at(sent: np.ndarray) -> tuple[tuple[int, int, int, dict, int], bool]:
    fraid, sow, pnum, fields, corrected = decode_subframe_bits(sent)
    return (fraid, sow, pnum, fields, corrected), _consistent(fraid, sow, pnum)


def find_d2_subframes(bits: np.ndarray, sync_errors: int = 0) -> tuple[list[D2Subframe], list[str]]:
    """Every subframe of a stream of soft D2 bits (one per 2 ms, bit 0 as +1) whose header is
    consistent, and one line per subframe of the stream's grid that is not
    (`d1nav.subframe_grid`)."""
    found, failures = [], []
    for start, inverted, (fraid, sow, pnum, fields, corrected), ok in subframe_grid(
        bits, _d2_at, "one satellite's D2 bits", sync_errors
    ):
        if ok:
            found.append(D2Subframe(start, inverted, fraid, sow, pnum, fields, corrected))
        else:
            failures.append(f"D2 subframe at bit {start}: FraID {fraid}, SOW {sow} and page {pnum} disagree; not used")
    return found, failures


def _joined(high: float, low: float, low_bits: int) -> int:
    return (int(high) << low_bits) | int(low)


def pages_to_ephemeris(pages: dict[int, dict[str, float]], prn: int) -> Ephemerides:
    """One `Ephemerides` record of BeiDou GEO ``prn`` (georinex names, radians, BDT) from
    the decoded pages 1 and 3-10 of subframe 1: T_GD1 as ``TGD`` (the B1I user's),
    ``TGD2``, SatH1, AODE, the URA of URAI (as `d1nav.subframes_to_ephemeris`).

    Raises
    ------
    ConfigError
        Naming the page missing, or toc and toe when they differ.
    """
    for p in EPHEMERIS_PAGES:
        if p not in pages:
            raise ConfigError(f"d2.page{p}", "missing: a D2 ephemeris needs pages 1 and 3-10 of subframe 1")
    merged = {k: v for p in EPHEMERIS_PAGES for k, v in pages[p].items()}
    for name, (high, low, n, scale) in _SPLIT.items():
        merged[name] = _joined(merged[high], merged[low], n) * scale
    if merged["toe_s"] != merged["toc_s"]:
        raise ConfigError("d2.toe", f"toe {merged['toe_s']:.0f} s differs from page 1's toc {merged['toc_s']:.0f} s")
    return beidou_record(merged, prn)


def decode_d2(bits: np.ndarray, prn: int) -> D2Message:
    """Decode one GEO satellite's D2 bit stream (one soft bit per 2 ms, in order, no gaps;
    ``prn`` names the record): subframes (`find_d2_subframes`), the last fields of each page,
    the record of the last ten pages in a row (one 30 s cycle) whose toc is their toe, and
    the BDT of the last subframe."""
    subframes, failures = find_d2_subframes(bits)
    pages: dict[int, dict[str, float]] = {}
    cycle: dict[int, D2Subframe] = {}
    ephemeris, bdt, week = None, None, None
    for sf in subframes:
        if sf.fraid == 1:
            pages[sf.pnum] = sf.fields
            if sf.pnum == 1:
                week = int(sf.fields["wn"])
            cycle = {p: v for p, v in cycle.items() if v.sow // 30 == sf.sow // 30} | {sf.pnum: sf}
            if sf.pnum == 10 and all(p in cycle for p in EPHEMERIS_PAGES):
                try:
                    ephemeris = pages_to_ephemeris({p: cycle[p].fields for p in EPHEMERIS_PAGES}, prn)
                except ConfigError as exc:
                    failures.append(f"D2 pages of SOW {cycle[1].sow}: {exc}; no ephemeris from them")
        bdt = (sf.start, week, sf.start_sow_s)
    return D2Message(subframes, ephemeris, bdt, pages, failures)


def ephemeris_to_pages(record: Ephemerides) -> dict[int, dict[str, float]]:
    """Field values of pages 1-10 of subframe 1 of one BeiDou record (`d1nav.record_values`,
    the split elements cut in two; page 2's ionosphere as zero, or ``iono`` in `encode_d2`);
    the BDT week is set when sent (`encode_d2`)."""
    values = record_values(record)
    for name, (high, low, n, scale) in _SPLIT.items():
        q = int(np.round(values[name] / scale))
        values[high], values[low] = q >> n, q & ((1 << n) - 1)
    return {p: {k: values[k] for k in PAGE_LAYOUTS[p] if k in values} for p in PAGE_LAYOUTS}


def encode_d2(
    record: Ephemerides, wn: int, first_sow: int, n_frames: int, iono: BdsKlobuchar | None = None
) -> np.ndarray:
    """±1 bits (int8, bit 0 as +1) of ``n_frames`` consecutive 3 s frames of one GEO
    satellite from BDT ``first_sow`` (a multiple of 3 s) of BDT week ``wn``: subframe 1 the
    page of each frame (page 2 the Klobuchar coefficients ``iono``, zero without),
    subframes 2-5 their header alone."""
    if first_sow % 3 or not 0 <= first_sow < _WEEK_S:
        raise ConfigError("first_sow", f"a D2 frame starts on a multiple of 3 s of BDT, got {first_sow}")
    base = ephemeris_to_pages(record)
    if iono is not None:
        base[2] = base[2] | iono.fields()
    out = []
    for k in range(n_frames):
        t = first_sow + 3 * k
        sow, wn_k = t % _WEEK_S, wn + t // _WEEK_S
        page = (sow // 3) % 10 + 1
        values = base[page] | ({"wn": wn_k % 8192} if page == 1 else {})
        out.append(encode_subframe(1, sow, values))
        out += [encode_subframe(f, sow, {}) for f in (2, 3, 4, 5)]
    return (1 - 2 * np.concatenate(out).astype(np.int8)).astype(np.int8)


def d2_symbols(
    record: Ephemerides, wn: int, sow_s: float, n_bits: int, iono: BdsKlobuchar | None = None
) -> tuple[np.ndarray, float]:
    """±1 D2 bits (int8) from the one in force at BDT ``sow_s`` of week ``wn`` on, for the IF
    generator's data (`beidou-b1i-geo`: one bit every 2 code periods), and the time (s) from
    the first bit's start to ``sow_s``. Frames as `encode_d2` (``iono`` in page 2; as
    `d1nav.d1_symbols` for D1)."""
    first = int(np.floor(sow_s / FRAME_S)) * 3
    into = sow_s - first
    skip = int(np.floor(into * SYMBOL_RATE_HZ))
    n_frames = int(np.ceil((skip + n_bits) / (FRAME_S * SYMBOL_RATE_HZ)))
    bits = encode_d2(record, wn + first // _WEEK_S, first % _WEEK_S, n_frames, iono)[skip : skip + n_bits]
    return bits, float(into - skip / SYMBOL_RATE_HZ)
