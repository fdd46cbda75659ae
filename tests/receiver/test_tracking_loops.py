"""Tracking loops in closed loop against the thermal-noise formulas and Kalman theory."""

import numpy as np
import pytest

import gnssframework as gf
from gnssframework.receiver.tracking.jitter import lock_indicator, loop_variance, pll_thermal_variance_rad2
from gnssframework.receiver.tracking.loop_filters import LoopFilter
from gnssframework.receiver.tracking.scalar import SignalTruth, run_closed_loop

T = 0.001


def _costas_wrap(phase):
    return (phase + np.pi / 2) % np.pi - np.pi / 2


@pytest.mark.parametrize("cn0", [40.0, 45.0])
def test_scalar_loop_jitter_matches_the_thermal_noise_formulas(cn0):
    rng = np.random.default_rng(int(cn0))
    truth = SignalTruth.from_dynamics(4.0, T, cn0, doppler_hz=np.full(64, -2500.0), carrier_phase0_rad=0.3)
    loop = gf.registry.create(
        "channel_filter", "scalar", pll_bandwidth_hz=10.0, pll_order=2, fll_bandwidth_hz=0.0, dll_bandwidth_hz=1.0
    )
    rec = run_closed_loop(loop, truth, rng, initial_doppler_hz=-2500.0)
    steady = slice(1000, None)
    pll = np.var(_costas_wrap(rec.phase_error_rad[steady]))
    assert pll == pytest.approx(pll_thermal_variance_rad2(cn0, 10.0, T), rel=0.20)
    disc = gf.registry.create("discriminator", "eml-envelope", coherent_time_s=T)
    dll = np.var(rec.code_error_chips[steady])
    assert dll == pytest.approx(loop_variance(disc.noise_variance(cn0), 1.0, T), rel=0.20)


def test_fll_assist_pulls_in_a_30_hz_error_and_the_lock_indicator_sees_it():
    rng = np.random.default_rng(5)
    truth = SignalTruth.from_dynamics(2.0, T, 42.0, doppler_hz=np.full(16, 1000.0), doppler_rate_hz_s=20.0)
    loop = gf.registry.create("channel_filter", "scalar", fll_bandwidth_hz=10.0)
    rec = run_closed_loop(loop, truth, rng, initial_doppler_hz=1030.0, record=("phase_disc_rad",))
    assert np.abs(rec.freq_error_hz[:20]).mean() > 20
    assert np.std(_costas_wrap(rec.phase_error_rad[-500:])) < 0.15
    # PLI on the last 0.5 s: close to 1 when locked.
    prompts = np.exp(1j * rec.phase_error_rad[-500:])
    assert np.median(lock_indicator(prompts)) > 0.9


@pytest.mark.parametrize("order, dynamics", [(2, "step"), (3, "ramp")])
def test_loop_order_removes_the_matching_steady_state_error(order, dynamics):
    # Noise-free (very high C/N0): order 2 tracks a frequency offset, order 3 a Doppler rate,
    # with zero steady-state phase error.
    rng = np.random.default_rng(0)
    rate = 50.0 if dynamics == "ramp" else 0.0
    truth = SignalTruth.from_dynamics(3.0, T, 120.0, doppler_hz=np.full(2, 100.0), doppler_rate_hz_s=rate)
    loop = gf.registry.create("channel_filter", "scalar", pll_order=order, fll_bandwidth_hz=0.0, pll_bandwidth_hz=15)
    rec = run_closed_loop(loop, truth, rng, initial_doppler_hz=100.0 + (0.0 if dynamics == "ramp" else 3.0))
    assert np.abs(rec.phase_error_rad[-200:]).max() < 1e-3


def test_loop_filter_rejects_bad_order_and_too_wide_bandwidth():
    with pytest.raises(gf.ConfigError, match="order"):
        LoopFilter(4, 10.0, T)
    with pytest.raises(gf.ConfigError, match="B_L T"):
        LoopFilter(2, 500.0, 0.001)


def _riccati_prior(F, H, Q, R, steps=5000):
    P = np.eye(F.shape[0])
    for _ in range(steps):
        S = H @ P @ H + R
        K = P @ H / S
        P = F @ (P - np.outer(K, H @ P)) @ F.T + Q
    return P


def test_kf_carrier_loop_error_variance_equals_its_riccati_prediction():
    rng = np.random.default_rng(9)
    cn0, runs, K = 40.0, 64, 4000
    r = float(gf.registry.create("discriminator", "costas-atan", coherent_time_s=T).noise_variance(cn0))
    q = [1e-6, 4.0]  # rad^2 and (rad/s)^2 per interval
    # Truth: the model the filter assumes (random-walk frequency, small phase noise).
    w = rng.standard_normal((K, runs)) * np.sqrt(q[1])
    omega = 2 * np.pi * 200.0 + np.cumsum(w, axis=0)
    phase = np.concatenate([np.zeros((1, runs)), np.cumsum(omega * T + rng.standard_normal((K, runs)) * 1e-3, 0)])
    truth = SignalTruth(
        code_phase_chips=np.zeros((K + 1, runs)) + np.arange(K + 1)[:, None] * 1.023e6 * T,
        carrier_phase_rad=phase,
        cn0_dbhz=cn0,
        coherent_time_s=T,
    )
    loop = gf.registry.create("channel_filter", "kf-carrier-loop", q=q, r=r, initial_std=[0.1, 10.0, 1.0])
    rec = run_closed_loop(loop, truth, rng, initial_doppler_hz=200.0)
    F = np.array([[1.0, T], [0.0, 1.0]])
    H = np.array([1.0, T / 2])
    P = _riccati_prior(F, H, np.diag(q), r)
    predicted = H @ P @ H
    measured = np.var(_costas_wrap(rec.phase_error_rad[1000:]))
    assert measured == pytest.approx(predicted, rel=0.15)


def test_kf_carrier_loop_with_three_states_tracks_a_doppler_ramp():
    rng = np.random.default_rng(2)
    truth = SignalTruth.from_dynamics(3.0, T, 45.0, doppler_hz=np.full(16, 300.0), doppler_rate_hz_s=40.0)
    loop = gf.registry.create("channel_filter", "kf-carrier-loop", states=3, q=[1e-4, 1e-2, 1.0], r=0.02)
    rec = run_closed_loop(loop, truth, rng, initial_doppler_hz=300.0)
    err = _costas_wrap(rec.phase_error_rad[-1000:])
    assert abs(np.mean(err)) < 0.02 and np.std(err) < 0.2


def test_kf_carrier_loop_q_length_must_match_states():
    with pytest.raises(gf.ConfigError, match="needs 3 values"):
        gf.registry.create("channel_filter", "kf-carrier-loop", states=3, q=[0.01, 0.1])


def test_closed_loop_refuses_a_channel_filter_that_cannot_steer_ncos():
    class Passive(gf.ChannelFilter):
        name = "passive"
        requires = ("correlators",)
        provides = ("code_error_chips",)

        def reset(self, batch_shape, context):
            pass

        def step(self, inputs):
            return {}

    truth = SignalTruth.from_dynamics(0.01, T, 45.0)
    with pytest.raises(gf.ConfigError, match="cannot close a tracking loop"):
        run_closed_loop(Passive(), truth, np.random.default_rng(0))
