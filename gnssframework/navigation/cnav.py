r"""GPS CNAV on L2C (IS-GPS-200, section 30 and 3.3.3.1.1): soft symbols to 300-bit
messages, the messages' header, ephemeris messages 10 and 11, and the encoder the IF
generator's ``gps-l2c`` streams take.

Message (IS-GPS-200 30.3.3, Figure 30-1 ff.): 300 bits, sent first bit first at 25 bit/s
(12 s a message):

=========  ======  ===============================================================
bits       width   field
=========  ======  ===============================================================
1-8        8       preamble ``10001011``
9-14       6       PRN
15-20      6       message type ID
21-37      17      message TOW count: SV time at the start of the *next* message,
                   in units of 6 s
38         1       alert flag
39-276     238     the type's data
277-300    24      CRC-24Q parity over bits 1-276 (30.3.5)
=========  ======  ===============================================================

Forward error correction (IS-GPS-200 3.3.3.1.1, Figure 3-17): the bit train is encoded
by the K = 7 rate-1/2 convolutional code with :math:`G_1 = 171_8` and
:math:`G_2 = 133_8` (`fec.conv_encode`), the :math:`G_1` symbol first and neither symbol
inverted, 50 symbol/s, one symbol a 20 ms CM code period. The encoding runs on without
break from message to message: no tail bits, no block boundaries. A receiver therefore
(i) decodes a whole gap-free run of symbols with a Viterbi decoder whose start state is
unknown, once for each of the two ways of pairing symbols, and (ii) finds the messages in
the bits by the preamble and a passing CRC. Both generators have an odd number of taps,
so a stream received 180 degrees off (every symbol negated) decodes to the complemented
bits: the preamble then shows as ``01110100`` and the complemented bits are the message.
(Galileo's code inverts its :math:`G_2` symbol; L2's does not, which PocketSDR's L2 CM
decoder agrees with: the same polynomials, no inversion.)

Time of a message: its first bit is sent at SV time ``6 x TOW count - 12`` s (the TOW
count dates the next message, one 12 s message later). As taken here, bit ``k`` of the
stream occupies the symbols ``2k`` and ``2k + 1`` after the pairing offset: the encoder
has no delay (:math:`u_k` taps both generators' most significant bit), so a message's
first bit and its first coded symbol start together.

Clock (types 30-37, Table 30-III: `parse_clock`), group delays and Klobuchar coefficients
(type 30, Table 30-IV: `parse_group_delays`) and GPS-UTC (type 33, Table 30-IX:
`parse_utc`) are read too; the other types' data (almanacs, EOP, differential
corrections, GGTO, text) are left as bits. `cnav_records` assembles types 10, 11, 30-37
and 30 into the `Ephemerides` records positions take.

Ephemeris (IS-GPS-200 30.3.3.1, Tables 30-I and 30-II; message types 10 and 11): the
elements relative to :math:`A_{REF} = 26\,559\,710` m and
:math:`\dot\Omega_{REF} = -2.6\times 10^{-9}` semicircles/s, with a rate of the semi-major
axis and of the mean motion difference:

.. math:: A_0 = A_{REF} + \Delta A,\quad A_k = A_0 + \dot A t_k,\quad
          n_A = \sqrt{\mu / A_0^3} + \Delta n_0 + \tfrac12 \Delta\dot n_0 t_k

and otherwise the LNAV user algorithm (Table 20-IV) with :math:`A_k` for the radius and
:math:`\dot\Omega = \dot\Omega_{REF} + \Delta\dot\Omega`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import ConfigError
from .ephemeris import GM_GPS_M3_S2, OMEGA_EARTH_RAD_S, Ephemerides
from .lnav import IonoUtc
from .fec import G1, G2, conv_encode, crc24q_bits, real_symbols, viterbi_decode

__all__ = [
    "PREAMBLE",
    "MESSAGE_BITS",
    "MESSAGE_S",
    "L5_MESSAGE_S",
    "SYMBOL_RATE_HZ",
    "TOW_UNIT_S",
    "A_REF_M",
    "OMEGA_DOT_REF_SC_S",
    "CnavMessage",
    "CnavDecode",
    "CnavEphemeris",
    "message_bits",
    "message_from_bits",
    "encode_cnav",
    "cnav_symbols",
    "decode_cnav",
    "ephemeris_payloads",
    "parse_ephemeris",
    "cnav_position",
    "CnavClock",
    "parse_clock",
    "CnavUtc",
    "parse_utc",
    "CnavGroupDelays",
    "parse_group_delays",
    "clock_payload",
]

#: Preamble of every CNAV message (IS-GPS-200 30.3.3).
PREAMBLE = np.array([1, 0, 0, 0, 1, 0, 1, 1], dtype=np.uint8)
#: Bits of a message; the CRC-24Q covers the first 276.
MESSAGE_BITS = 300
_CRC_BITS = 24
#: Length of a message at 25 bit/s (L2C), s.
MESSAGE_S = 12.0
#: Length of a message at 50 bit/s (L5 I5, IS-GPS-705 20.3.3: 100 symbols/s), s.
L5_MESSAGE_S = 6.0
#: L2 CM's symbol rate (one symbol a 20 ms code period), symbols/s.
SYMBOL_RATE_HZ = 50.0
#: Unit of the message TOW count, s.
TOW_UNIT_S = 6.0
#: Reference semi-major axis of messages 10 and 11, m (IS-GPS-200 Table 30-I).
A_REF_M = 26_559_710.0
#: Reference rate of right ascension, semicircles/s (IS-GPS-200 Table 30-I).
OMEGA_DOT_REF_SC_S = -2.6e-9
#: The L2C code's generators and inversions (IS-GPS-200 Figure 3-17: none inverted).
GENERATORS = (G1, G2)
INVERTED = (False, False)
_WEEK_S = 604_800.0
_DEFAULT_TYPE = 0  # message type 0: default message, alternating ones and zeros (IS-GPS-200 30.3.3)


@dataclass(frozen=True)
class CnavMessage:
    """One 300-bit message found in a symbol stream.

    ``start`` is the index, in the stream given to `decode_cnav`, of the first symbol of
    the message's first bit; ``inverted`` True where the stream came negated (the bits are
    given upright); ``crc_ok`` whether the CRC-24Q over bits 1-276 matches bits 277-300;
    ``message_s`` how long the message lasts on its signal (12 s on L2C, 6 s on L5: the
    TOW count dates the next message's start, IS-GPS-200 30.3.3.1.1.2, IS-GPS-705 20.3.3.1.1.2).
    """

    start: int
    prn: int
    msg_type: int
    tow_count: int
    alert: bool
    crc_ok: bool
    inverted: bool
    bits: np.ndarray = field(repr=False, compare=False)
    message_s: float = field(default=MESSAGE_S, compare=False)

    @property
    def hex(self) -> str:
        """The 300 bits as 75 hex digits, the first bit the most significant."""
        return "".join(f"{int(''.join(map(str, q)), 2):X}" for q in self.bits.reshape(-1, 4))

    @property
    def tow_s(self) -> float:
        """SV time of week at the start of this message, s (the TOW count dates the next)."""
        return (self.tow_count * TOW_UNIT_S - self.message_s) % _WEEK_S


@dataclass(frozen=True)
class CnavDecode:
    """What `decode_cnav` found: the messages in stream order, the pairing offset (0 or 1:
    the stream's first symbol is a bit's G1 or G2 symbol) and the polarity that found
    them (None where no message passed its CRC)."""

    messages: list[CnavMessage]
    pair_offset: int | None
    inverted: bool | None

    @property
    def failures(self) -> list[CnavMessage]:
        return [m for m in self.messages if not m.crc_ok]


def _unsigned(bits: np.ndarray, first: int, width: int) -> int:
    """Bits ``first .. first + width - 1`` (1-based, as the ICD numbers them), MSB first."""
    value = 0
    for b in bits[first - 1 : first - 1 + width]:
        value = (value << 1) | int(b)
    return value


def _signed(bits: np.ndarray, first: int, width: int) -> int:
    v = _unsigned(bits, first, width)
    return v - (1 << width) if v >> (width - 1) else v


def _put(bits: np.ndarray, first: int, width: int, value: int, name: str) -> None:
    """Write ``value`` (two's complement when negative) into bits ``first ..`` (1-based)."""
    if not -(1 << (width - 1)) <= value < (1 << width):
        raise ConfigError(name, f"{value} does not fit in {width} bits")
    v = value & ((1 << width) - 1)
    bits[first - 1 : first - 1 + width] = [(v >> (width - 1 - j)) & 1 for j in range(width)]


def _check_bits(bits: np.ndarray, n: int, name: str) -> np.ndarray:
    b = np.asarray(bits)
    if b.shape != (n,) or not np.isin(b, (0, 1)).all():
        raise ConfigError(name, f"needs {n} bits of 0 or 1, got shape {b.shape}")
    return b.astype(np.uint8)


def message_bits(
    prn: int, msg_type: int, tow_count: int, payload: np.ndarray | None = None, alert: bool = False
) -> np.ndarray:
    """A whole message (300 bits, 0/1): header, the 238 data bits ``payload`` (bits
    39-276; None: alternating ones and zeros, as the default message type 0 sends them)
    and its CRC-24Q (bits 277-300)."""
    if not 1 <= prn <= 63:
        raise ConfigError("prn", f"the CNAV PRN field holds 1-63, got {prn}")
    if not 0 <= msg_type <= 63:
        raise ConfigError("msg_type", f"a message type ID is 0-63, got {msg_type}")
    if not 0 <= tow_count < 100_800:
        raise ConfigError("tow_count", f"the TOW count (6 s units) is 0-100799, got {tow_count}")
    b = np.zeros(MESSAGE_BITS, dtype=np.uint8)
    b[:8] = PREAMBLE
    _put(b, 9, 6, prn, "prn")
    _put(b, 15, 6, msg_type, "msg_type")
    _put(b, 21, 17, tow_count, "tow_count")
    b[37] = int(bool(alert))
    b[38:276] = (np.arange(238) + 1) % 2 if payload is None else _check_bits(payload, 238, "payload")
    crc = int(crc24q_bits(b[:276]))
    _put(b, 277, 24, crc, "crc")
    return b


def message_from_bits(
    bits: np.ndarray, start: int = 0, inverted: bool = False, message_s: float = MESSAGE_S
) -> CnavMessage:
    """The header of a 300-bit message (upright bits) and whether its CRC-24Q passes."""
    b = _check_bits(bits, MESSAGE_BITS, "bits")
    crc_ok = int(crc24q_bits(b[:276])) == _unsigned(b, 277, 24)
    return CnavMessage(
        start,
        _unsigned(b, 9, 6),
        _unsigned(b, 15, 6),
        _unsigned(b, 21, 17),
        bool(b[37]),
        bool(crc_ok),
        inverted,
        b.copy(),
        message_s,
    )


def encode_cnav(messages: np.ndarray) -> np.ndarray:
    """±1 symbols (int8, bit 0 sent as +1) of the messages ``(n, 300)`` sent one after the
    other: one continuous convolutional encoding from a zero register, ``600 n`` symbols."""
    m = np.asarray(messages)
    if m.ndim != 2 or m.shape[1] != MESSAGE_BITS or m.shape[0] == 0:
        raise ConfigError("messages", f"needs (n, {MESSAGE_BITS}) bits, got shape {m.shape}")
    coded = conv_encode(m.reshape(-1), GENERATORS, INVERTED)
    return (1 - 2 * coded.astype(np.int8)).astype(np.int8)


def cnav_symbols(
    prn: int,
    tow_s: float,
    n_symbols: int,
    ephemeris: Ephemerides | None = None,
    wn: int = 0,
    iono: IonoUtc | None = None,
    isc_l2c_s: float | None = None,
    *,
    message_s: float = MESSAGE_S,
    isc_l5i5_s: float | None = None,
) -> tuple[np.ndarray, float]:
    """±1 CNAV symbols (int8) from the one in force at SV time ``tow_s`` on, for the IF
    generator's ``data_bits`` (`gps-l2c`: one symbol a 20 ms code period; with
    ``message_s = L5_MESSAGE_S``, `gps-l5i`'s 100 symbols/s), and the time (s) from the
    first symbol's start to ``tow_s`` (``first_bit_edge_s = -that``).

    Messages start on multiples of ``message_s`` (12 s on L2C, 6 s on L5) of the week; they
    cycle through types 10, 11 (`ephemeris_payloads` of the one-record ``ephemeris``, week
    ``wn``) and 30 (its clock, group delays, ``isc_l2c_s`` and ``isc_l5i5_s``, and
    ``iono``'s Klobuchar coefficients, `clock_payload`), the ``j``-th message of the week
    being the ``j mod 3``-th; they send the default type 0 only without an ephemeris. The
    encoder starts from a zero register at the start of the message in force.
    """
    if n_symbols < 1:
        raise ConfigError("n_symbols", f"must be at least 1, got {n_symbols}")
    rate = 2 * MESSAGE_BITS / message_s  # symbols/s
    first = int(np.floor(tow_s / message_s))
    skip = int(np.floor((tow_s - first * message_s) * rate))
    n_msg = int(np.ceil((skip + n_symbols) / (2 * MESSAGE_BITS)))
    payloads = None
    if ephemeris is not None:
        payloads = (
            *ephemeris_payloads(ephemeris, wn),
            clock_payload(ephemeris, wn, iono, isc_l2c_s, isc_l5i5_s=isc_l5i5_s),
        )
    rows = []
    for j in range(first, first + n_msg):
        start_s = (j * message_s) % _WEEK_S
        count = int(round(((start_s + message_s) % _WEEK_S) / TOW_UNIT_S))
        cycle: list[tuple[int, np.ndarray | None]] = [(_DEFAULT_TYPE, None)]
        if payloads is not None:
            cycle = [(10, payloads[0]), (11, payloads[1]), (30, payloads[2])]
        msg_type, payload = cycle[j % len(cycle)]
        rows.append(message_bits(prn, msg_type, count, payload))
    symbols = encode_cnav(np.array(rows))[skip : skip + n_symbols]
    return symbols, float(tow_s - first * message_s - skip / rate)


def _frames(bits: np.ndarray, offset: int, inverted: bool, message_s: float) -> list[CnavMessage]:
    """Messages of a decoded bit stream: the first preamble whose CRC passes fixes the
    frame; every 300 bits before and after it is a message (CRC checked)."""
    if bits.size < MESSAGE_BITS:
        return []
    windows = np.lib.stride_tricks.sliding_window_view(bits, MESSAGE_BITS)
    hits = np.flatnonzero((windows[:, :8] == PREAMBLE).all(axis=1))
    if hits.size == 0:
        return []
    w = windows[hits]
    ok = crc24q_bits(w[:, :276]) == (w[:, 276:].astype(np.int64) << np.arange(23, -1, -1)).sum(axis=1)
    if not ok.any():
        return []
    p0 = int(hits[np.argmax(ok)]) % MESSAGE_BITS
    return [
        message_from_bits(bits[p : p + MESSAGE_BITS], offset + 2 * p, inverted, message_s)
        for p in range(p0, bits.size - MESSAGE_BITS + 1, MESSAGE_BITS)
    ]


def decode_cnav(symbols: np.ndarray, prn: int | None = None, message_s: float = MESSAGE_S) -> CnavDecode:
    """The CNAV messages of one gap-free run of CM (or L5 I5) symbols (module text).

    Parameters
    ----------
    symbols
        One soft symbol per 20 ms CM code period, or per 10 ms of L5 I5 with its NH10
        overlay wiped off (bit 0 as +1, any scale: ±1 or the prompt's in-phase sums), ``(n,)``.
    prn
        For the error message only: the channel the symbols came from.
    message_s
        How long a message lasts on the signal (`MESSAGE_S` on L2C, `L5_MESSAGE_S` on L5):
        the messages' `CnavMessage.tow_s`.

    Returns
    -------
    CnavDecode
        The messages of the pairing offset and polarity with the most passing CRCs.
    """
    what = "one satellite's CM stream" if prn is None else f"PRN {prn}'s CM stream"
    s = np.asarray(symbols)
    if s.ndim == 1 and (np.iscomplexobj(s) or not np.all(np.isfinite(s))):
        raise ConfigError("symbols", f"{what}: must be finite real numbers (±1 or the prompt's in-phase sums)")
    y = real_symbols(s, what)
    best = CnavDecode([], None, None)
    score = 0
    for offset in (0, 1):
        n_bits = (y.size - offset) // 2
        if n_bits < MESSAGE_BITS:
            continue
        bits = viterbi_decode(
            y[offset : offset + 2 * n_bits], GENERATORS, INVERTED, terminated=False, start_known=False
        )
        for inverted in (False, True):
            found = _frames(bits ^ np.uint8(inverted), offset, inverted, message_s)
            good = sum(m.crc_ok for m in found)
            if good > score:
                best, score = CnavDecode(found, offset, inverted), good
    return best


# --- ephemeris: message types 10 and 11 ------------------------------------------------

#: Message type 10 fields after the header (IS-GPS-200 Table 30-I / Figure 30-1):
#: name, first bit (1-based), width, signed, scale factor.
_MT10 = (
    ("wn", 39, 13, False, 1.0),
    ("health_l1_l2_l5", 52, 3, False, 1.0),
    ("top_s", 55, 11, False, 300.0),
    ("ura_ed_index", 66, 5, True, 1.0),
    ("toe_s", 71, 11, False, 300.0),
    ("delta_a_m", 82, 26, True, 2.0**-9),
    ("a_dot_m_s", 108, 25, True, 2.0**-21),
    ("delta_n0_sc_s", 133, 17, True, 2.0**-44),
    ("delta_n0_dot_sc_s2", 150, 23, True, 2.0**-57),
    ("m0_sc", 173, 33, True, 2.0**-32),
    ("e", 206, 33, False, 2.0**-34),
    ("omega_sc", 239, 33, True, 2.0**-32),
    ("integrity_flag", 272, 1, False, 1.0),
    ("l2c_phasing", 273, 1, False, 1.0),
)
#: Message type 11 fields (IS-GPS-200 Table 30-I / Figure 30-2).
_MT11 = (
    ("toe_s", 39, 11, False, 300.0),
    ("omega0_sc", 50, 33, True, 2.0**-32),
    ("i0_sc", 83, 33, True, 2.0**-32),
    ("delta_omega_dot_sc_s", 116, 17, True, 2.0**-44),
    ("i0_dot_sc_s", 133, 15, True, 2.0**-44),
    ("cis_rad", 148, 16, True, 2.0**-30),
    ("cic_rad", 164, 16, True, 2.0**-30),
    ("crs_m", 180, 24, True, 2.0**-8),
    ("crc_m", 204, 24, True, 2.0**-8),
    ("cus_rad", 228, 21, True, 2.0**-30),
    ("cuc_rad", 249, 21, True, 2.0**-30),
)


@dataclass(frozen=True)
class CnavEphemeris:
    """The ephemeris of message types 10 and 11 (IS-GPS-200 Table 30-I), angles in
    semicircles as broadcast; ``toe_s`` and ``top_s`` seconds of week ``wn``."""

    prn: int
    wn: int
    health_l1_l2_l5: int
    top_s: float
    ura_ed_index: int
    toe_s: float
    delta_a_m: float
    a_dot_m_s: float
    delta_n0_sc_s: float
    delta_n0_dot_sc_s2: float
    m0_sc: float
    e: float
    omega_sc: float
    integrity_flag: int
    l2c_phasing: int
    omega0_sc: float
    i0_sc: float
    delta_omega_dot_sc_s: float
    i0_dot_sc_s: float
    cis_rad: float
    cic_rad: float
    crs_m: float
    crc_m: float
    cus_rad: float
    cuc_rad: float


def _fields(bits: np.ndarray, table) -> dict:
    out = {}
    for name, first, width, signed, scale in table:
        raw = (_signed if signed else _unsigned)(bits, first, width)
        out[name] = raw * scale if scale != 1.0 else raw
    return out


def parse_ephemeris(msg10: CnavMessage, msg11: CnavMessage) -> CnavEphemeris:
    """The ephemeris of a message 10 and a message 11 of one satellite and one toe,
    both with a passing CRC; refused in one line otherwise."""
    for name, m, t in (("msg10", msg10, 10), ("msg11", msg11, 11)):
        if m.msg_type != t:
            raise ConfigError(name, f"PRN {m.prn}: expected message type {t}, got {m.msg_type}")
        if not m.crc_ok:
            raise ConfigError(name, f"PRN {m.prn}: message type {t} failed its CRC-24Q")
    if msg10.prn != msg11.prn:
        raise ConfigError("msg11", f"PRN {msg11.prn} is not the PRN {msg10.prn} of message type 10")
    a, b = _fields(msg10.bits, _MT10), _fields(msg11.bits, _MT11)
    if a["toe_s"] != b.pop("toe_s"):
        raise ConfigError("msg11", f"PRN {msg10.prn}: toe of message types 10 and 11 differ (another issue of data)")
    return CnavEphemeris(prn=msg10.prn, **a, **b)


def ephemeris_payloads(record: Ephemerides, wn: int) -> tuple[np.ndarray, np.ndarray]:
    """Data bits (39-276) of message types 10 and 11 carrying the one LNAV-style record
    ``record`` (`Ephemerides`, angles in radians): its semi-major axis as ``ΔA``, its node
    rate as ``ΔΩ̇``, no ``Ȧ`` nor ``Δṅ0`` (zero), health 0, week ``wn``. Values are
    rounded to the CNAV scale factors; a toe off the 300 s grid or a value out of its field
    is refused in one line."""
    if record.sv.size != 1:
        raise ConfigError("record", f"needs one record, got {record.sv.size}")
    e = {k: float(v[0]) for k, v in record.elements.items()}
    toe = _on_grid(e["Toe"], "toe", record)
    sc = 1.0 / np.pi
    values10 = {
        "wn": wn % 8192,
        "health_l1_l2_l5": 0,
        "top_s": toe,
        "ura_ed_index": 0,
        "toe_s": toe,
        "delta_a_m": e["sqrtA"] ** 2 - A_REF_M,
        "a_dot_m_s": 0.0,
        "delta_n0_sc_s": e["DeltaN"] * sc,
        "delta_n0_dot_sc_s2": 0.0,
        "m0_sc": e["M0"] * sc,
        "e": e["Eccentricity"],
        "omega_sc": e["omega"] * sc,
        "integrity_flag": 0,
        "l2c_phasing": 0,
    }
    values11 = {
        "toe_s": toe,
        "omega0_sc": e["Omega0"] * sc,
        "i0_sc": e["Io"] * sc,
        "delta_omega_dot_sc_s": e["OmegaDot"] * sc - OMEGA_DOT_REF_SC_S,
        "i0_dot_sc_s": e["IDOT"] * sc,
        "cis_rad": e["Cis"],
        "cic_rad": e["Cic"],
        "crs_m": e["Crs"],
        "crc_m": e["Crc"],
        "cus_rad": e["Cus"],
        "cuc_rad": e["Cuc"],
    }
    sv = str(record.sv[0])
    return _payload(_MT10, values10, sv), _payload(_MT11, values11, sv)


def _payload(table, values: dict, sv: str) -> np.ndarray:
    """Data bits 39-276 of ``values`` in the fields of ``table``, rounded to their scales."""
    b = np.zeros(MESSAGE_BITS, dtype=np.uint8)
    for name, first, width, signed, scale in table:
        raw = int(round(values[name] / scale))
        if not signed and raw < 0:
            raise ConfigError("record", f"{sv}: {name} {values[name]:g} is negative")
        _put(b, first, width, raw, f"record {sv} {name}")
    return b[38:276]


def _on_grid(t_s: float, name: str, record: Ephemerides) -> float:
    if abs(t_s / 300.0 - round(t_s / 300.0)) > 1e-9:
        raise ConfigError("record", f"{record.sv[0]}: {name} {t_s:g} s is not a multiple of CNAV's 300 s")
    return float(t_s)


def cnav_position(eph: CnavEphemeris, t_s: np.ndarray | float) -> np.ndarray:
    """ECEF (WGS 84) position, m, ``(..., 3)``, of the satellite of ``eph`` at GPS time
    ``t_s`` (s of week), by IS-GPS-200 Table 30-II (module text)."""
    t = np.asarray(t_s, dtype=float)
    tk = t - eph.toe_s
    tk = tk - _WEEK_S * np.round(tk / _WEEK_S)
    pi = np.pi
    a0 = A_REF_M + eph.delta_a_m
    ak = a0 + eph.a_dot_m_s * tk
    n_a = np.sqrt(GM_GPS_M3_S2 / a0**3) + (eph.delta_n0_sc_s + 0.5 * eph.delta_n0_dot_sc_s2 * tk) * pi
    m = eph.m0_sc * pi + n_a * tk
    ecc = eph.e
    big_e = np.array(m, dtype=float, copy=True)
    for _ in range(10):
        big_e = big_e - (big_e - ecc * np.sin(big_e) - m) / (1 - ecc * np.cos(big_e))
    nu = np.arctan2(np.sqrt(1 - ecc**2) * np.sin(big_e), np.cos(big_e) - ecc)
    phi = nu + eph.omega_sc * pi
    s2, c2 = np.sin(2 * phi), np.cos(2 * phi)
    u = phi + eph.cus_rad * s2 + eph.cuc_rad * c2
    r = ak * (1 - ecc * np.cos(big_e)) + eph.crs_m * s2 + eph.crc_m * c2
    i = eph.i0_sc * pi + eph.i0_dot_sc_s * pi * tk + eph.cis_rad * s2 + eph.cic_rad * c2
    omega_dot = (OMEGA_DOT_REF_SC_S + eph.delta_omega_dot_sc_s) * pi
    node = eph.omega0_sc * pi + (omega_dot - OMEGA_EARTH_RAD_S) * tk - OMEGA_EARTH_RAD_S * eph.toe_s
    x_orb, y_orb = r * np.cos(u), r * np.sin(u)
    cn, sn, ci, si = np.cos(node), np.sin(node), np.cos(i), np.sin(i)
    return np.stack([x_orb * cn - y_orb * ci * sn, x_orb * sn + y_orb * ci * cn, y_orb * si], axis=-1)


# --- clock (message types 30-37) and UTC (type 33) -------------------------------------

#: The clock fields every message type 30-37 carries (IS-GPS-200 Table 30-III, Figures
#: 30-3 to 30-10): name, first bit, width, signed, scale factor.
_CLOCK = (
    ("top_s", 39, 11, False, 300.0),
    ("ura_ned0_index", 50, 5, True, 1.0),
    ("ura_ned1_index", 55, 3, False, 1.0),
    ("ura_ned2_index", 58, 3, False, 1.0),
    ("toc_s", 61, 11, False, 300.0),
    ("af0_s", 72, 26, True, 2.0**-35),
    ("af1_s_s", 98, 20, True, 2.0**-48),
    ("af2_s_s2", 118, 10, True, 2.0**-60),
)
#: The UTC parameters of message type 33 (IS-GPS-200 Table 30-IX, Figure 30-6).
_UTC = (
    ("a0_s", 128, 16, True, 2.0**-35),
    ("a1_s_s", 144, 13, True, 2.0**-51),
    ("a2_s_s2", 157, 7, True, 2.0**-68),
    ("delta_t_ls_s", 164, 8, True, 1.0),
    ("tot_s", 172, 16, False, 16.0),
    ("wn_ot", 188, 13, False, 1.0),
    ("wn_lsf", 201, 13, False, 1.0),
    ("dn", 214, 4, False, 1.0),
    ("delta_t_lsf_s", 218, 8, True, 1.0),
)


@dataclass(frozen=True)
class CnavClock:
    """The SV clock of message types 30-37 (IS-GPS-200 30.3.3.2, Table 30-III): the
    correction :math:`a_{f0} + a_{f1} (t - t_{oc}) + a_{f2} (t - t_{oc})^2` (s), ``toc_s``
    and ``top_s`` seconds of week, the URA_NED indices as broadcast."""

    prn: int
    msg_type: int
    top_s: float
    ura_ned0_index: int
    ura_ned1_index: int
    ura_ned2_index: int
    toc_s: float
    af0_s: float
    af1_s_s: float
    af2_s_s2: float


@dataclass(frozen=True)
class CnavUtc:
    """GPS-UTC parameters of message type 33 (IS-GPS-200 30.3.3.6, Table 30-IX)."""

    a0_s: float
    a1_s_s: float
    a2_s_s2: float
    delta_t_ls_s: int
    tot_s: float
    wn_ot: int
    wn_lsf: int
    dn: int
    delta_t_lsf_s: int


def _checked(msg: CnavMessage, types: tuple[int, ...], name: str) -> None:
    if msg.msg_type not in types:
        which = f"type {types[0]} does" if len(types) == 1 else f"types {types[0]}-{types[-1]} do"
        raise ConfigError(name, f"PRN {msg.prn}: message type {msg.msg_type} carries none ({which})")
    if not msg.crc_ok:
        raise ConfigError(name, f"PRN {msg.prn}: message type {msg.msg_type} failed its CRC-24Q")


def parse_clock(msg: CnavMessage) -> CnavClock:
    """The clock of a message of type 30-37 with a passing CRC; refused in one line otherwise."""
    _checked(msg, tuple(range(30, 38)), "msg")
    return CnavClock(prn=msg.prn, msg_type=msg.msg_type, **_fields(msg.bits, _CLOCK))


def parse_utc(msg: CnavMessage) -> CnavUtc:
    """The UTC parameters of a message of type 33 with a passing CRC; refused in one line otherwise."""
    _checked(msg, (33,), "msg")
    return CnavUtc(**_fields(msg.bits, _UTC))


# --- group delays and ionosphere (type 30) ----------------------------------------------

#: Message type 30's fields after the clock (IS-GPS-200 Table 30-IV, Figure 30-3).
_TYPE30 = (
    ("tgd_s", 128, 13, True, 2.0**-35),
    ("isc_l1ca_s", 141, 13, True, 2.0**-35),
    ("isc_l2c_s", 154, 13, True, 2.0**-35),
    ("isc_l5i5_s", 167, 13, True, 2.0**-35),
    ("isc_l5q5_s", 180, 13, True, 2.0**-35),
    ("alpha0_s", 193, 8, True, 2.0**-30),
    ("alpha1_s_sc", 201, 8, True, 2.0**-27),
    ("alpha2_s_sc2", 209, 8, True, 2.0**-24),
    ("alpha3_s_sc3", 217, 8, True, 2.0**-24),
    ("beta0_s", 225, 8, True, 2.0**11),
    ("beta1_s_sc", 233, 8, True, 2.0**14),
    ("beta2_s_sc2", 241, 8, True, 2.0**16),
    ("beta3_s_sc3", 249, 8, True, 2.0**16),
    ("wnop", 257, 8, False, 1.0),
)
#: The group delay fields, whose bit string 1000000000000 (-4096) means "not available"
#: (IS-GPS-200 30.3.3.3.1.1).
_DELAY_FIELDS = ("tgd_s", "isc_l1ca_s", "isc_l2c_s", "isc_l5i5_s", "isc_l5q5_s")
_NOT_AVAILABLE = -4096


@dataclass(frozen=True)
class CnavGroupDelays:
    """Group delays and Klobuchar coefficients of message type 30 (IS-GPS-200 30.3.3.3.1.1
    and 30.3.3.3.1.2, Table 30-IV): seconds, NaN where broadcast as not available. The user
    of L2C corrects its SV clock by :math:`\\Delta t_{SV} - T_{GD} + ISC_{L2C}` (30.3.3.3.1.1.1);
    ``iono`` holds the Klobuchar coefficients in `lnav.IonoUtc`'s units (L1 delay,
    20.3.3.5.2.5), its UTC fields zero; ``wnop`` the 8-bit week of ``top``."""

    prn: int
    tgd_s: float
    isc_l1ca_s: float
    isc_l2c_s: float
    isc_l5i5_s: float
    isc_l5q5_s: float
    iono: IonoUtc
    wnop: int


def parse_group_delays(msg: CnavMessage) -> CnavGroupDelays:
    """The group delays and Klobuchar coefficients of a type 30 message with a passing CRC;
    refused in one line otherwise."""
    _checked(msg, (30,), "msg")
    v = _fields(msg.bits, _TYPE30)
    for name in _DELAY_FIELDS:
        if v[name] == _NOT_AVAILABLE * 2.0**-35:
            v[name] = float("nan")
    iono = IonoUtc(
        (v["alpha0_s"], v["alpha1_s_sc"], v["alpha2_s_sc2"], v["alpha3_s_sc3"]),
        (v["beta0_s"], v["beta1_s_sc"], v["beta2_s_sc2"], v["beta3_s_sc3"]),
    )
    tgd, l1ca, l2c, l5i5, l5q5 = (float(v[k]) for k in _DELAY_FIELDS)
    return CnavGroupDelays(msg.prn, tgd, l1ca, l2c, l5i5, l5q5, iono, int(v["wnop"]))


def clock_payload(
    record: Ephemerides,
    wn: int,
    iono: IonoUtc | None = None,
    isc_l2c_s: float | None = None,
    *,
    isc_l5i5_s: float | None = None,
) -> np.ndarray:
    """Data bits (39-276) of a message type 30 for the one LNAV-style record ``record``: its
    clock (toc on the 300 s grid, ``top`` = toc, URA_NED indices 0), its T_GD, ``ISC_L1CA``
    zero (an L1 C/A user's clock as LNAV's), ``isc_l2c_s`` (None: sent as not available, so
    an L2C user takes :math:`\\gamma T_{GD}`), ``isc_l5i5_s`` for both L5 ISCs (None: not
    available), the Klobuchar coefficients of
    ``iono`` (None: zeros, which the Klobuchar model turns into its 5 ns night-time delay)
    and ``wn``'s low 8 bits as WNOP. Values are rounded to the scale factors; a value out of
    its field is refused in one line."""
    if record.sv.size != 1:
        raise ConfigError("record", f"needs one record, got {record.sv.size}")
    e = {k: float(v[0]) for k, v in record.elements.items()}
    toc = _on_grid(float(record.toc_s[0]), "toc", record)
    alpha, beta = (iono.alpha, iono.beta) if iono is not None else ((0.0,) * 4, (0.0,) * 4)
    na = _NOT_AVAILABLE * 2.0**-35
    values = {
        "top_s": toc,
        "ura_ned0_index": 0,
        "ura_ned1_index": 0,
        "ura_ned2_index": 0,
        "toc_s": toc,
        "af0_s": e["SVclockBias"],
        "af1_s_s": e["SVclockDrift"],
        "af2_s_s2": e["SVclockDriftRate"],
        "tgd_s": e["TGD"],
        "isc_l1ca_s": 0.0,
        "isc_l2c_s": na if isc_l2c_s is None else isc_l2c_s,
        "isc_l5i5_s": na if isc_l5i5_s is None else isc_l5i5_s,
        "isc_l5q5_s": na if isc_l5i5_s is None else isc_l5i5_s,
        "wnop": wn % 256,
    }
    names = (
        "alpha0_s",
        "alpha1_s_sc",
        "alpha2_s_sc2",
        "alpha3_s_sc3",
        "beta0_s",
        "beta1_s_sc",
        "beta2_s_sc2",
        "beta3_s_sc3",
    )
    values.update(zip(names, (*alpha, *beta)))
    return _payload(_CLOCK + _TYPE30, values, str(record.sv[0]))
