"""The search's carrier wipe-off (`fft_search._wiped_spectra`): a ``float32`` carrier from a
phase reduced to one cycle, against the exact ``complex128`` one, on the longest blocks a
search makes (80 ms at 4 MHz and a 4 MHz IF: 3e5 cycles of phase by the last sample)."""

from __future__ import annotations

import numpy as np
from scipy import fft

from gnssframework.receiver.acquisition.fft_search import _wiped_spectra


def test_the_float32_carrier_is_the_exact_one_to_float32_rounding():
    rng = np.random.default_rng(3)
    fs, if_hz, k, n = 4e6, 4.0e6 - 1234.5, 8, 40_000  # 8 blocks of 10 ms
    blocks = rng.standard_normal((k, n)).astype(np.float32)
    dopplers_hz = np.array([-5000.0, -37.5, 0.0, 4975.0])
    got = _wiped_spectra(blocks, dopplers_hz, fs, if_hz)
    t = (np.arange(k * n) / fs).reshape(k, n)
    exact = fft.fft(blocks[None] * np.exp(-2j * np.pi * (if_hz + dopplers_hz[:, None, None]) * t), axis=-1)
    # A float32 FFT's error grows as u log2(n) times its input's 2-norm (u = 2^-24; Higham,
    # *Accuracy and Stability of Numerical Algorithms*, 2nd ed., sec. 24.1); the carrier adds
    # a rounding of about u to each product (its angle cast to float32 after the reduction,
    # cos and sin in float32). Bound: 4 u log2(n) |x|_2 per block; measured about 0.3 of it.
    bound = 4 * 2.0**-24 * np.log2(n) * np.sqrt((blocks.astype(float) ** 2).sum(axis=1))[None, :, None]
    assert np.all(np.abs(got - exact) <= bound)
    # ... and the bound is tight enough to see a carrier a sample late (a phase error of
    # 2 pi f / fs: 6 rad at 4 MHz) or half a cycle off.
    late = fft.fft(blocks[None] * np.exp(-2j * np.pi * (if_hz + dopplers_hz[:, None, None]) * (t + 1 / fs)), axis=-1)
    assert np.any(np.abs(late - exact) > bound)
    assert np.any(np.abs(-exact - exact) > bound)
