r"""Lock detectors and bit synchronisation on a channel's one-code-period prompts (1 ms on L1 C/A).

- Phase-lock indicator (Van Dierendonck 1996; Kaplan & Hegarty, 3rd ed., sec. 8.10):
  :math:`\mathrm{PLI} = \sum (I_P^2 - Q_P^2) / \sum (I_P^2 + Q_P^2)`, the mean of
  :math:`\cos 2\phi` weighted by power; data bits do not change it. In noise it tends to
  :math:`\cos 2\phi \cdot A^2 / (A^2 + 2)` (unit-variance I and Q, :math:`A^2 = 2cT`).
- C/N0 by the narrow-wide power ratio or by moments: `gnssframework.signal.cn0`; or by
  any ``cn0_estimator`` plugin that reads the prompt only (`cn0_estimator_names`), on the
  whole window (docs/receiver/cn0-estimators.md: their bias and noise floor). The
  estimators measure the tracked component's C/N0; the detectors report the signal's
  (`signal_cn0_dbhz`): the same for a signal sent in every slot (L1 C/A), twice CM's on
  GPS L2C, whose CM and CL share the slots (IS-GPS-200, sec. 3.2.1.3) and the power
  (`GPS_L2C`), as the acquisition's C/N0 and the IF generator's ``cn0_dbhz`` do.
- Bit synchronisation by histogram: every bit change between consecutive 1 ms prompts
  (the prompt turned by more than 90 degrees, :math:`\mathrm{Re}(P_k P_{k-1}^*) < 0`,
  which needs frequency lock only, not phase lock) votes for its millisecond modulo 20;
  the bit edge is the bin that holds ``fraction`` of at least ``min_votes`` votes
  (Parkinson & Spilker 1996, vol. I, ch. 8: the histogram method).

The code period and the code periods per data symbol (1 ms and 20 on L1 C/A) are read
from the channel's `SignalSpec` (GPS L1 C/A by default).
"""

from __future__ import annotations

from functools import cache

import numpy as np

from ... import registry
from ...errors import ConfigError
from ...signal.cn0 import cn0_moments, cn0_nwpr
from ...signal.gps_l1ca import GPS_L1CA
from ...signal.spec import SignalSpec

__all__ = [
    "phase_lock_indicator",
    "window_detectors",
    "estimate_cn0",
    "signal_cn0_dbhz",
    "nwpr_block",
    "cn0_nwpr_bits",
    "BitSync",
    "bit_edge_from_votes",
    "bit_edge_by_energy",
    "CN0_ESTIMATORS",
    "cn0_estimator_names",
    "cn0_plugin",
]

#: The receiver's own estimators: ``nwpr`` on bit-aligned blocks after bit synchronisation
#: (moments before), ``moments``. Any other name is a ``cn0_estimator`` plugin.
CN0_ESTIMATORS = ("nwpr", "moments")


def cn0_estimator_names() -> list[str]:
    """Every name the lock detector takes: `CN0_ESTIMATORS`, then the registered
    ``cn0_estimator`` plugins that read the prompt only and are blind to data bits (the
    sample tracker has no noise-only correlator, and its window's prompts keep their bits;
    its own ``nwpr`` aligns its blocks with them)."""
    plugins = [
        n
        for n in registry.names("cn0_estimator")
        if (cls := registry.get("cn0_estimator", n)).needs == ("prompt",) and cls.bit_blind
    ]
    return list(dict.fromkeys([*CN0_ESTIMATORS, *plugins]))


@cache
def cn0_plugin(name: str):
    """The ``cn0_estimator`` plugin ``name`` with its default parameters (created once)."""
    return registry.create("cn0_estimator", name)


def phase_lock_indicator(prompts: np.ndarray) -> float:
    """PLI of a window of prompts (1.0: locked in phase, 0: no phase lock)."""
    p = np.asarray(prompts)
    power = np.sum(p.real**2 + p.imag**2)
    return float(np.sum(p.real**2 - p.imag**2) / power) if power > 0 else 0.0


def _periods_per_symbol(signal: SignalSpec) -> int:
    m = signal.code_periods_per_symbol
    if m is None:
        raise ConfigError("signal", f"{signal.name} carries no data symbols: no bit synchronisation")
    return m


