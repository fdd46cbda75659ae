"""RTS-smoothed estimates of the vector loop's nav filter as a comparison metric (issue 43).

`smooth_record` on a linear-Gaussian record (a plain Kalman filter written here) against the
joint posterior of all the states, solved as one weighted least-squares problem (the
information form: prior, every transition and every measurement as one linear system), which
is the smoothed distribution by definition; and the scenario's ``smoothed`` option on a short
run: the smoothed and filtered errors agree at the last epoch (nothing comes after it), and
the smoothed estimates are the better ones on these seeds; a nav filter whose prediction is
not linear on its 8 published states is refused.
"""

from __future__ import annotations

import numpy as np
import pytest

from gnssframework import random_streams as draw
from gnssframework.errors import ConfigError
from gnssframework.experiments import get_scenario
from gnssframework.receiver.tracking.vector import VectorRecord, smooth_record


def _spd(rng, n, scale):
    a = rng.standard_normal((n, n)) * scale
    return a @ a.T + scale**2 * np.eye(n)


def test_smooth_record_is_the_joint_posterior_of_a_linear_gaussian_run():
    rng = np.random.default_rng(4303)
    K, runs, n, m = 12, 2, 8, 5
    F = np.eye(n) + 0.1 * rng.standard_normal((n, n))
    Q, R, P0 = _spd(rng, n, 0.3), _spd(rng, m, 0.5), _spd(rng, n, 1.0)
    H = rng.standard_normal((m, n))
    x0 = rng.standard_normal((runs, n))
    truth = np.empty((K, runs, n))
    x = x0 + rng.standard_normal((runs, n)) @ np.linalg.cholesky(P0).T
    z = np.empty((K, runs, m))
    for k in range(K):
        if k:
            x = x @ F.T + rng.standard_normal((runs, n)) @ np.linalg.cholesky(Q).T
        truth[k] = x
        z[k] = x @ H.T + rng.standard_normal((runs, m)) @ np.linalg.cholesky(R).T
    # A plain Kalman filter; step 0 updates the initial estimate without a prediction.
    mean, cov = np.empty((K, runs, n)), np.empty((K, runs, n, n))
    xm, P = x0.copy(), np.broadcast_to(P0, (runs, n, n)).copy()
    for k in range(K):
        if k:
            xm, P = xm @ F.T, F @ P @ F.T + Q
        S = H @ P @ H.T + R
        G = P @ H.T @ np.linalg.inv(S)
        xm = xm + np.einsum("rij,rj->ri", G, z[k] - xm @ H.T)
        P = P - G @ H @ P
        mean[k], cov[k] = xm, P
    err = mean - truth
    record = VectorRecord(
        np.zeros((K, runs, 1)),
        np.zeros((K, runs, 1)),
        err[..., 0:3],
        err[..., 3:6],
        np.zeros((K, runs)),
        np.arange(K) * 0.01,
        estimate=mean,
        estimate_cov=cov,
    )
    pos, vel, cov_s = smooth_record(record, (F, Q), x0, P0)
    # The joint posterior: minimise |x_0 - x0|²_P0⁻¹ + Σ|x_k - F x_{k-1}|²_Q⁻¹ + Σ|z_k - H x_k|²_R⁻¹.
    N = K * n
    for r in range(runs):
        rows, rhs, w = [], [], []

        def block(k, width, value):  # a (width, N) row block with ``value`` at state k
            a = np.zeros((width, N))
            a[:, k * n : (k + 1) * n] = value
            return a

        rows.append(block(0, n, np.eye(n)))
        rhs.append(x0[r])
        w.append(np.linalg.inv(P0))
        for k in range(1, K):
            rows.append(block(k, n, np.eye(n)) - block(k - 1, n, F))
            rhs.append(np.zeros(n))
            w.append(np.linalg.inv(Q))
        for k in range(K):
            rows.append(block(k, m, H))
            rhs.append(z[k, r])
            w.append(np.linalg.inv(R))
        info = sum(a.T @ wi @ a for a, wi in zip(rows, w))
        b = sum(a.T @ wi @ y for a, wi, y in zip(rows, w, rhs))
        post = np.linalg.solve(info, b).reshape(K, n)
        post_cov = np.linalg.inv(info)
        np.testing.assert_allclose(pos[:, r], post[:, 0:3] - truth[:, r, 0:3], atol=1e-9)
        np.testing.assert_allclose(vel[:, r], post[:, 3:6] - truth[:, r, 3:6], atol=1e-9)
        for k in range(K):
            np.testing.assert_allclose(cov_s[k, r], post_cov[k * n : (k + 1) * n, k * n : (k + 1) * n], atol=1e-9)


def test_smoothing_needs_the_stored_estimates():
    rec = VectorRecord(
        *(np.zeros((2, 1, 1)),) * 2, np.zeros((2, 1, 3)), np.zeros((2, 1, 3)), np.zeros((2, 1)), np.zeros(2)
    )
    with pytest.raises(ConfigError, match="store_estimates"):
        smooth_record(rec, (np.eye(8), np.eye(8)), np.zeros(8), np.eye(8))


BASE = {
    "kind": "vector-tracking",
    "duration_s": 2.0,
    "channels": 8,
    "settle_s": 0.5,
    "steady_state_s": 1.0,
    "pcrb": False,
    "smoothed": True,
}
COMPONENTS = {
    "channel_filter": {"name": "discriminator", "params": {"code_discriminator": "eml-envelope"}},
    "nav_filter": {"name": "ekf-pv", "params": {"clock": "ocxo", "accel_psd": 1e-5}},
}


def test_the_scenario_scores_the_smoothed_estimates():
    scen = get_scenario(BASE)
    res = scen.run_batch({"cn0_dbhz": 40.0}, scen.build(COMPONENTS, None), 4, draw.run_streams(43, (0,), range(4)))
    s, sr = res.metrics, res.series
    # Nothing comes after the last epoch: smoothed = filtered there.
    np.testing.assert_allclose(sr["position_smoothed_error_m"][-1], sr["position_error_m"][-1], rtol=1e-9)
    np.testing.assert_allclose(sr["velocity_smoothed_error_m_s"][-1], sr["velocity_error_m_s"][-1], rtol=1e-9)
    # The smoothed mean square error is at most the filtered one in expectation (the
    # smoothed covariance is below the filtered); on these four runs the average shows it.
    assert np.mean(s["position_smoothed_error_rmse"]) < np.mean(s["position_error_rmse"])
    assert np.mean(s["velocity_smoothed_error_rmse"]) < np.mean(s["velocity_error_rmse"])
    assert np.all(np.isfinite(s["nees_position_smoothed"]))
    plain = get_scenario({**BASE, "smoothed": False})
    res = plain.run_batch({"cn0_dbhz": 40.0}, plain.build(COMPONENTS, None), 1, draw.run_streams(43, (0,), [0]))
    assert "position_smoothed_error_rmse" not in res.metrics  # optional: NaN in a comparison, with the reason
    assert "smoothed = true" in plain.undefined_reasons["position_smoothed_error_rmse"]


def test_a_nav_filter_with_more_states_than_it_publishes_is_refused():
    scen = get_scenario(BASE)
    plugins = scen.build({**COMPONENTS, "nav_filter": {"name": "ekf-pva"}}, None)
    with pytest.raises(ConfigError, match=r"candidates\[1\]\.nav_filter: scenario.smoothed needs .* 11 states"):
        scen.check_composition(plugins, "candidates[1]")
