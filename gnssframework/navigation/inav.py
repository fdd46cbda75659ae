"""Galileo I/NAV on E1-B (Galileo OS SIS ICD Issue 2.0/2.1): pages from symbols and back.

A nominal page (ICD 4.3.2) is two page parts of 1 s, even then odd, each 250 symbols at
250 symbol/s: the synchronisation pattern ``0101100000`` (10 symbols, 4.3.2.1) and 240
coded symbols, the part's 120 bits through the rate-1/2 K = 7 convolutional code and the
30 x 8 block interleaver (4.1.4; :mod:`~gnssframework.navigation.fec`). Before coding:

====== ================================================================================
part   bits
====== ================================================================================
even   Even/Odd = 0 (1), page type = 0 nominal (1), word bits 1-112 (112), tail (6)
odd    Even/Odd = 1 (1), page type (1), word bits 113-128 (16), OSNMA (40), SAR (22),
       spare (2), CRC (24), SSP (8), tail (6)
====== ================================================================================

The CRC-24Q (5.1.9.4) covers the 196 bits of the Even/Odd, page type and data fields of
both parts with OSNMA, SAR and spare (4.3.2.2, E1-B); not the sync patterns, the tails
nor the SSP. The tails are zero, so each part's code starts and ends in state 0.

Symbols are ±1 with bit 0 sent as +1 (the project's convention, as
:mod:`~gnssframework.navigation.lnav`); a Costas loop may leave every symbol inverted, which
the sync pattern's sign reveals. :func:`find_pages` searches a stream of soft symbols (one
per 4 ms code period) for page pairs, decodes them by Viterbi and keeps those whose CRC
holds; :func:`decode_inav` assembles words 1-5 into an ephemeris, reads the GST and keeps
words 5, 6 and 10's NeQuick, GST-UTC and GGTO (:mod:`~gnssframework.navigation.inav_params`). The
TOW of word types 0 and 5 is the GST at the start of the even part of the page that
carries it (ICD 5.1.2).

:func:`encode_inav` writes the pages of one satellite in the E1-B order of ICD 4.3.3
(indicative: its word types beyond 0-5 are sent here as word type 0 with the GST, but
word types 6 and 10 when GST-UTC and GGTO are given), pages
starting on the odd seconds of GST as the ICD's E1-B column does.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import ConfigError, GnssFrameworkError
from . import fec
from .ephemeris import Ephemerides
from .inav_params import InavIonoTime, iono_time_from_words
from .inav_words import WORD_BITS, decode_word, encode_word, ephemeris_to_words, words_to_ephemeris

__all__ = [
    "SYNC",
    "PART_SYMBOLS",
    "PAGE_SYMBOLS",
    "SYMBOL_RATE_HZ",
    "E1B_SUBFRAME_WORDS",
    "InavCrcError",
    "InavPage",
    "InavMessage",
    "page_part_bits",
    "encode_pages",
    "decode_pages",
    "find_pages",
    "decode_inav",
    "encode_inav",
    "inav_symbols",
    "crc_message",
]

#: Synchronisation pattern of every page part (ICD 4.3.2.1).
SYNC = np.array([0, 1, 0, 1, 1, 0, 0, 0, 0, 0], dtype=np.uint8)
#: Symbols of a page part (sync + 240 coded) and of a nominal page.
PART_SYMBOLS = 250
PAGE_SYMBOLS = 2 * PART_SYMBOLS
#: E1-B symbol rate (one symbol a 4 ms code period).
SYMBOL_RATE_HZ = 250.0
_PART_BITS = 120
_CODED = 240
#: Word types of the E1-B pages of a 30 s sub-frame, the first page's even part at GST
#: (mod 30 s) = 1 s (ICD 4.3.3, indicative; 7/9, 8/10, 17-20 alternate).
E1B_SUBFRAME_WORDS = (2, 4, 6, 7, 8, 17, 19, 16, 0, 22, 1, 3, 5, 0, 16)
_SYNC_PM = 1.0 - 2.0 * SYNC


class InavCrcError(GnssFrameworkError, ValueError):
    """An I/NAV page whose CRC-24Q does not hold (or whose Even/Odd flags are wrong)."""


@dataclass(frozen=True)
class InavPage:
    """One decoded page: ``start`` the index of its even part's first sync symbol in the
    stream, ``inverted`` the stream's polarity there, ``word`` the 128 word bits,
    ``word_type`` and ``fields`` (:func:`~gnssframework.navigation.inav_words.decode_word`)."""

    start: int
    inverted: bool
    word_type: int
    word: np.ndarray = field(repr=False)
    fields: dict[str, float] = field(repr=False)


@dataclass(frozen=True)
class InavMessage:
    """What one satellite's E1-B symbols decoded to.

    ``ephemeris``: the last complete set of words 1-4 of one IODnav with a word 5, as one
    record (None without); ``gst``: ``(symbol index, WN, TOW s)`` of the last word 0 or 5,
    the index that of the even part's start the TOW refers to; ``failures``: one line per
    page of the stream's page grid that did not decode (CRC-24Q or Even/Odd flags), so a
    corrupted page is reported, never used; ``iono_time`` the NeQuick coefficients, GST-UTC
    and GGTO of the last words 5, 6 and 10 (None without any of them).
    """

    pages: list[InavPage]
    ephemeris: Ephemerides | None
    gst: tuple[int, int, float] | None
    words: dict[int, dict[str, float]]
    failures: list[str]
    iono_time: InavIonoTime | None = None


def crc_message(parts: np.ndarray) -> np.ndarray:
    """The 196 bits the CRC covers of page parts ``(..., 2, 120)``: even bits 1-114, odd 1-82."""
    return np.concatenate([parts[..., 0, :114], parts[..., 1, :82]], axis=-1)


def page_part_bits(
    words: np.ndarray, osnma: np.ndarray | None = None, sar: np.ndarray | None = None, ssp: np.ndarray | None = None
) -> np.ndarray:
    """Even and odd parts ``(P, 2, 120)`` (0/1, before coding) of pages carrying ``words``
    ``(P, 128)``; OSNMA (40), SAR (22) and SSP (8) bits per page, zero when not given."""
    w = np.atleast_2d(np.asarray(words, dtype=np.uint8))
    if w.shape[-1] != WORD_BITS:
        raise ConfigError("words", f"an I/NAV word is {WORD_BITS} bits, got shape {w.shape}")
    p = w.shape[0]
    parts = np.zeros((p, 2, _PART_BITS), dtype=np.uint8)
    parts[:, 0, 2:114] = w[:, :112]
    parts[:, 1, 0] = 1
    parts[:, 1, 2:18] = w[:, 112:]
    for bits, first, n in ((osnma, 18, 40), (sar, 58, 22), (ssp, 106, 8)):
        if bits is not None:
            parts[:, 1, first : first + n] = np.broadcast_to(np.asarray(bits, np.uint8), (p, n))
    crc = fec.crc24q_bits(crc_message(parts))
    parts[:, 1, 82:106] = (crc[:, None] >> np.arange(23, -1, -1)) & 1
    return parts


def encode_pages(words: np.ndarray, **extra: np.ndarray) -> np.ndarray:
    """±1 symbols ``(P, 500)`` (int8, bit 0 as +1) of pages carrying ``words`` ``(P, 128)``:
    per part the sync pattern and the interleaved coded bits (``extra``: :func:`page_part_bits`)."""
    parts = page_part_bits(words, **extra)
    coded = fec.interleave(fec.conv_encode(parts))
    bits = np.concatenate([np.broadcast_to(SYNC, parts.shape[:2] + (10,)), coded], axis=-1)
    return (1 - 2 * bits.astype(np.int8)).reshape(parts.shape[0], PAGE_SYMBOLS).astype(np.int8)


def _decode_parts(symbols: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Viterbi-decoded parts ``(P, 2, 120)``, whether each page's CRC holds, and whether its
    Even/Odd flags read 0, 1, from page-aligned soft symbols ``(P, 500)`` of upright polarity."""
    coded = symbols.reshape(-1, 2, PART_SYMBOLS)[..., 10:]
    parts = fec.viterbi_decode(fec.deinterleave(coded))
    received = np.sum(parts[:, 1, 82:106].astype(np.int64) << np.arange(23, -1, -1), axis=-1)
    crc_ok = fec.crc24q_bits(crc_message(parts)) == received
    flags_ok = (parts[:, 0, 0] == 0) & (parts[:, 1, 0] == 1)
    return parts, crc_ok, flags_ok