def nwpr_block(signal: SignalSpec) -> int | None:
    """Prompts per NWPR block on ``signal``: its code periods per symbol (20 on L1 C/A), or
    None where the narrow-wide ratio has nothing to compare (no data symbols, or a symbol
    of one code period, as Galileo E1-B's 4 ms: NBP = WBP)."""
    m = signal.code_periods_per_symbol
    return m if m is not None and m >= 2 else None


def signal_cn0_dbhz(component_cn0_dbhz, signal: SignalSpec):
    r"""The signal's C/N0 (dB-Hz) from its tracked component's:
    :math:`C/N_0 = (C/N_0)_{comp} / d`, :math:`d` the component's share of the time
    (`SignalSpec.replica_duty`: 1 for L1 C/A, 1/2 for GPS L2 CM, whose slots alternate with
    CL's, IS-GPS-200 sec. 3.2.1.3, at the same power), so :math:`-10 \log_{10} d` dB more;
    the acquisition's C/N0 divides its block energy by the same duty."""
    return component_cn0_dbhz - 10.0 * np.log10(signal.replica_duty)


def estimate_cn0(prompts: np.ndarray, estimator: str, bit_phase: int | None, signal: SignalSpec = GPS_L1CA) -> float:
    """C/N0 (dB-Hz) of a window of one-code-period prompts (1 ms on L1 C/A).

    ``nwpr`` needs blocks free of bit edges: with the bit phase known (``bit_phase`` = the
    index in ``prompts`` of a bit's first code period) it sums bit-aligned blocks of one
    symbol (20 ms on L1 C/A); before bit synchronisation, or on a signal without data
    symbols or with one code period per symbol (`nwpr_block`), it falls back to
    ``moments``, which bits do not disturb. Any other name is a
    ``cn0_estimator`` plugin on the whole window (`cn0_estimator_names`).
    The signal's C/N0 (`signal_cn0_dbhz`) of the component's estimate.
    """
    p = np.asarray(prompts)
    period_s = signal.code_period_s
    if estimator not in CN0_ESTIMATORS:
        return float(signal_cn0_dbhz(cn0_plugin(estimator)(p, period_s), signal))
    m = nwpr_block(signal)
    if estimator == "nwpr" and m is not None and bit_phase is not None and p.size - bit_phase >= m:
        return float(signal_cn0_dbhz(cn0_nwpr(p[bit_phase:], period_s, m=m), signal))
    return float(signal_cn0_dbhz(cn0_moments(p, period_s), signal))


def cn0_nwpr_bits(prompts: np.ndarray, bit_phase: np.ndarray, coherent_time_s: float = 1e-3, m: int = 20) -> np.ndarray:
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
    if m < 2:
        raise ConfigError("m", f"the narrow-wide ratio needs at least 2 prompts per block, got {m} (`nwpr_block`)")
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
    """The bit edge (code period modulo the periods of a bit: ms mod 20 on L1 C/A) once one bin of the histogram ``votes`` holds ``fraction``
    of at least ``min_votes`` votes, else ``None``."""
    total = int(votes.sum())
    best = int(np.argmax(votes))
    if total >= min_votes and votes[best] >= fraction * total:
        return best
    return None


def bit_edge_by_energy(prompts: np.ndarray, first_period: int, per_bit: int, min_bits: int) -> int | None:
    r"""The bit edge (code period modulo ``per_bit``) that maximises the energy of whole-bit
    coherent sums over a window of prompts, or ``None`` with fewer than ``min_bits`` whole
    bits for some candidate.

    For each candidate edge :math:`e` the window's whole bits starting at periods
    :math:`\equiv e` are summed coherently and their powers added,
    :math:`E_e = \sum_b |\sum_{k \in b} P_k|^2`; the aligned candidate holds every bit's
    full energy, a candidate :math:`d` periods off loses :math:`(2d/N)` of the amplitude on
    every bit that changes sign (Kaplan & Hegarty, *Understanding GPS/GNSS*, 3rd ed., sec.
    8.9: the maximum-likelihood bit synchroniser). Unlike the histogram of sign changes
    between 1 ms prompts (`BitSync`), which needs each change to stand out of one period's
    noise, it integrates every period of the window. Over 400 ms of random bits (measured,
    200 windows a point) the histogram decides right in none at 34 dB-Hz, 64 % at 36 and
    97.5 % at 38; this in all of them from 32 dB-Hz up, and at 30 dB-Hz within one period
    (`tests/receiver/test_bit_sync_energy.py`).

    Parameters
    ----------
    prompts
        ``(W,)`` complex prompts of consecutive code periods, oldest first.
    first_period
        Index (in the channel's period count) of ``prompts[0]``.
    per_bit
        Code periods per data bit (20 on L1 C/A).
    min_bits
        Whole bits each candidate must hold before a decision.
    """
    p = np.asarray(prompts, complex)
    # Every candidate sums the same number of whole bits: (W - N + 1) // N. A candidate with
    # one bit more than the others would gain its energy whatever the signal.
    bits = (p.size - per_bit + 1) // per_bit
    if bits < min_bits:
        return None
    csum = np.concatenate(([0j], np.cumsum(p)))
    starts = np.arange(bits * per_bit)
    power = np.abs(csum[starts + per_bit] - csum[starts]) ** 2
    energy = np.bincount((first_period + starts) % per_bit, weights=power, minlength=per_bit)
    return int(np.argmax(energy))


