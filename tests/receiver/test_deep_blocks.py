"""The deep loop's block evaluations equal the per-interval ones they replaced (issue 11).

`DeepTruth.pseudoranges` (true pseudoranges of a block of epochs), the deep closer's
fit rows and interval fit and `StrapdownIns`'s deferred error-state transitions are
held bit for bit to the per-epoch formulas, written out here as the loop had them.

Bitwise by construction on any machine: the block and the per-epoch forms apply the same
elementwise operations and functions to the same values in the same order (no BLAS
product, no reduction whose order depends on the array's length). Marked ``other_machines``: .ci/other_machines.sh checks it
with NumPy's SIMD loops disabled and numba compiled for other targets.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from gnssframework.signal.constants import CA_CHIP_LENGTH_M, L1_WAVELENGTH_M
from test_deep_integration import _aided_setup

pytestmark = pytest.mark.other_machines


def _scenario_truth(runs=2, duration_s=0.3):
    from gnssframework.experiments import get_scenario

    scen = get_scenario(
        {"kind": "deep-integration", "duration_s": duration_s, "update_interval_s": 0.1, "settle_s": 0.0, "channels": 6}
    )
    return scen, scen._truth(scen.flight(), 45.0, runs, np.random.default_rng(3))


@pytest.mark.parametrize("vectorised", [False, True])
def test_block_pseudoranges_equal_the_per_epoch_pseudorange(vectorised):
    if vectorised:  # the scenario's truth, which gives receiver_positions
        _, truth = _scenario_truth()
        assert truth.receiver_positions is not None
    else:  # receiver_state at scalar times only: called per epoch
        truth, _ = _aided_setup(3, 0.05, accel_g=10.0)
        assert truth.receiver_positions is None
    T, K = truth.coherent_time_s, truth.epochs
    k0, k1 = 7, K + 1
    sat = truth.sat_state(np.arange(k0, k1) * T)[0]
    block = truth.pseudoranges(k0, k1, sat)
    want = np.stack([truth.pseudorange(k * T, k, sat[k - k0]) for k in range(k0, k1)])
    assert block.shape == want.shape
    np.testing.assert_array_equal(block, want)


def test_edge_states_pseudorange_across_block_boundaries():
    from gnssframework.receiver.deep.aided_tracking import _EdgeStates

    truth, _ = _aided_setup(2, 0.05)
    T, K = truth.coherent_time_s, truth.epochs
    edges = _EdgeStates(truth, K, block=7)  # blocks that end inside NCO intervals
    for k in range(K + 1):
        s = truth.sat_state(np.asarray(k * T))[0]
        np.testing.assert_array_equal(edges(k)[0], s)
        np.testing.assert_array_equal(edges.pseudorange(k), truth.pseudorange(k * T, k, s))


class _FixedNavigator:
    """Given kinematics per aiding instant (a dict t -> (p, v, a, b, d)); records nothing."""

    def __init__(self, kin):
        self.kin = kin

    def kinematics(self, t):
        return self.kin[round(t, 9)]

    def update(self, *a):
        pass


def test_deep_closer_channel_replica_equals_the_per_interval_range_formulas():
    # The replica of the deep loop is an engine Channel steered by range (DeepCloser); before
    # the engine the harness laid it out in ranges. Its true errors and NCO shifts, computed
    # here in the range domain interval by interval as that loop had them, must agree: the
    # carrier in the same operations (bit for bit), the code through chip phases
    # f_chip t - rho / chip (rounding of ~1e5-chip phases: 1e-9 chip).
    from gnssframework.receiver.deep.aiding import line_of_sight_kinematics, nco_schedule
    from gnssframework.receiver.engine.deep_closer import DeepCloser
    from gnssframework.receiver.engine.truth import code_phase_of_range
    from gnssframework.registry import create

    truth, rx = _aided_setup(3, 0.05, accel_g=20.0, jerk=True)
    T, K = truth.coherent_time_s, truth.epochs
    g = np.random.default_rng(5)
    batch = (3, 6)
    n_nco, n_upd = 5, 20
    kin = {}
    for k0 in range(0, K, n_nco):  # a navigator off the truth by a few metres, different at each aiding
        p, v, a = rx(k0 * T)
        kin[round(k0 * T, 9)] = (
            p + g.normal(size=(3, 3)) * 5,
            v + g.normal(size=(3, 3)),
            a + g.normal(size=(3, 3)),
            g.normal(size=3) * 10,
            g.normal(size=3),
        )
    closer = DeepCloser(
        create("channel_filter", "iq-filter", adapter=None, estimator="ukf", output="equivalent"), _FixedNavigator(kin)
    )
    closer.reset(batch, T, n_nco, n_upd, K, signal=truth.signal, cn0_dbhz=45.0)
    sat = lambda k: truth.sat_state(np.asarray(k * T))  # noqa: E731
    channel = closer.start(sat(0))
    theta0 = g.uniform(-np.pi, np.pi, batch)
    true_rho = lambda k: truth.pseudorange(k * T, k, sat(k)[0])  # noqa: E731
    carrier_rep, rep_end, rate_prev, slope = np.zeros(batch), None, None, None
    worst = 0.0
    for k in range(K):
        j = k % n_nco
        if j == 0:  # the aiding, as the loop had it
            p, v, a, b, d = kin[round(k * T, 9)]
            rho, rate, acc, _ = line_of_sight_kinematics(p, v, a, *sat(k), b, d)
            sched_range, sched_rate = nco_schedule(rho, rate, acc, T, n_nco)
            slope_new = acc
        nco_range, nco_rate = sched_range[j], sched_rate[j]
        shift_chips = np.zeros(batch) if rep_end is None else -(nco_range - rep_end) / CA_CHIP_LENGTH_M
        shift_hz = np.zeros(batch) if rate_prev is None else -(nco_rate - (rate_prev + slope * T)) / L1_WAVELENGTH_M
        rho0, rho1 = true_rho(k), true_rho(k + 1)
        rep_end = nco_range + nco_rate * T
        code_err = -0.5 * ((rho0 - nco_range) + (rho1 - rep_end)) / CA_CHIP_LENGTH_M  # truth - replica phase
        f_rep = -nco_rate / L1_WAVELENGTH_M
        ph0 = theta0 - 2 * np.pi * rho0 / L1_WAVELENGTH_M - carrier_rep
        carrier_rep_end = carrier_rep + 2 * np.pi * f_rep * T
        ph1 = theta0 - 2 * np.pi * rho1 / L1_WAVELENGTH_M - carrier_rep_end
        freq_err = (ph1 - ph0) / (2 * np.pi * T)

        err = channel.errors(
            code_phase_of_range(truth.signal, rho0, k * T),
            code_phase_of_range(truth.signal, rho1, (k + 1) * T),
            theta0 - 2 * np.pi * rho0 / L1_WAVELENGTH_M,
            theta0 - 2 * np.pi * rho1 / L1_WAVELENGTH_M,
            T,
        )
        np.testing.assert_array_equal(err.phase_rad, ph0)
        np.testing.assert_array_equal(err.freq_hz, freq_err)
        np.testing.assert_array_equal(closer.shift_hz, shift_hz)
        np.testing.assert_array_equal(channel.nco_range_m, nco_range)
        np.testing.assert_allclose(err.code_chips, code_err, rtol=0, atol=1e-9)
        np.testing.assert_allclose(channel.shift_chips, shift_chips, rtol=0, atol=1e-9)
        worst = max(worst, np.max(np.abs(code_err)))
        if k + 1 < K:
            closer_slope = closer.slope
            if (k + 1) % n_nco == 0:
                closer.reaid(k + 1, sat(k + 1))
            closer._command(channel, k + 1, closer_slope)
        rate_prev, slope, carrier_rep = nco_rate, slope_new, carrier_rep_end
    assert worst > 0.01  # the navigator's metres show: the comparison is not of zeros


def test_aided_tracking_same_record_with_and_without_vectorised_receiver_positions():
    from gnssframework.receiver.deep.aided_tracking import run_aided_tracking
    from gnssframework.registry import create
    from test_deep_integration import _OffsetNavigator

    _, truth = _scenario_truth(runs=2, duration_s=0.2)
    zero = np.zeros((2, 3))

    def run(tr):
        nav = _OffsetNavigator(
            lambda t: tr.receiver_state(t), zero + 3.0, zero + 0.1, np.zeros(2), np.zeros(2), (0.0, 0.0)
        )
        channel = create("channel_filter", "iq-filter", adapter=None, estimator="ukf", output="equivalent")
        carrier = create("channel_filter", "kf-carrier-loop", states=2, q=[0.0, 0.001], r=0.05)
        return run_aided_tracking(channel, nav, tr, np.random.default_rng(4), carrier_filter=carrier)

    a, b = run(truth), run(replace(truth, receiver_positions=None))
    for name in ("code_error_chips", "freq_error_hz", "residual_m", "residual_cov"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    np.testing.assert_array_equal(a.extra["phase_error_rad"], b.extra["phase_error_rad"])
    assert np.all(np.isfinite(a.residual_m))


def test_strapdown_deferred_transitions_equal_the_per_interval_accumulation():
    from gnssframework.inertial import error_model
    from gnssframework.experiments.scenarios.deep_integration_runs import _setup_ins

    scen, _ = _scenario_truth(runs=2, duration_s=0.3)
    ins, _ = _setup_ins(scen, scen.flight(), 2, np.random.default_rng(6))
    ref, _ = _setup_ins(scen, scen.flight(), 2, np.random.default_rng(6))
    Phi, Qd = np.broadcast_to(np.eye(15), (2, 15, 15)).copy(), np.zeros((2, 15, 15))
    dx = np.random.default_rng(7).normal(size=(2, 15)) * 1e-3
    for t_s, correct in ((0.05, False), (0.1, True), (0.2, False)):
        ins.advance(t_s)
        # Reference: one transition per IMU interval, multiplied up as it goes (the loop before).
        n = int(round(t_s / ref.dt))
        while ref.k < n:
            dth, dv = error_model.compensate_increments(
                ref.dtheta[ref.k], ref.dv[ref.k], ref.gyro_bias, ref.accel_bias, ref.dt
            )
            f_b = dv / ref.dt
            P, Q = error_model.error_state_transition(ref.state, f_b, ref.dt, ref.grade, method="second-order")
            Phi, Qd = P @ Phi, P @ Qd @ np.swapaxes(P, -1, -2) + Q
            ref.state = ref.mech.strapdown_step(ref.state, dth, dv, ref.dt, *ref.prev)
            ref.prev = (dth, dv)
            ref.k += 1
        got_Phi, got_Qd = ins.take_error_model()
        np.testing.assert_array_equal(got_Phi, Phi)
        np.testing.assert_array_equal(got_Qd, Qd)
        Phi, Qd = np.broadcast_to(np.eye(15), (2, 15, 15)).copy(), np.zeros((2, 15, 15))
        assert not np.array_equal(got_Phi, np.broadcast_to(np.eye(15), got_Phi.shape))
        if correct:
            ins.correct(dx)
            ref.correct(dx)
        np.testing.assert_array_equal(ins.state.position_ecef_m, ref.state.position_ecef_m)


@pytest.mark.parametrize("with_prev", [False, True])
@pytest.mark.parametrize("backend", ["numba", "numpy"])
def test_trusted_strapdown_step_equals_the_checked_step(with_prev, backend):
    from gnssframework.inertial.mechanisation import (
        MechanisationOptions,
        NavState,
        strapdown_step,
        strapdown_step_trusted,
    )

    g = np.random.default_rng(11)
    runs = 3
    q = g.normal(size=(runs, 4))
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    state = NavState(q, g.normal(size=(runs, 3)) * 200, np.array([-1.7e6, 4.9e6, 3.6e6]) + g.normal(size=(runs, 3)))
    dth, dv = g.normal(size=(runs, 3)) * 1e-3, g.normal(size=(runs, 3)) * 0.05
    prev = (g.normal(size=(runs, 3)) * 1e-3, g.normal(size=(runs, 3)) * 0.05) if with_prev else (None, None)
    opts = MechanisationOptions(backend=backend)
    a = strapdown_step_trusted(state, dth, dv, 0.005, *prev, options=opts)
    b = strapdown_step(state, dth, dv, 0.005, *prev, options=opts)
    for x, y in (
        (a.q_b_e, b.q_b_e),
        (a.velocity_ecef_mps, b.velocity_ecef_mps),
        (a.position_ecef_m, b.position_ecef_m),
    ):
        np.testing.assert_array_equal(x, y)
    assert not np.array_equal(a.position_ecef_m, state.position_ecef_m)


def test_interval_fit_equals_the_running_sum_of_the_loop():
    from gnssframework.receiver.engine.deep_closer import fit_rows, interval_fit
    from gnssframework.signal.gps_l1ca import GPS_L1CA

    truth, _ = _aided_setup(2, 0.05, accel_g=20.0)
    T = truth.coherent_time_s
    g = np.random.default_rng(12)
    batch = (2, 6)
    n_nco, n_upd = 5, 10
    rows, preds = [], []
    for k0 in (10, 15):
        rho = truth.pseudorange(k0 * T, k0, truth.sat_state(np.asarray(k0 * T))[0]) + g.normal(size=batch)
        rate, acc = g.normal(size=batch) * 300, g.normal(size=batch) * 50
        rows.append(fit_rows(k0, n_nco, T, n_upd, rho, rate, acc, k0 * T))
        preds.append((rho, rate, acc, k0))
    outputs = np.stack(
        [
            g.normal(size=(n_upd,) + batch) * 0.05,
            g.normal(size=(n_upd,) + batch) * 3,
            g.uniform(1e-4, 1e-2, (n_upd,) + batch),
            g.uniform(1.0, 50.0, (n_upd,) + batch),
        ]
    )
    replica = np.stack([g.normal(size=(n_upd,) + batch) * 3 + 2e7, g.normal(size=(n_upd,) + batch) * 300])
    normal, rhs = interval_fit(outputs, replica, rows, GPS_L1CA)
    # The loop before: a running sum, one coherent interval after the other, its rows and
    # predictions written out.
    want_n, want_r = np.zeros(batch + (3, 3)), np.zeros(batch + (3,))
    for i in range(n_upd):
        rho, rate, acc, k0 = preds[i // n_nco]
        k = k0 + i % n_nco
        tau = k * T + T / 2 - k0 * T
        dt = (k + 0.5) * T - (k // n_upd + 1) * n_upd * T
        h_rho, h_rate = np.array([1.0, dt, 0.5 * dt * dt]), np.array([0.0, 1.0, dt])
        w_rho = 1.0 / (outputs[2, i] * CA_CHIP_LENGTH_M**2)
        w_rate = 1.0 / (outputs[3, i] * L1_WAVELENGTH_M**2)
        z_rho = -outputs[0, i] * CA_CHIP_LENGTH_M + replica[0, i] - (rho + rate * tau + 0.5 * acc * tau**2)
        z_rate = -outputs[1, i] * L1_WAVELENGTH_M + replica[1, i] - (rate + acc * tau)
        want_n += w_rho[..., None, None] * np.outer(h_rho, h_rho) + w_rate[..., None, None] * np.outer(h_rate, h_rate)
        want_r += (w_rho * z_rho)[..., None] * h_rho + (w_rate * z_rate)[..., None] * h_rate
    np.testing.assert_array_equal(normal, want_n)
    np.testing.assert_array_equal(rhs, want_r)
