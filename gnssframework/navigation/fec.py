r"""Forward error correction of navigation messages: the K = 7 rate-1/2 convolutional code,
its Viterbi decoder, the block interleaver and the CRC-24Q.

These are the channel codes of the Galileo I/NAV and F/NAV messages (Galileo OS SIS ICD
Issue 2.0/2.1, 4.1.4 "FEC Coding and Interleaving", 5.1.9.4 "Checksum"); nothing here is
Galileo's beyond the default parameters, so other messages with the same code (SBAS L1,
BeiDou's CRC-24Q users, RTCM 3 frames) can take them.

Convolutional code (ICD 4.1.4.1): constraint length 7, generators
:math:`G_1 = 171_8` and :math:`G_2 = 133_8`, the :math:`G_1` symbol sent first and the
:math:`G_2` symbol inverted. With :math:`u_k` the input bit at step k, the generator's most
significant bit taps :math:`u_k` and its least :math:`u_{k-6}`:

.. math:: c_{1,k} = u_k \oplus u_{k-1} \oplus u_{k-2} \oplus u_{k-3} \oplus u_{k-6},\qquad
          c_{2,k} = \overline{u_k \oplus u_{k-2} \oplus u_{k-3} \oplus u_{k-5} \oplus u_{k-6}}

The register starts at zero and the message ends in six zero tail bits, which bring it back
to zero: the decoder's trellis is terminated at both ends.

Viterbi decoder: maximum likelihood on soft symbols (Viterbi 1967; Proakis, *Digital
Communications*, 8.2), the branch metric the correlation :math:`\sum_j y_j (1 - 2 c_j)`
of the received values :math:`y` (bit 0 sent as +1) with the branch's symbols, which is
the log-likelihood up to constants on an AWGN channel; hard decisions (±1) give the
minimum-Hamming-distance path. The add-compare-select runs over the 64 states and every
block of a batch at once, one NumPy step per trellis step.

Block interleaver (ICD 4.1.4.2): the coded symbols are written column by column into a
matrix of ``cols`` columns and ``rows`` rows and read out row by row (I/NAV: 30 columns,
8 rows, 240 symbols).

CRC-24Q (ICD 5.1.9.4; RTCM 10403.3 4.2): :math:`G(X) = (1+X) P(X)`, the polynomial
``0x1864CFB``, initial value 0, no reflection, no final XOR; the parity bits are the
remainder of :math:`m(X) X^{24}` divided by :math:`G(X)`, the first message bit the most
significant. Leading zero bits leave it unchanged, so a message of any bit length is padded
in front to whole bytes.
"""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError

__all__ = [
    "G1",
    "G2",
    "CONSTRAINT_LENGTH",
    "conv_encode",
    "viterbi_decode",
    "interleave",
    "deinterleave",
    "crc24q_bits",
    "CRC24Q_POLY",
    "real_symbols",
]

#: Generator polynomials of the Galileo I/NAV and F/NAV convolutional code (ICD 4.1.4.1), octal 171 and 133.
G1 = 0o171
G2 = 0o133
#: Constraint length: the current bit and six earlier ones.
CONSTRAINT_LENGTH = 7
#: CRC-24Q generator polynomial with its X^24 term (ICD 5.1.9.4).
CRC24Q_POLY = 0x1864CFB

_N_STATES = 1 << (CONSTRAINT_LENGTH - 1)


def _parity(x: np.ndarray) -> np.ndarray:
    x = np.asarray(x, dtype=np.int64)
    out = np.zeros_like(x)
    for k in range(CONSTRAINT_LENGTH):
        out ^= (x >> k) & 1
    return out


def _bits(bits: np.ndarray, name: str) -> np.ndarray:
    b = np.asarray(bits)
    if b.ndim == 0 or b.shape[-1] == 0:
        raise ConfigError(name, f"needs at least one bit, got shape {b.shape}")
    if not np.isin(b, (0, 1)).all():
        raise ConfigError(name, "bits must be 0 or 1")
    return b.astype(np.uint8)


