r"""Multi-channel correlator: every channel's early/prompt/late sums over its own sample range
in one pass, as a receiver's correlator bank does.

For channel c, samples :math:`x_n`, :math:`n = s_c \dots s_c + N_c - 1`, carrier NCO phase
:math:`\phi_c + i\,\Delta\phi_c` (cycles) and code NCO phase :math:`p_c + i\,\Delta p_c`
(chips), :math:`i = n - s_c`, tap :math:`t` at offset :math:`o_t` chips:

.. math:: C_{c,t} = \sum_i x_{s_c + i}\, e^{-j 2\pi(\phi_c + i \Delta\phi_c)}\,
          c_c\big(\lfloor p_c + o_t + i\,\Delta p_c \rfloor \bmod n\big)

with :math:`n` the table's length (1023 for L1 C/A; the NCO replicas of Kaplan & Hegarty,
*Understanding GPS/GNSS*, 3rd ed., sec. 8.8;
tap offsets added to the replica phase as in `gnssframework.signal.if_samples.correlate_if`).

The compiled kernel keeps both NCOs as fixed-point phase words (carrier in :math:`2^{-32}`
cycles, code in :math:`2^{-32}` chips), as hardware correlators do, and works in chunks of
`CHUNK` samples: the carrier replica of a chunk is the exact phasor of its first sample's
phase word times a per-channel table of :math:`e^{-j 2\pi i \Delta\phi}`, :math:`i <`
`CHUNK` (made in float64 by recurrence, the rotator of GNSS-SDR's VOLK kernels, in blocks
of 32 turned by the block's phasor, and restarted exactly every chunk, so no error
accumulates); the samples are read as recorded (``int8``, ``int16`` or ``float32``
components, interleaved I/Q or real), without a float copy of the block. The chunk's
products and sums are ``float32``, so :math:`|C^{compiled} - C^{exact}| \le` `ROUNDING`
:math:`\sum_i |x_i|` beyond the fixed-point words' rounding (`correlation_error_bound`).
`correlate_numpy` is the reference (exact ``exp``, float64), kept for tests and machines
without numba.

The kernels know no signal: a code table is any ±1 sequence of :math:`n` entries, indexed
by :math:`\lfloor p \rfloor \bmod n`. `replica_codes` makes the tables of a `SignalSpec`:
the code for BPSK; for BOC the spreading waveform as a table of sub-chips (code times
sub-carrier, `SignalSpec.spreading_table`), whose phases, steps and tap offsets are then
in sub-chips (chips times ``signal.subchips_per_chip``, `to_table_units`).
"""

from __future__ import annotations

import math
import threading

import numpy as np

from ...errors import ConfigError
from ...backend import get_backend
from .channel_groups import SPLIT_SAMPLES, run_groups, split_channels
from .code_tables import _MASK32, MAX_TAPS, CodeTables, _cached_tables, code_tables
from .replica_tables import replica_code_pair, replica_codes, to_table_units
from .nco_words import carrier_words, period_words
from .sample_power import sum_of_squares
from .correlator_reference import CHUNK, ROUNDING, correlate_numpy, correlate_periods_numpy, correlation_error_bound

__all__ = [
    "replica_codes",
    "replica_code_pair",
    "to_table_units",
    "correlate_channels",
    "correlate_numpy",
    "correlate_periods",
    "correlate_periods_numpy",
    "code_tables",
    "correlation_error_bound",
    "sum_of_squares",
    "CodeTables",
    "CHUNK",
    "ROUNDING",
    "MAX_TAPS",
    "SPLIT_SAMPLES",
]

_TWO_PI_2_32 = 2 * math.pi * 2.0**-32
_ROT_BLOCK = 32  # the carrier rotation table's recurrence block (`_rotations`)


# The kernels are plain functions specialised by `with_globals` (each twin has its own
# numba disk cache entry, which closures would not): ``_IQ`` (interleaved I/Q components or
# real samples), ``_M`` (the code tables' tap thresholds, `CodeTables`) and ``_EPL``
# (three taps: the fused E/P/L loop) are constants of each twin, and both drivers inline the same per-sample function, `_run`.
_IQ = True
_M = 1
_EPL = False


