"""GPS L1 C/A navigation message (LNAV, IS-GPS-200 20.3): encoder and decoder.

The message is 50 bit/s, in 300-bit subframes of ten 30-bit words; words carry 24 data
bits and 6 parity bits (20.3.5). Subframes 1-3 carry the clock and ephemeris of the
transmitting satellite (20.3.3.3, 20.3.3.4), subframe 4 page 18 the Klobuchar
ionospheric coefficients and the UTC parameters (20.3.3.5.1.6-7). Every subframe starts
with the telemetry word (preamble ``10001011``) and the hand-over word (HOW), whose
17-bit TOW count is the GPS time of the *next* subframe's start in units of 6 s
(20.3.3.2).

The encoder turns a broadcast record (:class:`~gnssframework.navigation.ephemeris.Ephemerides`,
angles in radians as RINEX writes them) into bits; the decoder finds subframes in a
stream of symbols of either polarity (a Costas loop leaves the carrier, hence every
bit, inverted or not: the preamble's polarity says which), checks every word's parity
and returns the decoded record in the same :class:`Ephemerides` form, so the same
:func:`~gnssframework.navigation.ephemeris.satellite_state` serves both. Bits are 0/1
arrays; symbols on the signal are ±1 with bit 0 sent as +1.

Quantities are broadcast as integers of the scale factors of IS-GPS-200 Tables 20-I,
20-III and 20-IX; angles in semicircles, converted with the ICD's value of pi
(`PI_IS_GPS`, 20.3.3.4.3).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import ConfigError
from .ephemeris import KEPLER_TO_RINEX, ORBIT_FIELDS, SEMICIRCLE_FIELDS, Ephemerides
from .fec import real_symbols
from .ura import URA_M

__all__ = [
    "PI_IS_GPS",
    "PREAMBLE",
    "BITS_PER_SUBFRAME",
    "IonoUtc",
    "Subframe",
    "LnavMessage",
    "parity_bits",
    "encode_words",
    "words_parity_ok",
    "encode_subframe",
    "ephemeris_to_fields",
    "encode_lnav",
    "lnav_symbols",
    "find_subframes",
    "decode_lnav",
    "fields_to_ephemeris",
    "URA_M",
]

#: The value of pi that converts semicircles to radians (IS-GPS-200 20.3.3.4.3).
PI_IS_GPS = 3.1415926535898
#: TLM preamble, bits 1-8 of every subframe (IS-GPS-200 20.3.3.1).
PREAMBLE = np.array([1, 0, 0, 0, 1, 0, 1, 1], dtype=np.uint8)
BITS_PER_WORD = 30
WORDS_PER_SUBFRAME = 10
BITS_PER_SUBFRAME = 300
SUBFRAME_S = 6.0
#: Seconds in a GPS week.
WEEK_S = 604_800.0

# Parity equations of IS-GPS-200 Table 20-XIV: for D25..D30, the source data bits d1..d24
# and which of the previous word's D29*, D30* enters.
_PARITY_TAPS = (
    ((1, 2, 3, 5, 6, 10, 11, 12, 13, 14, 17, 18, 20, 23), 29),
    ((2, 3, 4, 6, 7, 11, 12, 13, 14, 15, 18, 19, 21, 24), 30),
    ((1, 3, 4, 5, 7, 8, 12, 13, 14, 15, 16, 19, 20, 22), 29),
    ((2, 4, 5, 6, 8, 9, 13, 14, 15, 16, 17, 20, 21, 23), 30),
    ((1, 3, 5, 6, 7, 9, 10, 14, 15, 16, 17, 18, 21, 22, 24), 30),
    ((3, 5, 6, 8, 9, 10, 11, 13, 15, 19, 22, 23, 24), 29),
)
_H = np.zeros((6, 24), dtype=np.int64)
for _row, (_taps, _) in enumerate(_PARITY_TAPS):
    _H[_row, np.array(_taps) - 1] = 1
_USES_D30 = np.array([prev == 30 for _, prev in _PARITY_TAPS])

# Field layouts: name -> (parts as (first subframe bit, length), MSB part first; scale; signed).
# Bit numbers are those of the ICD's subframe figures (20-1): word w holds bits 30(w-1)+1..30w.
_Layout = dict[str, tuple[tuple[tuple[int, int], ...], float, bool]]
_HOW: _Layout = {
    "tow_count": (((31, 17),), 1, False),
    "alert": (((48, 1),), 1, False),
    "anti_spoof": (((49, 1),), 1, False),
    "subframe_id": (((50, 3),), 1, False),
}
_TLM: _Layout = {"tlm_message": (((9, 14),), 1, False), "integrity": (((23, 1),), 1, False)}
#: Subframe 1 (IS-GPS-200 20.3.3.3, Table 20-I).
SUBFRAME1: _Layout = {
    "week": (((61, 10),), 1, False),
    "l2_code": (((71, 2),), 1, False),
    "ura_index": (((73, 4),), 1, False),
    "health": (((77, 6),), 1, False),
    "iodc": (((83, 2), (211, 8)), 1, False),
    "l2p_flag": (((91, 1),), 1, False),
    "tgd_s": (((197, 8),), 2.0**-31, True),
    "toc_s": (((219, 16),), 2.0**4, False),
    "af2_s_s2": (((241, 8),), 2.0**-55, True),
    "af1_s_s": (((249, 16),), 2.0**-43, True),
    "af0_s": (((271, 22),), 2.0**-31, True),
}
#: Subframe 2 (20.3.3.4, Table 20-III); angles in semicircles.
SUBFRAME2: _Layout = {
    "iode": (((61, 8),), 1, False),
    "crs_m": (((69, 16),), 2.0**-5, True),
    "delta_n_sc_s": (((91, 16),), 2.0**-43, True),
    "m0_sc": (((107, 8), (121, 24)), 2.0**-31, True),
    "cuc_rad": (((151, 16),), 2.0**-29, True),
    "e": (((167, 8), (181, 24)), 2.0**-33, False),
    "cus_rad": (((211, 16),), 2.0**-29, True),
    "sqrt_a_sqrtm": (((227, 8), (241, 24)), 2.0**-19, False),
    "toe_s": (((271, 16),), 2.0**4, False),
    "fit_interval": (((287, 1),), 1, False),
    "aodo": (((288, 5),), 1, False),
}
#: Subframe 3 (20.3.3.4, Table 20-III); angles in semicircles.
SUBFRAME3: _Layout = {
    "cic_rad": (((61, 16),), 2.0**-29, True),
    "omega0_sc": (((77, 8), (91, 24)), 2.0**-31, True),
    "cis_rad": (((121, 16),), 2.0**-29, True),
    "i0_sc": (((137, 8), (151, 24)), 2.0**-31, True),
    "crc_m": (((181, 16),), 2.0**-5, True),
    "omega_sc": (((197, 8), (211, 24)), 2.0**-31, True),
    "omega_dot_sc_s": (((241, 24),), 2.0**-43, True),
    "iode": (((271, 8),), 1, False),
    "idot_sc_s": (((279, 14),), 2.0**-43, True),
}
#: Subframe 4 page 18 (20.3.3.5.1.6-7, Tables 20-X and 20-IX): data ID 01, SV ID 56.
PAGE18: _Layout = {
    "data_id": (((61, 2),), 1, False),
    "sv_id": (((63, 6),), 1, False),
    "alpha0_s": (((69, 8),), 2.0**-30, True),
    "alpha1_s_sc": (((77, 8),), 2.0**-27, True),
    "alpha2_s_sc2": (((91, 8),), 2.0**-24, True),
    "alpha3_s_sc3": (((99, 8),), 2.0**-24, True),
    "beta0_s": (((107, 8),), 2.0**11, True),
    "beta1_s_sc": (((121, 8),), 2.0**14, True),
    "beta2_s_sc2": (((129, 8),), 2.0**16, True),
    "beta3_s_sc3": (((137, 8),), 2.0**16, True),
    "a1_s_s": (((151, 24),), 2.0**-50, True),
    "a0_s": (((181, 24), (211, 8)), 2.0**-30, True),
    "tot_s": (((219, 8),), 2.0**12, False),
    "wnt": (((227, 8),), 1, False),
    "dt_ls_s": (((241, 8),), 1, True),
    "wn_lsf": (((249, 8),), 1, False),
    "dn": (((257, 8),), 1, False),
    "dt_lsf_s": (((271, 8),), 1, True),
}
#: Data ID and SV (page) ID of subframe 4 page 18 and of the pages 25 of subframes 4 and 5 (20.3.3.5.1).
PAGE18_SV_ID = 56
_DUMMY_PAGE: _Layout = {"data_id": (((61, 2),), 1, False), "sv_id": (((63, 6),), 1, False)}
_DUMMY_SV_ID = {4: 63, 5: 51}
_LAYOUTS = {1: SUBFRAME1, 2: SUBFRAME2, 3: SUBFRAME3}
_SEMICIRCLE_FIELDS = SEMICIRCLE_FIELDS
_TO_RINEX = {**KEPLER_TO_RINEX, "tgd_s": "TGD"}


@dataclass(frozen=True)
class IonoUtc:
    """Subframe 4 page 18: Klobuchar coefficients and UTC parameters (IS-GPS-200 20.3.3.5.1.6-7).

    ``alpha`` in s, s/semicircle, s/semicircle^2, s/semicircle^3; ``beta`` in s and the same per
    semicircle powers; ``a0_s``, ``a1_s_s`` the UTC polynomial, ``tot_s`` and ``wnt`` its reference
    time and (8-bit) week, ``dt_ls_s`` the current leap seconds, ``wn_lsf`` and ``dn`` the
    (8-bit) week and day of the next leap second, ``dt_lsf_s`` the leap seconds after it.
    """

    alpha: tuple[float, float, float, float]
    beta: tuple[float, float, float, float]
    a0_s: float = 0.0
    a1_s_s: float = 0.0
    tot_s: float = 0.0
    wnt: int = 0
    dt_ls_s: int = 0
    wn_lsf: int = 0
    dn: int = 0
    dt_lsf_s: int = 0

    def fields(self) -> dict[str, float]:
        out = {f"alpha{k}" + s: v for k, (v, s) in enumerate(zip(self.alpha, ("_s", "_s_sc", "_s_sc2", "_s_sc3")))}
        out.update({f"beta{k}" + s: v for k, (v, s) in enumerate(zip(self.beta, ("_s", "_s_sc", "_s_sc2", "_s_sc3")))})
        out.update(
            a0_s=self.a0_s,
            a1_s_s=self.a1_s_s,
            tot_s=self.tot_s,
            wnt=self.wnt % 256,
            dt_ls_s=self.dt_ls_s,
            wn_lsf=self.wn_lsf % 256,
            dn=self.dn,
            dt_lsf_s=self.dt_lsf_s,
            data_id=1,
            sv_id=PAGE18_SV_ID,
        )
        return out

    @classmethod
    def from_fields(cls, f: dict[str, float]) -> IonoUtc:
        keys = sorted(k for k in f if k.startswith("alpha")), sorted(k for k in f if k.startswith("beta"))
        return cls(
            tuple(f[k] for k in keys[0]),
            tuple(f[k] for k in keys[1]),
            f["a0_s"],
            f["a1_s_s"],
            f["tot_s"],
            int(f["wnt"]),
            int(f["dt_ls_s"]),
            int(f["wn_lsf"]),
            int(f["dn"]),
            int(f["dt_lsf_s"]),
        )


# ---------------------------------------------------------------------------------------------- parity
def parity_bits(data: np.ndarray, d29_prev: np.ndarray | int, d30_prev: np.ndarray | int) -> np.ndarray:
    """D25..D30 of words with source data bits ``data`` (``(..., 24)``, 0/1) after a word
    ending in ``d29_prev``, ``d30_prev`` (IS-GPS-200 Table 20-XIV)."""
    d = np.asarray(data, dtype=np.int64)
    prev = np.where(_USES_D30, np.asarray(d30_prev)[..., None], np.asarray(d29_prev)[..., None])
    return ((d @ _H.T + prev) % 2).astype(np.uint8)


def encode_words(data: np.ndarray, d29_prev: int = 0, d30_prev: int = 0, solve: tuple[int, ...] = ()) -> np.ndarray:
    """Transmitted bits of consecutive words (IS-GPS-200 20.3.5.2).

    Parameters
    ----------
    data
        ``(W, 24)`` source data bits d1..d24 (0/1).
    d29_prev, d30_prev
        Last two bits of the word sent before the first.
    solve
        Indices of words whose bits 23 and 24 carry no information and are chosen so that
        their D29 and D30 are zero (words 2 and 10 of a subframe, 20.3.5.2).

    Returns
    -------
    ``(W, 30)`` transmitted bits: D1..D24 = d XOR D30*, then the parity.
    """
    data = np.array(data, dtype=np.uint8)
    out = np.zeros((data.shape[0], BITS_PER_WORD), dtype=np.uint8)
    for w in range(data.shape[0]):  # chained: each word depends on the previous one's D29, D30
        d = data[w]
        if w in solve:
            for b23, b24 in ((0, 0), (0, 1), (1, 0), (1, 1)):
                d[22], d[23] = b23, b24
                if not parity_bits(d, d29_prev, d30_prev)[4:].any():
                    break
        out[w, :24] = d ^ d30_prev
        out[w, 24:] = parity_bits(d, d29_prev, d30_prev)
        d29_prev, d30_prev = int(out[w, 28]), int(out[w, 29])
    return out


def words_parity_ok(words: np.ndarray, prev: np.ndarray) -> np.ndarray:
    """Parity check of transmitted words ``(..., 30)`` given the two bits sent before each
    (``(..., 2)``, D29* and D30*): True where all six parity bits agree."""
    words = np.asarray(words, dtype=np.uint8)
    d30 = np.asarray(prev)[..., 1:2]
    data = words[..., :24] ^ d30
    return np.all(parity_bits(data, np.asarray(prev)[..., 0], np.asarray(prev)[..., 1]) == words[..., 24:], axis=-1)


# ---------------------------------------------------------------------------------------------- fields
def _put(bits: np.ndarray, layout: _Layout, values: dict[str, float], subframe: int) -> None:
    """Quantise ``values`` with the layout's scale factors into the 300 source bits."""
    for name, (parts, scale, signed) in layout.items():
        if name not in values:
            continue
        n = sum(length for _, length in parts)
        q = int(np.round(float(values[name]) / scale))
        lo, hi = (-(1 << (n - 1)), (1 << (n - 1)) - 1) if signed else (0, (1 << n) - 1)
        if not lo <= q <= hi:
            raise ConfigError(
                f"lnav.subframe{subframe}.{name}",
                f"{values[name]!r} does not fit {n} {'signed ' if signed else ''}bits of "
                f"scale {scale:g} (IS-GPS-200 20.3.3)",
            )
        q &= (1 << n) - 1  # two's complement
        shift = n
        for first, length in parts:
            shift -= length
            chunk = (q >> shift) & ((1 << length) - 1)
            bits[first - 1 : first - 1 + length] = (chunk >> np.arange(length - 1, -1, -1)) & 1


