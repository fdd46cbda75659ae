"""BeiDou D1 navigation message (BDS-SIS-ICD-B1I 3.0, sec. 5.1.3 and 5.2): subframes from
symbols and back, and the ephemeris subframes 1-3 carry.

D1 is sent at 50 bit/s by the MEO and IGSO satellites on B1I (each bit under NH20,
`signal.beidou_b1i`). A subframe lasts 6 s: 300 bits in ten 30-bit words; five subframes
make a 30 s frame, subframe ``k`` starting at a BDT second of week ``SOW`` with
``SOW mod 30 = 6 (k - 1)``. Word 1 is the preamble ``11100010010`` (11 bits), 4 reserved
bits, then one BCH(15,11,1) codeword: 11 information bits (the subframe ID ``FraID``, 3
bits, and the 8 high bits of ``SOW``) and 4 parity bits. Words 2-10 each carry 22
information bits as two BCH(15,11,1) codewords (sec. 5.1.3, Figure 5-4), interleaved bit by
bit: the first codeword on the word's odd bits (1st, 3rd, ...), the second on its even
bits. The code's generator polynomial is :math:`g(x) = x^4 + x + 1`; it corrects one error
per codeword (a Hamming code).

Fields lie on the *information bits* here: word 1's 26 (preamble, reserved, FraID, SOW high
bits) then each later word's 22, 224 in all. A field that the ICD splits across two words
is one run of this stream. Subframe 1 (sec. 5.2.4.3-5.2.4.10) holds SatH1, AODC, URAI, the
BDT week, toc, T_GD1, T_GD2, the Klobuchar alpha and beta, a2, a0, a1 and AODE; subframe 2
Delta-n, Cuc, M0, e, Cus, Crc, Crs, sqrt(A) and toe's 2 high bits; subframe 3 toe's 15 low
bits, i0, Cic, Omega-dot, Cis, IDOT, Omega0 and omega. Subframes 4 and 5 (almanac pages,
time offsets) are read to their header. A record's clock is the B3I clock (``clock_s``)
and its ``TGD`` T_GD1, the B1I user's delay (sec. 5.2.4.10).

Validity: BCH corrects, it does not detect. A subframe is kept when its preamble, its
FraID and its SOW agree (``FraID = (SOW / 6) mod 5 + 1``, SOW a multiple of 6 in the week);
an ephemeris when subframes 1-3 of one frame are kept and toc equals toe (the check RTKLIB
makes).

Truth (tests/navigation/test_d1nav.py): three real subframes of C06 (BDT week 810) and the
values GNSSTk decodes from them (its test data).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import ConfigError
from . import fec
from .bds_iono import BdsKlobuchar
from .bit_fields import Layout, decode_fields, encode_fields, field_integer
from .ephemeris import KEPLER_TO_RINEX, SEMICIRCLE_FIELDS, Ephemerides
from .lnav import URA_M

__all__ = [
    "D1_PREAMBLE",
    "SUBFRAME_BITS",
    "SUBFRAME_S",
    "SYMBOL_RATE_HZ",
    "INFO_BITS",
    "BDT_GPS_WEEK_OFFSET",
    "BDT_GPS_OFFSET_S",
    "SUBFRAME_LAYOUTS",
    "D1Subframe",
    "D1Message",
    "bch_encode",
    "bch_decode",
    "info_bits",
    "gps_time_of",
    "sent_bits",
    "PI_BDS",
    "interleave_subframe",
    "deinterleave_subframe",
    "encode_subframe",
    "decode_subframe_bits",
    "find_d1_subframes",
    "subframe_grid",
    "beidou_record",
    "subframes_to_ephemeris",
    "decode_d1",
    "record_values",
    "ephemeris_to_subframes",
    "encode_d1",
    "d1_symbols",
]

#: Preamble of every subframe (sec. 5.2.3).
D1_PREAMBLE = np.array([1, 1, 1, 0, 0, 0, 1, 0, 0, 1, 0], dtype=np.uint8)
SUBFRAME_BITS = 300
SUBFRAME_S = 6.0
#: D1 at 50 bit/s, uncoded: one symbol a bit.
SYMBOL_RATE_HZ = 50.0
#: Information bits of a subframe: word 1's 26 and 22 from each of words 2-10.
INFO_BITS = 26 + 9 * 22
#: BDT week 0 began at GPS week 1356 (2006-01-01 00:00:00 UTC), and BDT = GPST - 14 s.
BDT_GPS_WEEK_OFFSET = 1356
BDT_GPS_OFFSET_S = 14.0
#: BeiDou's pi for semicircles (sec. 5.2.4.12: 3.1415926535898).
PI_BDS = 3.1415926535898
_WEEK_S = 604_800
_PREAMBLE_PM = 1.0 - 2.0 * D1_PREAMBLE

# BCH(15,11,1) with g(x) = x^4 + x + 1, information bits first (the highest powers).
_G = 0b10011


def _parity_of(info: int) -> int:
    r = info << 4
    for k in range(14, 3, -1):
        if (r >> k) & 1:
            r ^= _G << (k - 4)
    return r


#: ``(11, 4)``: the parity of each information bit alone (most significant first).
_P = np.array([[(_parity_of(1 << (10 - i)) >> (3 - j)) & 1 for j in range(4)] for i in range(11)], np.uint8)
#: Parity-check matrix ``(4, 15)``: ``cw @ H.T`` is 0 for a codeword.
_H = np.concatenate([_P.T, np.eye(4, dtype=np.uint8)], axis=1)
#: Syndrome (as an integer, first row the most significant bit) -> the bit it flags (the 15
#: columns of H are the 15 non-zero syndromes; 0 flags none and is not used).
_ERROR_AT = np.zeros(16, np.int64)
_ERROR_AT[_H.T @ (1 << np.arange(3, -1, -1))] = np.arange(15)


def bch_encode(info: np.ndarray) -> np.ndarray:
    """Codewords ``(..., 15)`` (0/1) of information bits ``(..., 11)``: the bits, then the
    remainder of :math:`x^4 m(x)` divided by :math:`x^4 + x + 1`."""
    m = np.asarray(info, dtype=np.uint8)
    return np.concatenate([m, (m.astype(np.int64) @ _P) % 2], axis=-1).astype(np.uint8)


def bch_decode(codewords: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Information bits ``(..., 11)`` of received codewords ``(..., 15)`` with one error each
    corrected (the syndrome names the bit), and whether a bit was corrected."""
    cw = np.asarray(codewords, dtype=np.uint8).copy()
    syndrome = (cw.astype(np.int64) @ _H.T) % 2
    s = syndrome @ (1 << np.arange(3, -1, -1))
    flagged = s != 0
    pos = _ERROR_AT[s]
    rows = np.flatnonzero(flagged.ravel())
    flat = cw.reshape(-1, 15)
    flat[rows, pos.ravel()[rows]] ^= 1
    return flat.reshape(cw.shape)[..., :11], flagged


