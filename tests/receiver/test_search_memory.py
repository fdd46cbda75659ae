"""The acquisition search's memory bounds (`fft_search._CHUNK_ELEMENTS`, the pcps plugin's
`_GRID_ELEMENTS`) choose how much is held at once, never the numbers: the grid and the
results are the same to the bit with the smallest chunk and group."""

from __future__ import annotations

import numpy as np

import gnssframework_plugins.acquisition as pcps_module
from gnssframework import registry
from gnssframework.receiver.acquisition import fft_search
from gnssframework.receiver.frontend import SatelliteSignal, synthesize_samples

FS = 2.6e6


def test_one_doppler_bin_per_chunk_and_one_prn_per_group_give_the_same_search(monkeypatch):
    rng = np.random.default_rng(3)
    x = synthesize_samples(
        [SatelliteSignal(7, 47.0, 1250.0, 300.0), SatelliteSignal(20, 45.0, -2100.0, 40.0)], 0.02, FS, 0.0, rng
    )
    dopplers = np.arange(-10, 11) * 500.0
    default = fft_search.search_grid(x, FS, 0.0, (7, 20, 3), 2e-3, 4, dopplers, alternate=True)
    acq = registry.create("acquisition", "pcps", coherent_ms=2, noncoherent=4, alternate_blocks=True)
    found = acq.acquire(x, FS, 0.0, (7, 20, 3))
    monkeypatch.setattr(fft_search, "_CHUNK_ELEMENTS", 1)
    monkeypatch.setattr(pcps_module, "_GRID_ELEMENTS", 1)
    np.testing.assert_array_equal(
        fft_search.search_grid(x, FS, 0.0, (7, 20, 3), 2e-3, 4, dopplers, alternate=True), default
    )
    assert acq.acquire(x, FS, 0.0, (7, 20, 3)) == found
    assert [r.prn for r in found if r.detected] == [7, 20]


def test_a_weak_search_holds_no_array_of_every_bin_block_and_sample():
    """The `--weak` search's sizes (18 blocks of 10 ms at 2.6 MHz, code Doppler followed),
    peak traced allocations (NumPy reports its buffers to `tracemalloc`):

    - the fine search (21 bins) holds one ``(N, bins)`` carrier matrix, not the
      ``(bins, K, N)`` complex128 table of 150 MB (which it held, and 305 MB at peak,
      before 5 Dec 2026): under a quarter of that table;
    - the grid of one PRN (201 bins, 20 MB) is made chunk by chunk: the grid, the residue
      spectra and six chunks of transients at most (the ramp of the code Doppler is built
      in complex64, without complex128 temporaries)."""
    import tracemalloc

    n, k = 26_000, 18
    rng = np.random.default_rng(1)
    x = (rng.standard_normal(k * n) + 1j * rng.standard_normal(k * n)).astype(np.complex64)
    fine = -2775.0 + np.arange(-50.0, 51.0, 5.0)
    tracemalloc.start()
    try:
        fft_search.fine_doppler(x, FS, 0.0, 5, 246, 0.01, k, fine, True, code_doppler=True)
        fine_peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.reset_peak()
        dopplers = np.arange(-100, 101) * 50.0
        fft_search.search_grid(x, FS, 0.0, (5,), 0.01, k, dopplers, True, code_doppler=True)
        grid_peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert fine_peak < fine.size * k * n * 16 / 4
    grid, residues, chunk = dopplers.size * n * 4, 2 * k * n * 8, fft_search._CHUNK_ELEMENTS * 8
    assert grid_peak < grid + residues + 6 * chunk, (grid_peak, grid, chunk)
