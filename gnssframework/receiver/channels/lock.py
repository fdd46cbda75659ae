r"""Lock detectors and bit synchronisation on a channel's 1 ms prompts.

- Phase-lock indicator (Van Dierendonck 1996; Kaplan & Hegarty, 3rd ed., sec. 8.10):
  :math:`\mathrm{PLI} = \sum (I_P^2 - Q_P^2) / \sum (I_P^2 + Q_P^2)`, the mean of
  :math:`\cos 2\phi` weighted by power; data bits do not change it. In noise it tends to
  :math:`\cos 2\phi \cdot A^2 / (A^2 + 2)` (unit-variance I and Q, :math:`A^2 = 2cT`).
- C/N0 by the narrow-wide power ratio or by moments: `gnssframework.signal.cn0`.
- Bit synchronisation by histogram: every bit change between consecutive 1 ms prompts
  (the prompt turned by more than 90 degrees, :math:`\mathrm{Re}(P_k P_{k-1}^*) < 0`,
  which needs frequency lock only, not phase lock) votes for its millisecond modulo 20;
  the bit edge is the bin that holds ``fraction`` of at least ``min_votes`` votes
  (Parkinson & Spilker 1996, vol. I, ch. 8: the histogram method).
"""

from __future__ import annotations

import numpy as np

from ...signal.cn0 import cn0_moments, cn0_nwpr

__all__ = ["phase_lock_indicator", "estimate_cn0", "cn0_nwpr_bits", "BitSync", "bit_edge_from_votes", "CN0_ESTIMATORS"]

CN0_ESTIMATORS = ("nwpr", "moments")


def phase_lock_indicator(prompts: np.ndarray) -> float:
    """PLI of a window of prompts (1.0: locked in phase, 0: no phase lock)."""
    p = np.asarray(prompts)
    power = np.sum(p.real**2 + p.imag**2)
    return float(np.sum(p.real**2 - p.imag**2) / power) if power > 0 else 0.0


def estimate_cn0(prompts: np.ndarray, estimator: str, bit_phase: int | None) -> float:
    """C/N0 (dB-Hz) of a window of 1 ms prompts.

    ``nwpr`` needs blocks free of bit edges: with the bit phase known (``bit_phase`` = the
    index in ``prompts`` of a bit's first millisecond) it sums bit-aligned 20 ms blocks;
    before bit synchronisation it falls back to ``moments``, which bits do not disturb.
    """
    p = np.asarray(prompts)
    if estimator == "nwpr" and bit_phase is not None and p.size - bit_phase >= 20:
        return float(cn0_nwpr(p[bit_phase:], 1e-3, m=20))
    return float(cn0_moments(p, 1e-3))


def cn0_nwpr_bits(prompts: np.ndarray, bit_phase: np.ndarray, coherent_time_s: float = 1e-3,
                  m: int = 20) -> np.ndarray:
    """C/N0 (dB-Hz) by the narrow-wide power ratio of many channels' windows at once, each
    on the whole bits from its own bit phase on: `gnssframework.signal.cn0.cn0_nwpr` of
    ``prompts[j, bit_phase[j]:]`` for every row ``j`` (Van Dierendonck 1996), in one pass.

    Rows with fewer whole blocks of ``m`` than the longest are padded with blocks whose
    ratio counts as 0 and their mean divides by their own block count (a sum that ends in
    exact zeros is the same sum).

    Parameters
    ----------
    prompts
        ``(n_rows, n)`` windows of prompts, oldest first.
    bit_phase
        ``(n_rows,)`` index in each window of a bit's first prompt; at most ``n - m``.
    """
    p = np.asarray(prompts)
    first = np.asarray(bit_phase, np.int64)
    n = p.shape[1]
    blocks_per_row = (n - first) // m
    k = int(blocks_per_row.max())
    t = np.minimum(first[:, None] + np.arange(k * m), n - 1)  # padding reads the last prompt: masked below
    blocks = np.take_along_axis(p, t, axis=1).reshape(p.shape[0], k, m)
    wbp = np.sum(np.abs(blocks) ** 2, axis=2)
    nbp = np.abs(np.sum(blocks, axis=2)) ** 2
    ratio = np.divide(nbp, wbp, out=np.zeros_like(nbp), where=np.arange(k) < blocks_per_row[:, None])
    mu = np.sum(ratio, axis=1) / blocks_per_row
    return 10.0 * np.log10(np.clip((mu - 1.0) / (m - mu), 1e-12, None) / coherent_time_s)


def bit_edge_from_votes(votes: np.ndarray, min_votes: int, fraction: float = 0.7) -> int | None:
    """The bit edge (ms mod 20) once one bin of the histogram ``votes`` holds ``fraction``
    of at least ``min_votes`` votes, else ``None``."""
    total = int(votes.sum())
    best = int(np.argmax(votes))
    if total >= min_votes and votes[best] >= fraction * total:
        return best
    return None


class BitSync:
    """Histogram of bit changes over the 20 milliseconds of a bit."""

    def __init__(self, min_votes: int = 8, fraction: float = 0.7) -> None:
        self.votes = np.zeros(20, int)
        self.min_votes = min_votes
        self.fraction = fraction
        self.previous = 0j

    def add(self, ms_index: int, prompt: complex) -> int | None:
        """Vote with the prompt of millisecond ``ms_index``; the edge (ms mod 20) once decided."""
        if (prompt * np.conj(self.previous)).real < 0:
            self.votes[ms_index % 20] += 1
        self.previous = prompt
        return self.edge()

    def edge(self) -> int | None:
        return bit_edge_from_votes(self.votes, self.min_votes, self.fraction)
