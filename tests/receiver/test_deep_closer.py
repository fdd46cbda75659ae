"""The deep-integration loop as a composition of the engine (issue 36): `DeepCloser` on `Channel`s.

Independent truths: the aiding's known residual (a perfect navigator leaves only the
line of sight's jerk, j tau^3 / 6, between the replica and the true code), the correlator
law (a signal gain of zero leaves noise of unit-variance I and Q: E|P|^2 = 2), and the
source's contract (interval k of the run, not of the NCO block, indexes per-interval gains).
"""

from __future__ import annotations

import numpy as np
import pytest

from gnssframework.signal.constants import CA_CHIP_LENGTH_M
from test_deep_integration import G, _aided_setup, _OffsetNavigator


class _PromptPower:
    """A prefilter that records each interval's prompt power and hands over fixed outputs."""

    name = "prompt-power"
    requires = ("correlators",)
    provides = ("code_error_chips", "code_error_var_chips2", "freq_error_hz", "freq_error_var_hz2")

    def __init__(self):
        self.power = []

    def reset(self, batch_shape, context):
        self.zeros = np.zeros(batch_shape)

    def checked_step(self, inputs):
        self.power.append(np.abs(inputs["correlators"].prompt) ** 2)
        return {
            "code_error_chips": self.zeros,
            "code_error_var_chips2": self.zeros + 1e-3,
            "freq_error_hz": self.zeros,
            "freq_error_var_hz2": self.zeros + 10.0,
        }


def _perfect_navigator(rx, runs):
    zero3, zero = np.zeros((runs, 3)), np.zeros(runs)
    return _OffsetNavigator(rx, zero3, zero3, zero, zero, (100.0, 0.0))


def test_replica_of_a_perfect_navigator_follows_the_true_code_within_the_aiding_residual():
    # Truth clock bias 100 m, drift 0; the navigator has the truth's kinematics and clock: the
    # replica departs from the true code only by the jerk's j tau^3/6 over an NCO interval
    # (tau <= 5 ms: 50 g x 2.1e-8 s^3 = 1.0e-5 m), far below a chip; a sign slip anywhere in
    # the range -> code phase path (Channel.steer_range, code_phase_of_range) would show as
    # twice the range rate x T or more (> 1 m).
    from gnssframework.receiver.deep.aided_tracking import run_aided_tracking

    runs = 2
    truth, rx = _aided_setup(runs, 0.1, accel_g=20.0, jerk=True)
    rec = run_aided_tracking(_PromptPower(), _perfect_navigator(rx, runs), truth, np.random.default_rng(3))
    bound_m = 50 * G * 0.005**3 / 6
    assert np.max(np.abs(rec.code_error_chips)) * CA_CHIP_LENGTH_M < 2 * bound_m
    # And the frequency (the chord of a 20 g climb over 1 ms): within the jerk's j tau^2 / 2 / lambda.
    assert np.max(np.abs(rec.freq_error_hz)) < 50 * G * 0.005**2 / 2 / 0.19 + 1e-6


def test_the_source_gets_the_run_interval_index_and_the_truths_gains():
    # AnalyticSource.correlate(channel, k, ...) indexes per-interval gains by k, the run's
    # interval. The harness handed it the interval within the NCO block (0..n_nco-1) and
    # left the truth's signal and noise gains out: a fade after 50 ms was never seen.
    import gnssframework.receiver.deep.aided_tracking as deep
    from dataclasses import replace

    seen = []

    class _Spy(deep.AnalyticSource):
        def correlate(self, channel, k, errors=None, data_bit=1.0):
            seen.append(k)
            return super().correlate(channel, k, errors, data_bit)

    runs = 4
    truth, rx = _aided_setup(runs, 0.1)
    K = truth.epochs
    gain = np.ones((K, runs, 6))
    gain[K // 2 :] = 0.0  # the signal gone for the second half
    truth = replace(truth, signal_gain=gain)
    pre = _PromptPower()
    mp = pytest.MonkeyPatch()
    mp.setattr(deep, "AnalyticSource", _Spy)
    try:
        deep.run_aided_tracking(pre, _perfect_navigator(rx, runs), truth, np.random.default_rng(8))
    finally:
        mp.undo()
    assert seen == list(range(K))
    power = np.stack(pre.power)  # (K, runs, ch)
    # 45 dB-Hz, T = 1 ms: |P|^2 = A^2 + 2 = 2 c T + 2 = 65 with the signal; 2 (noise) without.
    n = power[K // 2 :].size
    assert abs(power[K // 2 :].mean() - 2.0) < 4 * 2.0 / np.sqrt(n)  # exponential law: sd = mean
    assert power[: K // 2].mean() > 50.0


def test_the_navigator_builds_its_kf_once_and_updates_as_the_one_call_form(monkeypatch):
    # PvaNavigator and its clock filter hold a LinearUpdate each: the kf plugin is built when
    # the navigator is, not at every integration update (it was built twice per update).
    from gnssframework import registry
    from gnssframework.receiver.deep.measurements import linear_update
    from gnssframework.receiver.deep.navigators import PvaNavigator

    made = []
    real = registry.create

    def counting(kind, name, **params):
        made.append((kind, name))
        return real(kind, name, **params)

    monkeypatch.setattr(registry, "create", counting)
    g = np.random.default_rng(2)
    runs, n = 2, 6
    los = g.normal(size=(runs, n, 3))
    los /= np.linalg.norm(los, axis=-1, keepdims=True)
    cov = np.broadcast_to(np.diag([4.0, 0.04]), (runs, n, 2, 2)).copy()
    cn0 = g.uniform(35, 50, (runs, n))
    P0 = np.diag([25.0] * 3 + [1.0] * 3 + [4.0] * 3)
    nav = PvaNavigator(
        np.zeros((runs, 3)), np.zeros((runs, 3)), np.zeros((runs, 3)), P0, np.zeros((runs, 2)), np.eye(2)
    )
    assert made == [("estimator", "kf"), ("estimator", "kf")]
    for i in range(3):
        P_before = nav.P.copy()
        res = g.normal(size=(runs, n, 2)) * [3.0, 0.2]
        nav.update(0.1 * (i + 1), res, cov, los, cn0)
    assert len(made) == 2
    # The held form gives the one-call form's update (a fresh kf per call).
    z, H, R = g.normal(size=(runs, 4)), g.normal(size=(runs, 4, 9)), np.broadcast_to(np.eye(4), (runs, 4, 4))
    a = nav._linear(np.zeros((runs, 9)), P_before, z, H, R, step=5)
    b = linear_update(np.zeros((runs, 9)), P_before, z, H, R, name="pva-navigator", step=5)
    np.testing.assert_array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])
