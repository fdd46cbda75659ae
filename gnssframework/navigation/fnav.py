"""Galileo F/NAV on E5a-I (Galileo OS SIS ICD Issue 2.1, sec. 4.2): pages from symbols
and back, and the ephemeris they carry.

A page (ICD 4.2.2) lasts 10 s: 500 symbols at 50 symbol/s, the synchronisation pattern
``101101110000`` (12 symbols) and 488 coded symbols, the page's 244 bits through the
rate-1/2 K = 7 convolutional code of I/NAV (G2 inverted) and a 61 x 8 block interleaver
(4.1.4; :mod:`~gnssframework.navigation.fec`). The 244 bits are the page type (6), the
navigation data (208), the CRC-24Q over those 214 (24) and a zero tail (6).

Page types 1-4 carry the ephemeris and clock of one IODnav (ICD 4.2.4, Table "F/NAV page
types" and the field tables of 5.1): type 1 the SVID, IODnav, clock (t0c, af0-af2), SISA
index, NeQuick ai0-ai2 and region flags, BGD(E1,E5a), E5a signal health and data validity
and the GST week and time of week; type 2 M0, Omega-dot, e, sqrt(A), Omega0, i-dot; type 3
i0, omega, Delta-n, the harmonic corrections Cuc, Cus, Crc, Crs and t0e; type 4 Cic, Cis,
the GST-UTC (A0, A1, Delta t_LS, t0t, WN0t, WN_LSF, DN, Delta t_LSF) and GST-GPS (t0G,
A0G, A1G, WN0G) conversions. Types 2-4 close with the GST of their own page. Types 5 and 6
(almanacs) are read as their type only. The scale factors are I/NAV's for the same
parameters (ICD 5.1); the bit positions differ.

A record's clock is for the E1,E5a pair: its ``TGD`` holds BGD(E1,E5a), the E1 single-
frequency user's delay, and its health the RINEX 3 Galileo health word's E5a bits (bit 3
DVS, bits 4-5 HS). The TOW of every page is the GST at the start of its first sync symbol
(ICD 5.1.2).

Truth (tests/navigation/test_fnav.py): six real F/NAV pages of E01 and the values GNSSTk
decodes from them (its test data), whose CRC-24Q the layout here must find at bits 215-238.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import ConfigError
from . import fec
from .bit_fields import Layout, decode_fields, encode_fields, field_integer
from .ephemeris import KEPLER_TO_RINEX, Ephemerides
from .inav_words import galileo_record, record_fields, sisa_index

__all__ = [
    "FNAV_SYNC",
    "PAGE_SYMBOLS",
    "PAGE_BITS",
    "SYMBOL_RATE_HZ",
    "PAGE_S",
    "PAGE_LAYOUTS",
    "FnavPage",
    "FnavMessage",
    "encode_page",
    "decode_page_bits",
    "page_symbols",
    "find_fnav_pages",
    "decode_fnav",
    "pages_to_ephemeris",
    "ephemeris_to_pages",
    "encode_fnav",
    "fnav_symbols",
]

#: Synchronisation pattern of every F/NAV page (ICD 4.2.2.1).
FNAV_SYNC = np.array([1, 0, 1, 1, 0, 1, 1, 1, 0, 0, 0, 0], dtype=np.uint8)
#: Symbols of a page (sync + 488 coded), its bits before coding, its length and rate.
PAGE_SYMBOLS = 500
PAGE_BITS = 244
PAGE_S = 10.0
SYMBOL_RATE_HZ = 50.0
_CODED = 488
_ROWS, _COLS = 8, 61
_CRC_COVERED = 214
_SYNC_PM = 1.0 - 2.0 * FNAV_SYNC

# name -> (first bit, 1-based within the page; length; scale; signed). Page type: bits 1-6.
PAGE_LAYOUTS: dict[int, Layout] = {
    1: {
        "svid": (7, 6, 1, False),
        "iodnav": (13, 10, 1, False),
        "toc_s": (23, 14, 60, False),
        "af0_s": (37, 31, 2.0**-34, True),
        "af1_s_s": (68, 21, 2.0**-46, True),
        "af2_s_s2": (89, 6, 2.0**-59, True),
        "sisa_index": (95, 8, 1, False),
        "ai0_sfu": (103, 11, 2.0**-2, False),
        "ai1_sfu_deg": (114, 11, 2.0**-8, True),
        "ai2_sfu_deg2": (125, 14, 2.0**-15, True),
        "region1": (139, 1, 1, False),
        "region2": (140, 1, 1, False),
        "region3": (141, 1, 1, False),
        "region4": (142, 1, 1, False),
        "region5": (143, 1, 1, False),
        "bgd_e1e5a_s": (144, 10, 2.0**-32, True),
        "e5a_hs": (154, 2, 1, False),
        "wn": (156, 12, 1, False),
        "tow_s": (168, 20, 1, False),
        "e5a_dvs": (188, 1, 1, False),
    },
    2: {
        "iodnav": (7, 10, 1, False),
        "m0_sc": (17, 32, 2.0**-31, True),
        "omega_dot_sc_s": (49, 24, 2.0**-43, True),
        "e": (73, 32, 2.0**-33, False),
        "sqrt_a_sqrtm": (105, 32, 2.0**-19, False),
        "omega0_sc": (137, 32, 2.0**-31, True),
        "idot_sc_s": (169, 14, 2.0**-43, True),
        "wn": (183, 12, 1, False),
        "tow_s": (195, 20, 1, False),
    },
    3: {
        "iodnav": (7, 10, 1, False),
        "i0_sc": (17, 32, 2.0**-31, True),
        "omega_sc": (49, 32, 2.0**-31, True),
        "delta_n_sc_s": (81, 16, 2.0**-43, True),
        "cuc_rad": (97, 16, 2.0**-29, True),
        "cus_rad": (113, 16, 2.0**-29, True),
        "crc_m": (129, 16, 2.0**-5, True),
        "crs_m": (145, 16, 2.0**-5, True),
        "toe_s": (161, 14, 60, False),
        "wn": (175, 12, 1, False),
        "tow_s": (187, 20, 1, False),
    },
    4: {
        "iodnav": (7, 10, 1, False),
        "cic_rad": (17, 16, 2.0**-29, True),
        "cis_rad": (33, 16, 2.0**-29, True),
        "a0_s": (49, 32, 2.0**-30, True),
        "a1_s_s": (81, 24, 2.0**-50, True),
        "dt_ls_s": (105, 8, 1, True),
        "tot_s": (113, 8, 3600, False),
        "wnt": (121, 8, 1, False),
        "wn_lsf": (129, 8, 1, False),
        "dn": (137, 3, 1, False),
        "dt_lsf_s": (140, 8, 1, True),
        "t0g_s": (148, 8, 3600, False),
        "a0g_s": (156, 16, 2.0**-35, True),
        "a1g_s_s": (172, 12, 2.0**-51, True),
        "wn0g": (184, 6, 1, False),
        "tow_s": (190, 20, 1, False),
    },
}
#: Ephemeris and clock fields (the names above) -> georinex names; ``TGD`` is BGD(E1,E5a).
_TO_RINEX = {**KEPLER_TO_RINEX, "bgd_e1e5a_s": "TGD"}
#: RINEX 3 Galileo SV health bits of the F/NAV fields (RINEX 3.04 Table A8).
_HEALTH_SHIFT = {"e5a_dvs": 3, "e5a_hs": 4}


@dataclass(frozen=True)
class FnavPage:
    """One decoded page: ``start`` the index of its first sync symbol in the stream,
    ``inverted`` the stream's polarity there, ``page_type`` and ``fields`` (physical units),
    ``bits`` the 244 page bits."""

    start: int
    inverted: bool
    page_type: int
    fields: dict[str, float] = field(repr=False)
    bits: np.ndarray = field(repr=False)

    @property
    def word_type(self) -> int:
        """The page type, under the name an I/NAV page's type has (the receiver's reports
        read both)."""
        return self.page_type


@dataclass(frozen=True)
class FnavMessage:
    """What one satellite's E5a-I symbols decoded to: the pages (CRC passed), the record of
    the last pages 1-4 of one IODnav (None without), ``gst`` ``(symbol index, WN, TOW s)`` of
    the last page with a TOW (its first sync symbol's; the WN of the last page that sent one,
    None where no page has: page type 4 sends none), the last fields of each page type, and one line per page of the
    stream's page grid that failed its CRC. ``iono_time`` is None: page types 1 and 4's
    NeQuick, GST-UTC and GGTO fields are decoded into ``fields``, not assembled (as I/NAV's
    are)."""

    pages: list[FnavPage]
    ephemeris: Ephemerides | None
    gst: tuple[int, int | None, float] | None
    fields: dict[int, dict[str, float]]
    failures: list[str]
    iono_time: None = None


def encode_page(page_type: int, values: dict[str, float]) -> np.ndarray:
    """The 244 bits (0/1) of one page: ``values`` quantised with the ICD's scale factors
    (fields not given are 0), the CRC-24Q over bits 1-214, a zero tail. A value out of its
    field is refused in one line."""
    if page_type not in PAGE_LAYOUTS:
        raise ConfigError("page_type", f"F/NAV page types {sorted(PAGE_LAYOUTS)} are encoded, got {page_type}")
    layout = {"page_type": (1, 6, 1.0, False), **PAGE_LAYOUTS[page_type]}
    values = {**values, "page_type": page_type}
    bits = encode_fields(PAGE_BITS, layout, values, f"fnav.page{page_type}", "Galileo OS SIS ICD 4.2.4")
    crc = int(fec.crc24q_bits(bits[:_CRC_COVERED]))
    bits[_CRC_COVERED : _CRC_COVERED + 24] = (crc >> np.arange(23, -1, -1)) & 1
    return bits


def decode_page_bits(bits: np.ndarray) -> tuple[int, dict[str, float], bool]:
    """Page type, scaled fields (physical units; none for types 5, 6 and others) and
    whether the CRC-24Q holds, of 244 page bits."""
    b = np.asarray(bits, dtype=np.uint8)
    if b.shape != (PAGE_BITS,):
        raise ConfigError("bits", f"an F/NAV page is {PAGE_BITS} bits, got shape {b.shape}")
    crc_ok = int(fec.crc24q_bits(b[:_CRC_COVERED])) == field_integer(b, _CRC_COVERED + 1, 24)
    page_type = field_integer(b, 1, 6)
    return page_type, decode_fields(b, PAGE_LAYOUTS.get(page_type, {})), crc_ok


def page_symbols(pages: np.ndarray) -> np.ndarray:
    """±1 symbols ``(P, 500)`` (int8, bit 0 as +1) of pages ``(P, 244)``: the sync pattern
    and the interleaved coded bits."""
    p = np.atleast_2d(np.asarray(pages, dtype=np.uint8))
    if p.shape[-1] != PAGE_BITS:
        raise ConfigError("pages", f"an F/NAV page is {PAGE_BITS} bits, got shape {p.shape}")
    coded = fec.interleave(fec.conv_encode(p), _ROWS, _COLS)
    bits = np.concatenate([np.broadcast_to(FNAV_SYNC, (p.shape[0], FNAV_SYNC.size)), coded], axis=-1)
    return (1 - 2 * bits.astype(np.int8)).astype(np.int8)


def _decode_blocks(s: np.ndarray, starts: np.ndarray, polarity: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Viterbi-decoded pages ``(K, 244)`` at ``starts`` and whether each CRC holds."""
    blocks = s[starts[:, None] + np.arange(PAGE_SYMBOLS)] * polarity[:, None]
    pages = fec.viterbi_decode(fec.deinterleave(blocks[:, FNAV_SYNC.size :], _ROWS, _COLS))
    received = np.sum(pages[:, _CRC_COVERED : _CRC_COVERED + 24].astype(np.int64) << np.arange(23, -1, -1), axis=-1)
    return pages, fec.crc24q_bits(pages[:, :_CRC_COVERED]) == received


