"""The tracking-threshold scenario's receiver oscillator, and the Kalman carrier loop's model
of it: the phase jitter a clock adds to a PLL is the closed form of its h-parameters, the
loop's process noise is the clock's, and the samples source carries the same clock."""

import numpy as np
import pytest

from gnssframework import registry
from gnssframework.errors import ConfigError
from gnssframework.experiments.scenarios import get_scenario

F_L1_HZ = 1575.42e6
# The presets' h-parameters written out (gnssframework.simulation.clock documents them), not
# read from the code under test: white FM h0 and random-walk FM h_-2.
H = {"tcxo-hq": (2e-21, 2e-20), "tcxo": (2e-19, 2e-20)}


def _scalar(bw, **kw):
    return registry.create("channel_filter", "scalar", pll_bandwidth_hz=bw, fll_bandwidth_hz=0.0, pll_order=2, **kw)


def _phase_variance(oscillator, runs=100, seed=5):
    sc = get_scenario(
        {
            "kind": "tracking-threshold",
            "duration_s": 5.0,
            "settle_s": 1.0,
            "coherent_time_s": 0.001,
            "oscillator": oscillator,
        }
    )
    r = sc.run_batch({"cn0_dbhz": 55.0}, {"channel_filter": _scalar(10.0)}, runs, seed)
    assert r.metrics["loss_of_lock"].sum() == 0
    return r.metrics["phase_jitter_rad"] ** 2


def test_an_oscillators_phase_jitter_in_a_pll_is_the_closed_form_of_its_h_parameters():
    """A 2nd-order PLL (zeta = 1/sqrt 2, w0 = B_L / 0.53: a = sqrt(2) w0, b = w0^2) at
    B_L T = 0.01, where the continuous loop describes the discrete one. The clock's phase
    2 pi f_c b(t) is driven by white FM of two-sided density N1 = (2 pi f_c)^2 h0 / 2 and
    random-walk FM, N2 = (2 pi f_c)^2 2 pi^2 h_-2 on its second derivative; the loop's error
    is N1 through s / (s^2 + a s + b) and N2 through 1 / (s^2 + a s + b): variance
    N1 / (2 a) + N2 / (2 a b). The same runs with an ideal clock (the oscillator draws from
    its own stream, so the thermal noise is the same) give the thermal part to subtract."""
    h0, h_2 = H["tcxo-hq"]
    w0 = 10.0 / 0.53
    a, b = np.sqrt(2) * w0, w0**2
    k = (2 * np.pi * F_L1_HZ) ** 2
    expected = k * h0 / 2 / (2 * a) + k * 2 * np.pi**2 * h_2 / (2 * a * b)
    added = _phase_variance("tcxo-hq") - _phase_variance("none")
    se = added.std(ddof=1) / np.sqrt(added.size)
    # 3 Monte Carlo standard errors, and 5 % for the continuous approximation at B_L T = 0.01.
    assert abs(added.mean() - expected) < 3 * se + 0.05 * expected, (added.mean(), se, expected)


def test_a_cases_oscillator_overrides_the_scenarios_and_none_is_the_ideal_clock():
    sc = get_scenario({"kind": "tracking-threshold", "duration_s": 2.0, "oscillator": "tcxo"})
    ideal = get_scenario({"kind": "tracking-threshold", "duration_s": 2.0})
    channel = {"channel_filter": _scalar(18.0)}
    with_case_none = sc.run_batch({"cn0_dbhz": 45.0, "oscillator": "none"}, channel, 4, 2).metrics
    np.testing.assert_array_equal(
        with_case_none["phase_jitter_rad"],
        ideal.run_batch({"cn0_dbhz": 45.0}, channel, 4, 2).metrics["phase_jitter_rad"],
    )
    with_tcxo = sc.run_batch({"cn0_dbhz": 45.0}, channel, 4, 2).metrics
    assert np.all(with_tcxo["phase_jitter_rad"] > with_case_none["phase_jitter_rad"])


