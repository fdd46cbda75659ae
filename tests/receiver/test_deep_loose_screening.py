"""Loose coupling's measurement model (issue 22): trailing rate window, correlated DLL errors, innovation gate."""

from types import SimpleNamespace

import numpy as np
import pytest

from gnssframework.experiments.scenarios import get_scenario
from gnssframework.receiver.deep.loose import (
    correlated_error_inflation,
    fix_gate,
    line_of_sight_accel,
    trailing_rate_measurement,
)
from gnssframework.signal.constants import L1_WAVELENGTH_M


def test_trailing_rate_is_the_rate_at_the_update_instant_and_reads_nothing_after_it():
    # A range with constant acceleration: the trailing window's mean rate refers to its
    # middle, and the carry by a * delta / 2 makes it the rate at the edge, exactly.
    T, K, window, k_edge = 0.001, 400, 20, 300
    v0, a = 120.0, -35.0
    t = np.arange(K + 1)[:, None, None] * T
    carrier = 2.0e7 + v0 * t + a * t**2 / 2 + np.zeros((1, 2, 3))
    freq_err = np.zeros((K, 2, 3))
    record = SimpleNamespace(freq_error_hz=freq_err)
    rate = trailing_rate_measurement(record, carrier, k_edge, window, T, np.full((2, 3), a))
    np.testing.assert_allclose(rate, v0 + a * k_edge * T, rtol=0, atol=1e-6)
    # The replica's frequency errors after the edge do not enter; those in the window do, times lambda.
    freq_err[k_edge:] = 1e3
    np.testing.assert_array_equal(
        trailing_rate_measurement(record, carrier, k_edge, window, T, np.full((2, 3), a)), rate
    )
    freq_err[k_edge - window : k_edge] = 2.0
    np.testing.assert_allclose(
        trailing_rate_measurement(record, carrier, k_edge, window, T, np.full((2, 3), a)),
        rate + 2.0 * L1_WAVELENGTH_M,
        rtol=0,
        atol=1e-6,
    )


def test_line_of_sight_accel_projects_the_relative_acceleration():
    sat = np.array([[2.0e7, 0.0, 0.0], [0.0, 2.0e7, 0.0]])
    acc_s = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    out = line_of_sight_accel(sat, acc_s, np.zeros((1, 3)), np.array([[3.0, 4.0, 5.0]]))
    np.testing.assert_allclose(out, [[1.0 - 3.0, -4.0]])


