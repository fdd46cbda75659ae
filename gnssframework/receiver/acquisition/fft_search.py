r"""Parallel code-phase search: one FFT correlation per Doppler bin and coherent block.

For a block :math:`x_k[n]` of :math:`N` samples (the coherent time), the circular
correlation with the sampled code :math:`c[n]` at every lag at once is

.. math:: z_k[s] = \mathrm{IFFT}\big(\mathrm{FFT}(x_k[n] e^{-j 2\pi (f_{IF} + f_D) t_n})
          \cdot \overline{\mathrm{FFT}(c[n])}\big)[s]

(Borre et al., *A Software-Defined GPS and Galileo Receiver*, 2007, sec. 6.3; van
Nee & Coenen 1991). The Doppler-wiped blocks' FFTs do not depend on the PRN, so they are
computed once for every satellite.

The replica :math:`c[n]` is the searched signal's spreading waveform
(`SignalSpec.spreading_table`: the code for BPSK, code times sub-carrier for BOC), so
the search is the same for every signal a `SignalSpec` describes (a BOC signal is then
searched with its full, narrow-peaked correlation: the lag grid must resolve its peak,
two samples a sub-chip or more).

A BOC signal can instead be searched *BPSK-like* (``bpsk_like``): its code without the
sub-carrier, shifted to the upper and to the lower sub-carrier frequency, is correlated
with the samples and the two powers are summed,

.. math:: S = \sum_k \big(|z^{+}_k[s]|^2 + |z^{-}_k[s]|^2\big), \qquad
          r^{\pm}[n] = c(\lfloor x_n \rfloor)\, e^{\pm j 2\pi (m/n) x_n}

at code phase :math:`x_n` chips (Martin, Heiries, Julien, Macabiau, "BOC(x,y) signal
acquisition techniques and performances", ION GPS/GNSS 2003; Betz, *Engineering Satellite-
Based Navigation and Timing*, 2016, ch. 19). Each side band's correlation with a BOC(m,n)
signal is the BPSK triangle, a chip wide either side, not the BOC triangle train: no side
peaks, and a coarse lag grid straddles less of it. Each side band holds :math:`4/\pi^2` of a
sine-phased BOC's power (`sideband_power_fraction`), so the two cost 0.9 dB against the
matched replica when the grid is on the peak, and their noise is independent where the
sample rate does not alias :math:`2 f_{sc}` to zero (`sideband_overlap`).
"""

from __future__ import annotations

import numpy as np
from scipy import fft

from ...signal.gps_l1ca import GPS_L1CA
from ...signal.spec import SignalSpec

__all__ = [
    "code_replica",
    "sideband_replicas",
    "sideband_overlap",
    "sideband_power_fraction",
    "search_grid",
    "fine_doppler",
    "first_period_lag",
    "overlay_refine_periods",
    "overlay_doppler",
]

#: Complex elements of one Doppler chunk of wiped blocks (8 MB of complex64: bounds the
#: memory of a search, whose transients are a few times this; the FFTs of a row do not
#: depend on the chunk).
_CHUNK_ELEMENTS = 1 << 20
#: Largest set of residue spectra `_DopplerSpectra` shifts from (complex elements, 32 MB of
#: complex64; two 80 ms blocks' worth at 26 MHz): a grid with more residues is wiped per bin.
_RESIDUE_ELEMENTS = 1 << 22


def code_replica(
    prn: int, n_samples: int, sample_rate_hz: float, chip_offset: float = 0.0, signal: SignalSpec = GPS_L1CA
) -> np.ndarray:
    """``n_samples`` of ``signal``'s spreading waveform of ``prn`` (the ±1 code for BPSK)
    sampled at ``sample_rate_hz``, chip 0 at sample 0 (``float32``)."""
    chips = chip_offset + np.arange(n_samples) * (signal.chip_rate_hz / sample_rate_hz)
    return signal.spreading_at(signal.spreading_table(prn), chips).astype(np.float32)