def _page(parts: np.ndarray, start: int, inverted: bool) -> InavPage:
    word = np.concatenate([parts[0, 2:114], parts[1, 2:18]])
    word_type, fields = decode_word(word)
    return InavPage(start, inverted, word_type, word, fields)


def decode_pages(symbols: np.ndarray) -> list[InavPage]:
    """Decode page-aligned soft symbols ``(P, 500)`` (upright polarity; sync patterns
    included and not checked).

    Raises
    ------
    ConfigError
        For symbols of the wrong shape or not finite.
    InavCrcError
        Naming the first page whose CRC-24Q or Even/Odd flags fail.
    """
    s = np.atleast_2d(np.asarray(symbols, dtype=float))
    if s.ndim != 2 or s.shape[-1] != PAGE_SYMBOLS or not np.all(np.isfinite(s)):
        raise ConfigError(
            "symbols",
            f"I/NAV pages are {PAGE_SYMBOLS} finite symbols each (two parts of "
            f"{PART_SYMBOLS}), got shape {np.shape(symbols)}",
        )
    parts, crc_ok, flags_ok = _decode_parts(s)
    for k in np.flatnonzero(~(crc_ok & flags_ok)):
        what = "CRC-24Q failed" if not crc_ok[k] else "Even/Odd flags are not 0, 1"
        raise InavCrcError(
            f"I/NAV page {k} (symbols {k * PAGE_SYMBOLS}-{(k + 1) * PAGE_SYMBOLS - 1}): {what}; "
            f"its word (type {_page(parts[k], 0, False).word_type} as read) is not used"
        )
    return [_page(parts[k], k * PAGE_SYMBOLS, False) for k in range(s.shape[0])]


