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