def sideband_replicas(
    prn: int, n_samples: int, sample_rate_hz: float, signal: SignalSpec, chip_offset: float = 0.0
) -> np.ndarray:
    r"""``(2, n_samples)`` ``complex64``: the BPSK-like search's replicas of ``prn``, the
    tracked component's code without its sub-carrier times :math:`e^{+j 2\pi (m/n) x}`
    (upper side band) and :math:`e^{-j 2\pi (m/n) x}` (lower), at code phase :math:`x`
    chips (chip 0 at sample 0, as `code_replica`); :math:`m/n` sub-carrier cycles a chip
    (one for BOC(1,1), the main term of CBOC(6,1,1/11))."""
    chips = chip_offset + np.arange(n_samples) * (signal.chip_rate_hz / sample_rate_hz)
    code = signal.code(prn).astype(np.float64)
    c = code[np.floor(chips).astype(np.int64) % code.size]
    turns = (signal.subcarrier.m / signal.subcarrier.n) * chips
    upper = c * np.exp(2j * np.pi * (turns - np.floor(turns)))
    return np.stack([upper, upper.conj()]).astype(np.complex64)


def sideband_overlap(n_samples: int, sample_rate_hz: float, signal: SignalSpec) -> float:
    r""":math:`|\langle r^+, r^- \rangle| / n`, the normalised inner product of the two side
    bands' replicas over a block: the correlation of their noises. It is
    :math:`|\frac{1}{n}\sum_n e^{j 4\pi f_{sc} t_n}|`, near 0 unless the sample rate aliases
    :math:`2 f_{sc}` to zero (2.046 MHz for BOC(1,1): both replicas the same), where the
    summed statistic is no longer chi-square with :math:`4K` degrees of freedom."""
    chips = np.arange(n_samples) * (signal.chip_rate_hz / sample_rate_hz)
    turns = 2.0 * (signal.subcarrier.m / signal.subcarrier.n) * chips
    return float(np.abs(np.mean(np.exp(2j * np.pi * (turns - np.floor(turns))))))


def sideband_power_fraction(prn: int, n_samples: int, sample_rate_hz: float, signal: SignalSpec) -> float:
    r"""Share of the signal's power the two side bands' correlations hold together, on the
    peak: :math:`g = \sum_\pm |\langle s, r^\pm\rangle|^2 / (\|s\|^2 \|r^\pm\|^2)` with
    :math:`s` the signal's sampled spreading waveform (`code_replica`). A sine-phased
    BOC(1,1) gives :math:`2 \cdot 4/\pi^2 = 0.81` (each side band the square wave's
    fundamental, amplitude :math:`2/\pi`), CBOC(6,1,1/11) :math:`10/11` of that. The
    BPSK-like search's C/N0 divides it out, as the full search's divides out the duty."""
    s = code_replica(prn, n_samples, sample_rate_hz, signal=signal).astype(np.float64)
    r = sideband_replicas(prn, n_samples, sample_rate_hz, signal).astype(np.complex128)
    inner = r.conj() @ s
    return float(np.sum(np.abs(inner) ** 2) / (s @ s * n_samples))


def _replicas(
    prn: int, n: int, sample_rate_hz: float, signal: SignalSpec, bpsk_like: bool, chip_offset: float = 0.0
) -> np.ndarray:
    """``(S, n)`` replicas a search correlates with: the spreading waveform (``S = 1``) or
    the two side bands (``bpsk_like``), chip ``chip_offset`` at sample 0."""
    if bpsk_like:
        return sideband_replicas(prn, n, sample_rate_hz, signal, chip_offset)
    return code_replica(prn, n, sample_rate_hz, chip_offset, signal=signal)[None]


def _blocks(samples: np.ndarray, n: int, noncoherent: int) -> np.ndarray:
    return np.asarray(samples[: n * noncoherent]).reshape(noncoherent, n)