def test_inflation_matches_a_simulated_first_order_loop():
    # Independent peer: a first-order loop at T = 1 ms (e <- e - K (e + n), K = 4 B_L T,
    # Kaplan and Hegarty 2017, the gain of a first-order loop of noise bandwidth B_L) on
    # white discriminator noise, sampled every 0.1 s: the mean of N samples has the
    # variance of one sample over N times the inflation factor.
    rng = np.random.default_rng(22)
    T, bandwidth_hz, interval_s, samples, runs = 0.001, 1.0, 0.1, 200, 2000
    gain = 4 * bandwidth_hz * T
    step = int(round(interval_s / T))
    e = rng.standard_normal(runs) * np.sqrt(gain / (2 - gain))  # the loop's stationary variance
    kept = np.empty((samples, runs))
    for k in range(samples * step):
        e = e - gain * (e + rng.standard_normal(runs))
        if (k + 1) % step == 0:
            kept[(k + 1) // step - 1] = e
    ratio = np.var(kept.mean(axis=0)) / (np.var(kept) / samples)
    expected = correlated_error_inflation(bandwidth_hz, interval_s)
    # The discrete loop's correlation is (1 - K)^100 against exp(-0.4) (0.2 % apart); the
    # finite-N mean lowers the factor by 2 rho / (N (1 - rho)^2) = 0.04; the ratio's
    # sampling SE over 2000 runs is sqrt(2 / 2000) = 3 %: 4 SE.
    assert expected == pytest.approx((1 + np.exp(-0.4)) / (1 - np.exp(-0.4)), rel=1e-12)
    assert ratio == pytest.approx(expected, rel=4 * np.sqrt(2 / runs))


def test_gate_refuses_at_its_false_alarm_rate_and_refuses_an_outlier():
    rng = np.random.default_rng(23)
    runs, m, p = 20000, 6, 0.01
    A = rng.standard_normal((m, m))
    S = A @ A.T + m * np.eye(m)
    nu = rng.standard_normal((runs, m)) @ np.linalg.cholesky(S).T
    refused = 1.0 - fix_gate(nu, np.broadcast_to(S, (runs, m, m)), p).mean()
    assert abs(refused - p) < 4 * np.sqrt(p * (1 - p) / runs)  # binomial SE
    outlier = nu[:1] + 30.0 * np.sqrt(np.diag(S))  # a slipped loop: 30 sigma on every component
    assert not fix_gate(outlier, S[None], p)[0]


class _StillIns:
    """A strapdown solution at rest that only records corrections (the stub of deep_ins.StrapdownSolution)."""

    def __init__(self, runs):
        self.p, self.v = np.zeros((runs, 3)), np.zeros((runs, 3))

    def take_error_model(self):
        return np.eye(15), 1e-6 * np.eye(15)

    def kinematics(self):
        return self.p, self.v, np.zeros_like(self.p)

    def correct(self, dx):
        self.p, self.v = self.p - dx[:, 6:9], self.v - dx[:, 3:6]


def test_gated_loose_update_ignores_a_slipped_fix_and_uses_a_good_one():
    import gnssframework as gf
    from gnssframework.interfaces import RunContext
    from gnssframework.receiver.deep.ins_navigator import loose_update

    runs = 2
    ekf = gf.registry.create("nav_filter", "ins-ekf")
    ekf.reset((runs,), RunContext(initial_cov=np.eye(15)))  # 1 m, 1 m/s of INS error
    cov = np.broadcast_to(np.eye(6), (runs, 6, 6)).copy()  # fixes: 1 m, 1 m/s
    fix_p = np.array([[1.0, -0.5, 0.3], [200.0, 0.0, 0.0]])  # run 0 consistent, run 1 a 200 m outlier
    fix_v = np.zeros((runs, 3))
    ins = _StillIns(runs)
    loose_update(ins, ekf, fix_p, fix_v, cov, gate_probability=0.01)
    # Run 0: the plain Kalman update, half-way with equal variances; run 1: not moved.
    np.testing.assert_allclose(ins.p[0], fix_p[0] / 2, rtol=1e-3)
    np.testing.assert_allclose(ins.p[1], 0.0, atol=1e-6)
    ungated = _StillIns(runs)
    ekf.reset((runs,), RunContext(initial_cov=np.eye(15)))
    loose_update(ungated, ekf, fix_p, fix_v, cov)
    np.testing.assert_allclose(ungated.p[1], fix_p[1] / 2, rtol=1e-3)  # without the gate it is taken


@pytest.mark.parametrize("extra", [{"loose_rate_window": "trailing"}, {"loose_dll_correlation": "loop"}])
def test_each_loose_option_changes_the_loose_candidate_and_only_it(extra):
    import gnssframework as gf

    base = {"kind": "deep-integration", "profile": "straight", "duration_s": 1.0, "settle_s": 0.3, "channels": 6}
    plugins = {
        "channel_filter": gf.registry.create("channel_filter", "scalar"),
        "nav_filter": gf.registry.create("nav_filter", "ins-ekf"),
    }
    out = {}
    for name, params in (("given", base), ("option", {**base, **extra})):
        scenario = get_scenario(params)
        out[name] = scenario.run_batch({"cn0_dbhz": 40.0}, plugins, 2, np.random.default_rng(5)).metrics
    # Same draws, another measurement model: the position errors differ, the tracking does not.
    np.testing.assert_array_equal(out["option"]["code_tracking_error_rmse"], out["given"]["code_tracking_error_rmse"])
    assert not np.array_equal(
        out["option"]["horizontal_position_error_rmse"], out["given"]["horizontal_position_error_rmse"]
    )
