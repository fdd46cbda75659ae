r"""Multi-channel correlator: every channel's early/prompt/late sums over its own sample range
in one pass, as a receiver's correlator bank does.

For channel c, samples :math:`x_n`, :math:`n = s_c \dots s_c + N_c - 1`, carrier NCO phase
:math:`\phi_c + i\,\Delta\phi_c` (cycles) and code NCO phase :math:`p_c + i\,\Delta p_c`
(chips), :math:`i = n - s_c`, tap :math:`t` at offset :math:`o_t` chips:

.. math:: C_{c,t} = \sum_i x_{s_c + i}\, e^{-j 2\pi(\phi_c + i \Delta\phi_c)}\,
          c_c\big(\lfloor p_c + o_t + i\,\Delta p_c \rfloor \bmod 1023\big)

(the NCO replicas of Kaplan & Hegarty, *Understanding GPS/GNSS*, 3rd ed., sec. 8.8;
tap offsets added to the replica phase as in `gnssframework.signal.if_samples.correlate_if`).
The compiled kernel makes the carrier by phase accumulation and a 4096-entry sine table,
as hardware correlators do; its phase error is at most :math:`\pi/4096` rad, so
:math:`|C^{compiled} - C^{exact}| \le \frac{\pi}{4096} \sum_i |x_i|`. `correlate_numpy`
is the reference (exact ``exp``), kept for tests and machines without numba.
"""

from __future__ import annotations

import numpy as np

from ...errors import ConfigError
from ...backend import get_backend

__all__ = ["correlate_channels", "correlate_numpy", "correlate_periods", "correlate_periods_numpy", "code_tables",
           "TABLE_BITS"]

#: log2 of the carrier table's length.
TABLE_BITS = 12
_N_TABLE = 1 << TABLE_BITS
_COS = np.cos(2 * np.pi * np.arange(_N_TABLE) / _N_TABLE).astype(np.float32)
_SIN = np.sin(2 * np.pi * np.arange(_N_TABLE) / _N_TABLE).astype(np.float32)


def correlate_numpy(samples: np.ndarray, starts: np.ndarray, counts: np.ndarray, code_phase_chips: np.ndarray,
                    code_step_chips: np.ndarray, carrier_phase_cycles: np.ndarray, carrier_step_cycles: np.ndarray,
                    codes: np.ndarray, offsets_chips: np.ndarray) -> np.ndarray:
    """Reference: ``(n_channels, n_taps)`` complex sums, exact carrier (see module docstring)."""
    out = np.zeros((len(starts), len(offsets_chips)), complex)
    n_code = codes.shape[1]
    for c in range(len(starts)):  # the reference: clarity over speed
        i = np.arange(counts[c])
        x = samples[starts[c]:starts[c] + counts[c]]
        base = x * np.exp(-2j * np.pi * (carrier_phase_cycles[c] + i * carrier_step_cycles[c]))
        for t, off in enumerate(offsets_chips):
            idx = np.floor(code_phase_chips[c] + off + i * code_step_chips[c]).astype(np.int64) % n_code
            out[c, t] = np.sum(base * codes[c, idx])
    return out


