"""The navigation filter on observables leaves out a satellite with a pseudorange fault.

Observables of a static station are built from real broadcast records by an independent
light-time loop (`station_observables`, shared with `test_receiver_nav_filter`), with
white noise of the filter's stated variances; from epoch 20 on, one satellite's pseudorange carries a step
of 40 m. With the innovation test (`filtered.innovation_exclusion`, chi-square at
p = 1e-4) the filter leaves out that satellite at every faulty epoch, keeps every other,
and its position stays inside a bound at every epoch; with no test (``exclusion="none"``)
the fault drags the position out of that bound.

The bound: the filter, fusing epochs, is at least as good as one epoch's weighted least
squares, whose position error ``e`` has the covariance ``C = σ² (H^T W H)^-1`` (its
position block) with the same weights; ``e^T C^-1 e`` is then at most chi-square with
3 degrees of freedom, and the bound is its 1 - 1e-6 quantile.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2

from gnssframework.errors import ConfigError
from gnssframework.receiver.navigation.filtered import filter_epochs, innovation_exclusion, EpochMeasurements
from gnssframework.receiver.navigation.fixes import solve_epochs
from gnssframework.receiver.navigation.observables import Observables
from station_observables import C, L1_WAVELENGTH_M, STATION, geometry, visible

T0, EPOCHS, FAULT_EPOCH, FAULT_M = 518_700.0, 60, 20, 40.0
SIGMA_M, SIGMA_RATE = 1.0, 0.05
BIAS_M = 1500.0


def _scenario():
    sel, nav = visible(T0, 15.0)
    prn = np.array([int(s[1:]) for s in sel.sv])
    rng = np.random.default_rng(2025)
    t = T0 + np.arange(EPOCHS, dtype=float)
    pr, tx, dop = (np.zeros((EPOCHS, prn.size)) for _ in range(3))
    for k, tk in enumerate(t):
        pr[k], tx[k], _, el = geometry(sel, tk, BIAS_M)
        rate = geometry(sel, tk + 0.5, BIAS_M)[0] - geometry(sel, tk - 0.5, BIAS_M)[0]
        sin_el = np.sin(el)
        pr[k] += rng.standard_normal(prn.size) * SIGMA_M / sin_el
        dop[k] = -(rate + rng.standard_normal(prn.size) * SIGMA_RATE / sin_el) / L1_WAVELENGTH_M
    _, _, los, el = geometry(sel, T0, BIAS_M)
    obs = Observables(
        t + BIAS_M / C, t - T0, prn, tx, pr, dop, np.zeros_like(pr), np.full(pr.shape, 45.0), {}, None, None
    )
    return nav, obs, los, el


def _faulty(obs, j):
    pr = obs.pseudorange_m.copy()
    pr[FAULT_EPOCH:, j] += FAULT_M
    return Observables(
        obs.rx_time_s,
        obs.sample_time_s,
        obs.prn,
        obs.transmit_s,
        pr,
        obs.doppler_hz,
        obs.carrier_cycles,
        obs.cn0_dbhz,
        {},
        None,
        None,
    )


def _wls_position_cov(los, el):
    H = np.hstack([-los, np.ones((los.shape[0], 1))])
    W = np.diag(np.sin(el) ** 2)
    return SIGMA_M**2 * np.linalg.inv(H.T @ W @ H)[:3, :3], H, W


@pytest.fixture(scope="module")
def runs():
    nav, obs, los, el = _scenario()
    cov, H, W = _wls_position_cov(los, el)
    # The satellite whose fault moves the least-squares position furthest in the metric of C.
    gain = (np.linalg.inv(H.T @ W @ H) @ H.T @ W)[:3]
    shift = [FAULT_M * gain[:, j] @ np.linalg.solve(cov, FAULT_M * gain[:, j]) for j in range(obs.prn.size)]
    j = int(np.argmax(shift))
    faulty = _faulty(obs, j)
    wls = solve_epochs(faulty, nav, ionosphere=False, sigma_m=SIGMA_M, elevation_mask_deg=10.0, reference_week=1316)
    common = dict(
        rinex=nav,
        ionosphere=False,
        sigma_m=SIGMA_M,
        sigma_rate_m_s=SIGMA_RATE,
        elevation_mask_deg=10.0,
        reference_week=1316,
    )
    gated = filter_epochs(
        faulty, wls, "ekf-pv", {"accel_psd": 0.01}, exclusion="innovation", innovation_false_alarm=1e-4, **common
    )
    ungated = filter_epochs(faulty, wls, "ekf-pv", {"accel_psd": 0.01}, exclusion="none", **common)
    return obs, cov, j, shift[j], gated, ungated


def _mahalanobis(table, cov):
    err = table.ecef_m - STATION
    return np.einsum("ki,ij,kj->k", err, np.linalg.inv(cov), err)


def test_the_innovation_test_leaves_out_the_faulty_satellite_and_keeps_the_position_in_its_bound(runs):
    obs, cov, j, shift, gated, _ = runs
    bound = chi2.ppf(1 - 1e-6, 3)
    assert shift > 4 * bound  # the fault is large enough to matter (checked, not assumed)
    assert len(gated) == EPOCHS
    bad = int(obs.prn[j])
    others = set(int(p) for p in obs.prn) - {bad}
    for k, used in enumerate(gated.used_prns):
        if k >= FAULT_EPOCH:
            assert bad not in used and gated.excluded_prn[k] == bad
        else:
            assert gated.excluded_prn[k] == 0
        assert others <= set(used)
    assert np.all(_mahalanobis(gated, cov) < bound)


def test_without_the_test_the_fault_drags_the_position_out_of_its_bound(runs):
    obs, cov, j, _, _, ungated = runs
    bound = chi2.ppf(1 - 1e-6, 3)
    d2 = _mahalanobis(ungated, cov)
    assert np.all(d2[:FAULT_EPOCH] < bound)  # the same filter, before the fault
    assert np.all(d2[-10:] > bound)
    assert all(int(obs.prn[j]) in used for used in ungated.used_prns)


def test_a_fault_free_epoch_passes_and_one_fault_among_many_is_the_one_left_out():
    """The statistic against an exact prediction is the noise's chi-square; a 30-sigma
    range error on one satellite is identified among eight."""
    rng = np.random.default_rng(5)
    u = rng.standard_normal((8, 3))
    u[:, 2] = np.abs(u[:, 2]) + 0.3
    u /= np.linalg.norm(u, axis=1)[:, None]
    sat = 2.6e7 * u
    x = np.r_[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 100.0, 1.0]
    rng_m, rate = np.linalg.norm(sat, axis=1) + 100.0, np.full(8, 1.0)
    m = EpochMeasurements(
        sat,
        np.zeros((8, 3)),
        rng_m + rng.standard_normal(8),
        rate + 0.1 * rng.standard_normal(8),
        np.ones(8),
        np.full(8, 0.01),
    )
    P = np.diag([1.0] * 3 + [0.01] * 3 + [1.0, 0.01])
    keep, stat = innovation_exclusion(x, P, m, 1e-3)
    assert keep.all() and stat < chi2.ppf(1 - 1e-3, 16)
    m.range_m[3] += 30.0 * np.sqrt(2.0)  # innovation variance 1 (R) + about 1 (P)
    keep, _ = innovation_exclusion(x, P, m, 1e-3)
    assert np.flatnonzero(~keep).tolist() == [3]


def test_bad_exclusion_settings_are_refused():
    nav, obs, _, _ = _scenario()
    wls = solve_epochs(obs, nav, ionosphere=False, reference_week=1316)
    with pytest.raises(ConfigError, match="exclusion: got 'raim'; allowed: innovation, least-squares, none"):
        filter_epochs(obs, wls, rinex=nav, exclusion="raim")
    with pytest.raises(ConfigError, match="innovation_false_alarm: must be a probability"):
        filter_epochs(obs, wls, rinex=nav, innovation_false_alarm=0.0)
