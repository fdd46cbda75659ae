"""Tight-coupling update (`ins_navigator.tight_update`) against a hand-built information-form solution."""

from __future__ import annotations

import numpy as np
import pymap3d
import pytest

from gnssframework.errors import NumericalError
from gnssframework.receiver.deep.ins_navigator import tight_update
from gnssframework.receiver.deep.loose import pv_fix
from gnssframework.registry import create
from gnssframework.simulation.constellation import nominal_constellation

LAT, LON, H = 34.23, 108.3576, 590.6


def _sats(n):
    const = nominal_constellation()
    sats = const.subset(const.visible(0.0, LAT, LON, H, 10.0, n))
    s, sv, _ = sats.state(np.asarray(0.0))
    return s, sv


class _FixedIns:
    """A one-epoch INS: given position and velocity, identity transition, no process noise."""

    def __init__(self, p, v):
        self.p, self.v = np.array(p, float), np.array(v, float)
        self.applied = None

    def take_error_model(self):
        runs = len(self.p)
        return np.broadcast_to(np.eye(15), (runs, 15, 15)).copy(), np.zeros((runs, 15, 15))

    def kinematics(self):
        return self.p.copy(), self.v.copy(), np.zeros_like(self.p)

    def correct(self, dx):
        self.applied = dx
        self.p = self.p - dx[:, 6:9]
        self.v = self.v - dx[:, 3:6]


def _ekf(P0):
    ekf = create("nav_filter", "ins-ekf")
    from gnssframework.interfaces import RunContext

    ekf.reset((len(P0),), RunContext(initial_cov=P0))
    return ekf


def _truth_measurements(s, sv, r, v, b, d):
    """Pseudoranges and rates from a receiver at r, v with clock b (m), d (m/s), written out here."""
    diff = s - r
    rng = np.sqrt(np.sum(diff**2, axis=-1))
    e = diff / rng[:, None]
    return rng + b, np.sum(e * (sv - v), axis=-1) + d


def test_tight_update_equals_the_information_form_by_hand():
    s, sv = _sats(6)
    n = len(s)
    r = np.array(pymap3d.geodetic2ecef(LAT, LON, H))
    v = np.array(pymap3d.enu2uvw(60.0, -20.0, 5.0, LAT, LON))
    g = np.random.default_rng(11)
    p_ins = r + np.array([3.0, -2.0, 4.0])
    v_ins = v + np.array([0.2, 0.1, -0.3])
    rho, rate = _truth_measurements(s, sv, r, v, 250.0, -3.0)
    var_r = g.uniform(0.5, 4.0, n)
    var_v = g.uniform(0.01, 0.05, n)
    rho = rho + g.normal(size=n) * np.sqrt(var_r)
    rate = rate + g.normal(size=n) * np.sqrt(var_v)
    cn0 = g.uniform(35.0, 48.0, n)
    P0 = np.diag(
        np.concatenate([np.full(3, 1e-4), np.full(3, 0.25), np.full(3, 25.0), np.full(3, 1e-8), np.full(3, 1e-4)])
    )
    ins = _FixedIns(p_ins[None], v_ins[None])
    ekf = _ekf(P0[None])
    dx = tight_update(ins, ekf, rho[None], rate[None], var_r[None], var_v[None], s, sv, cn0[None])[0]

    # By hand: residuals at the INS, lines of sight at the INS, the difference operator against
    # the highest-C/N0 channel, information form (Groves 2013, eq. 3.43 ff.).
    e = (s - p_ins) / np.linalg.norm(s - p_ins, axis=-1)[:, None]
    z = np.concatenate([rho - np.linalg.norm(s - p_ins, axis=-1), rate - np.sum(e * (sv - v_ins), axis=-1)])
    Hu = np.zeros((2 * n, 15))
    Hu[:n, 6:9] = e
    Hu[n:, 3:6] = e
    ref = int(np.argmax(cn0))
    D1 = np.array(
        [[(1.0 if j == i else 0.0) - (1.0 if j == ref else 0.0) for j in range(n)] for i in range(n) if i != ref]
    )
    D = np.block([[D1, np.zeros_like(D1)], [np.zeros_like(D1), D1]])
    R = D @ np.diag(np.concatenate([var_r, var_v])) @ D.T
    Hd, zd = D @ Hu, D @ z
    info = np.linalg.inv(P0) + Hd.T @ np.linalg.solve(R, Hd)
    P_post = np.linalg.inv(info)
    x_post = P_post @ Hd.T @ np.linalg.solve(R, zd)
    np.testing.assert_allclose(dx, x_post, rtol=0, atol=1e-9 * np.max(np.abs(x_post)))
    np.testing.assert_allclose(ekf.cov[0], P_post, rtol=0, atol=1e-9 * np.max(np.abs(P_post)))
    # The clock (250 m, -3 m/s) cancels: the same update without it gives the same estimate.
    ins2, ekf2 = _FixedIns(p_ins[None], v_ins[None]), _ekf(P0[None])
    dx2 = tight_update(ins2, ekf2, rho[None] - 250.0, rate[None] + 3.0, var_r[None], var_v[None], s, sv, cn0[None])
    np.testing.assert_allclose(dx2[0], dx, rtol=0, atol=1e-9 * np.max(np.abs(x_post)))