def _run(
    x, q_sign, s, n, ph, dph, u, dp, idp, pat, thr, rot_r, rot_i, br, bi, code, acc_r, acc_i
):  # pragma: no cover - compiled
    # n samples from sample s into acc_r/acc_i (one per tap); returns the carrier and code
    # words after them. Chunk by chunk, loops that vectorise: each sample's pattern index
    # (the prompt's word u + idp[i], idp[i] = i dp, its chip and the taps' thresholds
    # crossed in it, `CodeTables`) into code; then the patterns themselves (one scalar
    # gather per sample, the only loop that does not vectorise); then the baseband (chunk's
    # exact first phasor times the rot table) and each tap's dot product, summed in float32,
    # the chunk sums in float64. For E/P/L (``_EPL``: three taps) the baseband and the three
    # taps are one loop (the baseband stays in registers); otherwise the baseband goes into
    # br/bi and each tap has its own loop.
    n_taps = acc_r.shape[0]
    done = 0
    while done < n:
        m = min(CHUNK, n - done)
        theta = _TWO_PI_2_32 * (ph & _MASK32)
        c0r = np.float32(math.cos(theta))
        c0i = np.float32(-math.sin(theta))
        for i in range(m):
            w = u + idp[i]
            frac = w & _MASK32
            k = (w >> 32) * (_M + 1)
            for j in range(_M):
                k += np.int64(frac >= thr[j])
            code[i] = np.int32(k)
        for i in range(m):
            code[i] = pat[np.uint64(code[i])]  # (unsigned: no negative-index wrap, 1.3x faster)
        if _EPL and _IQ:
            xs = x[2 * (s + done) : 2 * (s + done + m)]
            e_r = e_i = p_r = p_i = l_r = l_i = np.float32(0.0)
            for i in range(m):
                cr = c0r * rot_r[i] - c0i * rot_i[i]  # exp(-j phase)
                ci = c0r * rot_i[i] + c0i * rot_r[i]
                a = np.float32(xs[2 * i])
                b = q_sign * np.float32(xs[2 * i + 1])
                zr = a * cr - b * ci
                zi = a * ci + b * cr
                cd = code[i]  # each tap's sign a select: the same products as times ±1, 1.25x faster
                e_r += -zr if cd & 1 else zr
                e_i += -zi if cd & 1 else zi
                p_r += -zr if cd & 2 else zr
                p_i += -zi if cd & 2 else zi
                l_r += -zr if cd & 4 else zr
                l_i += -zi if cd & 4 else zi
            acc_r[0] += e_r
            acc_i[0] += e_i
            acc_r[1] += p_r
            acc_i[1] += p_i
            acc_r[2] += l_r
            acc_i[2] += l_i
        elif _EPL:
            xs = x[s + done : s + done + m]
            e_r = e_i = p_r = p_i = l_r = l_i = np.float32(0.0)
            for i in range(m):
                a = np.float32(xs[i])
                zr = a * (c0r * rot_r[i] - c0i * rot_i[i])
                zi = a * (c0r * rot_i[i] + c0i * rot_r[i])
                cd = code[i]
                e_r += -zr if cd & 1 else zr
                e_i += -zi if cd & 1 else zi
                p_r += -zr if cd & 2 else zr
                p_i += -zi if cd & 2 else zi
                l_r += -zr if cd & 4 else zr
                l_i += -zi if cd & 4 else zi
            acc_r[0] += e_r
            acc_i[0] += e_i
            acc_r[1] += p_r
            acc_i[1] += p_i
            acc_r[2] += l_r
            acc_i[2] += l_i
        else:
            if _IQ:
                xs = x[2 * (s + done) : 2 * (s + done + m)]
                for i in range(m):
                    cr = c0r * rot_r[i] - c0i * rot_i[i]  # exp(-j phase)
                    ci = c0r * rot_i[i] + c0i * rot_r[i]
                    a = np.float32(xs[2 * i])
                    b = q_sign * np.float32(xs[2 * i + 1])
                    br[i] = a * cr - b * ci
                    bi[i] = a * ci + b * cr
            else:
                xs = x[s + done : s + done + m]
                for i in range(m):
                    a = np.float32(xs[i])
                    br[i] = a * (c0r * rot_r[i] - c0i * rot_i[i])
                    bi[i] = a * (c0r * rot_i[i] + c0i * rot_r[i])
            for t in range(n_taps):
                sr = np.float32(0.0)
                si = np.float32(0.0)
                for i in range(m):
                    v = np.float32(1 - 2 * ((code[i] >> t) & 1))
                    sr += br[i] * v
                    si += bi[i] * v
                acc_r[t] += sr
                acc_i[t] += si
        u += m * dp
        ph += m * dph
        done += m
    return ph, u