class BitSync:
    """Histogram of bit changes over the code periods of a bit (the 20 milliseconds of an
    L1 C/A bit; ``signal.code_periods_per_symbol``)."""

    def __init__(self, min_votes: int = 8, fraction: float = 0.7, signal: SignalSpec = GPS_L1CA) -> None:
        self.votes = np.zeros(_periods_per_symbol(signal), int)
        self.min_votes = min_votes
        self.fraction = fraction
        self.previous = 0j

    def add(self, ms_index: int, prompt: complex) -> int | None:
        """Vote with the prompt of code period ``ms_index``; the edge (period modulo the
        periods of a bit) once decided."""
        if (prompt * np.conj(self.previous)).real < 0:
            self.votes[ms_index % self.votes.size] += 1
        self.previous = prompt
        return self.edge()

    def edge(self) -> int | None:
        return bit_edge_from_votes(self.votes, self.min_votes, self.fraction)


def window_detectors(
    win: np.ndarray, bit_phases: list[int | None], lock_window_ms: int, estimator: str, signal: SignalSpec
) -> tuple[np.ndarray, np.ndarray]:
    r"""Phase lock indicator and C/N0 (dB-Hz) of channels with full prompt windows, in one pass.

    Parameters
    ----------
    win
        ``(n_channels, size)`` complex prompts, one code period each, oldest first.
    bit_phases
        Per channel, the index in its window of a data bit's first period (None: no bit sync).
    lock_window_ms
        Periods (the last ones) the phase lock indicator uses:
        :math:`(\sum I^2 - Q^2) / (\sum I^2 + Q^2)` (0 where the power is 0).
    estimator
        ``"nwpr"``: narrow-wide power ratio on each synchronised channel's whole bits
        (`cn0_nwpr_bits`), moments (`cn0_moments`, which need no bit phase) on the others;
        ``"moments"`` on every channel; another name: the registered ``cn0_estimator`` plugin
        on every channel's whole window.
    signal
        The tracked signal (its code period and periods per symbol).

    Returns
    -------
    pli, cn0_dbhz
        ``(n_channels,)`` each; the C/N0 the signal's (`signal_cn0_dbhz`).
    """
    size = win.shape[1]
    lock = win[:, size - min(lock_window_ms, size) :]
    power = np.sum(lock.real**2 + lock.imag**2, axis=1)
    pli = np.sum(lock.real**2 - lock.imag**2, axis=1) / np.where(power > 0, power, 1.0)
    pli[power <= 0] = 0.0
    cn0 = np.zeros(len(win))
    per_bit = nwpr_block(signal)
    period_s = signal.code_period_s
    nwpr = [
        j
        for j, bp in enumerate(bit_phases)
        if estimator == "nwpr" and per_bit is not None and bp is not None and size - bp >= per_bit
    ]
    rest = sorted(set(range(len(win))) - set(nwpr))
    if estimator not in CN0_ESTIMATORS:  # a cn0_estimator plugin: every channel's whole window
        rest, cn0 = [], cn0_plugin(estimator)(win, period_s)
    if rest:
        cn0[rest] = cn0_moments(win[rest].T, period_s)
    if nwpr:
        phases = np.array([bit_phases[j] for j in nwpr])
        cn0[nwpr] = cn0_nwpr_bits(win[nwpr], phases, period_s, m=per_bit if per_bit is not None else 20)
    return pli, signal_cn0_dbhz(cn0, signal)
