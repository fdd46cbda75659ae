"""Navigation-data symbols from a tracked channel: its bit-aligned integrations, bit by bit.

After bit synchronisation a channel integrates ``coherent_ms`` (1-20 ms, dividing 20)
from a bit edge on (the ``extended`` stage of
`gnssframework.receiver.channels.SampleTracker`), so each 20 ms bit is the sum of
``20 / coherent_ms`` consecutive rows of its record. A run of such rows without a gap
(a channel that loses lock starts a new run when it is extended again) gives one stream
of soft symbols for the LNAV decoder, and every row its place in the stream: the bit it
belongs to and the milliseconds since that bit's edge (its row starts on a code epoch).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...errors import ConfigError
from ...signal.gps_l1ca import GPS_L1CA
from ...signal.navdata import data_bit_period_s
from ...signal.spec import SignalSpec

__all__ = ["BitRun", "bit_runs", "bit_ms"]


def bit_ms(signal: SignalSpec = GPS_L1CA) -> int:
    """Milliseconds per data bit of ``signal`` (`data_bit_period_s`; 20, C/A code periods,
    per LNAV bit of GPS L1 C/A)."""
    return round(data_bit_period_s(signal) * 1e3)


@dataclass(frozen=True)
class BitRun:
    """One gap-free stream of bits of a channel.

    Attributes
    ----------
    symbols
        ``(B,)`` the in-phase prompt summed over each bit (soft symbols, sign = bit).
    rows
        ``(R,)`` indices of the record rows in the run (``R = B * bit_ms / coherent_ms``).
    bit_of_row
        ``(R,)`` index in ``symbols`` of the bit each row belongs to.
    ms_in_bit
        ``(R,)`` code periods from that bit's edge to the row's first code epoch.
    """

    symbols: np.ndarray
    rows: np.ndarray
    bit_of_row: np.ndarray
    ms_in_bit: np.ndarray


def bit_runs(
    time_s: np.ndarray,
    prompt_i: np.ndarray,
    coherent_ms: np.ndarray,
    bit_aligned: np.ndarray,
    min_bits: int = 1,
    signal: SignalSpec = GPS_L1CA,
) -> list[BitRun]:
    """Split a channel's record into gap-free runs of bit-aligned rows and sum them into bits.

    Parameters
    ----------
    time_s, prompt_i, coherent_ms
        ``(N,)`` columns of the record: each row's start (receive time), in-phase prompt
        and integration length.
    bit_aligned
        ``(N,)`` True for rows integrated from a bit edge on (the ``extended`` stage).
    min_bits
        Shorter runs are left out.
    signal
        The tracked signal: its data bit is `bit_ms` long.
    """
    time_s, prompt_i = np.asarray(time_s, float), np.asarray(prompt_i, float)
    coherent_ms, aligned = np.asarray(coherent_ms, int), np.asarray(bit_aligned, bool)
    if not time_s.shape == prompt_i.shape == coherent_ms.shape == aligned.shape or time_s.ndim != 1:
        raise ConfigError(
            "bit_runs",
            f"columns of one record must be 1-D and of one length, got {time_s.shape}, "
            f"{prompt_i.shape}, {coherent_ms.shape}, {aligned.shape}",
        )
    rows = np.flatnonzero(aligned)
    if rows.size == 0:
        return []
    per_bit_ms = bit_ms(signal)
    if np.any(per_bit_ms % coherent_ms[rows]):
        raise ConfigError("coherent_ms", f"bit-aligned integrations must divide {per_bit_ms} ms")
    # A new run where rows are not consecutive in the record, the integration length changes,
    # or the time step is not the integration length (half a code period of slack).
    t, c = time_s[rows], coherent_ms[rows]
    breaks = (np.diff(rows) != 1) | (np.diff(c) != 0) | (np.abs(np.diff(t) - c[:-1] * 1e-3) > 0.5e-3)
    out = []
    for part in np.split(np.arange(rows.size), np.flatnonzero(breaks) + 1):
        per_bit = per_bit_ms // int(c[part[0]])
        n_bits = part.size // per_bit  # a last bit not wholly integrated is left out
        if n_bits < min_bits:
            continue
        r = rows[part[: n_bits * per_bit]]
        k = np.arange(r.size)
        out.append(
            BitRun(prompt_i[r].reshape(n_bits, per_bit).sum(axis=1), r, k // per_bit, (k % per_bit) * int(c[part[0]]))
        )
    return out