def interleave_subframe(logical: np.ndarray) -> np.ndarray:
    """The 300 bits as sent, of a subframe written word by word as the ICD lists it (word 1
    as sent; each later word its two codewords' information bits, 11 + 11, then their
    parity bits, 4 + 4: GNSSTk's and u-blox's layout)."""
    b = np.asarray(logical, dtype=np.uint8).reshape(-1, SUBFRAME_BITS)
    words = b[:, 30:].reshape(b.shape[0], 9, 30)
    cw1 = np.concatenate([words[..., :11], words[..., 22:26]], axis=-1)
    cw2 = np.concatenate([words[..., 11:22], words[..., 26:]], axis=-1)
    sent = np.empty_like(words)
    sent[..., 0::2], sent[..., 1::2] = cw1, cw2
    return np.concatenate([b[:, :30], sent.reshape(b.shape[0], -1)], axis=-1).reshape(np.shape(logical))


def deinterleave_subframe(sent: np.ndarray) -> np.ndarray:
    """The inverse of `interleave_subframe`."""
    b = np.asarray(sent, dtype=np.uint8).reshape(-1, SUBFRAME_BITS)
    words = b[:, 30:].reshape(b.shape[0], 9, 30)
    cw1, cw2 = words[..., 0::2], words[..., 1::2]
    logical = np.concatenate([cw1[..., :11], cw2[..., :11], cw1[..., 11:], cw2[..., 11:]], axis=-1)
    return np.concatenate([b[:, :30], logical.reshape(b.shape[0], -1)], axis=-1).reshape(np.shape(sent))


