"""The search's carrier wipe-off (`fft_search._wiped_spectra`, `fft_search._DopplerSpectra`): a ``float32`` carrier from a
phase reduced to one cycle, against the exact ``complex128`` one, on the longest blocks a
search makes (80 ms at 4 MHz and a 4 MHz IF: 3e5 cycles of phase by the last sample)."""

from __future__ import annotations

import numpy as np
from scipy import fft

from gnssframework.receiver.acquisition.fft_search import _DopplerSpectra, _wiped_spectra


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


def _exact(blocks, dopplers_hz, fs, if_hz):
    k, n = blocks.shape
    t = (np.arange(k * n) / fs).reshape(k, n)
    return fft.fft(blocks[None] * np.exp(-2j * np.pi * (if_hz + dopplers_hz[:, None, None]) * t), axis=-1)


def test_bins_whole_dft_bins_apart_are_shifts_of_two_spectra():
    """A 10 ms search's grid at 50 Hz steps is two residues 100 Hz (one DFT bin) apart:
    every bin's spectrum is one of two, shifted (`_DopplerSpectra`), within the same
    float32 bound as the carrier above, for every chunk of the grid."""
    rng = np.random.default_rng(4)
    fs, if_hz, k, n = 2.6e6, 1.25e5, 4, 26_000
    blocks = rng.standard_normal((k, n)).astype(np.float32)
    dopplers_hz = np.arange(-5000.0, 5000.0 + 25.0, 50.0)  # 201 bins
    spectra = _DopplerSpectra(blocks, dopplers_hz, fs, if_hz)
    assert spectra.base is not None and spectra.base.shape[0] == 2
    bound = 4 * 2.0**-24 * np.log2(n) * np.sqrt((blocks.astype(float) ** 2).sum(axis=1))[None, :, None]
    for lo, hi in ((0, 7), (7, 150), (150, 201)):
        assert np.all(np.abs(spectra.chunk(lo, hi) - _exact(blocks, dopplers_hz[lo:hi], fs, if_hz)) <= bound)
    # A shift the wrong way (W_0[q - m]) is far outside it.
    wrong = np.take_along_axis(
        spectra.base[spectra.residue_of[:20]], ((np.arange(n) - spectra.shift[:20, None]) % n)[:, None, :], axis=-1
    )
    assert np.any(np.abs(wrong[2:] - _exact(blocks, dopplers_hz[2:20], fs, if_hz)) > bound)


def test_bins_not_whole_dft_bins_apart_are_wiped_each_on_its_own():
    # 2.0461 MHz: a 1 ms block of 2046 samples, bins of 1000.05 Hz; the grid's 500 Hz steps
    # are no whole number of them.
    rng = np.random.default_rng(5)
    fs, n = 2.0461e6, 2046
    blocks = rng.standard_normal((2, n)).astype(np.float32)
    dopplers_hz = np.arange(-5000.0, 5000.0 + 250.0, 500.0)
    spectra = _DopplerSpectra(blocks, dopplers_hz, fs, 0.0)
    assert spectra.base is None
    np.testing.assert_array_equal(spectra.chunk(3, 9), _wiped_spectra(blocks, dopplers_hz[3:9], fs, 0.0))


def test_residue_spectra_beyond_their_memory_bound_are_wiped_per_bin(monkeypatch):
    from gnssframework.receiver.acquisition import fft_search

    rng = np.random.default_rng(6)
    blocks = rng.standard_normal((2, 2600)).astype(np.float32)
    dopplers_hz = np.arange(-5000.0, 5000.0 + 250.0, 500.0)  # 1 ms blocks: two residues
    assert fft_search._DopplerSpectra(blocks, dopplers_hz, 2.6e6, 0.0).base.shape[0] == 2
    monkeypatch.setattr(fft_search, "_RESIDUE_ELEMENTS", 2 * blocks.size - 1)
    spectra = fft_search._DopplerSpectra(blocks, dopplers_hz, 2.6e6, 0.0)
    assert spectra.base is None
    np.testing.assert_array_equal(spectra.chunk(0, 5), _wiped_spectra(blocks, dopplers_hz[:5], 2.6e6, 0.0))
