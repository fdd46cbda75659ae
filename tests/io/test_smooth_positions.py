"""``gnssframework smooth-positions`` (`gnssframework.io.positions.smooth_positions`):
the forward position filter then the RTS pass, against independent truths.

- closed form: with the ``kf`` engine the smoothed positions and variances equal the joint
  Gaussian posterior of the constant-acceleration model (dense least squares over the whole
  track, no recursion);
- the forward filter's own output: smoothed variance <= filtered variance at every fix;
- a simulated track: smoothed RMSE below filtered RMSE, paired over runs, with its SE.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pymap3d

import gnssframework as gf
from gnssframework.cli import main
from gnssframework.io.nmea import NmeaFixes
from gnssframework.io.positions import _local_track, smooth_positions

LOG = Path(__file__).resolve().parents[2] / "examples" / "data" / "static_receiver.nmea"
LAT0, LON0 = 30.5281, 114.3545


def track_fixes(rng, K: int, sigma_m: float = 3.0):
    """A manoeuvring track (random-walk acceleration) seen with white noise, as NMEA fixes;
    also its true north/east (m) about (LAT0, LON0)."""
    acc = np.cumsum(rng.normal(0.0, 0.05, (K, 2)), axis=0)
    vel = 5.0 + np.cumsum(acc, axis=0)
    truth = np.cumsum(vel, axis=0)
    meas = truth + rng.normal(0.0, sigma_m, truth.shape)
    lat, lon, _ = pymap3d.enu2geodetic(meas[:, 1], meas[:, 0], 0.0, LAT0, LON0, 0.0)
    fixes = NmeaFixes(np.arange(K, dtype=float), np.asarray(lat), np.asarray(lon), np.zeros(K), np.arange(1, K + 1))
    return fixes, truth


def dense_posterior(model, initial, zs):
    """Mean and marginal covariances of x_0..x_{K-1} given zs, one coordinate (least squares)."""
    K, n = zs.shape[0], model.F.shape[0]
    N = (K + 1) * n
    J, b = np.zeros((N, N)), np.zeros(N)
    W0 = np.linalg.inv(initial.cov)
    J[:n, :n] += W0
    b[:n] += W0 @ initial.mean
    Qi, Ri = np.linalg.inv(model.Q), np.linalg.inv(model.R)
    for k in range(K):
        i = (k + 1) * n
        A = np.zeros((n, N))
        A[:, i : i + n] = np.eye(n)
        A[:, i - n : i] = -model.F
        J += A.T @ Qi @ A
        B = np.zeros((1, N))
        B[:, i : i + n] = model.H
        J += B.T @ Ri @ B
        b += B.T @ Ri @ zs[k : k + 1]
    cov = np.linalg.inv(J)
    mean = cov @ b
    return mean.reshape(K + 1, n)[1:], np.array([cov[(k + 1) * n, (k + 1) * n] for k in range(K)])


def test_smoothed_track_is_the_joint_posterior_of_the_position_model(rng):
    fixes, _ = track_fixes(rng, 40)
    track = smooth_positions(fixes, "kf")
    zs, _, _ = _local_track(fixes)  # the filter's input (north, east metres)
    nav = gf.registry.create("nav_filter", "position-ca", dt_s=1.0)
    for c, (pos, var) in enumerate(((track.north_m, track.var_north_m2), (track.east_m, track.var_east_m2))):
        mean, cov = dense_posterior(nav.model(1.0), nav.initial(zs[0, c]), zs[:, c])
        np.testing.assert_allclose(pos, mean[:, 0], rtol=0, atol=1e-6)
        np.testing.assert_allclose(var, cov, rtol=1e-8)


def test_smoothing_beats_filtering_on_simulated_tracks(rng):
    """Smoothed variance <= filtered at every fix; RMSE lower, paired over 8 runs."""
    diffs = []
    for _ in range(8):
        fixes, truth = track_fixes(rng, 120)
        track = smooth_positions(fixes, "UKF")
        assert np.all(track.var_north_m2 <= track.filtered_var_north_m2 * (1 + 1e-12))
        assert np.all(track.var_east_m2 <= track.filtered_var_east_m2 * (1 + 1e-12))
        np.testing.assert_allclose(track.var_north_m2[-1], track.filtered_var_north_m2[-1], rtol=1e-12)
        e, n, _ = pymap3d.geodetic2enu(track.lat_deg, track.lon_deg, 0.0, LAT0, LON0, 0.0)
        fn, fe = (track.filtered_north_m, track.filtered_east_m)
        # the filtered track in the same frame as the truth: shift the local origin back
        zs, lat0, lon0 = _local_track(fixes)
        on, oe = (lambda enu: (enu[1], enu[0]))(pymap3d.geodetic2enu(lat0, lon0, 0.0, LAT0, LON0, 0.0))
        rmse_s = np.sqrt(np.mean((n - truth[:, 0]) ** 2 + (e - truth[:, 1]) ** 2))
        rmse_f = np.sqrt(np.mean((fn + on - truth[:, 0]) ** 2 + (fe + oe - truth[:, 1]) ** 2))
        diffs.append(rmse_s - rmse_f)
    d = np.array(diffs)
    se = d.std(ddof=1) / np.sqrt(d.size)
    assert d.mean() + 3 * se < 0, (d.mean(), se)


def test_cli_smooth_positions_writes_the_smoothed_track_and_variances(tmp_path, capsys):
    out = tmp_path / "smoothed.csv"
    assert main(["smooth-positions", str(LOG), "--out", str(out), "--filter", "kf"]) == 0
    assert "500 fixes smoothed" in capsys.readouterr().out
    with open(out) as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 500
    sv = np.array([float(r["smoothed_var_north_m2"]) for r in rows])
    fv = np.array([float(r["filtered_var_north_m2"]) for r in rows])
    assert np.all(sv <= fv * (1 + 1e-5)) and np.all(sv > 0)  # the CSV keeps 6 decimals
    # the static receiver: the smoothed track is closer to the truth than the raw fixes
    lat = np.array([float(r["smoothed_lat_deg"]) for r in rows])
    lon = np.array([float(r["smoothed_lon_deg"]) for r in rows])
    raw_lat = np.array([float(r["lat_deg"]) for r in rows])
    raw_lon = np.array([float(r["lon_deg"]) for r in rows])

    def rms(la, lo):
        e, n, _ = pymap3d.geodetic2enu(la, lo, 0.0, LAT0, LON0, 0.0)
        return np.sqrt(np.mean(e**2 + n**2))

    assert rms(lat, lon) < rms(raw_lat, raw_lon)