def _codewords(sent: np.ndarray) -> np.ndarray:
    """``(..., 19, 15)``: word 1's codeword, then words 2-10's two each, as sent."""
    b = np.asarray(sent, dtype=np.uint8)
    words = b[..., 30:].reshape(*b.shape[:-1], 9, 30)
    pairs = np.stack([words[..., 0::2], words[..., 1::2]], axis=-2).reshape(*b.shape[:-1], 18, 15)
    return np.concatenate([b[..., None, 15:30], pairs], axis=-2)


def info_bits(sent: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Information bits ``(..., 224)`` of subframes as sent (D1's or D2's), and the codewords
    corrected in each."""
    info, corrected = bch_decode(_codewords(sent))
    b = np.asarray(sent, dtype=np.uint8)
    return np.concatenate([b[..., :15], info.reshape(*info.shape[:-2], -1)], axis=-1), corrected.sum(axis=-1)


def sent_bits(info: np.ndarray) -> np.ndarray:
    """The 300 bits as sent of 224 information bits (the inverse of `info_bits`; D2's
    subframes are built alike)."""
    i = np.asarray(info, dtype=np.uint8)
    first = bch_encode(i[15:26])
    pairs = bch_encode(i[26:].reshape(18, 11)).reshape(9, 2, 15)
    words = np.empty((9, 30), np.uint8)
    words[:, 0::2], words[:, 1::2] = pairs[:, 0], pairs[:, 1]
    return np.concatenate([i[:15], first, words.ravel()])


_HEADER: Layout = {"preamble": (1, 11, 1, False), "rev": (12, 4, 1, False), "fraid": (16, 3, 1, False)}
_SOW: Layout = {"sow": (19, 20, 1, False)}
#: name -> (first information bit, 1-based; length; scale; signed), per FraID (sec. 5.2.3).
SUBFRAME_LAYOUTS: dict[int, Layout] = {
    1: {
        "sath1": (39, 1, 1, False),
        "aodc": (40, 5, 1, False),
        "urai": (45, 4, 1, False),
        "wn": (49, 13, 1, False),
        "toc_s": (62, 17, 8, False),
        "tgd1_s": (79, 10, 1e-10, True),
        "tgd2_s": (89, 10, 1e-10, True),
        "alpha0_s": (99, 8, 2.0**-30, True),
        "alpha1_s_sc": (107, 8, 2.0**-27, True),
        "alpha2_s_sc2": (115, 8, 2.0**-24, True),
        "alpha3_s_sc3": (123, 8, 2.0**-24, True),
        "beta0_s": (131, 8, 2.0**11, True),
        "beta1_s_sc": (139, 8, 2.0**14, True),
        "beta2_s_sc2": (147, 8, 2.0**16, True),
        "beta3_s_sc3": (155, 8, 2.0**16, True),
        "af2_s_s2": (163, 11, 2.0**-66, True),
        "af0_s": (174, 24, 2.0**-33, True),
        "af1_s_s": (198, 22, 2.0**-50, True),
        "aode": (220, 5, 1, False),
    },
    2: {
        "delta_n_sc_s": (39, 16, 2.0**-43, True),
        "cuc_rad": (55, 18, 2.0**-31, True),
        "m0_sc": (73, 32, 2.0**-31, True),
        "e": (105, 32, 2.0**-33, False),
        "cus_rad": (137, 18, 2.0**-31, True),
        "crc_m": (155, 18, 2.0**-6, True),
        "crs_m": (173, 18, 2.0**-6, True),
        "sqrt_a_sqrtm": (191, 32, 2.0**-19, False),
        "toe_msb": (223, 2, 1, False),
    },
    3: {
        "toe_lsb": (39, 15, 1, False),
        "i0_sc": (54, 32, 2.0**-31, True),
        "cic_rad": (86, 18, 2.0**-31, True),
        "omega_dot_sc_s": (104, 24, 2.0**-43, True),
        "cis_rad": (128, 18, 2.0**-31, True),
        "idot_sc_s": (146, 14, 2.0**-43, True),
        "omega0_sc": (160, 32, 2.0**-31, True),
        "omega_sc": (192, 32, 2.0**-31, True),
    },
}
#: Elements of a record (the names above) -> georinex names; ``TGD`` is T_GD1 (B1I).
_TO_RINEX = {**KEPLER_TO_RINEX, "tgd1_s": "TGD"}


def gps_time_of(start: int, wn: int | None, sow: float) -> tuple[int, int | None, float]:
    """``(start, BDT week, BDT s of week)`` as GPS time: ``(start, GPS week, GPS s of week)``
    (BDT + 14 s, its week + 1356; None for an unknown week)."""
    t = sow + BDT_GPS_OFFSET_S
    carry = int(t >= _WEEK_S)
    return start, None if wn is None else wn + BDT_GPS_WEEK_OFFSET + carry, t - carry * _WEEK_S


@dataclass(frozen=True)
class D1Subframe:
    """One decoded subframe: ``start`` the index of its first bit in the stream,
    ``inverted`` the stream's polarity there, ``fraid`` and ``sow`` (BDT s of week at its
    first bit), ``fields`` (physical units), ``corrected`` the codewords BCH corrected."""

    start: int
    inverted: bool
    fraid: int
    sow: int
    fields: dict[str, float] = field(repr=False)
    corrected: int = 0

    @property
    def word_type(self) -> int:
        """The subframe ID, under the name an I/NAV page's type has (the receiver's reports
        read both)."""
        return self.fraid


@dataclass(frozen=True)
class D1Message:
    """What one satellite's D1 bits decoded to: the subframes kept, the record of the last
    subframes 1-3 of one frame (None without), ``bdt`` ``(bit index, BDT week, SOW)`` of
    the last subframe kept (the week of the last subframe 1 before it; None before one),
    the last fields of each subframe ID, and one line per subframe of the stream's grid
    that was not kept. ``iono_time`` is None (I/NAV's NeQuick and time parameters have no
    D1 counterpart here); ``iono`` the Klobuchar coefficients of the last subframe 1
    (`bds_iono.BdsKlobuchar`, BeiDou's own model)."""

    subframes: list[D1Subframe]
    ephemeris: Ephemerides | None
    bdt: tuple[int, int | None, int] | None
    fields: dict[int, dict[str, float]]
    failures: list[str]
    iono_time: None = None

    @property
    def pages(self) -> list[D1Subframe]:
        """The subframes, under the name I/NAV's and F/NAV's messages give their pages."""
        return self.subframes

    @property
    def iono(self) -> BdsKlobuchar | None:
        """The last subframe 1's Klobuchar coefficients (None without a subframe 1)."""
        return BdsKlobuchar.from_fields(self.fields[1]) if 1 in self.fields else None

    @property
    def gst(self) -> tuple[int, int | None, float] | None:
        """``bdt`` in GPS time, as the receiver dates rows: ``(bit index, GPS week, GPS s
        of week)`` (BDT + 14 s; BDT week + 1356)."""
        return None if self.bdt is None else gps_time_of(*self.bdt)


def encode_subframe(fraid: int, sow: int, values: dict[str, float]) -> np.ndarray:
    """The 300 bits (0/1) as sent of one subframe: preamble, ``fraid`` (1-5), ``sow``,
    ``values`` quantised with the ICD's scale factors (fields not given, and subframes 4-5's
    contents, are 0), BCH-encoded and interleaved. A value out of its field is refused."""
    if fraid not in (1, 2, 3, 4, 5):
        raise ConfigError("fraid", f"a D1 subframe ID is 1-5, got {fraid}")
    if sow % 6 or not 0 <= sow < _WEEK_S or (sow // 6) % 5 + 1 != fraid:
        raise ConfigError("sow", f"subframe {fraid} starts on SOW = 6 (5 k + {fraid - 1}) s of the week, got {sow}")
    layout = {**_HEADER, **_SOW, **SUBFRAME_LAYOUTS.get(fraid, {})}
    values = {**values, "preamble": int("11100010010", 2), "rev": 0, "fraid": fraid, "sow": sow}
    info = encode_fields(INFO_BITS, layout, values, f"d1.subframe{fraid}", "BDS-SIS-ICD-B1I 3.0 5.2")
    return sent_bits(info)


def decode_subframe_bits(sent: np.ndarray) -> tuple[int, int, dict[str, float], int]:
    """FraID, SOW, scaled fields (physical units; none for subframes 4-5) and the codewords
    corrected, of 300 bits as sent."""
    b = np.asarray(sent, dtype=np.uint8)
    if b.shape != (SUBFRAME_BITS,):
        raise ConfigError("bits", f"a D1 subframe is {SUBFRAME_BITS} bits, got shape {b.shape}")
    info, corrected = info_bits(b)
    fraid = field_integer(info, 16, 3)
    sow = field_integer(info, 19, 20)
    return fraid, sow, decode_fields(info, SUBFRAME_LAYOUTS.get(fraid, {})), int(corrected)


def _consistent(fraid: int, sow: int) -> bool:
    return 1 <= fraid <= 5 and sow % 6 == 0 and sow < _WEEK_S and (sow // 6) % 5 + 1 == fraid


def _d1_at(sent: np.ndarray) -> tuple[tuple[int, int, dict, int], bool]:
    fraid, sow, fields, corrected = decode_subframe_bits(sent)
    return (fraid, sow, fields, corrected), _consistent(fraid, sow)


def subframe_grid(
    bits: np.ndarray, decode: Callable[[np.ndarray], tuple[Any, bool]], what: str, sync_errors: int = 0
) -> list[tuple[int, bool, Any, bool]]:
    """``(start, inverted, decoded, consistent)`` of every whole subframe on the grid of a
    stream of soft D1 or D2 bits (bit 0 as +1): the candidates where 11 bits match the
    preamble (either polarity, at most ``sync_errors`` wrong) and whose header ``decode``
    (of 300 bits as sent) finds consistent give the grid, the most common start modulo 300;
    [] without one. ``what`` names the stream in a refusal."""
    s = fec.real_symbols(bits, what)
    if not 0 <= sync_errors < 3:
        raise ConfigError("sync_errors", f"must be 0-2, got {sync_errors}")
    n = s.size
    if n < SUBFRAME_BITS:
        return []
    match = np.lib.stride_tricks.sliding_window_view(np.sign(s), D1_PREAMBLE.size) @ _PREAMBLE_PM
    starts = np.arange(n - SUBFRAME_BITS + 1)
    need = D1_PREAMBLE.size - 2 * sync_errors
    up, down = match[starts] >= need, match[starts] <= -need

    def at(first: np.ndarray, polarity: np.ndarray) -> list[tuple[Any, bool]]:
        blocks = (s[first[:, None] + np.arange(SUBFRAME_BITS)] * polarity[:, None] < 0).astype(np.uint8)
        return [decode(b) for b in blocks]

    cand = np.flatnonzero(up | down)
    good = np.array([ok for _, ok in at(cand, np.where(up[cand], 1.0, -1.0))], bool)
    if not good.any():
        return []
    offsets, counts = np.unique(cand[good] % SUBFRAME_BITS, return_counts=True)
    grid = np.arange(int(offsets[np.argmax(counts)]), n - SUBFRAME_BITS + 1, SUBFRAME_BITS)
    pol = np.where(match[grid] >= 0, 1.0, -1.0)
    return [(int(g), bool(p < 0), d, ok) for g, p, (d, ok) in zip(grid, pol, at(grid, pol))]


def find_d1_subframes(bits: np.ndarray, sync_errors: int = 0) -> tuple[list[D1Subframe], list[str]]:
    """Every subframe of a stream of soft D1 bits (one per 20 ms, NH20 wiped, bit 0 as +1)
    whose header is consistent, and one line per subframe of the stream's grid that is not
    (`subframe_grid`)."""
    found, failures = [], []
    for start, inverted, (fraid, sow, fields, corrected), ok in subframe_grid(
        bits, _d1_at, "one satellite's D1 bits", sync_errors
    ):
        if ok:
            found.append(D1Subframe(start, inverted, fraid, sow, fields, corrected))
        else:
            failures.append(
                f"D1 subframe at bit {start}: FraID {fraid} and SOW {sow} disagree (or no preamble); not used"
            )
    return found, failures


def beidou_record(merged: dict[str, float], prn: int) -> Ephemerides:
    """One `Ephemerides` record of BeiDou ``prn`` from the decoded fields of one D1 or D2
    ephemeris (`KEPLER_TO_RINEX`'s names, semicircles taken to radians with BeiDou's pi;
    ``tgd1_s`` as ``TGD``, ``tgd2_s``, ``sath1``, ``aode``, ``urai``)."""
    elements = {
        rinex: np.array([merged[name] * (PI_BDS if name in SEMICIRCLE_FIELDS else 1.0)])
        for name, rinex in _TO_RINEX.items()
    }
    elements["TGD2"] = np.array([merged["tgd2_s"]])
    return Ephemerides(
        np.array([f"C{prn:02d}"]),
        np.array([float(merged["toc_s"])]),
        elements,
        np.array([float(merged["sath1"])]),
        np.array([float(merged["aode"])]),
        np.array([float(URA_M[int(merged["urai"])])]),
    )


def subframes_to_ephemeris(fields: dict[int, dict[str, float]], prn: int) -> Ephemerides:
    """One `Ephemerides` record of BeiDou ``prn`` (georinex names, radians, BDT) from the
    decoded subframes 1-3 of one frame: its B3I clock with ``TGD`` = T_GD1 (the B1I user's),
    ``TGD2``, SatH1 as health, AODE as issue of data, the URA of URAI (GPS's table, sec.
    5.2.4.5).

    Raises
    ------
    ConfigError
        Naming the subframe missing, or toc and toe when they differ.
    """
    for t in (1, 2, 3):
        if t not in fields:
            raise ConfigError(f"d1.subframe{t}", "missing: a D1 ephemeris needs subframes 1-3")
    toe = (int(fields[2]["toe_msb"]) << 15 | int(fields[3]["toe_lsb"])) * 8.0
    if toe != fields[1]["toc_s"]:
        raise ConfigError("d1.toe", f"toe {toe:.0f} s differs from subframe 1's toc {fields[1]['toc_s']:.0f} s")
    merged = {k: v for t in (3, 2, 1) for k, v in fields[t].items()} | {"toe_s": toe}
    return beidou_record(merged, prn)


def decode_d1(bits: np.ndarray, prn: int) -> D1Message:
    """Decode one satellite's D1 bit stream (one soft bit per 20 ms, NH20 wiped, in order, no
    gaps; ``prn`` names the record, D1 does not carry it): subframes (`find_d1_subframes`),
    the last fields of each ID, the record of the last subframes 1-3 of one frame whose toc
    is their toe, and the BDT of the last subframe."""
    subframes, failures = find_d1_subframes(bits)
    fields: dict[int, dict[str, float]] = {}
    ephemeris, bdt, week = None, None, None
    frame: dict[int, D1Subframe] = {}
    for sf in subframes:
        fields[sf.fraid] = sf.fields
        if sf.fraid == 1:
            week = int(sf.fields["wn"])
        bdt = (sf.start, week, sf.sow)
        frame = {k: v for k, v in frame.items() if v.sow // 30 == sf.sow // 30} | {sf.fraid: sf}
        if sf.fraid == 3 and all(t in frame for t in (1, 2, 3)):
            try:
                ephemeris = subframes_to_ephemeris({t: frame[t].fields for t in (1, 2, 3)}, prn)
            except ConfigError as exc:
                failures.append(f"D1 frame at SOW {frame[1].sow}: {exc}; no ephemeris from it")
    return D1Message(subframes, ephemeris, bdt, fields, failures)


def record_values(record: Ephemerides) -> dict[str, float]:
    """The D1 and D2 field values of one BeiDou record (`KEPLER_TO_RINEX`'s names in
    semicircles, toc = toe, ``tgd1_s`` from ``TGD``, ``tgd2_s`` from ``TGD2`` where the
    record has it, SatH1, AODE modulo 32, URAI from the accuracy, AODC 0): the inverse of
    `beidou_record`."""
    values: dict[str, float] = {}
    for name, rinex in _TO_RINEX.items():
        v = float(record.elements[rinex][0])
        values[name] = v / PI_BDS if name in SEMICIRCLE_FIELDS else v
    acc = float(record.accuracy_m[0]) if record.accuracy_m is not None else np.nan
    tgd2 = record.elements.get("TGD2")
    values.update(
        toc_s=float(values["toe_s"]),
        tgd2_s=0.0 if tgd2 is None or not np.isfinite(tgd2[0]) else float(tgd2[0]),
        sath1=int(record.health[0]),
        aode=int(record.iode[0]) % 32,
        aodc=0,
        urai=int(np.searchsorted(URA_M[:15], acc)) if np.isfinite(acc) and acc >= 0 else 15,
    )
    return values


def ephemeris_to_subframes(record: Ephemerides) -> dict[int, dict[str, float]]:
    """Field values of subframes 1-3 of one BeiDou record (`record_values`, toe split between
    subframes 2 and 3); the BDT week and SOW are set when sent (`encode_d1`). The Klobuchar
    coefficients are sent as zero."""
    values = record_values(record)
    toe = int(round(values["toe_s"] / 8))
    values.update(toc_s=8.0 * toe, toe_msb=toe >> 15, toe_lsb=toe & 0x7FFF)
    return {t: {k: values[k] for k in SUBFRAME_LAYOUTS[t] if k in values} for t in (1, 2, 3)}


def encode_d1(
    record: Ephemerides, wn: int, first_sow: int, n_subframes: int, iono: BdsKlobuchar | None = None
) -> np.ndarray:
    """±1 bits (int8, bit 0 as +1) of ``n_subframes`` consecutive subframes of one satellite
    from BDT ``first_sow`` (a multiple of 6 s) of BDT week ``wn`` on: subframes 1-3 carry
    ``record`` (subframe 1 the Klobuchar coefficients ``iono``, zero without), 4 and 5
    their header alone."""
    if first_sow % 6 or not 0 <= first_sow < _WEEK_S:
        raise ConfigError("first_sow", f"a D1 subframe starts on a multiple of 6 s of BDT, got {first_sow}")
    base = ephemeris_to_subframes(record)
    if iono is not None:
        base[1] = base[1] | iono.fields()
    out = []
    for k in range(n_subframes):
        t = first_sow + 6 * k
        sow, wn_k = t % _WEEK_S, wn + t // _WEEK_S
        fraid = (sow // 6) % 5 + 1
        values = base.get(fraid, {}) | ({"wn": wn_k % 8192} if fraid == 1 else {})
        out.append(encode_subframe(fraid, sow, values))
    return (1 - 2 * np.concatenate(out).astype(np.int8)).astype(np.int8)


def d1_symbols(
    record: Ephemerides, wn: int, sow_s: float, n_bits: int, iono: BdsKlobuchar | None = None
) -> tuple[np.ndarray, float]:
    """±1 D1 bits (int8) from the one in force at BDT ``sow_s`` of week ``wn`` on, for the IF
    generator's data (`beidou-b1i`: one bit every 20 code periods), and the time (s) from
    the first bit's start to ``sow_s``. Subframes as `encode_d1` (``iono`` in subframe 1)."""
    first = int(np.floor(sow_s / SUBFRAME_S)) * 6
    into = sow_s - first
    skip = int(np.floor(into * SYMBOL_RATE_HZ))
    n_sub = int(np.ceil((skip + n_bits) / SUBFRAME_BITS))
    bits = encode_d1(record, wn, first % _WEEK_S, n_sub, iono)[skip : skip + n_bits]
    return bits, float(into - skip / SYMBOL_RATE_HZ)