def find_fnav_pages(symbols: np.ndarray, sync_errors: int = 1) -> tuple[list[FnavPage], list[str]]:
    """Every page of a stream of soft E5a-I symbols (one per 20 ms, overlay wiped) whose CRC
    holds, and one line per page of the stream's page grid that failed: as I/NAV's
    `inav.find_pages`, the candidates where 12 symbols match the sync pattern (either
    polarity, at most ``sync_errors`` wrong), the grid the most common start modulo 500 of
    the pages kept, every whole grid page then decoded."""
    s = fec.real_symbols(symbols, "one satellite's E5a-I stream")
    if not 0 <= sync_errors < FNAV_SYNC.size // 2:
        raise ConfigError("sync_errors", f"must be 0-{FNAV_SYNC.size // 2 - 1}, got {sync_errors}")
    n = s.size
    if n < PAGE_SYMBOLS:
        return [], []
    match = np.lib.stride_tricks.sliding_window_view(np.sign(s), FNAV_SYNC.size) @ _SYNC_PM
    starts = np.arange(n - PAGE_SYMBOLS + 1)
    need = FNAV_SYNC.size - 2 * sync_errors
    up, down = match[starts] >= need, match[starts] <= -need
    cand = np.flatnonzero(up | down)
    if cand.size == 0:
        return [], []
    pages, ok = _decode_blocks(s, cand, np.where(up[cand], 1.0, -1.0))
    if not ok.any():
        return [], []
    offsets, counts = np.unique(cand[ok] % PAGE_SYMBOLS, return_counts=True)
    grid = np.arange(int(offsets[np.argmax(counts)]), n - PAGE_SYMBOLS + 1, PAGE_SYMBOLS)
    pol = np.where(match[grid] >= 0, 1.0, -1.0)
    pages, ok = _decode_blocks(s, grid, pol)
    found = []
    for k in np.flatnonzero(ok):
        page_type, fields, _ = decode_page_bits(pages[k])
        found.append(FnavPage(int(grid[k]), bool(pol[k] < 0), page_type, fields, pages[k]))
    failures = [f"F/NAV page at symbol {int(grid[k])}: CRC-24Q failed; not used" for k in np.flatnonzero(~ok)]
    return found, failures