def _soft(symbols: np.ndarray) -> np.ndarray:
    return fec.real_symbols(symbols, "one satellite's E1-B stream")


def find_pages(symbols: np.ndarray, sync_errors: int = 1) -> tuple[list[InavPage], list[str]]:
    """Every page of a stream of soft E1-B symbols whose CRC holds, and one line per page
    of the stream's page grid that failed.

    Candidates are the positions where the signs of 10 symbols match the sync pattern
    (either polarity) but for at most ``sync_errors`` and do again 250 symbols later;
    they are decoded together and a page is kept when its Even/Odd flags read 0, 1 and
    its CRC holds. The grid is then the most
    common start modulo 500 of those pages, and every whole page on it is decoded, sync
    pattern matched or not (polarity: the sign of both sync correlations); a grid page whose
    flags or CRC fail is reported, not used. Pages off the grid (a stream with a gap) are
    not searched for.
    """
    s = _soft(symbols)
    if not 0 <= sync_errors < SYNC.size // 2:
        raise ConfigError("sync_errors", f"must be 0-{SYNC.size // 2 - 1}, got {sync_errors}")
    n = s.size
    if n < PAGE_SYMBOLS:
        return [], []
    windows = np.lib.stride_tricks.sliding_window_view(np.sign(s), SYNC.size)
    match = windows @ _SYNC_PM
    last = n - PAGE_SYMBOLS
    starts = np.arange(last + 1)
    need = SYNC.size - 2 * sync_errors  # each sign error lowers the match by 2
    up = (match[starts] >= need) & (match[starts + PART_SYMBOLS] >= need)
    down = (match[starts] <= -need) & (match[starts + PART_SYMBOLS] <= -need)
    cand = np.flatnonzero(up | down)
    if cand.size == 0:
        return [], []
    pol = np.where(up[cand], 1.0, -1.0)
    parts, crc_ok, flags_ok = _decode_blocks(s, cand, pol)
    good = crc_ok & flags_ok
    if not good.any():
        return [], []
    # The page grid of the kept pages: decode every grid position, sync pattern or not
    # (symbol errors in a sync pattern should not lose its page), polarity from both syncs.
    offsets, counts = np.unique(cand[good] % PAGE_SYMBOLS, return_counts=True)
    grid = np.arange(int(offsets[np.argmax(counts)]), last + 1, PAGE_SYMBOLS)
    sync_sum = match[grid] + match[grid + PART_SYMBOLS]
    grid_pol = np.where(sync_sum >= 0, 1.0, -1.0)
    parts, crc_ok, flags_ok = _decode_blocks(s, grid, grid_pol)
    pages = [_page(parts[k], int(grid[k]), bool(grid_pol[k] < 0)) for k in np.flatnonzero(crc_ok & flags_ok)]
    failures = [
        f"I/NAV page at symbol {int(grid[k])}: "
        f"{'CRC-24Q failed' if not crc_ok[k] else 'Even/Odd flags are not 0, 1'}; not used"
        for k in np.flatnonzero(~(crc_ok & flags_ok))
    ]
    return pages, failures