def test_noise_free_update_removes_a_known_ins_error():
    s, sv = _sats(6)
    n = len(s)
    r = np.array(pymap3d.geodetic2ecef(LAT, LON, H))
    v = np.array(pymap3d.enu2uvw(60.0, -20.0, 5.0, LAT, LON))
    dr, dv = np.array([4.0, -3.0, 5.0]), np.array([0.3, -0.2, 0.1])
    rho, rate = _truth_measurements(s, sv, r, v, -80.0, 1.5)
    P0 = np.diag(np.concatenate([np.full(3, 1e-4), np.full(3, 1.0), np.full(3, 100.0), np.full(6, 1e-8)]))
    ins = _FixedIns((r + dr)[None], (v + dv)[None])
    tight_update(
        ins,
        _ekf(P0[None]),
        rho[None],
        rate[None],
        np.full((1, n), 1e-6),
        np.full((1, n), 1e-8),
        s,
        sv,
        np.full(n, 45.0),
    )
    # Left: the linearisation (|dr|^2 / (2 rho) < 1e-6 m on ranges; on rates the line of sight
    # turned by |dr| / rho = 3e-7 rad times |s_dot - v| < 4 km/s: 1.3e-3 m/s, times the
    # geometry's dilution, a few) and the prior's shrinkage (R / P0 = 1e-8).
    np.testing.assert_allclose(ins.p[0], r, atol=1e-4)
    np.testing.assert_allclose(ins.v[0], v, atol=1e-2)
    assert np.linalg.norm(ins.v[0] - v) < 0.1 * np.linalg.norm(dv)


def test_three_channels_still_update_where_a_fix_needs_four():
    s, sv = _sats(3)
    r = np.array(pymap3d.geodetic2ecef(LAT, LON, H))
    v = np.zeros(3)
    dr = np.array([4.0, -3.0, 5.0])
    rho, rate = _truth_measurements(s, sv, r, v, 10.0, 0.0)
    var_r, var_v = np.full((1, 3), 1e-6), np.full((1, 3), 1e-8)
    with pytest.raises(NumericalError, match="singular geometry"):
        pv_fix(rho[None], rate[None], var_r, var_v, s, sv, (r + dr)[None], v[None])
    P0 = np.diag(np.concatenate([np.full(3, 1e-4), np.full(3, 1.0), np.full(3, 100.0), np.full(6, 1e-8)]))
    ins = _FixedIns((r + dr)[None], v[None])
    tight_update(ins, _ekf(P0[None]), rho[None], rate[None], var_r, var_v, s, sv, np.full(3, 45.0))
    # Two differences see two directions: the error along them is removed, the third is not.
    e = (s - r) / np.linalg.norm(s - r, axis=-1)[:, None]
    seen = np.linalg.qr((e[1:] - e[0]).T)[0]  # (3, 2) orthonormal basis of the differences' span
    left = ins.p[0] - r
    assert np.linalg.norm(seen.T @ left) < 1e-4
    unseen = np.cross(seen[:, 0], seen[:, 1])
    np.testing.assert_allclose(unseen @ left, unseen @ dr, atol=1e-4)


