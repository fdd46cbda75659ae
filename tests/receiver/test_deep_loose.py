"""Loose-coupling baseline pieces: the weighted least-squares fix and the scalar loops' measurements."""

from __future__ import annotations

import numpy as np
import pymap3d

from gnssframework.receiver.deep.loose import pv_fix, scalar_measurement_variances, scalar_measurements, scalar_tracking
from gnssframework.registry import create
from gnssframework.simulation.constellation import nominal_constellation


def _geometry():
    const = nominal_constellation()
    lat, lon, h = 34.23, 108.3576, 590.6
    sats = const.subset(const.visible(0.0, lat, lon, h, 10.0, 6))
    s, sv, _ = sats.state(np.asarray(0.0))
    r = np.array(pymap3d.geodetic2ecef(lat, lon, h))
    v = np.array(pymap3d.enu2uvw(50.0, 50.0, 50.0, lat, lon))
    return s, sv, r, v


def _true(s, sv, r, v, b, d):
    e = (s - r) / np.linalg.norm(s - r, axis=-1, keepdims=True)
    return np.linalg.norm(s - r, axis=-1) + b, np.sum(e * (sv - v), -1) + d


def test_pv_fix_recovers_the_truth_and_its_covariance_is_consistent():
    s, sv, r, v = _geometry()
    runs = 4000
    rho, rate = _true(s, sv, r, v, 123.0, -4.0)
    g = np.random.default_rng(3)
    var_r = g.uniform(1.0, 9.0, size=(runs, len(s)))
    var_v = g.uniform(0.01, 0.04, size=(runs, len(s)))
    start_p = r + g.normal(size=(runs, 3)) * 100.0
    start_v = v + g.normal(size=(runs, 3)) * 5.0
    # Noise free: the fix is the truth whatever the starting point.
    p, vv, _ = pv_fix(
        np.broadcast_to(rho, var_r.shape), np.broadcast_to(rate, var_r.shape), var_r, var_v, s, sv, start_p, start_v
    )
    np.testing.assert_allclose(p, np.broadcast_to(r, p.shape), atol=1e-5)
    np.testing.assert_allclose(vv, np.broadcast_to(v, vv.shape), atol=1e-7)
    # With noise: NEES of [position, velocity] averages 6 (Monte Carlo, 4000 draws: SE 0.055).
    p, vv, cov = pv_fix(
        rho + g.normal(size=var_r.shape) * np.sqrt(var_r),
        rate + g.normal(size=var_v.shape) * np.sqrt(var_v),
        var_r,
        var_v,
        s,
        sv,
        start_p,
        start_v,
    )
    err = np.concatenate([p - r, vv - v], -1)
    nees = np.einsum("ri,rij,rj->r", err, np.linalg.inv(cov), err)
    assert abs(nees.mean() - 6.0) < 4 * np.sqrt(12 / runs), nees.mean()


def test_scalar_loops_read_the_range_within_their_thermal_variance():
    # Constant-rate lines of sight (a 50 m/s flight): the scalar loops' pseudorange and rate errors
    # have the thermal variances of scalar_measurement_variances (code to 30 %, rate below 2x;
    # the rate's formula takes the window's end points as independent).
    s, sv, r, v = _geometry()
    runs, T, K = 8, 1e-3, 1500
    t = np.arange(K + 1) * T
    rho = np.stack([_true(s, sv, r + v * tk, v, 100.0, 0.0)[0] for tk in t])[:, None, :].repeat(runs, 1)
    rec = scalar_tracking(create("channel_filter", "scalar"), rho, 45.0, T, np.random.default_rng(9))
    err_rho, err_rate = [], []
    for k in range(500, K - 20, 10):
        true_rate = (rho[k + 2] - rho[k]) / (2 * T)
        m_rho, m_rate = scalar_measurements(rec, rho[k + 1], true_rate, k, 20)
        err_rho.append(m_rho - rho[k + 1])
        err_rate.append(m_rate - true_rate)
    err_rho, err_rate = np.array(err_rho), np.array(err_rate)
    var_code, var_rate = scalar_measurement_variances(45.0, T, 1.0, 15.0, 0.02)
    assert 0.7 < np.var(err_rho) / var_code < 1.3, np.var(err_rho) / var_code
    assert abs(np.mean(err_rho)) < 1.0  # 1 Hz DLL: about 30 independent samples per channel, SE 0.2 m
    assert 0.3 < np.var(err_rate) / var_rate < 2.0, np.var(err_rate) / var_rate
    assert abs(np.mean(err_rate)) < 4 * np.sqrt(var_rate / err_rate.size * 2)
