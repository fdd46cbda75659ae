"""The correlator's reference sums and its stated error: `correlate_numpy` (exact ``exp``,
float64, channel by channel) and `correlate_periods_numpy`, against which the compiled kernel
of `correlator` is held to `correlation_error_bound`; kept for tests and machines without
numba. The equation is `correlator`'s module text."""

from __future__ import annotations

import numpy as np

__all__ = ["CHUNK", "ROUNDING", "correlation_error_bound", "correlate_numpy", "correlate_periods_numpy"]

#: Samples per chunk of the compiled kernel (its carrier restarts exactly every chunk).
CHUNK = 512
#: Relative error of the compiled kernel's float32 arithmetic, per unit of sum |x|: the
#: carrier phasor (two float32 products, about 4 ulp of 2^-24) and a chunk's float32 sum of
#: up to CHUNK products (Higham's gamma_n, n = CHUNK + 2 ulp of 2^-24).
ROUNDING = (CHUNK + 8) * 2.0**-24


def correlation_error_bound(samples: np.ndarray, start: int, count: int, run_before: int = 0) -> float:
    """Largest difference allowed between the compiled and the reference sums of ``count``
    samples from ``start``: `ROUNDING` plus the phase rounding of the NCO words (half a
    :math:`2^{-32}` cycle of the initial word, plus one per sample of the step's rounding,
    over the ``run_before`` samples the carrier ran before this range too), per unit of
    each sample's magnitude."""
    mag = np.abs(samples[start : start + count])
    phase_err = 2 * np.pi * 2.0**-32 * (1 + run_before + np.arange(count))
    return float(np.sum(mag * (ROUNDING + phase_err)) + 1e-9 * np.sum(mag))


def correlate_numpy(
    samples: np.ndarray,
    starts: np.ndarray,
    counts: np.ndarray,
    code_phase_chips: np.ndarray,
    code_step_chips: np.ndarray,
    carrier_phase_cycles: np.ndarray,
    carrier_step_cycles: np.ndarray,
    codes: np.ndarray,
    offsets_chips: np.ndarray,
) -> np.ndarray:
    """Reference: ``(n_channels, n_taps)`` complex sums, exact carrier (see module docstring)."""
    out = np.zeros((len(starts), len(offsets_chips)), complex)
    n_code = codes.shape[1]
    for c in range(len(starts)):  # the reference: clarity over speed
        i = np.arange(counts[c])
        x = samples[starts[c] : starts[c] + counts[c]]
        base = x * np.exp(-2j * np.pi * (carrier_phase_cycles[c] + i * carrier_step_cycles[c]))
        for t, off in enumerate(offsets_chips):
            idx = np.floor(code_phase_chips[c] + off + i * code_step_chips[c]).astype(np.int64) % n_code
            out[c, t] = np.sum(base * codes[c, idx])
    return out


def correlate_periods_numpy(
    samples: np.ndarray,
    starts: np.ndarray,
    n_periods: np.ndarray,
    code_phase_chips: np.ndarray,
    code_step_chips: np.ndarray,
    carrier_phase_cycles: np.ndarray,
    carrier_step_cycles: np.ndarray,
    codes: np.ndarray,
    offsets_chips: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Reference of `correlate_periods`: period by period with `correlate_numpy`."""
    n_ch, n_code = len(starts), codes.shape[1]
    sums = np.zeros((n_ch, max(1, int(np.max(n_periods, initial=1))), len(offsets_chips)), complex)
    counts = np.zeros(sums.shape[:2], np.int64)
    for c in range(n_ch):
        start, phase, cycles = int(starts[c]), float(code_phase_chips[c]), float(carrier_phase_cycles[c])
        for k in range(int(n_periods[c])):
            n = int(np.ceil((n_code - phase) / code_step_chips[c]))
            sums[c, k] = correlate_numpy(
                samples,
                np.array([start]),
                np.array([n]),
                np.array([phase]),
                code_step_chips[c : c + 1],
                np.array([cycles]),
                carrier_step_cycles[c : c + 1],
                codes[c : c + 1],
                offsets_chips,
            )[0]
            counts[c, k] = n
            start += n
            phase += n * code_step_chips[c] - n_code
            cycles += n * carrier_step_cycles[c]
    return sums, counts
