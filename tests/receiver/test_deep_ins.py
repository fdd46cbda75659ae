"""The INS navigator of deep integration in closed loop, on a linear error-state stand-in for the INS.

The stand-in (test-only) adds to the true trajectory an INS error that evolves exactly by a
15-state linear error model with known process noise, so the closed loop's consistency
can be checked against the chi-square law: after each integration update the error left
in the INS, normalised by ``ins-ekf``'s covariance, must average the state dimension over
runs. The prefilters are the real ``iq-filter`` in the real harness; only the INS is
replaced (the mechanisation is tested in ``gnssframework.inertial``'s own tests).
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import expm

from gnssframework.interfaces import RunContext
from gnssframework.receiver.deep.aided_tracking import run_aided_tracking
from gnssframework.receiver.deep.ins_navigator import InsNavigator, loose_update
from gnssframework.receiver.deep.navigators import ClockFilter
from gnssframework.registry import create

from test_deep_integration import _aided_setup, _iq_filter

G = 9.80665


def _skew(v):
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def _error_model(f_ecef, dt, gyro_psd=1e-9, accel_psd=1e-5, bias_psd=1e-10):
    """Continuous 15-state error model: dpsi' = -dbg, dv' = -[f x] dpsi + dba, dr' = dv, biases random walks."""
    A = np.zeros((15, 15))
    A[0:3, 12:15] = -np.eye(3)
    A[3:6, 0:3] = -_skew(f_ecef)
    A[3:6, 9:12] = np.eye(3)
    A[6:9, 3:6] = np.eye(3)
    Qc = np.diag([gyro_psd] * 3 + [accel_psd] * 3 + [0.0] * 3 + [bias_psd] * 6)
    # Van Loan: exact discretisation of F and Q over dt.
    M = np.zeros((30, 30))
    M[:15, :15] = -A
    M[:15, 15:] = Qc
    M[15:, 15:] = A.T
    E = expm(M * dt)
    Phi = E[15:, 15:].T
    return Phi, Phi @ E[:15, 15:]


class _LinearErrorIns:
    """Truth plus an error that follows the linear model exactly (a stand-in for a strapdown INS)."""

    def __init__(self, truth_state, err0, rng, dt=0.005, f_ecef=None):
        self.truth_state = truth_state
        self.err = err0.copy()
        self.rng = rng
        self.dt = dt
        self.t = 0.0
        self.Phi_step, self.Q_step = _error_model(np.array([0.0, 0.0, G]) if f_ecef is None else f_ecef, dt)
        self.Lq = np.linalg.cholesky(self.Q_step + 1e-30 * np.eye(15))
        runs = err0.shape[0]
        self.Phi = np.broadcast_to(np.eye(15), (runs, 15, 15)).copy()
        self.Qd = np.zeros((runs, 15, 15))

    def advance(self, t_s):
        while self.t < t_s - 1e-9:
            self.err = self.err @ self.Phi_step.T + self.rng.normal(size=self.err.shape) @ self.Lq.T
            self.Phi = self.Phi_step @ self.Phi
            self.Qd = self.Phi_step @ self.Qd @ self.Phi_step.T + self.Q_step
            self.t += self.dt

    def kinematics(self):
        p, v, a = self.truth_state(self.t)
        return p + self.err[:, 6:9], v + self.err[:, 3:6], a

    def take_error_model(self):
        out = (self.Phi, self.Qd)
        runs = self.err.shape[0]
        self.Phi = np.broadcast_to(np.eye(15), (runs, 15, 15)).copy()
        self.Qd = np.zeros((runs, 15, 15))
        return out

    def correct(self, dx):
        self.err = self.err - dx


def _P0():
    return np.diag(
        [(0.5 * np.pi / 180) ** 2] * 3
        + [0.3**2] * 3
        + [5.0**2] * 3
        + [(1e-3 * G) ** 2] * 3
        + [(1.0 * np.pi / 180 / 3600) ** 2] * 3
    )