def _get(bits: np.ndarray, layout: _Layout) -> dict[str, float]:
    """Field values (scaled, physical units) from 300 source bits."""
    out = {}
    for name, (parts, scale, signed) in layout.items():
        q = 0
        n = 0
        for first, length in parts:
            for b in bits[first - 1 : first - 1 + length]:
                q = (q << 1) | int(b)
            n += length
        if signed and q >> (n - 1):
            q -= 1 << n
        out[name] = q * scale if scale != 1 else q
    return out


def ephemeris_to_fields(record: Ephemerides, week: int) -> tuple[dict, dict, dict]:
    """Subframe 1, 2, 3 field values of one GPS record (angles in semicircles), with the
    transmission ``week`` (its 10 LSBs are sent). IODC is sent equal to IODE (its upper
    two bits zero) and the URA index is the smallest whose bound holds the record's accuracy."""
    if record.sv.size != 1 or not str(record.sv[0]).startswith("G"):
        raise ConfigError("record", f"one GPS record is encoded at a time, got {list(record.sv)}")
    e = {k: float(v[0]) for k, v in record.elements.items()}
    acc = float(record.accuracy_m[0]) if record.accuracy_m is not None else np.nan
    ura = int(np.searchsorted(URA_M[:15], acc)) if np.isfinite(acc) and acc >= 0 else 15
    iode = int(record.iode[0])
    sf1 = {
        "week": week % 1024,
        "ura_index": min(ura, 15),
        "health": int(record.health[0]),
        "iodc": iode,
        "tgd_s": e["TGD"],
        "toc_s": float(record.toc_s[0]),
        "af2_s_s2": e["SVclockDriftRate"],
        "af1_s_s": e["SVclockDrift"],
        "af0_s": e["SVclockBias"],
    }
    rad = {rinex: name for name, rinex in _TO_RINEX.items()}
    orbit = {rad[k]: (e[k] / PI_IS_GPS if rad[k] in _SEMICIRCLE_FIELDS else e[k]) for k in ORBIT_FIELDS}
    sf2 = {k: orbit[k] for k in SUBFRAME2 if k in orbit} | {"iode": iode}
    sf3 = {k: orbit[k] for k in SUBFRAME3 if k in orbit} | {"iode": iode}
    return sf1, sf2, sf3