def _rotations(dph, rot_r, rot_i):  # pragma: no cover - compiled
    # exp(-j 2 pi i dph 2^-32) for the samples i of a chunk, in float64: the first
    # `_ROT_BLOCK` by recurrence, then each further block as those turned by the block's own
    # phasor (itself by recurrence). No chain is longer than CHUNK / _ROT_BLOCK + _ROT_BLOCK
    # products, so the error (about that many float64 ulps) stays far below the float32
    # cast, and the second step's products do not wait on each other.
    theta = _TWO_PI_2_32 * (dph & _MASK32)
    wr, wi = math.cos(theta), -math.sin(theta)
    fr, fi = np.empty(_ROT_BLOCK), np.empty(_ROT_BLOCK)
    zr, zi = 1.0, 0.0
    for i in range(_ROT_BLOCK):
        fr[i], fi[i] = zr, zi
        zr, zi = zr * wr - zi * wi, zr * wi + zi * wr
    br, bi = zr, zi  # exp(-j 2 pi _ROT_BLOCK dph 2^-32)
    zr, zi = 1.0, 0.0
    for b in range(CHUNK // _ROT_BLOCK):
        for i in range(_ROT_BLOCK):
            rot_r[b * _ROT_BLOCK + i] = zr * fr[i] - zi * fi[i]
            rot_i[b * _ROT_BLOCK + i] = zr * fi[i] + zi * fr[i]
        zr, zi = zr * br - zi * bi, zr * bi + zi * br


def _channels(
    x, q_sign, starts, counts, carrier0, dcarrier, code0, dcode, pat, thr, out_r, out_i
):  # pragma: no cover - compiled
    # counts[c] samples of channel c from starts[c]; channels in parallel in the parallel
    # twin (each channel's arithmetic is the same whichever thread runs it).
    n_taps = out_r.shape[1]
    for c in prange(starts.shape[0]):
        rot_r, rot_i = np.empty(CHUNK, np.float32), np.empty(CHUNK, np.float32)
        br, bi = np.empty(CHUNK, np.float32), np.empty(CHUNK, np.float32)
        code = np.empty(CHUNK, np.int32)
        acc_r, acc_i = np.zeros(n_taps), np.zeros(n_taps)
        _rotations_(dcarrier[c], rot_r, rot_i)
        idp = np.arange(CHUNK) * dcode[c]
        _run_(
            x,
            q_sign,
            starts[c],
            counts[c],
            carrier0[c],
            dcarrier[c],
            code0[c],
            dcode[c],
            idp,
            pat[c],
            thr,
            rot_r,
            rot_i,
            br,
            bi,
            code,
            acc_r,
            acc_i,
        )
        out_r[c] = acc_r
        out_i[c] = acc_i


def _periods(
    x, q_sign, starts, n_periods, carrier0, dcarrier, code0, dcode, wrap, period_word, pat, thr, out_r, out_i, counts
):  # pragma: no cover - compiled
    # n_periods[c] whole code periods of channel c: a period ends on the sample where the
    # prompt's code word reaches ``wrap`` (the next epoch), i.e. after ceil((wrap - u) / dp)
    # samples; the word then steps back one code length, and the carrier runs on.
    n_taps = out_r.shape[2]
    for c in prange(starts.shape[0]):
        rot_r, rot_i = np.empty(CHUNK, np.float32), np.empty(CHUNK, np.float32)
        br, bi = np.empty(CHUNK, np.float32), np.empty(CHUNK, np.float32)
        code = np.empty(CHUNK, np.int32)
        acc_r, acc_i = np.zeros(n_taps), np.zeros(n_taps)
        dph, dp = dcarrier[c], dcode[c]
        _rotations_(dph, rot_r, rot_i)
        idp = np.arange(CHUNK) * dp
        s, ph, u = starts[c], carrier0[c], code0[c]
        for k in range(n_periods[c]):
            n = (wrap - u + dp - 1) // dp
            acc_r[:] = 0.0
            acc_i[:] = 0.0
            ph, u = _run_(x, q_sign, s, n, ph, dph, u, dp, idp, pat[c], thr, rot_r, rot_i, br, bi, code, acc_r, acc_i)
            out_r[c, k] = acc_r
            out_i[c, k] = acc_i
            counts[c, k] = n
            s += n
            u -= period_word


_KERNELS: dict[tuple[bool, int, bool, bool], tuple] = {}


def _kernels(iq: bool, m: int, parallel: bool, n_taps: int = 0) -> tuple:
    """The (fixed-count, whole-periods) kernels for sample kind ``iq``, ``m`` thresholds,
    serial or over the channels in parallel (the same body: ``prange`` is ``range`` in the
    serial twin), with the fused E/P/L loop when ``n_taps`` is 3."""
    epl = n_taps == 3
    key = (iq, m, parallel, epl)
    if key not in _KERNELS:
        tag = f"_{'iq' if iq else 'real'}{m}{'_par' if parallel else ''}{'_epl' if epl else ''}"
        inline = numba.njit(inline="always", fastmath=True, nogil=True)
        run = inline(with_globals(_run, tag, _IQ=iq, _M=m, _EPL=epl))
        rotations = inline(with_globals(_rotations, tag))
        compiled = numba.njit(cache=True, nogil=True, fastmath=True, parallel=parallel)
        _KERNELS[key] = tuple(
            compiled(with_globals(fn, tag, _run_=run, _rotations_=rotations)) for fn in (_channels, _periods)
        )
    return _KERNELS[key]


def _parallel(parallel: bool) -> bool:
    # numba's workqueue threading layer takes parallel kernels from the main thread only.
    return parallel and threading.current_thread() is threading.main_thread()


try:
    import numba
    from numba import prange

    from ...estimation.compiled.specialise import with_globals

    HAVE_NUMBA = True
except ImportError:  # pragma: no cover
    HAVE_NUMBA = False


def _as_complex(samples: np.ndarray, iq: bool, q_sign: int) -> np.ndarray:
    """The samples as the reference takes them: complex128 (I/Q) or float64 (real)."""
    if iq:
        x = np.asarray(samples, float).reshape(-1, 2)
        return x[:, 0] + 1j * q_sign * x[:, 1]
    return np.asarray(samples, complex if np.iscomplexobj(samples) else float)


def _kernel_input(samples: np.ndarray, iq: bool) -> tuple[np.ndarray, bool]:
    """What the compiled kernel reads: interleaved components or real samples, in the type
    they were recorded in where the kernel takes it (int8, int16, float32), and whether
    they are I/Q."""
    if np.iscomplexobj(samples):
        return np.ascontiguousarray(samples, np.complex64).view(np.float32), True
    x = np.asarray(samples)
    if x.dtype not in (np.int8, np.int16, np.float32):
        x = x.astype(np.float32)
    return np.ascontiguousarray(x), bool(iq)


def _n_samples(samples: np.ndarray, iq: bool) -> int:
    return samples.shape[0] // 2 if iq and not np.iscomplexobj(samples) else samples.shape[0]


def correlate_channels(
    samples: np.ndarray,
    starts: np.ndarray,
    counts: np.ndarray,
    code_phase_chips: np.ndarray,
    code_step_chips: np.ndarray,
    carrier_phase_cycles: np.ndarray,
    carrier_step_cycles: np.ndarray,
    codes: np.ndarray,
    offsets_chips: np.ndarray,
    backend: str | None = None,
    tables: CodeTables | None = None,
    iq: bool = False,
    q_sign: int = 1,
    parallel: bool = False,
    threads: int | None = None,
) -> np.ndarray:
    """Correlate every channel over its sample range: ``(n_channels, n_taps)`` complex.

    Parameters
    ----------
    samples
        Samples of a block: ``complex64``/``complex128`` (I/Q) or real; or, with ``iq``,
        interleaved I/Q components as recorded (``int8``, ``int16`` or ``float32``, I
        first), read without a float copy.
    starts, counts
        First sample (index into ``samples``) and number of samples of each channel.
    code_phase_chips, code_step_chips
        Code NCO phase at the first sample and its advance per sample.
    carrier_phase_cycles, carrier_step_cycles
        Carrier NCO phase (cycles) at the first sample and its advance per sample
        (IF + Doppler over the sample rate).
    codes
        ``(n_channels, n_code)`` ±1 ``float32`` codes (``(n, 1023)`` for L1 C/A;
        `replica_codes` of any BPSK or BOC `SignalSpec`).
    offsets_chips
        Tap offsets (early negative), added to the replica phase.
    backend
        ``"numba"`` or ``"numpy"``; default: the library's backend
        (`gnssframework.backend.get_backend`).
    tables
        `code_tables` of ``codes`` and ``offsets_chips`` made once by a caller that
        correlates the same channels many times (used when it fits this call).
    iq, q_sign
        ``samples`` are interleaved components; ``q_sign`` -1 reads them as I - jQ (a
        front end with an inverted Q branch).
    parallel
        Channels on numba's threads (``prange``; bit-identical results whatever their
        number), from the main thread only. Off by default: in the tracking loop, calls
        every 1-10 ms with Python between them, it did not help on two shared cores
        (docs/benchmarks.md, "Tracking on samples").
    threads
        Without ``parallel``: the channels in contiguous groups on the calling thread and
        up to ``threads - 1`` helper threads (`gnssframework.estimation.compiled.pool`: the
        calling thread starts at once and never waits for a helper to wake), for calls of
        at least `SPLIT_SAMPLES` samples; results bit-identical whatever the number.
        Default: `gnssframework.backend.get_threads` (the cores available).
    """
    starts = np.asarray(starts, np.int64)
    counts = np.asarray(counts, np.int64)
    n_samples = _n_samples(samples, iq)
    if starts.size and (starts.min() < 0 or (starts + counts).max() > n_samples):
        raise ConfigError(
            "starts",
            f"a channel's sample range [{starts.min()}, {(starts + counts).max()}) lies "
            f"outside the block of {n_samples} samples",
        )
    use = backend or get_backend()
    if use != "numba" or not HAVE_NUMBA:
        return correlate_numpy(
            _as_complex(samples, iq and not np.iscomplexobj(samples), q_sign),
            starts,
            counts,
            code_phase_chips,
            code_step_chips,
            carrier_phase_cycles,
            carrier_step_cycles,
            codes,
            offsets_chips,
        )
    x, cplx = _kernel_input(samples, iq)
    n_ch, n_taps = len(starts), len(offsets_chips)
    n_code = codes.shape[1]
    carrier0, dcarrier = carrier_words(carrier_phase_cycles, carrier_step_cycles)
    # The prompt's code word (offset 0, the taps' words follow from it, `CodeTables`) in
    # 2^-32 chips from one code period before the table's start (so early taps never
    # index below 0); the phase reduced to [-n/2, n/2): a phase just below a code epoch
    # stays just below 0.
    phase = np.mod(np.asarray(code_phase_chips, float) + n_code / 2, n_code) - n_code / 2
    code0 = np.floor((phase + n_code) * 2.0**32).astype(np.int64)
    step = np.asarray(code_step_chips, float)
    dcode = np.rint(step * 2.0**32).astype(np.int64)
    reach = n_code + phase.max(initial=0.0) + float((counts * step).max(initial=0.0)) + 2
    n_chips = int(np.ceil(reach / n_code)) * n_code
    if tables is None or not tables.fits(n_ch, offsets_chips, n_chips):
        tables = _cached_tables(codes, offsets_chips, n_chips // n_code)
    out_r = np.empty((n_ch, n_taps))
    out_i = np.empty((n_ch, n_taps))
    par = _parallel(parallel)
    kernel = _kernels(cplx, tables.thresholds.size, par, n_taps)[0]
    groups = [(0, n_ch)] if par else split_channels(n_ch, int(counts.sum()), threads)
    q, pat, thr = np.float32(q_sign), tables.patterns, tables.thresholds

    def call(lo: int, hi: int) -> None:
        kernel(
            x,
            q,
            starts[lo:hi],
            counts[lo:hi],
            carrier0[lo:hi],
            dcarrier[lo:hi],
            code0[lo:hi],
            dcode[lo:hi],
            pat[lo:hi],
            thr,
            out_r[lo:hi],
            out_i[lo:hi],
        )

    run_groups(groups, call, threads)
    return out_r + 1j * out_i


def correlate_periods(
    samples: np.ndarray,
    starts: np.ndarray,
    n_periods: np.ndarray,
    code_phase_chips: np.ndarray,
    code_step_chips: np.ndarray,
    carrier_phase_cycles: np.ndarray,
    carrier_step_cycles: np.ndarray,
    codes: np.ndarray,
    offsets_chips: np.ndarray,
    backend: str | None = None,
    tables: CodeTables | None = None,
    iq: bool = False,
    q_sign: int = 1,
    parallel: bool = False,
    threads: int | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Correlate ``n_periods[c]`` whole code periods of every channel c, each from code epoch
    to code epoch (the replica's own), with the NCOs held over them.

    Each period ends on the first sample at which the replica's code phase reaches the next
    epoch (1023 chips past the last), so the caller need not know the sample counts in
    advance. ``code_phase_chips`` is the phase at ``starts`` (just after an epoch, in
    ``(-1, 1)`` chips). One tap is the prompt (offset 0); at most `MAX_TAPS` taps.
    ``samples``, ``iq``, ``q_sign``, ``parallel`` and ``threads`` as in `correlate_channels`.

    Returns
    -------
    sums, counts
        ``(n_channels, max n_periods, n_taps)`` complex sums and ``(n_channels, max
        n_periods)`` samples of each period (0 past a channel's ``n_periods``).
    """
    starts = np.asarray(starts, np.int64)
    n_periods = np.asarray(n_periods, np.int64)
    offsets_chips = np.asarray(offsets_chips, float)
    n_code = codes.shape[1]
    taps = offsets_chips.tolist()  # (a list's membership test: a tenth of np.any's time)
    if 0.0 not in taps or len(taps) > MAX_TAPS:
        raise ConfigError(
            "offsets_chips",
            f"correlate_periods needs a tap at offset 0 (the prompt, whose epochs "
            f"end the periods) and at most {MAX_TAPS} taps; got {taps}",
        )
    phase, step = np.asarray(code_phase_chips, float), np.asarray(code_step_chips, float)
    carrier_phase, carrier_step = np.asarray(carrier_phase_cycles, float), np.asarray(carrier_step_cycles, float)
    # The carrier words, the prompt's code word in 2^-32 chips from one code length before
    # the table's start (a period ends when it reaches two code lengths: its next epoch),
    # and where the periods reach, in one compiled pass (`nco_words.period_words`).
    carrier0, dcarrier, code0, dcode, first, reach, p_max, work = period_words(
        starts, n_periods, phase, step, carrier_phase, carrier_step, n_code
    )
    n_samples = _n_samples(samples, iq)
    if starts.size and (first < 0 or reach > n_samples):
        raise ConfigError(
            "starts",
            f"a channel's periods [{first}, {reach}) reach outside the block of {n_samples} samples",
        )
    use = backend or get_backend()
    if use != "numba" or not HAVE_NUMBA:
        return correlate_periods_numpy(
            _as_complex(samples, iq and not np.iscomplexobj(samples), q_sign),
            *(starts, n_periods, phase, step, carrier_phase, carrier_step, codes, offsets_chips),
        )
    x, cplx = _kernel_input(samples, iq)
    n_ch = len(starts)
    period_word = np.int64(n_code) << np.int64(32)
    if tables is None or not tables.fits(n_ch, offsets_chips, 3 * n_code):
        tables = _cached_tables(codes, offsets_chips, 3)
    out_r = np.zeros((n_ch, p_max, offsets_chips.size))
    out_i = np.zeros((n_ch, p_max, offsets_chips.size))
    counts = np.zeros((n_ch, p_max), np.int64)
    par = _parallel(parallel)
    kernel = _kernels(cplx, tables.thresholds.size, par, offsets_chips.size)[1]
    groups = [(0, n_ch)] if par else split_channels(n_ch, work, threads)
    q, pat, thr = np.float32(q_sign), tables.patterns, tables.thresholds

    def call(lo: int, hi: int) -> None:
        kernel(
            x,
            q,
            starts[lo:hi],
            n_periods[lo:hi],
            carrier0[lo:hi],
            dcarrier[lo:hi],
            code0[lo:hi],
            dcode[lo:hi],
            2 * period_word,
            period_word,
            pat[lo:hi],
            thr,
            out_r[lo:hi],
            out_i[lo:hi],
            counts[lo:hi],
        )

    run_groups(groups, call, threads)
    return out_r + 1j * out_i, counts