def test_deep_loop_with_ins_navigator_is_consistent_and_converges():
    runs = 16
    truth, rx = _aided_setup(runs, 1.5)
    g = np.random.default_rng(21)
    P0 = _P0()
    err0 = g.normal(size=(runs, 15)) @ np.linalg.cholesky(P0).T
    ins = _LinearErrorIns(rx, err0, np.random.default_rng(22))
    ekf = create("nav_filter", "ins-ekf")
    ekf.reset((runs,), RunContext(initial_cov=P0))
    clock = ClockFilter(np.array([100.0, 0.0]) + g.normal(size=(runs, 2)) * [3.0, 0.3], np.diag([9.0, 0.09]))
    nees, nees_pv, pos = [], [], []

    def record(t, nav):
        e = nav.ins.err
        nees.append(np.einsum("ri,rij,rj->r", e, np.linalg.inv(nav.ekf.cov), e))
        nees_pv.append(np.einsum("ri,rij,rj->r", e[:, 3:9], np.linalg.inv(nav.ekf.cov[:, 3:9, 3:9]), e[:, 3:9]))
        pos.append(e[:, 6:9])

    nav = InsNavigator(ins, ekf, clock, on_update=record)
    run_aided_tracking(_iq_filter(), nav, truth, np.random.default_rng(5), pull_in_updates=1)
    nees, nees_pv, pos = np.array(nees)[2:], np.array(nees_pv)[2:], np.array(pos)
    # chi-square(15) averaged over 16 runs and 12 correlated updates: SE at most sqrt(30/16) = 1.4;
    # the velocity-position marginal, chi-square(6): SE at most sqrt(12/16) = 0.87.
    assert 15 - 4.5 < nees.mean() < 15 + 4.5, nees.mean()
    assert 6 - 2.7 < nees_pv.mean() < 6 + 2.7, nees_pv.mean()
    assert np.sqrt(np.mean(pos[-3:] ** 2)) < 0.5 * np.sqrt(np.mean(err0[:, 6:9] ** 2))
    # The clock filter follows the true clock (bias 100 m) to within a few metres.
    assert np.sqrt(np.mean((clock.c[:, 0] - 100.0) ** 2)) < 3.0


def test_loose_update_with_an_exact_fix_puts_the_ins_on_the_fix():
    # A perfect IMU (no process noise over a zero interval) and a fix far better than the INS:
    # the corrected INS equals the fix to the ratio of the variances.
    runs = 3

    def rx(t):
        return np.zeros((runs, 3)) + [1e6, 2e6, 3e6], np.zeros((runs, 3)) + [50.0, 0, 0], np.zeros((runs, 3))

    g = np.random.default_rng(1)
    P0 = _P0()
    ins = _LinearErrorIns(rx, g.normal(size=(runs, 15)) @ np.linalg.cholesky(P0).T, g)
    ekf = create("nav_filter", "ins-ekf")
    ekf.reset((runs,), RunContext(initial_cov=P0))
    fix_p, fix_v, _ = rx(0.0)
    loose_update(ins, ekf, fix_p, fix_v, np.broadcast_to(np.eye(6) * 1e-8, (runs, 6, 6)))
    np.testing.assert_allclose(ins.err[:, 3:9], 0.0, atol=1e-3)


def test_prefilter_output_stays_unbiased_under_a_20_g_acceleration_with_acceleration_aiding():
    # A navigator off the truth by fixed errors, the receiver accelerating at 20 g from t = 0:
    # the acceleration-aided replica ramps with the line of sight, and the prefilter must not
    # mistake that ramp for its own error (it did when the harness handed it every replica
    # change as an NCO shift: normalised rate bias above 10 at 20 g).
    from test_deep_integration import _aided_nees

    _, z, _ = _aided_nees("equivalent", accel_g=20.0)
    bias = z.mean(axis=0)
    se = z.std(axis=0) / np.sqrt(len(z) / 4)  # residuals correlated over a few updates
    assert np.all(np.abs(bias) < 4 * se + 0.2), (bias, se)
    assert 0.5 < np.mean(z[:, 1] ** 2) < 1.5


def test_the_strapdown_ins_refuses_to_advance_beyond_its_increments_with_a_config_error():
    # ruff F821: the refusal raised a NameError (ConfigError was not imported) instead of the
    # one-line error; 10 increments of 5 ms reach 0.05 s, not 0.1 s.
    import pytest

    from gnssframework.errors import ConfigError
    from gnssframework.inertial.mechanisation import NavState
    from gnssframework.receiver.deep.strapdown import StrapdownIns

    state0 = NavState(np.array([[1.0, 0.0, 0.0, 0.0]]), np.zeros((1, 3)), np.array([[6378137.0, 0.0, 0.0]]))
    ins = StrapdownIns(state0, np.zeros((10, 1, 3)), np.zeros((10, 1, 3)), 0.005, None)
    with pytest.raises(ConfigError, match=r"StrapdownIns: no IMU increments beyond 0\.05 s \(asked 0\.1 s\)"):
        ins.advance(0.1)