try:
    import numba

    @numba.njit(cache=True, nogil=True, fastmath=True)
    def _kernel3(x, cplx, starts, counts, carrier0, dcarrier, code0, dcode, tables, cos_t, sin_t, out_r,
                 out_i):  # pragma: no cover - compiled
        # Three taps (early, prompt, late) in registers: the common case. Carrier phase is a
        # 32-bit fraction of a cycle (table index = its top TABLE_BITS bits; the carry above
        # bit 32 is masked off);
        # code positions are 32.32 fixed point into a code table repeated so that no
        # index wraps within the call.
        shift = np.int64(32 - TABLE_BITS)
        mask = np.int64(cos_t.shape[0] - 1)
        for c in range(starts.shape[0]):
            row = tables[c]
            s = starts[c]
            ph = carrier0[c]
            dph = dcarrier[c]
            p0, p1, p2 = code0[c, 0], code0[c, 1], code0[c, 2]
            dp = dcode[c]
            r0 = r1 = r2 = m0 = m1 = m2 = 0.0
            for i in range(counts[c]):
                k = (ph >> shift) & mask
                co = cos_t[k]
                si = sin_t[k]
                if cplx:  # interleaved I/Q
                    a = x[2 * (s + i)]
                    b = x[2 * (s + i) + 1]
                    br = a * co + b * si  # x * exp(-j phi)
                    bi = b * co - a * si
                else:
                    a = x[s + i]
                    br = a * co
                    bi = -a * si
                v0 = row[p0 >> 32]
                v1 = row[p1 >> 32]
                v2 = row[p2 >> 32]
                r0 += br * v0
                m0 += bi * v0
                r1 += br * v1
                m1 += bi * v1
                r2 += br * v2
                m2 += bi * v2
                p0 += dp
                p1 += dp
                p2 += dp
                ph += dph
            out_r[c, 0], out_r[c, 1], out_r[c, 2] = r0, r1, r2
            out_i[c, 0], out_i[c, 1], out_i[c, 2] = m0, m1, m2

    @numba.njit(cache=True, nogil=True, fastmath=True)
    def _kernel(x, cplx, starts, counts, carrier0, dcarrier, code0, dcode, tables, cos_t, sin_t, out_r,
                out_i):  # pragma: no cover - compiled
        # Any number of taps (extra taps beyond E/P/L), same arithmetic.
        shift = np.int64(32 - TABLE_BITS)
        mask = np.int64(cos_t.shape[0] - 1)
        n_taps = code0.shape[1]
        acc_r = np.zeros(n_taps)
        acc_i = np.zeros(n_taps)
        pos = np.zeros(n_taps, np.int64)
        for c in range(starts.shape[0]):
            row = tables[c]
            s = starts[c]
            ph = carrier0[c]
            dph = dcarrier[c]
            dp = dcode[c]
            for t in range(n_taps):
                acc_r[t] = 0.0
                acc_i[t] = 0.0
                pos[t] = code0[c, t]
            for i in range(counts[c]):
                k = (ph >> shift) & mask
                co = cos_t[k]
                si = sin_t[k]
                if cplx:
                    a = x[2 * (s + i)]
                    b = x[2 * (s + i) + 1]
                    br = a * co + b * si
                    bi = b * co - a * si
                else:
                    a = x[s + i]
                    br = a * co
                    bi = -a * si
                for t in range(n_taps):
                    v = row[pos[t] >> 32]
                    acc_r[t] += br * v
                    acc_i[t] += bi * v
                    pos[t] += dp
                ph += dph
            for t in range(n_taps):
                out_r[c, t] = acc_r[t]
                out_i[c, t] = acc_i[t]

    @numba.njit(cache=True, nogil=True, fastmath=True)
    def _periods3(x, cplx, starts, n_periods, carrier0, dcarrier, code0, dcode, wrap, period_word, tables, cos_t, sin_t, out_r,
                  out_i, counts):  # pragma: no cover - compiled
        # Like _kernel3, over n_periods[c] whole code periods of channel c: a period ends on
        # the sample where the prompt's code position reaches ``wrap`` (the next epoch);
        # every tap then steps back one code length, and the carrier runs on.
        shift = np.int64(32 - TABLE_BITS)
        mask = np.int64(cos_t.shape[0] - 1)
        for c in range(starts.shape[0]):
            row = tables[c]
            i = starts[c]
            ph = carrier0[c]
            dph = dcarrier[c]
            p0, p1, p2 = code0[c, 0], code0[c, 1], code0[c, 2]
            dp = dcode[c]
            for k in range(n_periods[c]):
                r0 = r1 = r2 = m0 = m1 = m2 = 0.0
                n = 0
                while p1 < wrap:
                    kk = (ph >> shift) & mask
                    co = cos_t[kk]
                    si = sin_t[kk]
                    if cplx:
                        a = x[2 * i]
                        b = x[2 * i + 1]
                        br = a * co + b * si
                        bi = b * co - a * si
                    else:
                        a = x[i]
                        br = a * co
                        bi = -a * si
                    v0 = row[p0 >> 32]
                    v1 = row[p1 >> 32]
                    v2 = row[p2 >> 32]
                    r0 += br * v0
                    m0 += bi * v0
                    r1 += br * v1
                    m1 += bi * v1
                    r2 += br * v2
                    m2 += bi * v2
                    p0 += dp
                    p1 += dp
                    p2 += dp
                    ph += dph
                    i += 1
                    n += 1
                out_r[c, k, 0], out_r[c, k, 1], out_r[c, k, 2] = r0, r1, r2
                out_i[c, k, 0], out_i[c, k, 1], out_i[c, k, 2] = m0, m1, m2
                counts[c, k] = n
                p0 -= period_word
                p1 -= period_word
                p2 -= period_word

    HAVE_NUMBA = True
except ImportError:  # pragma: no cover
    HAVE_NUMBA = False