def _wiped_spectra(blocks: np.ndarray, dopplers_hz: np.ndarray, sample_rate_hz: float, if_hz: float) -> np.ndarray:
    """``(n_doppler, K, N)`` FFTs of the blocks after carrier wipe-off (time continuous across blocks).

    The carrier's phase is computed in cycles in ``float64`` and reduced to one cycle before
    a ``float32`` cosine and sine (the phase of sample 80 ms into a 4 MHz IF is 3e5 cycles:
    reduced first, its ``float32`` angle is within 5e-7 rad of the exact one): with the
    FFTs, half the time of a ``complex128`` ``exp`` for the same ``complex64`` replica
    (`benchmarks/acquisition.py`).
    """
    K, N = blocks.shape
    cycles = np.multiply.outer(if_hz + dopplers_hz, np.arange(K * N) / sample_rate_hz)
    angle = (2.0 * np.pi) * (cycles - np.floor(cycles)).astype(np.float32)
    carrier = np.empty(angle.shape, np.complex64)
    carrier.real = np.cos(angle)
    carrier.imag = -np.sin(angle)
    return fft.fft(blocks[None].astype(np.complex64) * carrier.reshape(-1, K, N), axis=-1, workers=1)


class _DopplerSpectra:
    r"""The wiped blocks' FFTs of every Doppler bin of a `search_grid` call (for all its PRNs),
    made, where the bins lie whole DFT bins apart, by shifting a few.

    A Doppler :math:`f_r + m f_s/N` (:math:`f_s/N` the DFT's bin, :math:`1/T` for a block
    of :math:`T` s) wipes block :math:`k` with :math:`e^{-j2\pi f_r t_n}
    e^{-j2\pi m (kN + n)/N} = e^{-j2\pi f_r t_n} e^{-j2\pi m n/N}`: the residue's wiped
    spectrum shifted by :math:`m` bins, :math:`W_m[q] = W_0[(q + m) \bmod N]` (the DFT's shift
    theorem; the block's own phase :math:`e^{-j2\pi m k}` is 1). A grid at half-bin steps
    (the searches' default :math:`1/(2T)`) has two residues: two carriers and FFTs per
    search instead of one per bin. Bins that are not whole DFT bins apart (a block of
    :math:`N = \mathrm{round}(T f_s)` samples with :math:`T f_s` not whole), or whose residues'
    spectra would hold more than `_RESIDUE_ELEMENTS`, are wiped each on its own
    (`_wiped_spectra`).
    """

    def __init__(self, blocks: np.ndarray, dopplers_hz: np.ndarray, sample_rate_hz: float, if_hz: float) -> None:
        self.blocks, self.fs, self.if_hz = blocks, float(sample_rate_hz), float(if_hz)
        self.dopplers_hz = np.asarray(dopplers_hz, float)
        n = blocks.shape[1]
        bin_hz = self.fs / n
        whole = np.floor(self.dopplers_hz / bin_hz + 1e-9)
        key = np.round(self.dopplers_hz / bin_hz - whole, 6)
        residues, first, self.residue_of = np.unique(key, return_index=True, return_inverse=True)
        self.base = None
        if residues.size < self.dopplers_hz.size and residues.size * blocks.size <= _RESIDUE_ELEMENTS:
            self.base = _wiped_spectra(blocks, self.dopplers_hz[first], self.fs, self.if_hz)
            # Each bin's shift from its residue's first bin, exact when the grid is whole bins apart.
            shift = (self.dopplers_hz - self.dopplers_hz[first][self.residue_of]) / bin_hz
            self.shift = np.rint(shift).astype(np.int64)
            if not np.allclose(shift, self.shift, rtol=0, atol=1e-6):
                self.base = None

    def chunk(self, lo: int, hi: int) -> np.ndarray:
        """``(hi - lo, K, N)`` spectra of bins ``lo`` to ``hi``."""
        if self.base is None:
            return _wiped_spectra(self.blocks, self.dopplers_hz[lo:hi], self.fs, self.if_hz)
        n = self.blocks.shape[1]
        out = np.empty((len(self.shift[lo:hi]),) + self.base.shape[1:], self.base.dtype)
        # W_m[q] = W_0[(q + m) mod N]: two slice copies a bin (a gather by an index array
        # took ten times as long, a third of a 20 ms code's search)
        for row, residue, m in zip(out, self.residue_of[lo:hi], self.shift[lo:hi] % n):
            row[:, : n - m] = self.base[residue, :, m:]
            row[:, n - m :] = self.base[residue, :, :m]
        return out