def encode_subframe(
    subframe_id: int, tow_count: int, values: dict[str, float], d29_prev: int = 0, d30_prev: int = 0
) -> np.ndarray:
    """The 300 transmitted bits of one subframe (TLM, HOW with ``tow_count``, words 3-10).

    ``values`` are the fields of that subframe's layout (`SUBFRAME1`, `SUBFRAME2`,
    `SUBFRAME3`; `PAGE18` for subframe 4 with ``sv_id`` 56); a subframe 4 or 5 without
    values carries a page 25 of no content (SV ID 63 and 51, IS-GPS-200 20.3.3.5.1).
    """
    if subframe_id not in (1, 2, 3, 4, 5):
        raise ConfigError("subframe_id", f"must be 1-5, got {subframe_id}")
    bits = np.zeros(BITS_PER_SUBFRAME, dtype=np.uint8)
    bits[:8] = PREAMBLE
    _put(bits, _HOW, {"tow_count": tow_count, "subframe_id": subframe_id}, subframe_id)
    if subframe_id in _LAYOUTS:
        layout = _LAYOUTS[subframe_id]
    elif values:
        layout = PAGE18
    else:
        layout, values = _DUMMY_PAGE, {"data_id": 1, "sv_id": _DUMMY_SV_ID[subframe_id]}
    _put(bits, layout, values, subframe_id)
    data = bits.reshape(WORDS_PER_SUBFRAME, BITS_PER_WORD)[:, :24]
    return encode_words(data, d29_prev, d30_prev, solve=(1, 9)).reshape(-1)