def code_tables(codes: np.ndarray, periods: int = 3) -> np.ndarray:
    """``codes`` repeated ``periods`` times along the chips (``float32``): the tables the
    compiled kernel indexes without wrapping. Three periods cover one code period of
    integration from any start phase with taps up to a period either side."""
    return np.tile(np.ascontiguousarray(codes, np.float32), (1, periods))


def correlate_channels(samples: np.ndarray, starts: np.ndarray, counts: np.ndarray, code_phase_chips: np.ndarray,
                       code_step_chips: np.ndarray, carrier_phase_cycles: np.ndarray,
                       carrier_step_cycles: np.ndarray, codes: np.ndarray, offsets_chips: np.ndarray,
                       backend: str | None = None, tables: np.ndarray | None = None) -> np.ndarray:
    """Correlate every channel over its sample range: ``(n_channels, n_taps)`` complex.

    Parameters
    ----------
    samples
        ``complex64`` (I/Q) or ``float32`` (real) samples of a block.
    starts, counts
        First sample (index into ``samples``) and number of samples of each channel.
    code_phase_chips, code_step_chips
        Code NCO phase at the first sample and its advance per sample.
    carrier_phase_cycles, carrier_step_cycles
        Carrier NCO phase (cycles) at the first sample and its advance per sample
        (IF + Doppler over the sample rate).
    codes
        ``(n_channels, 1023)`` ±1 ``float32`` codes.
    offsets_chips
        Tap offsets (early negative), added to the replica phase.
    backend
        ``"numba"`` or ``"numpy"``; default: the library's backend
        (`gnssframework.backend.get_backend`).
    tables
        `code_tables` of ``codes`` made once by a caller that correlates the same
        channels many times (used when long enough for this call).
    """
    starts = np.asarray(starts, np.int64)
    counts = np.asarray(counts, np.int64)
    if starts.size and (starts.min() < 0 or (starts + counts).max() > samples.shape[0]):
        raise ConfigError("starts", f"a channel's sample range [{starts.min()}, {(starts + counts).max()}) lies "
                          f"outside the block of {samples.shape[0]} samples")
    use = backend or get_backend()
    if use != "numba" or not HAVE_NUMBA:
        return correlate_numpy(samples, starts, counts, code_phase_chips, code_step_chips, carrier_phase_cycles,
                               carrier_step_cycles, codes, offsets_chips)
    cplx = bool(np.iscomplexobj(samples))
    x = (np.ascontiguousarray(samples, np.complex64).view(np.float32) if cplx
         else np.ascontiguousarray(samples, np.float32))
    n_ch, n_taps = len(starts), len(offsets_chips)
    n_code = codes.shape[1]
    # Fixed-point NCO words: carrier in 2^-32 cycles, code in 2^-32 chips from one code
    # period before the table's start (so early taps never index below 0).
    cycles = np.asarray(carrier_phase_cycles, float)
    carrier0 = np.floor((cycles - np.floor(cycles)) * 2.0**32).astype(np.int64)
    dcarrier = np.rint(np.mod(np.asarray(carrier_step_cycles, float), 1.0) * 2.0**32).astype(np.int64)
    # The phase reduced to [-n/2, n/2): a phase just below a code epoch stays just below 0.
    phase = np.mod(np.asarray(code_phase_chips, float) + n_code / 2, n_code) - n_code / 2
    base = phase[:, None] + np.asarray(offsets_chips, float) + n_code
    code0 = np.floor(base * 2.0**32).astype(np.int64)
    step = np.asarray(code_step_chips, float)
    dcode = np.rint(step * 2.0**32).astype(np.int64)
    reach = base.max(initial=0.0) + float((counts * step).max(initial=0.0)) + 2
    reps = int(np.ceil(reach / n_code))
    if tables is None or tables.shape[1] < reps * n_code:
        tables = code_tables(codes, reps)
    out_r = np.empty((n_ch, n_taps))
    out_i = np.empty((n_ch, n_taps))
    kernel = _kernel3 if n_taps == 3 else _kernel
    kernel(x, cplx, starts, counts, carrier0, dcarrier, code0, dcode, tables, _COS, _SIN, out_r, out_i)
    return out_r + 1j * out_i