def _decode_blocks(
    s: np.ndarray, starts: np.ndarray, polarity: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    blocks = s[starts[:, None] + np.arange(PAGE_SYMBOLS)] * polarity[:, None]
    return _decode_parts(blocks)


def decode_inav(symbols: np.ndarray) -> InavMessage:
    """Decode one satellite's E1-B symbol stream (one soft symbol per 4 ms, in order, no
    gaps): pages (:func:`find_pages`), the last words of each type, the ephemeris from the
    last words 1-4 that share an IODnav (ICD 5.1.9.2) with the last word 5, the GST, and
    the NeQuick, GST-UTC and GGTO parameters of the last words 5, 6 and 10."""
    pages, failures = find_pages(symbols)
    words: dict[int, dict[str, float]] = {}
    ephemeris = None
    gst = None
    for p in pages:
        words[p.word_type] = p.fields
        if p.word_type == 5 or (p.word_type == 0 and p.fields.get("time") == 2):
            gst = (p.start, int(p.fields["wn"]), float(p.fields["tow_s"]))
        if (
            p.word_type in (1, 2, 3, 4, 5)
            and all(t in words for t in (1, 2, 3, 4, 5))
            and len({words[t]["iodnav"] for t in (1, 2, 3, 4)}) == 1
        ):
            ephemeris = words_to_ephemeris(words)
    return InavMessage(pages, ephemeris, gst, words, failures, iono_time_from_words(words))


def encode_inav(
    record: Ephemerides,
    wn: int,
    first_tow_s: int,
    n_pages: int,
    bgd_e1e5a_s: float = 0.0,
    ai_sfu: tuple[float, float, float] = (0.0, 0.0, 0.0),
    iono_time: InavIonoTime | None = None,
) -> np.ndarray:
    """±1 symbols (int8, bit 0 as +1) of ``n_pages`` consecutive E1-B pages of one
    satellite, the first starting at GST second of week ``first_tow_s`` (odd: E1-B pages
    start on odd seconds, ICD 4.3.3), in the order of `E1B_SUBFRAME_WORDS`: words 1-5 carry
    ``record`` (:func:`~gnssframework.navigation.inav_words.ephemeris_to_words`), word 5
    and every other word type go out with the GST of their page (others as word type 0).
    With ``iono_time``, its ``utc`` goes out as word type 6 (with its page's TOW) and its
    ``ggto`` as word type 10 in the slot of words 8/10 of every sub-frame (its almanac
    fields 0), and its ``ai_sfu``, when given, replaces ``ai_sfu``."""
    if first_tow_s % 2 != 1 or not 0 <= first_tow_s < 604_800:
        raise ConfigError("first_tow_s", f"an E1-B page starts on an odd second of the week, got {first_tow_s}")
    if n_pages < 1:
        raise ConfigError("n_pages", f"must be at least 1, got {n_pages}")
    utc = ggto = None
    if iono_time is not None:
        ai_sfu = iono_time.ai_sfu if iono_time.ai_sfu is not None else ai_sfu
        utc, ggto = iono_time.utc, iono_time.ggto
    base = ephemeris_to_words(record, wn, 0, bgd_e1e5a_s, ai_sfu)
    words = np.empty((n_pages, WORD_BITS), dtype=np.uint8)
    for k in range(n_pages):
        tow = (first_tow_s + 2 * k) % 604_800
        wn_k = (wn + (first_tow_s + 2 * k) // 604_800) % 4096
        wt = E1B_SUBFRAME_WORDS[((tow - 1) % 30) // 2]
        if wt in (1, 2, 3, 4):
            words[k] = encode_word(wt, base[wt])
        elif wt == 5:
            words[k] = encode_word(5, base[5] | {"wn": wn_k, "tow_s": tow})
        elif wt == 6 and utc is not None:
            words[k] = encode_word(6, utc.fields() | {"tow_s": tow})
        elif wt == 8 and ggto is not None:
            words[k] = encode_word(10, ggto.fields())
        else:
            words[k] = encode_word(0, {"time": 2, "wn": wn_k, "tow_s": tow})
    return encode_pages(words).reshape(-1)


def inav_symbols(
    record: Ephemerides,
    wn: int,
    tow_s: float,
    n_symbols: int,
    bgd_e1e5a_s: float = 0.0,
    ai_sfu: tuple[float, float, float] = (0.0, 0.0, 0.0),
    iono_time: InavIonoTime | None = None,
) -> tuple[np.ndarray, float]:
    """±1 E1-B symbols (int8, bit 0 as +1) from the one in force at GST ``tow_s`` (week
    ``wn``) on, for the IF generator's ``data_bits`` (`galileo-e1b`: one symbol a 4 ms code
    period); and the time (s) from the first symbol's start to ``tow_s``
    (``first_bit_edge_s = -that``). Pages as :func:`encode_inav`."""
    first = int(np.floor((tow_s - 1.0) / 2.0)) * 2 + 1  # the page in force started on an odd second
    if first < 0:
        first, wn = first + 604_800, wn - 1
    into_page_s = (tow_s - first) % 604_800  # in [0, 2)
    skip = int(np.floor(into_page_s * SYMBOL_RATE_HZ))
    n_pages = int(np.ceil((skip + n_symbols) / PAGE_SYMBOLS))
    symbols = encode_inav(record, wn, first, n_pages, bgd_e1e5a_s, ai_sfu, iono_time)[skip : skip + n_symbols]
    return symbols, float(into_page_s - skip / SYMBOL_RATE_HZ)