def first_period_lag(lag: int, sample_rate_hz: float, signal: SignalSpec = GPS_L1CA) -> int:
    """The first sample at which a code period starts, from a peak ``lag`` of a search grid.

    A block of several code periods (10 ms of the 1 ms C/A code) correlates equally at every
    period's start: its grid holds a copy of the peak one period apart, and which copy the
    argmax takes is decided by rounding (another arithmetic, another CPU, another copy). The
    copies are one start: this is the first, ``lag`` modulo the samples of a code period
    (`AcquisitionResult.code_phase_samples`), rounded to a sample.
    """
    per_code = sample_rate_hz * signal.code_length_chips / signal.chip_rate_hz
    return int(np.rint(lag % per_code)) % max(1, int(np.rint(per_code)))


def _sum_blocks(power: np.ndarray, alternate: bool) -> np.ndarray:
    """:math:`\\sum_k` over axis 1 of ``power``, or with ``alternate`` the larger of the sums
    over the even and over the odd blocks (`search_grid`)."""
    if not alternate:
        return np.sum(power, axis=1)
    return np.maximum(np.sum(power[:, 0::2], axis=1), np.sum(power[:, 1::2], axis=1))


def search_grid(
    samples: np.ndarray,
    sample_rate_hz: float,
    if_hz: float,
    prns: tuple[int, ...],
    coherent_time_s: float,
    noncoherent: int,
    dopplers_hz: np.ndarray,
    alternate: bool = False,
    signal: SignalSpec = GPS_L1CA,
    code_doppler: bool = False,
    bpsk_like: bool = False,
) -> np.ndarray:
    """Raw grid :math:`\\sum_k |z_k[s]|^2` per PRN, Doppler bin and code lag: ``(n_prn, n_doppler, N)``.

    ``samples`` must hold ``noncoherent`` blocks of ``N = round(coherent_time_s * fs)``.

    ``alternate`` (for a coherent time of half a data bit, 10 ms): the larger of the sums
    over the even blocks and over the odd blocks. A 20 ms bit has one possible edge per
    20 ms, at a fixed phase, so it falls in blocks of one parity only: the other parity's
    blocks are free of bit transitions, and the statistic keeps their full coherent gain.

    ``code_doppler``: follow the code Doppler across the blocks. The code arrives at the
    chip rate times :math:`1 + f_D/f_c` (carrier and code share the satellite's motion),
    so block :math:`k`'s peak is :math:`k N f_D / f_c` samples earlier than block 0's
    (5 kHz at L1: 3.2 chips/s, half a chip in 154 ms); each block's correlation is
    shifted back by that, a fraction of a sample included (the phase ramp
    :math:`e^{-j 2\\pi m d_k / N}` on its spectrum, the DFT's shift theorem), before the
    sum, and the grid's lag is block 0's: a long non-coherent sum keeps its gain
    (Kaplan & Hegarty, *Understanding GPS/GNSS*, 3rd ed., sec. 8.4). Without it (the
    default) the blocks are summed at the same lag.

    ``bpsk_like`` (a BOC signal): the sum runs over both side bands' correlations too
    (module docstring), :math:`2K` terms instead of :math:`K`.
    """
    n = int(round(coherent_time_s * sample_rate_hz))
    blocks = _blocks(samples, n, noncoherent)
    codes = [fft.fft(_replicas(p, n, sample_rate_hz, signal, bpsk_like), axis=-1, workers=1).conj() for p in prns]
    out = np.empty((len(prns), dopplers_hz.size, n), np.float32)
    step = max(1, _CHUNK_ELEMENTS // (noncoherent * n))
    wiped = _DopplerSpectra(blocks, dopplers_hz, sample_rate_hz, if_hz)
    for lo in range(0, dopplers_hz.size, step):
        spectra = wiped.chunk(lo, lo + step)
        if code_doppler:
            spectra *= _code_drift_ramp(dopplers_hz[lo : lo + step], noncoherent, n, signal.carrier_freq_hz)
        for i in range(len(prns)):
            z = fft.ifft(spectra * codes[i][0], axis=-1, workers=1)
            power = z.real**2 + z.imag**2
            for code in codes[i][1:]:  # the BPSK-like search's second side band
                z = fft.ifft(spectra * code, axis=-1, workers=1)
                power += z.real**2 + z.imag**2
            out[i, lo : lo + step] = _sum_blocks(power, alternate)
    return out


def _code_drift_ramp(dopplers_hz: np.ndarray, blocks: int, n: int, carrier_hz: float) -> np.ndarray:
    """``(n_doppler, K, N)`` phase ramps that delay block ``k``'s correlation by the code's
    drift :math:`d_k = k N f_D / f_c` samples, landing its peak on block 0's lag (`search_grid`)."""
    drift = np.arange(blocks)[None, :] * n * dopplers_hz[:, None] / carrier_hz  # (n_doppler, K) samples
    m = fft.fftfreq(n, 1.0 / n) / n  # signed DFT bin indices, in cycles per sample
    # float32 angles and a complex64 result, no complex128 transient: |angle| < 2 pi x the
    # drift (a few samples), so float32 keeps it within 1e-6 rad.
    angle = (2.0 * np.pi) * drift.astype(np.float32)[:, :, None] * m.astype(np.float32)
    ramp = np.empty(angle.shape, np.complex64)
    np.cos(angle, out=ramp.real)
    np.sin(angle, out=angle)
    np.negative(angle, out=ramp.imag)
    return ramp


def fine_doppler(
    samples: np.ndarray,
    sample_rate_hz: float,
    if_hz: float,
    prn: int,
    code_start_sample: int,
    coherent_time_s: float,
    noncoherent: int,
    dopplers_hz: np.ndarray,
    alternate: bool = False,
    signal: SignalSpec = GPS_L1CA,
    bpsk_like: bool = False,
    code_doppler: bool = False,
) -> np.ndarray:
    """Raw :math:`\\sum_k |z_k|^2` at one code lag for each of ``dopplers_hz`` (the fine
    search; ``alternate`` and ``bpsk_like`` as `search_grid`).

    ``code_doppler``: block :math:`k`'s replica starts :math:`d_k = k N f_D / f_c` samples
    earlier (`search_grid`'s drift, at the middle of ``dopplers_hz``, a fraction of a sample
    included), so the code lag ``code_start_sample`` is block 0's, as the grid reports it.

    The carrier of bin :math:`d` at sample :math:`s` of block :math:`k` is
    :math:`e^{-j2\\pi (f_{IF} + f_d)(kN + s)/f_s}`: block :math:`k`'s factor
    :math:`e^{-j2\\pi (f_{IF} + f_d) kN/f_s}` has unit modulus and leaves
    :math:`|z_k|^2` as it is, so every block takes the same ``(N, n_doppler)`` carriers
    :math:`e^{-j2\\pi (f_{IF} + f_d) s/f_s}` and the bins' correlations are one matrix
    product ``wiped @ carriers``. Memory is ``N x n_doppler`` instead of
    ``n_doppler x K x N`` (a weak search's 21 fine bins of 18 blocks of 10 ms at 2.6 MHz:
    9 MB instead of 157 MB), and any set of Dopplers is computed the same way.
    """
    n = int(round(coherent_time_s * sample_rate_hz))
    blocks = _blocks(samples, n, noncoherent)
    # conj: the correlation is sum x r*, as the grid's conjugated replica spectra (real for BPSK).
    K = blocks.shape[0]
    if code_doppler:  # (S, K, n): each block's replica at its drifted start
        mid_hz = float(np.median(dopplers_hz))
        drift = np.arange(K) * n * mid_hz / signal.carrier_freq_hz  # samples earlier, block k
        chips = -(code_start_sample - drift) * (signal.chip_rate_hz / sample_rate_hz)
        replicas = np.stack([_replicas(prn, n, sample_rate_hz, signal, bpsk_like, c) for c in chips], axis=1).conj()
    else:
        replicas = np.roll(_replicas(prn, n, sample_rate_hz, signal, bpsk_like), code_start_sample, axis=-1).conj()
    dopplers_hz = np.asarray(dopplers_hz, float)
    carriers = np.exp(-2j * np.pi * np.multiply.outer(np.arange(n) / sample_rate_hz, if_hz + dopplers_hz))
    power = np.zeros((dopplers_hz.size, K))
    for replica in replicas:  # the replica, or the two side bands
        power += (np.abs((blocks * replica) @ carriers) ** 2).T
    return _sum_blocks(power, alternate)


def overlay_refine_periods(signal: SignalSpec) -> int:
    """Code periods `overlay_doppler` correlates for ``signal``: two overlay periods and one
    more, for a tracked component whose overlay spans at most 20 ms (NH10, NH20, CS20_1:
    L5, E5a-I, B1I D1); 0 (no refinement) without an overlay or for a longer one (E1-C's
    CS25 of 100 ms, E5a-Q's CS100), where the extra samples would outgrow the search."""
    n = signal.overlay_length(0)
    return 2 * n + 1 if n and n * signal.code_period_s <= 0.02 + 1e-12 else 0


def overlay_doppler(
    samples: np.ndarray,
    sample_rate_hz: float,
    if_hz: float,
    prn: int,
    code_start_sample: int,
    doppler_hz: float,
    signal: SignalSpec,
    min_margin: float = 1.5,
) -> float | None:
    r"""The Doppler of a found signal under a 1 kHz-class overlay, refined by the overlay's
    differential detector (`signal.overlay.overlay_sync`): prompts of one code period each
    from ``code_start_sample`` at ``doppler_hz`` (`overlay_refine_periods` of them), whose
    neighbour products, matched against the overlay's, give the residual frequency
    unambiguously within :math:`\pm 1/(2T)` (500 Hz for a 1 ms code).

    Why: a search of 1 ms blocks resolves Doppler only to the width of a 1 ms block's
    response (hundreds of Hz), and a loop whose discriminator must ignore the overlay's
    sign flips (a two-quadrant FLL, a Costas PLL) pulls in within :math:`\pm 1/(4T)` = 250
    Hz: further off, it locks 500 Hz away. None where the samples hold too few periods or
    the overlay's match does not stand ``min_margin`` times above the next shift's (too
    weak to trust)."""
    from ...signal.overlay import overlay_sync

    periods = overlay_refine_periods(signal)
    n = int(round(signal.code_period_s * sample_rate_hz))
    starts = code_start_sample + np.round(np.arange(periods) * signal.code_period_s * sample_rate_hz).astype(np.int64)
    if periods == 0 or starts[-1] + n > samples.shape[0]:
        return None
    rate = signal.chip_rate_hz * (1.0 + doppler_hz / signal.carrier_freq_hz) / sample_rate_hz
    replica = signal.spreading_at(signal.spreading_table(prn), np.arange(n) * rate)
    idx = starts[:, None] + np.arange(n)
    x = np.asarray(samples)[idx] * np.exp(-2j * np.pi * (((if_hz + doppler_hz) * idx / sample_rate_hz) % 1.0))
    prompts = x @ replica
    sync = overlay_sync(prompts, signal.overlay(prn), signal.code_period_s)
    return float(doppler_hz + sync.freq_error_hz) if sync.margin >= min_margin else None