def test_ins_ekf_coupling_picks_the_tight_candidate():
    from gnssframework.experiments.scenarios.deep_integration import _kind

    scalar = create("channel_filter", "scalar")
    assert _kind({"channel_filter": scalar, "nav_filter": create("nav_filter", "ins-ekf")}) == "loose"
    assert _kind({"channel_filter": scalar, "nav_filter": create("nav_filter", "ins-ekf", coupling="tight")}) == "tight"
    prefilter = create("channel_filter", "iq-filter", output="equivalent")
    assert (
        _kind({"channel_filter": prefilter, "nav_filter": create("nav_filter", "ins-ekf", coupling="tight")}) == "deep"
    )


def _hdop_dll_bound_m(sc, cn0_dbhz, dll_bandwidth_hz):
    """Horizontal position error of one epoch's clock-free least squares on the scalar DLLs'
    pseudoranges: sqrt(trace of the east/north block of sigma^2 (G^T G)^-1), G = [-e_enu, 1],
    sigma^2 the DLL's thermal variance (`scalar_measurement_variances`, Kaplan and Hegarty eq. 8.44)."""
    from gnssframework.receiver.deep.loose import scalar_measurement_variances

    p = sc.params
    s, _, _ = sc.satellites().state(np.asarray(p.start_time_s))
    r = np.array(pymap3d.geodetic2ecef(p.lat_deg, p.lon_deg, p.height_m))
    e = (s - r) / np.linalg.norm(s - r, axis=-1)[:, None]
    lat, lon = np.radians(p.lat_deg), np.radians(p.lon_deg)
    enu = np.array(
        [
            [-np.sin(lon), np.cos(lon), 0.0],
            [-np.sin(lat) * np.cos(lon), -np.sin(lat) * np.sin(lon), np.cos(lat)],
            [np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)],
        ]
    )
    G = np.column_stack([-(e @ enu.T), np.ones(len(e))])
    var_code, _ = scalar_measurement_variances(cn0_dbhz, p.coherent_time_s, dll_bandwidth_hz, 20.7, p.rate_window_s)
    C = float(var_code) * np.linalg.inv(G.T @ G)
    return float(np.sqrt(C[0, 0] + C[1, 1]))


@pytest.mark.slow
def test_tight_candidate_end_to_end_is_within_the_dll_and_geometry_bound():
    # examples/deep_integration_ci.toml's scenario and loose candidate, cut to 4 s of the level
    # start of the flight, one case (45 dB-Hz), 2 runs; loose and tight on common random numbers.
    from gnssframework.experiments.scenarios import get_scenario

    sc = get_scenario(
        {
            "kind": "deep-integration",
            "profile": "pull-up",
            "duration_s": 4.0,
            "settle_s": 1.0,
            "coherent_time_s": 0.001,
            "imu_interval_s": 0.005,
            "nco_interval_s": 0.005,
            "update_interval_s": 0.1,
            "channels": 8,
            "clock": "ocxo",
            "loose_rate_window": "trailing",
            "loose_dll_correlation": "loop",
            "loose_gate_probability": 0.001,
        }
    )
    out = {}
    for coupling in ("loose", "tight"):
        plugins = {
            "channel_filter": create("channel_filter", "scalar", pll_bandwidth_hz=20.7, dll_bandwidth_hz=0.21),
            "nav_filter": create("nav_filter", "ins-ekf", coupling=coupling),
        }
        res = sc.run_batch({"name": "45dBHz", "cn0_dbhz": 45.0}, plugins, 2, np.random.default_rng(2222))
        out[coupling] = np.asarray(res.metrics["horizontal_position_error_rmse"])
    tight, loose = out["tight"], out["loose"]
    assert np.all(np.isfinite(tight))
    # Bound: one epoch's least-squares horizontal error from the DLL's thermal noise through this
    # sky's geometry (0.55 m here); the INS filter only averages it. Each run's RMS is over
    # 3 s of errors correlated over 1/(4 B_L) = 1.2 s, so a few (>= 2) independent samples of a
    # 2-D error: P(mean square > 9 x its expectation) <= exp(-9) = 1.2e-4 per run. Hence 3x.
    bound_m = 3.0 * _hdop_dll_bound_m(sc, 45.0, 0.21)
    assert np.all(tight < bound_m), (tight, bound_m)
    # With every channel in and the fix's full covariance, the fix carries the same information as
    # its channels (linear least squares with a free clock = single differences): the two agree
    # up to the linearisation and the gate's rare rejections.
    np.testing.assert_allclose(tight, loose, rtol=0.05)