def pages_to_ephemeris(fields: dict[int, dict[str, float]]) -> Ephemerides:
    """One `Ephemerides` record (georinex names, radians) from decoded page types 1-4 of one
    IODnav: its clock for E1,E5a (``TGD`` = BGD(E1,E5a), ``FNAV`` 1), SISA and E5a health.

    Raises
    ------
    ConfigError
        Naming the page type missing or the one whose IODnav differs from type 1's.
    """
    for t in (1, 2, 3, 4):
        if t not in fields:
            raise ConfigError(f"fnav.page{t}", "missing: an F/NAV ephemeris needs page types 1-4")
    iod = fields[1]["iodnav"]
    for t in (2, 3, 4):
        if fields[t]["iodnav"] != iod:
            raise ConfigError(
                f"fnav.page{t}.iodnav",
                f"{fields[t]['iodnav']} differs from page 1's {iod} (ICD 5.1.9.2: one IODnav per ephemeris set)",
            )
    merged = {k: v for t in (4, 3, 2, 1) for k, v in fields[t].items()}
    return galileo_record(merged, _TO_RINEX, _HEALTH_SHIFT, fnav=True)


def decode_fnav(symbols: np.ndarray) -> FnavMessage:
    """Decode one satellite's E5a-I symbol stream (one soft symbol per 20 ms, overlay wiped,
    in order, no gaps): pages (`find_fnav_pages`), the last fields of each type, the record
    of the last pages 1-4 that share an IODnav, and the GST of the last page with one."""
    pages, failures = find_fnav_pages(symbols)
    fields: dict[int, dict[str, float]] = {}
    ephemeris = None
    gst = None
    for p in pages:
        fields[p.page_type] = p.fields
        if "tow_s" in p.fields:  # page type 4 sends a TOW without WN: the last WN serves, or none
            wn = p.fields.get("wn", gst[1] if gst is not None else None)
            gst = (p.start, None if wn is None else int(wn), float(p.fields["tow_s"]))
        if (
            p.page_type in (1, 2, 3, 4)
            and all(t in fields for t in (1, 2, 3, 4))
            and len({fields[t]["iodnav"] for t in (1, 2, 3, 4)}) == 1
        ):
            ephemeris = pages_to_ephemeris(fields)
    return FnavMessage(pages, ephemeris, gst, fields, failures)