def encode_lnav(
    record: Ephemerides, week: int, first_tow_s: float, n_subframes: int, iono_utc: IonoUtc | None = None
) -> np.ndarray:
    """Bits (0/1) of ``n_subframes`` consecutive subframes of one satellite, the first one
    starting at GPS time of week ``first_tow_s`` (a multiple of 6 s; its subframe ID is
    ``(first_tow_s / 6) mod 5 + 1``, as the frame of 30 s starts on the 30 s of the week).

    Subframes 1-3 carry ``record``, subframe 4 page 18 ``iono_utc`` in every frame (a page
    25 of no content without it), subframe 5 a page 25 of no content.
    """
    if first_tow_s % SUBFRAME_S != 0 or not 0 <= first_tow_s < WEEK_S:
        raise ConfigError("first_tow_s", f"a subframe starts on a multiple of 6 s of the week, got {first_tow_s}")
    sf = dict(zip((1, 2, 3), ephemeris_to_fields(record, week)))
    sf[4] = iono_utc.fields() if iono_utc is not None else {}
    sf[5] = {}
    out = np.zeros((n_subframes, BITS_PER_SUBFRAME), dtype=np.uint8)
    prev = (0, 0)
    for k in range(n_subframes):
        start_count = int(first_tow_s // SUBFRAME_S) + k
        sid = start_count % 5 + 1
        out[k] = encode_subframe(sid, (start_count + 1) % int(WEEK_S / SUBFRAME_S), sf[sid], *prev)
        prev = (int(out[k, -2]), int(out[k, -1]))
    return out.reshape(-1)


def lnav_symbols(
    record: Ephemerides, week: int, tow_s: float, n_bits: int, iono_utc: IonoUtc | None = None
) -> tuple[np.ndarray, float]:
    """±1 symbols (bit 0 sent as +1) of the LNAV bits from the one in force at GPS time
    ``tow_s`` on, for the IF generator's ``data_bits``; and the time (s) from the first
    symbol's start to ``tow_s`` (``first_bit_edge_s = -that``)."""
    first = np.floor(tow_s / SUBFRAME_S) * SUBFRAME_S
    skip = int(np.floor((tow_s - first) * 50))
    n_sf = int(np.ceil((skip + n_bits) / BITS_PER_SUBFRAME))
    bits = encode_lnav(record, week, first, n_sf, iono_utc)[skip : skip + n_bits]
    return (1 - 2 * bits.astype(np.int8)).astype(np.int8), float(tow_s - first - skip / 50)


# ---------------------------------------------------------------------------------------------- decoding
@dataclass(frozen=True)
class Subframe:
    """One parity-checked subframe found in a symbol stream.

    ``start`` is the index of its first bit in the stream, ``tow_s`` the GPS time of week at
    its start (HOW TOW count x 6 s - 6 s), ``inverted`` whether the stream's polarity was
    inverted (preamble received as ``01110100``), ``fields`` the decoded values of its layout.
    """

    start: int
    subframe_id: int
    tow_s: float
    inverted: bool
    fields: dict[str, float] = field(repr=False)


@dataclass(frozen=True)
class LnavMessage:
    """What a symbol stream of one satellite decoded to.

    ``ephemeris`` is the last complete set of subframes 1-3 whose IODC and IODEs agree on
    their low 8 bits (IS-GPS-200 20.3.3.4.1), as one record; ``ephemerides`` every such set
    as ``(bit, record)``, ``bit`` the index in the stream just after the subframe that
    completed it (when a receiver has it); ``iono_utc`` the last subframe 4 page 18;
    ``week`` the 10-bit transmission week of the last subframe 1; ``week_bits`` how many
    low bits of the week ``week`` holds (10 for LNAV; a CNAV stream gives type 10's 13).
    """

    prn: int
    subframes: list[Subframe]
    ephemeris: Ephemerides | None
    iono_utc: IonoUtc | None
    week: int | None
    ephemerides: list[tuple[int, Ephemerides]] = field(default_factory=list)
    week_bits: int = 10


def _hard_bits(symbols: np.ndarray) -> np.ndarray:
    return (real_symbols(symbols) < 0).astype(np.uint8)


def find_subframes(symbols: np.ndarray) -> list[Subframe]:
    """Every complete subframe in a ±1 (or soft, sign-decided) symbol stream: preamble
    search in both polarities, then all ten words' parity (IS-GPS-200 20.3.5.2, with the
    previous word's D29*, D30*, taken as 0 before the stream's first bit as they are after
    word 10), a subframe ID of 1-5 and a TOW count below one week."""
    bits = _hard_bits(symbols)
    n = bits.size
    if n < BITS_PER_SUBFRAME:
        return []
    windows = np.lib.stride_tricks.sliding_window_view(bits, 8)[: n - BITS_PER_SUBFRAME + 1]
    upright = np.all(windows == PREAMBLE, axis=1)
    inverted = np.all(windows == 1 - PREAMBLE, axis=1)
    found = []
    for p in np.flatnonzero(upright | inverted):
        inv = bool(inverted[p])
        sub = bits[p : p + BITS_PER_SUBFRAME] ^ np.uint8(inv)
        before = bits[p - 2 : p] ^ np.uint8(inv) if p >= 2 else np.zeros(2, np.uint8)
        words = sub.reshape(WORDS_PER_SUBFRAME, BITS_PER_WORD)
        prev = np.vstack([before, words[:-1, 28:]])
        if not words_parity_ok(words, prev).all() or words[[1, 9], 28:].any():  # words 2, 10 end in 00
            continue
        data = (words[:, :24] ^ prev[:, 1:2]).reshape(-1)
        source = np.zeros(BITS_PER_SUBFRAME, np.uint8)
        source.reshape(WORDS_PER_SUBFRAME, BITS_PER_WORD)[:, :24] = data.reshape(WORDS_PER_SUBFRAME, 24)
        how = _get(source, _HOW)
        if not 1 <= how["subframe_id"] <= 5 or how["tow_count"] >= WEEK_S / SUBFRAME_S:
            continue
        sid = int(how["subframe_id"])
        layout = _LAYOUTS.get(sid, _DUMMY_PAGE)
        values = _get(source, layout)
        if sid == 4 and values["sv_id"] == PAGE18_SV_ID:
            values = _get(source, PAGE18)
        tow = (how["tow_count"] * SUBFRAME_S - SUBFRAME_S) % WEEK_S
        found.append(Subframe(int(p), sid, float(tow), inv, values))
    return _confirmed(found)


def _confirmed(candidates: list[Subframe]) -> list[Subframe]:
    """Frame synchronisation: parity alone passes a data word that happens to read as a
    preamble (the words after it are valid words too), so a candidate is kept when the
    subframe 300 bits before or after it has the TOW 6 s before or after; a lone candidate
    (no other overlaps it) is kept as it is, for streams of one subframe."""
    starts = {s.start: s for s in candidates}

    def neighbour(s: Subframe) -> bool:
        return any(
            (o := starts.get(s.start + sign * BITS_PER_SUBFRAME)) is not None
            and (o.tow_s - s.tow_s - sign * SUBFRAME_S) % WEEK_S == 0
            for sign in (-1, 1)
        )

    confirmed = [s for s in candidates if neighbour(s)]
    lone = [
        s
        for s in candidates
        if not neighbour(s) and all(abs(o.start - s.start) >= BITS_PER_SUBFRAME for o in candidates if o is not s)
    ]
    return sorted(confirmed + lone, key=lambda s: s.start)


def fields_to_ephemeris(prn: int, sf1: dict, sf2: dict, sf3: dict) -> Ephemerides:
    """One :class:`Ephemerides` record (georinex names, radians) from decoded subframes 1-3."""
    merged = {**sf1, **sf2, **sf3}
    elements = {
        rinex: np.array([merged[name] * (PI_IS_GPS if name in _SEMICIRCLE_FIELDS else 1.0)])
        for name, rinex in _TO_RINEX.items()
    }
    return Ephemerides(
        np.array([f"G{prn:02d}"]),
        np.array([float(sf1["toc_s"])]),
        elements,
        np.array([float(sf1["health"])]),
        np.array([float(sf2["iode"])]),
        np.array([URA_M[int(sf1["ura_index"])]]),
    )


def decode_lnav(symbols: np.ndarray, prn: int) -> LnavMessage:
    """Decode one satellite's symbol stream (one symbol per 20 ms bit, in order, no gaps).

    The ephemeris is the last set of subframes 1, 2 and 3 with IODE(2) = IODE(3) = the low
    8 bits of IODC (IS-GPS-200 20.3.3.4.1: upper IODC bits may legally differ from IODE's,
    so only the low 8 bits are compared).
    """
    subframes = find_subframes(symbols)
    last: dict[int, Subframe] = {}
    ephemerides: list[tuple[int, Ephemerides]] = []
    iono_utc = None
    week = None
    for s in subframes:
        last[s.subframe_id] = s
        if s.subframe_id == 1:
            week = int(s.fields["week"])
        if s.subframe_id == 4 and s.fields.get("sv_id") == PAGE18_SV_ID:
            iono_utc = IonoUtc.from_fields(s.fields)
        if s.subframe_id in (1, 2, 3) and all(k in last for k in (1, 2, 3)):
            iodc = int(last[1].fields["iodc"]) & 0xFF
            if last[2].fields["iode"] == iodc and last[3].fields["iode"] == iodc:
                record = fields_to_ephemeris(prn, last[1].fields, last[2].fields, last[3].fields)
                ephemerides.append((s.start + BITS_PER_SUBFRAME, record))
    ephemeris = ephemerides[-1][1] if ephemerides else None
    return LnavMessage(prn, subframes, ephemeris, iono_utc, week, ephemerides)