def test_samples_following_an_ideal_clock_are_the_generators_samples():
    """The samples source's interval-by-interval signal (what carries an oscillator) with
    no clock motion is `generate_if_samples`' signal with the same noise draws, to float32."""
    from gnssframework.experiments.scenarios.tracking_threshold import _samples_following
    from gnssframework.receiver.engine.truth import LoopTruth
    from gnssframework.signal.if_samples import generate_if_samples

    T, fs, f = 0.01, 2.046e6, 1500.0
    truth = LoopTruth.from_dynamics(0.2, T, 40.0, doppler_hz=np.full(1, f), extra_cycles=np.zeros((21, 1)))
    mine, sigma = _samples_following(truth, 1, fs, 40.0, np.random.default_rng(4))
    ref = generate_if_samples(
        1, 0.2, fs, 0.0, 40.0, np.random.default_rng(4), doppler_hz=f, complex_samples=True, sample_type="float32"
    )
    assert sigma == ref.noise_std and mine.shape == ref.samples.shape
    np.testing.assert_allclose(mine, ref.samples, atol=1e-5)


@pytest.mark.slow
def test_an_oscillator_adds_the_same_jitter_on_samples_as_on_the_analytic_model():
    """The GNSS-grade TCXO on both sources at 45 dB-Hz (18 Hz PLL, T = 10 ms; the cheaper
    TCXO makes both sources lose lock in every run there): the phase variance it adds
    (the same runs with an ideal clock subtracted: on each source the thermal noise is the
    same with and without it) agrees between the sources within 4 standard errors of their
    difference (different noise and clock draws: unpaired), and is well above zero."""
    ch = {"channel_filter": _scalar(18.0, dll_bandwidth_hz=0.5)}
    added = {}
    for src in ("samples", "analytic"):
        var = {}
        for osc in ("tcxo-hq", "none"):
            sc = get_scenario({"kind": "tracking-threshold", "duration_s": 3.0, "settle_s": 1.0, "oscillator": osc})
            m = sc.run_batch({"cn0_dbhz": 45.0, "source": src}, ch, 12, 6).metrics
            assert m["loss_of_lock"].sum() == 0
            var[osc] = m["phase_jitter_rad"] ** 2
        added[src] = var["tcxo-hq"] - var["none"]
    a, s = added["analytic"], added["samples"]
    se = np.hypot(a.std(ddof=1) / np.sqrt(a.size), s.std(ddof=1) / np.sqrt(s.size))
    assert abs(s.mean() - a.mean()) < 4 * se, (s.mean(), a.mean(), se)
    assert s.mean() > 4 * s.std(ddof=1) / np.sqrt(s.size), s


@pytest.mark.parametrize("unit, u", [("rad", 1.0), ("deg", np.pi / 180), ("cycles", 2 * np.pi)])
def test_the_kalman_loops_clock_noise_is_the_clocks_covariance_on_its_phase_and_frequency(unit, u):
    # Phase 2 pi f_c b (rad) and frequency 2 pi f_c d (rad/s) of the clock's bias b and drift
    # d, whose covariance over T is [[S_f T + S_g T^3/3, S_g T^2/2], [S_g T^2/2, S_g T]]
    # (S_f = h0/2, S_g = 2 pi^2 h_-2): in the loop's unit, (2 pi f_c / u)^2 times it.
    h0, h_2 = H["tcxo"]
    T = 0.01
    sf, sg = h0 / 2, 2 * np.pi**2 * h_2
    clock = np.array([[sf * T + sg * T**3 / 3, sg * T**2 / 2], [sg * T**2 / 2, sg * T]])
    q = [0.01, 0.1]
    plain = registry.create("channel_filter", "kf-carrier-loop", q=q, angle_unit=unit)
    with_clock = registry.create("channel_filter", "kf-carrier-loop", q=q, angle_unit=unit, clock="tcxo")
    np.testing.assert_allclose(plain.process_noise(T), np.diag(q))
    np.testing.assert_allclose(with_clock.process_noise(T), np.diag(q) + (2 * np.pi * F_L1_HZ / u) ** 2 * clock)


def test_an_unknown_clock_is_refused_naming_the_field():
    with pytest.raises(ConfigError, match="clock"):
        registry.create("channel_filter", "kf-carrier-loop", clock="rubidium")