def ephemeris_to_pages(
    record: Ephemerides, wn: int, ai_sfu: tuple[float, float, float] = (0.0, 0.0, 0.0)
) -> dict[int, dict[str, float]]:
    """Field values of page types 1-4 of one Galileo record whose clock is for E1,E5a
    (``TGD`` as BGD(E1,E5a)); every page's ``wn`` (12 bits sent) and ``tow_s`` are set when
    it is sent (`encode_fnav`). Type 4's time conversions are sent as zero."""
    values = record_fields(record, _TO_RINEX)
    values.update(iodnav=int(record.iode[0]), svid=int(str(record.sv[0])[1:]))
    acc = float(record.accuracy_m[0]) if record.accuracy_m is not None else np.nan
    health = int(record.health[0])
    values.update(
        sisa_index=sisa_index(acc),
        ai0_sfu=ai_sfu[0],
        ai1_sfu_deg=ai_sfu[1],
        ai2_sfu_deg2=ai_sfu[2],
        e5a_dvs=(health >> 3) & 1,
        e5a_hs=(health >> 4) & 3,
        wn=wn % 4096,
    )
    return {t: {k: values[k] for k in PAGE_LAYOUTS[t] if k in values} for t in (1, 2, 3, 4)}


def encode_fnav(record: Ephemerides, wn: int, first_tow_s: int, n_pages: int) -> np.ndarray:
    """±1 symbols (int8) of ``n_pages`` consecutive pages of one satellite from GST
    ``first_tow_s`` (a multiple of 10 s) on: page types 1, 2, 3, 4 in turn (the ``j``-th
    page of the week the ``j mod 4``-th), each with the GST of its start; the almanac pages
    (5, 6) of the ICD's sub-frame are not sent."""
    if first_tow_s % 10 or not 0 <= first_tow_s < 604_800:
        raise ConfigError("first_tow_s", f"an F/NAV page starts on a multiple of 10 s of GST, got {first_tow_s}")
    base = ephemeris_to_pages(record, wn)
    pages = []
    for k in range(n_pages):
        tow = (first_tow_s + 10 * k) % 604_800
        wn_k = (wn + (first_tow_s + 10 * k) // 604_800) % 4096
        t = (tow // 10) % 4 + 1
        pages.append(encode_page(t, base[t] | {"wn": wn_k, "tow_s": tow}))
    return page_symbols(np.array(pages)).reshape(-1)


def fnav_symbols(record: Ephemerides, wn: int, tow_s: float, n_symbols: int) -> tuple[np.ndarray, float]:
    """±1 E5a-I symbols (int8) from the one in force at GST ``tow_s`` on, for the IF
    generator's ``data_bits`` (`galileo-e5ai`: one symbol every 20 code periods), and the
    time (s) from the first symbol's start to ``tow_s``. Pages as `encode_fnav`."""
    first = int(np.floor(tow_s / PAGE_S)) * 10
    into = tow_s - first
    skip = int(np.floor(into * SYMBOL_RATE_HZ))
    n_pages = int(np.ceil((skip + n_symbols) / PAGE_SYMBOLS))
    symbols = encode_fnav(record, wn, first % 604_800, n_pages)[skip : skip + n_symbols]
    return symbols, float(into - skip / SYMBOL_RATE_HZ)
