r"""SBAS L1 messages (RTCA DO-229 Appendix A, A.4; ICAO Annex 10 Vol. I Appendix B, 3.5.2-3.5.3):
250-bit messages from 500 symbol/s soft symbols and back.

A message is 250 bits sent at 250 bit/s, one a second, first bit first:

======= ====== =====================================================================
bits    length field
======= ====== =====================================================================
0-7     8      preamble: one 8-bit part of ``01010011 10011010 11000110``
               (``0x53``, ``0x9A``, ``0xC6``), the parts in turn in successive messages
8-13    6      message type (0-63)
14-225  212    data (not interpreted here)
226-249 24     parity: CRC-24Q (:func:`~gnssframework.navigation.fec.crc24q_bits`) of bits 0-225
======= ====== =====================================================================

The leading edge of the first symbol that depends on a message's first bit leaves the
satellite on a whole second of SBAS network time (Annex 10 App. B 3.5.2, message
synchronization). The bit stream is convolutionally encoded at rate 1/2 with constraint
length 7 and the generators :math:`G_1 = 171_8`, :math:`G_2 = 133_8` (Annex 10 App. B
3.5.2, convolutional encoding), the :math:`G_1` symbol of each bit first and neither
inverted (Galileo I/NAV inverts :math:`G_2`; SBAS does not, as PocketSDR's SBAS decoder
reads it): 500 symbols/s, one symbol 2 ms = 2 code periods of the 1 ms C/A-family code.
The encoder runs on without a break from message to message (no tail bits, no block
boundary), so a receiver cuts a window out of the symbol stream, decodes it by Viterbi
from an unknown state, and looks for preambles in the decoded bits.

A receiver knows neither

* which of two successive symbols is a bit's :math:`G_1` symbol (the symbol-pair
  alignment): both offsets are decoded and the one whose messages pass the CRC is kept;
* the carrier phase to 180 degrees (a Costas loop): every symbol may come inverted. Both
  generators have an odd number of taps (5 each), so inverted symbols are the code word of
  the complemented bits: the decoder's bits come complemented, and the preamble, read
  upright or complemented, gives the polarity of each message.

Symbols are ±1 with bit 0 sent as +1 (the project's convention, as
:mod:`~gnssframework.navigation.inav`). :func:`find_messages` decodes a stream; the encoder
side (:func:`message_bits`, :func:`encode_messages`, :func:`sbas_symbols`) writes a
message stream for the IF generator's ``data_bits``. The preamble, the message type and
the CRC are read here; the data field's contents (masks, fast and long-term corrections,
ionospheric grid, GEO navigation) by `sbas_content`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import ConfigError
from . import fec

__all__ = [
    "PREAMBLES",
    "MESSAGE_BITS",
    "MESSAGE_SYMBOLS",
    "DATA_BITS",
    "SYMBOL_RATE_HZ",
    "GENERATORS",
    "INVERTED",
    "SbasMessage",
    "message_bits",
    "parse_message",
    "messages_from_hex",
    "encode_messages",
    "sbas_symbols",
    "decode_stream",
    "find_messages",
]

#: The three 8-bit preamble parts, in the order successive messages send them (Annex 10 App. B 3.5.3, preamble).
PREAMBLES = (0x53, 0x9A, 0xC6)
#: Bits of one message: preamble 8, type 6, data 212, parity 24.
MESSAGE_BITS = 250
#: Coded symbols of one message (rate 1/2): one second at 500 symbols/s.
MESSAGE_SYMBOLS = 2 * MESSAGE_BITS
#: Bits of the data field.
DATA_BITS = 212
#: Coded symbols per second (one symbol 2 ms).
SYMBOL_RATE_HZ = 500.0
#: Convolutional code generators, octal 171 and 133: the :math:`G_1` symbol first.
GENERATORS = (fec.G1, fec.G2)
#: Neither generator's symbol is inverted (unlike Galileo I/NAV's :math:`G_2`).
INVERTED = (False, False)
_CRC_BITS = 226
_WEIGHTS8 = 1 << np.arange(7, -1, -1)
_WEIGHTS6 = 1 << np.arange(5, -1, -1)
_WEIGHTS24 = (1 << np.arange(23, -1, -1)).astype(np.int64)


@dataclass(frozen=True)
class SbasMessage:
    """One message read from a stream.

    ``start``: the index, in the stream given, of the first symbol of the message's first
    bit; ``inverted``: the stream's polarity there (its preamble came complemented);
    ``preamble`` and ``message_type`` as read (after the polarity); ``crc_ok``: the
    CRC-24Q of bits 0-225 equals bits 226-249 and the preamble is one of `PREAMBLES`;
    ``bits``: the 250 bits (0/1, upright).
    """

    start: int
    inverted: bool
    preamble: int
    message_type: int
    crc_ok: bool
    bits: np.ndarray = field(repr=False)

    @property
    def hex(self) -> str:
        """The 250 bits as 64 hexadecimal digits, six zero bits appended (the form receiver
        logs such as RTKLIB's write: 32 bytes, the first bit the most significant)."""
        return _to_hex(self.bits)


def _to_hex(bits: np.ndarray) -> str:
    return np.packbits(np.r_[np.asarray(bits, np.uint8), np.zeros(6, np.uint8)]).tobytes().hex()


def _bits_of(value: int, n: int) -> np.ndarray:
    return ((int(value) >> np.arange(n - 1, -1, -1)) & 1).astype(np.uint8)


def _crc_holds(bits: np.ndarray) -> np.ndarray:
    """Whether the parity of each message ``(..., 250)`` is the CRC-24Q of its bits 0-225."""
    received = np.sum(bits[..., _CRC_BITS:].astype(np.int64) * _WEIGHTS24, axis=-1)
    return fec.crc24q_bits(bits[..., :_CRC_BITS]) == received


def message_bits(preamble_index: int, message_type: int, data: np.ndarray) -> np.ndarray:
    """The 250 bits (0/1) of one message: preamble part ``preamble_index`` (0, 1, 2 for
    ``0x53``, ``0x9A``, ``0xC6``), the 6-bit ``message_type``, the 212 ``data`` bits and
    the CRC-24Q of those 226 bits (Annex 10 App. B 3.5.3)."""
    if preamble_index not in (0, 1, 2):
        raise ConfigError("preamble_index", f"must be 0, 1 or 2 (0x53, 0x9A, 0xC6), got {preamble_index}")
    if not 0 <= int(message_type) < 64 or int(message_type) != message_type:
        raise ConfigError("message_type", f"must be an integer 0-63, got {message_type}")
    d = np.asarray(data)
    if d.shape != (DATA_BITS,) or not np.isin(d, (0, 1)).all():
        raise ConfigError("data", f"an SBAS message carries {DATA_BITS} bits of 0/1, got shape {d.shape}")
    head = np.r_[_bits_of(PREAMBLES[preamble_index], 8), _bits_of(message_type, 6), d.astype(np.uint8)]
    return np.r_[head, _bits_of(int(fec.crc24q_bits(head)), 24)]


def parse_message(bits: np.ndarray) -> tuple[int, int, bool]:
    """``(preamble, message type, CRC and preamble good)`` of one message's 250 bits (0/1)."""
    b = np.asarray(bits)
    if b.shape != (MESSAGE_BITS,) or not np.isin(b, (0, 1)).all():
        raise ConfigError("bits", f"an SBAS message is {MESSAGE_BITS} bits of 0/1, got shape {b.shape}")
    b = b.astype(np.uint8)
    preamble, mtype = int(b[:8] @ _WEIGHTS8), int(b[8:14] @ _WEIGHTS6)
    return preamble, mtype, bool(_crc_holds(b)) and preamble in PREAMBLES


def messages_from_hex(texts: list[str]) -> np.ndarray:
    """Messages ``(M, 250)`` (0/1) from hexadecimal texts of at least 250 bits each (the
    first bit the most significant; bits past 250 are ignored)."""
    out = []
    for text in texts:
        try:
            raw = bytes.fromhex(text.strip())
        except ValueError:
            raise ConfigError("hex", f"not hexadecimal: {text!r}") from None
        bits = np.unpackbits(np.frombuffer(raw, np.uint8))
        if bits.size < MESSAGE_BITS:
            raise ConfigError("hex", f"an SBAS message is {MESSAGE_BITS} bits, got {bits.size} in {text!r}")
        out.append(bits[:MESSAGE_BITS])
    return np.array(out, dtype=np.uint8).reshape(-1, MESSAGE_BITS)


def encode_messages(messages: np.ndarray, register: np.ndarray | None = None) -> np.ndarray:
    """±1 symbols (int8, bit 0 as +1) of messages ``(M, 250)`` sent one after the other:
    ``2 x 250 M`` symbols, the encoder's register continuing across messages (no tail).

    ``register``: the 6 bits sent before the first message (oldest first; zero when not
    given), which the first symbols depend on, as in a stream cut out of a continuous one.
    """
    m = np.asarray(messages)
    if m.ndim != 2 or m.shape[1] != MESSAGE_BITS:
        raise ConfigError("messages", f"SBAS messages are (M, {MESSAGE_BITS}) bits, got shape {m.shape}")
    lead = np.zeros(fec.CONSTRAINT_LENGTH - 1, np.uint8) if register is None else np.asarray(register, np.uint8)
    if lead.shape != (fec.CONSTRAINT_LENGTH - 1,):
        raise ConfigError("register", f"the encoder's register holds 6 bits, got shape {lead.shape}")
    coded = fec.conv_encode(np.r_[lead, m.reshape(-1)], GENERATORS, INVERTED)[2 * lead.size :]
    return (1 - 2 * coded.astype(np.int8)).astype(np.int8)


def sbas_symbols(messages: np.ndarray, skip_symbols: int, n_symbols: int) -> np.ndarray:
    """``n_symbols`` ±1 symbols (int8) of the stream :func:`encode_messages` makes of
    ``messages``, from symbol ``skip_symbols`` on: the IF generator's ``data_bits`` for
    ``sbas-l1`` (one symbol each 2 ms), a recording starting part-way through a message."""
    if skip_symbols < 0 or n_symbols < 1:
        raise ConfigError("n_symbols", f"needs skip_symbols >= 0 and n_symbols >= 1, got {skip_symbols}, {n_symbols}")
    symbols = encode_messages(messages)
    if skip_symbols + n_symbols > symbols.size:
        raise ConfigError(
            "messages",
            f"{np.shape(messages)[0]} messages are {symbols.size} symbols; {skip_symbols} + {n_symbols} were asked for",
        )
    return symbols[skip_symbols : skip_symbols + n_symbols]


def _candidates(bits: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start indices of every whole message whose first 8 bits are a preamble, upright or
    complemented, and each one's polarity (True: complemented)."""
    last = bits.size - MESSAGE_BITS
    if last < 0:
        return np.zeros(0, int), np.zeros(0, bool)
    words = np.lib.stride_tricks.sliding_window_view(bits[: last + 8], 8) @ _WEIGHTS8
    up = np.isin(words, PREAMBLES)
    down = np.isin(words ^ 0xFF, PREAMBLES)
    starts = np.flatnonzero(up | down)
    return starts, down[starts] & ~up[starts]


def _blocks(bits: np.ndarray, starts: np.ndarray, inverted: np.ndarray) -> np.ndarray:
    return bits[starts[:, None] + np.arange(MESSAGE_BITS)] ^ inverted[:, None].astype(np.uint8)


def _polarity(bits: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """Whether each message's first 8 bits are nearer a complemented preamble than an
    upright one (Hamming distance to the nearest of the three)."""
    first = bits[starts[:, None] + np.arange(8)]
    pre = np.array([_bits_of(p, 8) for p in PREAMBLES])
    dist = np.count_nonzero(first[:, None, :] != pre[None], axis=-1).min(axis=1)
    dist_inv = np.count_nonzero(first[:, None, :] != (1 - pre)[None], axis=-1).min(axis=1)
    return dist_inv < dist


#: Bits each window of :func:`decode_stream` keeps, and the bits decoded on either side of
#: them and dropped (the survivor paths of a K = 7 code merge within a few constraint
#: lengths; 96 bits is about 14).
WINDOW_BITS = 4096
MARGIN_BITS = 96
_WINDOWS_AT_ONCE = 8


def decode_stream(symbols: np.ndarray, window_bits: int = WINDOW_BITS, margin_bits: int = MARGIN_BITS) -> np.ndarray:
    """Viterbi-decoded bits of a pair-aligned stretch of a continuous stream (``2n`` soft
    symbols, the first a :math:`G_1` symbol): ``n`` bits (0/1).

    The stream is cut into windows of ``window_bits`` kept bits, each decoded with
    ``margin_bits`` more on either side (where the stream has them) from an unknown start
    state to the best end state, and the margins dropped: memory grows with the window,
    not with the stream (the decoder's branch metrics are 128 values a bit), and the kept
    bits are those of one decoding of the whole stream once the survivor paths have merged
    inside the margins. Windows go to the batched decoder a few at a time.
    """
    y = np.asarray(symbols, dtype=float)
    if window_bits < 1 or margin_bits < 0:
        raise ConfigError(
            "window_bits", f"needs window_bits >= 1 and margin_bits >= 0, got {window_bits}, {margin_bits}"
        )
    n = y.size // 2
    if y.ndim != 1 or y.size != 2 * n or n == 0:
        raise ConfigError(
            "symbols", f"a pair-aligned stream is an even, non-zero number of symbols, got shape {y.shape}"
        )
    if n <= window_bits + 2 * margin_bits:
        return fec.viterbi_decode(y, GENERATORS, INVERTED, terminated=False, start_known=False)
    out = np.empty(n, dtype=np.uint8)
    keep = np.arange(0, n, window_bits)
    span = window_bits + 2 * margin_bits
    # every window decodes `span` bits: those at the stream's ends are shifted inwards
    first = np.clip(keep - margin_bits, 0, n - span)
    for g in range(0, keep.size, _WINDOWS_AT_ONCE):
        sl = slice(g, g + _WINDOWS_AT_ONCE)
        idx = 2 * first[sl, None] + np.arange(2 * span)
        bits = fec.viterbi_decode(y[idx], GENERATORS, INVERTED, terminated=False, start_known=False)
        for row, k0, f0 in zip(bits, keep[sl], first[sl]):
            k1 = min(k0 + window_bits, n)
            out[k0:k1] = row[k0 - f0 : k1 - f0]
    return out


def find_messages(symbols: np.ndarray) -> tuple[list[SbasMessage], list[str]]:
    """Every whole message in a stream of soft SBAS L1 symbols (one per 2 ms, in order, no
    gaps), and one line per message of the stream's message grid whose CRC failed.

    Both symbol-pair alignments are Viterbi-decoded from an unknown start state to the
    best end state (:func:`decode_stream`, window by window); in each, every
    position whose 8 bits read a preamble (upright or complemented) starts a candidate,
    kept when its CRC-24Q holds. The alignment with more kept candidates wins; its message
    grid is the most common start modulo 250 of those, and every whole message on the grid
    is read (polarity from its first 8 bits) and reported, its CRC good or not: a message
    whose CRC fails is listed in the failures and returned with ``crc_ok`` False, never as
    good. A stream with no message whose CRC holds gives no messages and no failures.

    Raises
    ------
    ConfigError
        For fewer symbols than one message (500), or symbols not 1-D, real and finite.
    """
    s = fec.real_symbols(symbols, "one satellite's SBAS L1 stream")
    if s.size < MESSAGE_SYMBOLS:
        raise ConfigError(
            "symbols",
            f"an SBAS L1 message is {MESSAGE_SYMBOLS} symbols (1 s at 500 symbols/s); got {s.size}",
        )
    decoded = []
    for align in (0, 1):
        n_bits = (s.size - align) // 2
        bits = decode_stream(s[align : align + 2 * n_bits])
        starts, inv = _candidates(bits)
        good = _crc_holds(_blocks(bits, starts, inv)) if starts.size else np.zeros(0, bool)
        decoded.append((int(np.count_nonzero(good)), -align, bits, starts, good))
    count, neg_align, bits, starts, good = max(decoded, key=lambda d: d[:2])
    align = -neg_align
    if count == 0:
        return [], []
    offsets, counts = np.unique(starts[good] % MESSAGE_BITS, return_counts=True)
    grid = np.arange(int(offsets[np.argmax(counts)]), bits.size - MESSAGE_BITS + 1, MESSAGE_BITS)
    inverted = _polarity(bits, grid)
    blocks = _blocks(bits, grid, inverted)
    messages, failures = [], []
    for k, start in enumerate(grid):
        preamble, mtype, ok = parse_message(blocks[k])
        first = align + 2 * int(start)
        messages.append(SbasMessage(first, bool(inverted[k]), preamble, mtype, ok, blocks[k]))
        if not ok:
            failures.append(
                f"SBAS message at symbol {first}: "
                f"{'CRC-24Q failed' if preamble in PREAMBLES else f'preamble 0x{preamble:02X} is not one of 0x53 0x9A 0xC6'}"
                f" (type {mtype} as read); not used"
            )
    return messages, failures
