"""The chi-square and Student t quantiles the receiver and the statistics take from
`scipy.special` (so that they need not import `scipy.stats`, a second of every run's
start-up) are `scipy.stats`'s own, to the bit, NaN where it gives NaN."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from gnssframework.experiments.stats import t_quantile as _t
from gnssframework.navigation.pvt import chi2_ppf
from gnssframework.receiver.acquisition.threshold import noise_floor, threshold_from_pfa

PROBABILITIES = (0.5, 0.9, 0.95, 0.975, 0.99, 0.999, 1 - 1e-5, 1 - 1e-7)


@pytest.mark.parametrize("q", PROBABILITIES)
def test_chi2_ppf_is_scipy_stats(q):
    for dof in range(-1, 41):
        ours, theirs = chi2_ppf(q, dof), float(stats.chi2.ppf(q, dof))
        assert ours == theirs or (np.isnan(ours) and np.isnan(theirs)), (q, dof, ours, theirs)


@pytest.mark.parametrize("alternate", [False, True])
def test_acquisition_threshold_and_noise_floor_are_the_chi2_quantiles(alternate):
    grid = np.random.default_rng(3).chisquare(4, 500)
    for k in (1, 2, 5, 10):
        for pfa, cells in ((1e-3, 41 * 2600), (0.01, 1000), (0.2, 10)):
            p = -np.expm1(np.log1p(-pfa) / cells)
            q = -np.expm1(0.5 * np.log1p(-p)) if alternate else p
            assert threshold_from_pfa(pfa, cells, k, alternate) == float(stats.chi2.isf(q, 2 * k))
        median = stats.chi2.ppf(np.sqrt(0.5), 2 * k) if alternate else stats.chi2.median(2 * k)
        assert noise_floor(grid, k, alternate) == float(np.median(grid) / median)


def test_student_t_quantile_is_scipy_stats():
    for n in range(0, 60):
        ours, theirs = _t(n), float(stats.t.ppf(0.975, n - 1))
        assert ours == theirs or (np.isnan(ours) and np.isnan(theirs)), (n, ours, theirs)