def conv_encode(
    bits: np.ndarray, generators: tuple[int, int] = (G1, G2), inverted: tuple[bool, bool] = (False, True)
) -> np.ndarray:
    """Coded symbols (0/1) of ``bits`` (``(..., n)``, 0/1) from a zero register: ``(..., 2n)``,
    the two generators' symbols of each bit in turn, each XOR 1 where ``inverted``.

    Written as the convolution of the bit sequence with each generator's taps (the
    generator's bit ``6 - d`` multiplies :math:`u_{k-d}`), modulo 2.
    """
    u = _bits(bits, "bits")
    n = u.shape[-1]
    padded = np.concatenate([np.zeros(u.shape[:-1] + (CONSTRAINT_LENGTH - 1,), np.uint8), u], axis=-1)
    out = np.empty(u.shape[:-1] + (2 * n,), dtype=np.uint8)
    for j, (g, inv) in enumerate(zip(generators, inverted)):
        c = np.full(u.shape, int(inv), dtype=np.uint8)
        for d in range(CONSTRAINT_LENGTH):
            if (g >> (CONSTRAINT_LENGTH - 1 - d)) & 1:
                c ^= padded[..., CONSTRAINT_LENGTH - 1 - d : CONSTRAINT_LENGTH - 1 - d + n]
        out[..., j::2] = c
    return out


def _branch_symbols(generators: tuple[int, int], inverted: tuple[bool, bool]) -> np.ndarray:
    """``(128, 2)`` ±1 symbols sent for each register value r = (u_k, u_{k-1}, ..., u_{k-6})."""
    r = np.arange(1 << CONSTRAINT_LENGTH)
    c = np.stack([_parity(r & g) ^ int(inv) for g, inv in zip(generators, inverted)], axis=-1)
    return 1.0 - 2.0 * c


