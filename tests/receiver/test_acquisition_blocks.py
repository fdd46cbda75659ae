"""The non-coherent block count chosen from detection theory (`threshold.blocks_for_detection`),
checked by Monte Carlo of the square-law statistic itself: complex blocks of a unit-variance
noise (I and Q) plus a signal of power ``2 (C/N0) T`` at a random phase, ``|z|^2`` summed over
``K`` blocks, against the chi-square threshold of `threshold_from_pfa` (Kaplan & Hegarty,
*Understanding GPS/GNSS*, 3rd ed., sec. 8.4). Independent of scipy's non-central chi-square.
"""

from __future__ import annotations

import numpy as np
import pytest

from gnssframework.errors import ConfigError
from gnssframework.receiver.acquisition.threshold import blocks_for_detection, detection_probability, threshold_from_pfa

T = 0.010
CELLS = 201 * 2600  # a +-5 kHz search of 10 ms blocks at 2.6 MHz
PFA = 1e-3
TRIALS = 20_000


def _simulated_pd(cn0_dbhz: float, blocks: int, threshold: float, rng: np.random.Generator) -> float:
    amplitude = np.sqrt(2 * 10 ** (cn0_dbhz / 10) * T)
    phase = rng.uniform(0, 2 * np.pi, (TRIALS, blocks))
    z = (
        amplitude * np.exp(1j * phase)
        + rng.standard_normal((TRIALS, blocks))
        + 1j * rng.standard_normal((TRIALS, blocks))
    )
    return float(np.mean(np.sum(np.abs(z) ** 2, axis=1) > threshold))


@pytest.mark.parametrize("cn0_dbhz", [30.0, 27.0])
def test_fewest_blocks_reach_the_detection_probability_by_monte_carlo(cn0_dbhz):
    rng = np.random.default_rng(7)
    pd = 0.9
    k = blocks_for_detection(cn0_dbhz, T, pd, PFA, CELLS)
    se = np.sqrt(pd * (1 - pd) / TRIALS)
    at_k = _simulated_pd(cn0_dbhz, k, threshold_from_pfa(PFA, CELLS, k), rng)
    below = _simulated_pd(cn0_dbhz, k - 1, threshold_from_pfa(PFA, CELLS, k - 1), rng)
    assert at_k > pd - 4 * se, (k, at_k)  # K blocks are enough ...
    assert below < pd + 4 * se, (k, below)  # ... and K - 1 are not
    # The closed form itself against the simulation at K.
    assert abs(detection_probability(cn0_dbhz, T, k, threshold_from_pfa(PFA, CELLS, k)) - at_k) < 4 * se


def test_more_blocks_for_a_weaker_signal_or_a_straddle_loss():
    counts = [blocks_for_detection(c, T, 0.9, PFA, CELLS, alternate=True) for c in (35.0, 30.0, 25.0)]
    assert counts[0] < counts[1] < counts[2]
    # A loss of L dB is the same as a signal L dB weaker.
    assert blocks_for_detection(30.0, T, 0.9, PFA, CELLS, loss_db=3.0) == blocks_for_detection(27.0, T, 0.9, PFA, CELLS)


def test_unreachable_detection_names_pd():
    with pytest.raises(ConfigError, match="pd"):
        blocks_for_detection(10.0, T, 0.9, PFA, CELLS, max_blocks=5)
    with pytest.raises(ConfigError, match="pd"):
        blocks_for_detection(30.0, T, 1.0, PFA, CELLS)
