"""The loop's estimate of a start-time error (`vector_time.TimeOffsetEstimator`) on
constructed epochs: residuals that are the satellites' range rates times a known offset,
plus white noise and a position and clock error the projection must remove.

Truths: the offset put in, and Student's t for the coverage of the batch-means sigma."""

from __future__ import annotations

import numpy as np
from scipy import stats

from gnssframework.receiver.navigation.vector_time import BATCHES, TimeOffsetEstimator

WINDOW_S = 2.0
EPOCH_S = 0.01


def _geometry(rng, n: int) -> tuple[np.ndarray, np.ndarray]:
    los = rng.normal(size=(n, 3))
    los[:, 2] = np.abs(los[:, 2])  # satellites above the horizon
    los /= np.linalg.norm(los, axis=1, keepdims=True)
    return los, rng.uniform(-800.0, 800.0, n)  # lines of sight, range rates (m/s)


def _window(est: TimeOffsetEstimator, rng, offset_s: float, noise_m: float, t0: float, use_until_s: float):
    """Epochs of one window from ``t0``; channels read until ``use_until_s`` (recording time)."""
    los, rate = _geometry(rng, 6)
    found = None
    t = t0
    while found is None:
        dr, db = rng.normal(0, 30.0, 3), rng.normal(0, 50.0)  # what the filter has not absorbed
        residual = rate * offset_s - los @ dr + db + rng.normal(0, noise_m, rate.size)
        use = np.full(rate.size, t < use_until_s)
        found = est.add(t, residual, np.full(rate.size, noise_m**2), los, rate, use)
        t += EPOCH_S
    return found, t


def test_the_estimate_is_the_offset_and_its_sigma_covers_it_as_students_t_says():
    """300 windows of white code errors (10 m) about an offset of 30 ms: the estimates'
    mean is the offset within four standard errors, and the offset is outside the two-sided
    95 % t-interval of the window's sigma in 5 % of windows (99.9 % binomial bounds: 4 to 30
    of 300), with the degrees of freedom of ten balanced batches."""
    rng = np.random.default_rng(40)
    offsets, outside, dofs = [], 0, set()
    for _ in range(300):
        est = TimeOffsetEstimator(WINDOW_S)
        est.restart(0.0)
        found, _ = _window(est, rng, 0.030, 10.0, 0.0, np.inf)
        offsets.append(found.offset_s)
        dofs.add(found.dof)
        outside += abs(found.offset_s - 0.030) > stats.t.ppf(0.975, found.dof) * found.sigma_s
    offsets = np.array(offsets)
    assert abs(offsets.mean() - 0.030) < 4 * offsets.std(ddof=1) / np.sqrt(offsets.size)
    low, high = stats.binom.ppf([0.0005, 0.9995], 300, 0.05)
    assert low <= outside <= high, outside
    assert dofs == {BATCHES - 1}  # ten full batches (the window's closing epoch, alone in an eleventh, not counted)


def test_a_window_whose_information_is_in_one_batch_moves_nothing():
    """Channels read for the first batch and one epoch of the second: two batches with
    information, one of them nearly all of it. Their batch-means variance is near zero (both
    estimate the same offset), and before, with one degree of freedom (batches less one), a
    20 ms offset passed Student's t at 1e-4 (6,366 sigmas): the start time moved on a variance
    nothing supports. Now a batch counts with a tenth of the largest batch's information
    (`MIN_BATCH_SHARE`): no degree of freedom, not significant."""
    rng = np.random.default_rng(7)
    est = TimeOffsetEstimator(WINDOW_S)
    est.restart(0.0)
    found, _ = _window(est, rng, 0.020, 0.01, 0.0, WINDOW_S / BATCHES + EPOCH_S / 2)
    assert found.dof == 0 and not found.significant(1e-4)
    assert abs(found.offset_s - 0.020) < 1e-3  # the estimate itself is right: only its trust is refused
