"""The fine Doppler search (`fft_search.fine_doppler`, one carrier matrix for every block) gives the
statistic of the definition: per bin and block, the sum of samples times code replica
times the bin's own carrier, computed here directly sample by sample over the bins."""

from __future__ import annotations

import numpy as np
import pytest

from gnssframework.receiver.acquisition import code_replica, fine_doppler


def _direct(x, fs, if_hz, prn, lag, n, k, dopplers_hz):
    replica = np.roll(code_replica(prn, n, fs), lag).astype(float)
    t = np.arange(k * n) / fs
    out = []
    for f in dopplers_hz:  # one bin at a time: no shared factor
        z = (x * np.tile(replica, k) * np.exp(-2j * np.pi * (if_hz + f) * t)).reshape(k, n).sum(axis=1)
        out.append(np.sum(np.abs(z) ** 2))
    return np.array(out)


@pytest.mark.parametrize("fs, if_hz", [(2.6e6, 0.0), (4e6, 1.25e6)])
def test_fine_search_matches_the_definition_per_bin(fs, if_hz):
    rng = np.random.default_rng(3)
    n, k = int(round(1e-3 * fs)), 4
    x = rng.standard_normal(k * n) + 1j * rng.standard_normal(k * n)
    fine = -1250.0 + np.arange(-500.0, 525.0, 25.0)  # the plugin's grid: coarse bin +- a step
    got = fine_doppler(x, fs, if_hz, 5, 77, 1e-3, k, fine)
    want = _direct(x, fs, if_hz, 5, 77, n, k, fine)
    # Both are sums of k*n float64 products; the phase argument (up to 2 pi f t ~ 3e4 rad)
    # carries ~1e-12 rad of rounding, far below this bound.
    np.testing.assert_allclose(got, want, rtol=1e-9)
    # A grid that is not evenly spaced takes the per-bin path: the same values.
    uneven = fine[[0, 3, 4, 10]]
    np.testing.assert_allclose(fine_doppler(x, fs, if_hz, 5, 77, 1e-3, k, uneven), want[[0, 3, 4, 10]], rtol=1e-9)