def viterbi_decode(
    symbols: np.ndarray,
    generators: tuple[int, int] = (G1, G2),
    inverted: tuple[bool, bool] = (False, True),
    terminated: bool = True,
    start_known: bool = True,
) -> np.ndarray:
    """Maximum-likelihood bits ``(..., n)`` (0/1) of soft symbols ``(..., 2n)`` (bit 0 sent as +1).

    Parameters
    ----------
    symbols
        Received values in the encoder's order (``conv_encode``), any real scale: ±1 hard
        decisions or the prompt correlator's in-phase sums (their sign and size).
    terminated
        The block ends with K - 1 = 6 zero tail bits (the trellis ends in state 0), as every
        I/NAV and F/NAV page part does; False takes the best metric at the end.
    start_known
        The register starts at zero (a block code, as I/NAV's parts); False starts every
        state with one metric, for a window cut out of a continuous stream (SBAS L1; GPS
        CNAV, IS-GPS-200 3.3.3.1.1), whose first bits then decode from the symbols alone.

    Returns
    -------
    ``(..., n)`` decoded bits, tail bits included.
    """
    y = np.asarray(symbols, dtype=float)
    if y.ndim == 0 or y.shape[-1] == 0 or y.shape[-1] % 2:
        raise ConfigError("symbols", f"a rate-1/2 block has an even, non-zero number of symbols, got shape {y.shape}")
    if not np.all(np.isfinite(y)):
        raise ConfigError("symbols", "must be finite real numbers")
    batch = y.shape[:-1]
    y = y.reshape(-1, y.shape[-1] // 2, 2)
    m, n = y.shape[0], y.shape[1]
    # Branch metrics of every register value at every step: (m, n, 128).
    bm = np.einsum("mkj,rj->mkr", y, _branch_symbols(generators, inverted))
    ns = np.arange(_N_STATES)
    metric = np.full((m, _N_STATES), -np.inf)
    metric[:, 0 if start_known else slice(None)] = 0.0
    # State s = (u_{k-1}, ..., u_{k-6}) as 6 bits, u_{k-1} the most significant; entering state
    # ns comes from predecessor ((ns & 31) << 1) | b with register value 2 ns + b.
    pred = ((ns & (_N_STATES // 2 - 1)) << 1)[None, :]
    decisions = np.empty((n, m, _N_STATES), dtype=bool)
    for k in range(n):  # the trellis recursion is sequential; states and blocks are vectorised
        cand0 = metric[:, pred[0]] + bm[:, k, 2 * ns]
        cand1 = metric[:, pred[0] | 1] + bm[:, k, 2 * ns + 1]
        decisions[k] = cand1 > cand0
        metric = np.where(decisions[k], cand1, cand0)
    state = np.zeros(m, dtype=np.int64) if terminated else np.argmax(metric, axis=1)
    bits = np.empty((m, n), dtype=np.uint8)
    rows = np.arange(m)
    for k in range(n - 1, -1, -1):
        bits[:, k] = state >> (CONSTRAINT_LENGTH - 2)
        state = ((state & (_N_STATES // 2 - 1)) << 1) | decisions[k, rows, state]
    return bits.reshape(batch + (n,))


def interleave(symbols: np.ndarray, rows: int = 8, cols: int = 30) -> np.ndarray:
    """Block interleaving (ICD 4.1.4.2): ``(..., rows*cols)`` written column by column into
    ``cols`` columns of ``rows``, read row by row."""
    s = np.asarray(symbols)
    if s.ndim == 0 or s.shape[-1] != rows * cols:
        raise ConfigError(
            "symbols", f"a {cols} x {rows} block interleaver takes {rows * cols} symbols, got shape {s.shape}"
        )
    return np.swapaxes(s.reshape(s.shape[:-1] + (cols, rows)), -1, -2).reshape(s.shape)


def deinterleave(symbols: np.ndarray, rows: int = 8, cols: int = 30) -> np.ndarray:
    """Inverse of :func:`interleave`: ``(..., rows*cols)`` read as ``rows`` rows of ``cols``,
    returned column by column."""
    s = np.asarray(symbols)
    if s.ndim == 0 or s.shape[-1] != rows * cols:
        raise ConfigError(
            "symbols", f"a {cols} x {rows} block de-interleaver takes {rows * cols} symbols, got shape {s.shape}"
        )
    return np.swapaxes(s.reshape(s.shape[:-1] + (rows, cols)), -1, -2).reshape(s.shape)


def _crc_table() -> np.ndarray:
    table = np.zeros(256, dtype=np.int64)
    for byte in range(256):
        crc = byte << 16
        for _ in range(8):
            crc <<= 1
            if crc & 0x1000000:
                crc ^= CRC24Q_POLY
        table[byte] = crc & 0xFFFFFF
    return table


_CRC_TABLE = _crc_table()


def crc24q_bits(bits: np.ndarray) -> np.ndarray:
    """CRC-24Q (ICD 5.1.9.4) of messages of bits ``(..., n)`` (0/1, first bit the most
    significant): ``(...)`` integers below 2^24. Table-driven a byte at a time over the batch."""
    b = _bits(bits, "bits")
    pad = (-b.shape[-1]) % 8
    b = np.concatenate([np.zeros(b.shape[:-1] + (pad,), np.uint8), b], axis=-1)
    data = np.packbits(b, axis=-1).astype(np.int64)
    crc = np.zeros(b.shape[:-1], dtype=np.int64)
    for j in range(data.shape[-1]):
        crc = ((crc << 8) & 0xFFFFFF) ^ _CRC_TABLE[((crc >> 16) ^ data[..., j]) & 0xFF]
    return crc


def real_symbols(symbols: np.ndarray, what: str = "one satellite's stream") -> np.ndarray:
    """``symbols`` as a 1-D float array (±1 or a prompt's in-phase sums), refused in one line
    naming ``symbols`` when not 1-D, complex or not finite."""
    s = np.asarray(symbols)
    if s.ndim != 1:
        raise ConfigError("symbols", f"{what} is 1-D, got shape {s.shape}")
    if np.iscomplexobj(s) or not np.all(np.isfinite(s)):
        raise ConfigError("symbols", "must be finite real numbers (±1 or the prompt's in-phase sums)")
    return s.astype(float)
