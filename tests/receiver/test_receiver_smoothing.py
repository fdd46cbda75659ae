"""The receiver's navigation-filter positions smoothed forward-backward (``receive --smooth``,
`filtered_smoothing`).

- The backward pass equals FilterPy's ``KalmanFilter.rts_smoother`` (an independent RTS
  implementation) on the same forward pass, F and Q, run by run.
- On the static station of `test_receiver_nav_exclusion` (real broadcast records, an
  independent light-time loop, white noise of the stated variances): the last row of a run
  is the filter's (nothing after it), every smoothed row's protection levels are at most
  the filter's (``P^s <= P``), and the smoothed positions are nearer the station.
- A filter whose state is not the published 8, and --smooth without --nav-filter or with
  several signals, are refused in one line.
"""

from __future__ import annotations

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter

from gnssframework import registry
from gnssframework.errors import ConfigError
from gnssframework.receiver.navigation.filtered import filter_epochs
from gnssframework.receiver.navigation.filtered_smoothing import check_smoothable, smooth_runs
from gnssframework.receiver.navigation.fixes import solve_epochs
from station_observables import STATION
from test_receiver_nav_exclusion import SIGMA_M, SIGMA_RATE, _scenario


def _forward_pass(rng, K, F, Q):
    """A Kalman filter's forward pass on a random linear model with these F and Q: filtered
    means and covariances ``(K, 8)``, ``(K, 8, 8)``."""
    H = rng.standard_normal((5, 8))
    R = np.diag(rng.uniform(0.5, 2.0, 5))
    x, P = np.zeros(8), np.eye(8) * 10.0
    xs, Ps = [], []
    for k in range(K):
        if k:
            x, P = F @ x, F @ P @ F.T + Q
        S = H @ P @ H.T + R
        G = P @ H.T @ np.linalg.inv(S)
        x = x + G @ (rng.standard_normal(5) * 3.0 - H @ x)
        P = (np.eye(8) - G @ H) @ P
        P = 0.5 * (P + P.T)
        xs.append(x)
        Ps.append(P)
    return np.array(xs), np.array(Ps)


def test_the_backward_pass_equals_filterpys_rts_smoother_run_by_run():
    rng = np.random.default_rng(4)
    F, Q = registry.create("nav_filter", "ekf-pv", accel_psd=0.3).transition(0.5)
    xs, Ps = _forward_pass(rng, 30, F, Q)
    got_x, got_P = smooth_runs(xs, Ps, [0, 12], F, Q)
    kf = KalmanFilter(dim_x=8, dim_z=1)
    for a, b in ((0, 12), (12, 30)):  # each run alone: the second starts afresh at 12
        ref_x, ref_P, _, _ = kf.rts_smoother(xs[a:b], Ps[a:b], Fs=[F] * (b - a), Qs=[Q] * (b - a))
        np.testing.assert_allclose(got_x[a:b], ref_x, rtol=0, atol=1e-9 * np.abs(ref_x).max())
        np.testing.assert_allclose(got_P[a:b], ref_P, rtol=0, atol=1e-9 * np.abs(ref_P).max())
    # The last estimate of each run is the filter's; the others moved.
    assert np.array_equal(got_x[11], xs[11]) and np.array_equal(got_x[29], xs[29])
    assert np.abs(got_x[:11] - xs[:11]).max() > 1e-3


@pytest.fixture(scope="module")
def station_runs():
    nav, obs, _, _ = _scenario()
    common = dict(ionosphere=False, sigma_m=SIGMA_M, elevation_mask_deg=10.0, reference_week=1316)
    wls = solve_epochs(obs, nav, **common)
    args = (obs, wls, "ekf-pv", {"accel_psd": 0.01})
    kw = dict(rinex=nav, sigma_rate_m_s=SIGMA_RATE, integrity_risk=1e-7, **common)
    return filter_epochs(*args, **kw), filter_epochs(*args, smooth=True, **kw)


def test_smoothed_receiver_positions_end_at_the_filters_and_are_tighter_and_nearer(station_runs):
    forward, smoothed = station_runs
    assert len(forward) == len(smoothed) > 50
    np.testing.assert_array_equal(smoothed.ecef_m[-1], forward.ecef_m[-1])
    # P^s <= P: the levels (monotone in the position covariance) never grow; before the
    # end they shrink (the later epochs inform the earlier).
    for pl in ("hpl_m", "vpl_m"):
        assert np.all(smoothed.columns[pl] <= forward.columns[pl] * (1 + 1e-9))
        assert np.median(smoothed.columns[pl][:-10] / forward.columns[pl][:-10]) < 0.8  # measured 0.70
    err = lambda t: np.linalg.norm(t.ecef_m - STATION, axis=1)  # noqa: E731
    # Nearer the station: the RMS over the run (measured 1.07 m against 1.84 m) and over the
    # first 20 epochs, where the forward filter has had least to fuse (measured 0.40 of it).
    assert np.sqrt(np.mean(err(smoothed) ** 2)) < np.sqrt(np.mean(err(forward) ** 2))
    assert np.sqrt(np.mean(err(smoothed)[:20] ** 2)) < 0.7 * np.sqrt(np.mean(err(forward)[:20] ** 2))


def test_smoothing_refuses_a_filter_of_other_states_in_one_line():
    nav = registry.create("nav_filter", "ekf-pva")
    with pytest.raises(ConfigError, match="smooth.*ekf-pva.*states"):
        check_smoothable(nav, "ekf-pva", 1.0)


@pytest.mark.parametrize(
    "options, message",
    [
        (["--smooth"], "--smooth: smooths a navigation filter's positions"),
        (["--smooth", "--signal", "gps-l1ca,galileo-e1b"], "--smooth: not with several signals"),
    ],
)
def test_smooth_without_its_filter_is_refused_in_one_line(tmp_path, capsys, options, message):
    from gnssframework.cli import main

    rec = tmp_path / "x.bin"
    np.zeros(4000, np.int8).tofile(rec)
    code = main(["receive", str(rec), "--format", "ci8", "--fs", "4e6", "--out", str(tmp_path / "o"), *options])
    err = capsys.readouterr().err.strip().splitlines()
    assert code != 0 and len(err) == 1 and err[0].startswith("error: " + message), err