def correlate_periods_numpy(samples: np.ndarray, starts: np.ndarray, n_periods: np.ndarray,
                            code_phase_chips: np.ndarray, code_step_chips: np.ndarray,
                            carrier_phase_cycles: np.ndarray, carrier_step_cycles: np.ndarray, codes: np.ndarray,
                            offsets_chips: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Reference of `correlate_periods`: period by period with `correlate_numpy`."""
    n_ch, n_code = len(starts), codes.shape[1]
    sums = np.zeros((n_ch, max(1, int(np.max(n_periods, initial=1))), len(offsets_chips)), complex)
    counts = np.zeros(sums.shape[:2], np.int64)
    for c in range(n_ch):
        start, phase, cycles = int(starts[c]), float(code_phase_chips[c]), float(carrier_phase_cycles[c])
        for k in range(int(n_periods[c])):
            n = int(np.ceil((n_code - phase) / code_step_chips[c]))
            sums[c, k] = correlate_numpy(samples, np.array([start]), np.array([n]), np.array([phase]),
                                         code_step_chips[c:c + 1], np.array([cycles]), carrier_step_cycles[c:c + 1],
                                         codes[c:c + 1], offsets_chips)[0]
            counts[c, k] = n
            start += n
            phase += n * code_step_chips[c] - n_code
            cycles += n * carrier_step_cycles[c]
    return sums, counts


def correlate_periods(samples: np.ndarray, starts: np.ndarray, n_periods: np.ndarray, code_phase_chips: np.ndarray,
                      code_step_chips: np.ndarray, carrier_phase_cycles: np.ndarray,
                      carrier_step_cycles: np.ndarray, codes: np.ndarray, offsets_chips: np.ndarray,
                      backend: str | None = None, tables: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Correlate ``n_periods[c]`` whole code periods of every channel c, each from code epoch
    to code epoch (the replica's own), with the NCOs held over them.

    Each period ends on the first sample at which the replica's code phase reaches the next
    epoch (1023 chips past the last), so the caller need not know the sample counts in
    advance. ``code_phase_chips`` is the phase at ``starts`` (just after an epoch, in
    ``(-1, 1)`` chips). Three taps (early, prompt, late) only.

    Returns
    -------
    sums, counts
        ``(n_channels, max n_periods, 3)`` complex sums and ``(n_channels, max n_periods)``
        samples of each period (0 past a channel's ``n_periods``).
    """
    starts = np.asarray(starts, np.int64)
    n_periods = np.asarray(n_periods, np.int64)
    offsets_chips = np.asarray(offsets_chips, float)
    if offsets_chips.size != 3:
        raise ConfigError("offsets_chips", f"correlate_periods takes 3 taps (early, prompt, late), got "
                          f"{offsets_chips.size}")
    step = np.asarray(code_step_chips, float)
    n_code = codes.shape[1]
    need = starts + np.ceil((n_periods * n_code - np.asarray(code_phase_chips, float)) / step + 1).astype(np.int64)
    if starts.size and (starts.min() < 0 or need.max() > samples.shape[0]):
        raise ConfigError("starts", f"a channel's periods [{starts.min()}, {need.max()}) reach outside the block of "
                          f"{samples.shape[0]} samples")
    use = backend or get_backend()
    if use != "numba" or not HAVE_NUMBA:
        return correlate_periods_numpy(samples, starts, n_periods, np.asarray(code_phase_chips, float), step,
                                       np.asarray(carrier_phase_cycles, float),
                                       np.asarray(carrier_step_cycles, float), codes, offsets_chips)
    cplx = bool(np.iscomplexobj(samples))
    x = (np.ascontiguousarray(samples, np.complex64).view(np.float32) if cplx
         else np.ascontiguousarray(samples, np.float32))
    n_ch = len(starts)
    cycles = np.asarray(carrier_phase_cycles, float)
    carrier0 = np.floor((cycles - np.floor(cycles)) * 2.0**32).astype(np.int64)
    dcarrier = np.rint(np.mod(np.asarray(carrier_step_cycles, float), 1.0) * 2.0**32).astype(np.int64)
    # Code positions in 2^-32 chips from one code length before the table's start; a period
    # ends when the prompt reaches two code lengths (its next epoch).
    base = np.asarray(code_phase_chips, float)[:, None] + offsets_chips + n_code
    code0 = np.floor(base * 2.0**32).astype(np.int64)
    dcode = np.rint(step * 2.0**32).astype(np.int64)
    period_word = np.int64(n_code) << np.int64(32)
    if tables is None or tables.shape[1] < 3 * n_code:
        tables = code_tables(codes, 3)
    p_max = max(1, int(n_periods.max(initial=1)))
    out_r = np.zeros((n_ch, p_max, 3))
    out_i = np.zeros((n_ch, p_max, 3))
    counts = np.zeros((n_ch, p_max), np.int64)
    _periods3(x, cplx, starts, n_periods, carrier0, dcarrier, code0, dcode, 2 * period_word, period_word, tables,
              _COS, _SIN, out_r, out_i, counts)
    return out_r + 1j * out_i, counts
