"""The loop engine (issue 36): one closer on the analytic model and on IF samples of the
same signal; the Channel's sign convention against independent truths."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from gnssframework.receiver.engine.channel import Channel
from gnssframework.receiver.engine.samples import SampleSource
from gnssframework.receiver.engine.truth import LoopTruth, SignalTruth, VectorTruth, code_phase_of_range
from gnssframework.signal.correlator_model import correlator_mean
from gnssframework.signal.gps_l1ca import GPS_L1CA
from gnssframework.signal.if_samples import generate_if_samples

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "docs"))
import engine_sources  # noqa: E402


@pytest.mark.slow
def test_the_same_scalar_closer_gives_the_same_error_statistics_on_both_sources():
    # 45 dB-Hz, constant Doppler, the registry's scalar loop started 0.05 chip and 3 Hz
    # off: per run the mean and the standard deviation of the code, phase and frequency
    # errors after the pull-in. Across runs each has a mean and a standard error (from
    # the runs' spread); the two sources agree within 4 combined standard errors.
    stats = engine_sources.both_sources(runs=8, duration_s=0.4, settle_s=0.15, seed=11)
    summ = engine_sources.summary(stats)
    for key, (m_a, se_a) in summ["analytic"].items():
        m_s, se_s = summ["samples"][key]
        assert se_a > 0 and se_s > 0, key
        assert abs(m_s - m_a) < 4 * np.hypot(se_a, se_s), f"{key}: analytic {m_a} ± {se_a}, samples {m_s} ± {se_s}"
    # The loops did track (not two sources agreeing on a lost loop): code within a tenth of
    # a chip, phase jitter a small fraction of a radian.
    for src in ("analytic", "samples"):
        assert abs(summ[src]["code_chips_mean"][0]) < 0.05 and summ[src]["phase_rad_std"][0] < 0.1


@pytest.mark.parametrize("code_error_chips", [-0.3, 0.0, 0.2])
def test_sample_source_correlators_follow_the_analytic_model_without_noise(code_error_chips):
    # Noise-free samples of a signal whose code is ahead of the replica by code_error_chips
    # (truth minus replica) and whose carrier is phase_err rad ahead: the sample source's
    # taps are the model's mean R(err - o) e^{j phase} (sampled triangle: 1 % of A).
    fs, T, cn0 = 4e6, 1e-3, 45.0
    x = generate_if_samples(
        3,
        2 * T,
        fs,
        0.0,
        cn0,
        np.random.default_rng(0),
        code_phase_chips=10.0,
        carrier_phase_rad=0.4,
        complex_samples=True,
        noise=False,
    )
    channel = Channel(
        GPS_L1CA,
        np.array([10.0 - code_error_chips]),
        np.array([GPS_L1CA.chip_rate_hz]),
        np.array([0.1]),
        np.array([0.0]),
    )
    corr = SampleSource(x.samples, fs, 0.0, GPS_L1CA.code(3)[None, :], T, noise_std=x.noise_std).correlate(channel, 0)
    amp = np.sqrt(2 * 10 ** (cn0 / 10) * T)
    mean = correlator_mean(amp, code_error_chips, 0.3, 0.0, T, np.array([-0.5, 0.0, 0.5]))
    got = np.array([corr.early[0], corr.prompt[0], corr.late[0]])
    np.testing.assert_allclose(got, mean, atol=0.01 * amp)


def test_range_steering_follows_the_range_convention():
    # A replica commanded the true range and rate has no error; one commanded 10 m long
    # has the code error +10 m / chip length (truth minus replica code phase: the replica lags) and a rate 0.5 m/s high a
    # frequency error +0.5 / wavelength Hz (f = -rate / lambda).
    T, t0 = 1e-3, 0.02
    rho0, rate = 2.1e7, -350.0
    rho = lambda t: rho0 + rate * t  # noqa: E731
    truth_code = [code_phase_of_range(GPS_L1CA, rho(t), t) for t in (t0, t0 + T)]
    truth_carrier = [-2 * np.pi * rho(t) / GPS_L1CA.wavelength_m for t in (t0, t0 + T)]
    for d_range, d_rate in ((0.0, 0.0), (10.0, 0.5)):
        ch = Channel.from_range((1,), np.array([rho(t0) + d_range]), np.array([rate + d_rate]), t_s=t0)
        ch.carrier_phase_rad = np.array([truth_carrier[0]])
        err = ch.errors(truth_code[0], truth_code[1], truth_carrier[0], truth_carrier[1], T)
        assert err.code_chips[0] == pytest.approx((d_range + d_rate * T / 2) / GPS_L1CA.chip_length_m, abs=1e-6)
        # carrier phases of ~7e8 rad: a few of their ulps over 2 pi T
        tol_hz = 10 * np.spacing(abs(truth_carrier[1])) / (2 * np.pi * T)
        assert err.freq_hz[0] == pytest.approx(d_rate / GPS_L1CA.wavelength_m, abs=tol_hz)
    # steering: the next command's code jump is the range change over the chip length, negated
    ch.steer_range(np.array([rho(t0 + T) + 4.0]), np.array([rate]), t0 + T)
    assert ch.shift_chips[0] == pytest.approx(-(4.0 - 10.0 - 0.5 * T) / GPS_L1CA.chip_length_m, abs=1e-6)
    assert ch.shift_hz[0] == pytest.approx(0.5 / GPS_L1CA.wavelength_m, rel=1e-9)


def test_the_former_truth_types_build_one_loop_truth():
    a = SignalTruth(np.zeros((3, 2)), np.zeros((3, 2)), 45.0, 1e-3)
    b = VectorTruth(None, None, np.zeros((3, 2, 2)), 45.0, 1e-3)
    assert type(a) is type(b) is LoopTruth and isinstance(a, SignalTruth) and a.epochs == b.epochs == 2
    c = SignalTruth.from_dynamics(0.01, 1e-3, 45.0, doppler_hz=np.full(2, 100.0))
    assert isinstance(c, LoopTruth) and c.code_phase_chips.shape == (11, 2)


class _FixedChannelFilter:
    name, requires = "fixed", ("correlators",)
    provides = ("code_error_chips", "code_error_var_chips2", "freq_error_hz", "freq_error_var_hz2")

    def reset(self, batch, context):
        self.batch = batch

    def checked_step(self, inputs):
        self.inputs = inputs
        return {
            "code_error_chips": np.full(self.batch, 0.1),
            "code_error_var_chips2": np.full(self.batch, 0.01),
            "freq_error_hz": np.full(self.batch, 0.2),
            "freq_error_var_hz2": np.full(self.batch, 1.0),
        }


class _CapturingNav:
    name, requires = "capture", ("code_error_chips", "freq_error_hz")
    provides = ("position_m", "velocity_m_s", "clock_m", "cov", "nco_range_m", "nco_range_rate_m_s")

    def reset(self, batch, context):
        self.batch = batch

    def checked_step(self, inputs):
        self.inputs = inputs
        return {"nco_range_m": inputs["replica_range_m"] + 7.0, "nco_range_rate_m_s": inputs["replica_rate_m_s"]}


def test_vector_closer_hands_the_nav_filter_range_errors_and_steers_by_range():
    # The one sign change of the engine: the channel filter's code error (truth minus
    # replica code phase) reaches the nav filter negated (a range error in chips); the
    # frequency error is passed as it is; the range command moves the replica's code phase
    # by minus its range change over the chip length.
    from gnssframework.interfaces import RunContext
    from gnssframework.receiver.engine.closers import VectorCloser

    T, batch = 0.01, (2, 3)
    ch = Channel.from_range(batch, np.full(batch, 2.0e7), np.full(batch, 100.0))
    closer = VectorCloser(_FixedChannelFilter(), nav := _CapturingNav())
    closer.reset(ch, RunContext(coherent_time_s=T, early_late_spacing_chips=1.0, epoch_interval_s=T, cn0_dbhz=45.0))
    assert nav.batch == (2,)
    code_end, _ = ch.run_interval(T)
    out = closer.channel_step(ch, None)
    closer.nav_step(ch, out, {}, T, T)
    np.testing.assert_array_equal(nav.inputs["code_error_chips"], -0.1)
    np.testing.assert_array_equal(nav.inputs["freq_error_hz"], 0.2)
    np.testing.assert_allclose(nav.inputs["replica_range_m"], 2.0e7 + 100.0 * T / 2)
    # commanded: the mid-interval replica range + 7 m, i.e. 7 m + half an interval's motion past its end
    np.testing.assert_allclose(ch.nco_range_m, 2.0e7 + 100.0 * T / 2 + 7.0)
    np.testing.assert_allclose(ch.shift_chips, -(7.0 - 100.0 * T / 2) / GPS_L1CA.chip_length_m, atol=1e-7)
    np.testing.assert_allclose(ch.code_phase_chips, code_end + ch.shift_chips, atol=1e-7)
    np.testing.assert_allclose(ch.carrier_freq_hz, -100.0 / GPS_L1CA.wavelength_m)


@pytest.mark.slow
def test_the_same_vector_closer_gives_the_same_error_statistics_on_both_sources():
    # The vector loop (discriminator channel filters, ekf-pv nav filter, one VectorCloser)
    # on the analytic model and on IF samples of the same truth (six satellites of the
    # vector-tracking scenario, static, OCXO clock, 45 dB-Hz, 10 ms), each channel in its
    # own stream: per run the RMS position and velocity errors and the replicas' code and
    # frequency error means and spreads after 0.3 s; across runs each agrees within 4
    # combined standard errors (docs/engine_sources.py's 24-run table: within 1.4).
    summ = engine_sources.summary(
        engine_sources.vector_both_sources(runs=8, duration_s=1.0, settle_s=0.3, seed=5, streams=("samples",))
    )
    for key, (m_a, se_a) in summ["analytic"].items():
        m_s, se_s = summ["samples"][key]
        assert se_a > 0 and se_s > 0, key
        assert abs(m_s - m_a) < 4 * np.hypot(se_a, se_s), f"{key}: analytic {m_a} ± {se_a}, samples {m_s} ± {se_s}"
    # The loops did track: metre-level positions, replica code errors of a hundredth of a chip.
    for src in ("analytic", "samples"):
        assert summ[src]["position_rms_m"][0] < 5.0 and summ[src]["code_std_chips"][0] < 0.01


@pytest.mark.parametrize("streams", ["per-channel", "one"])
def test_truth_samples_hold_the_truths_code_and_carrier(streams):
    # Noise-free samples of a vector truth, correlated by a replica commanded the true
    # range and rate at t = 0 and the true carrier phase: every channel's prompt is the
    # full amplitude sqrt(2 c T) at phase 0, early and late half of it (sampled triangle
    # and the interval's range change: 2 % of A). In one stream the other five
    # satellites' cross-correlation adds to each tap (C/A: at most 10^(-23.9/20) = 6.4 %
    # of A per satellite, far less over 10 ms of distinct Dopplers): 10 %.
    from gnssframework.experiments import get_scenario
    from gnssframework.receiver.engine.truth_samples import truth_ranges_m, truth_samples

    scen = get_scenario({**engine_sources.VECTOR_SCENARIO, "duration_s": 0.02})
    truth = scen.truth(45.0, 1, np.random.default_rng(2))[0]
    T, fs = truth.coherent_time_s, 4e6
    codes = np.stack([GPS_L1CA.code(p) for p in engine_sources.VECTOR_PRNS]).astype(np.float32)
    theta0 = np.linspace(-3.0, 3.0, len(engine_sources.VECTOR_PRNS))
    x = truth_samples(truth, fs, codes, theta0, np.random.default_rng(3), streams=streams, noise=False)
    rho, _ = truth_ranges_m(truth, 0)
    rate = (rho[1] - rho[0]) / T
    ch = Channel.from_range((1, rho.shape[1]), rho[0][None], rate[None], signal=GPS_L1CA)
    ch.carrier_phase_rad = (theta0 - 2 * np.pi * rho[0] / GPS_L1CA.wavelength_m)[None]
    corr = SampleSource(x, fs, 0.0, codes, T).correlate(ch, 0)
    amp = np.sqrt(2 * 10 ** (45.0 / 10) * T)
    tol = 0.02 if streams == "per-channel" else 0.10
    np.testing.assert_allclose(corr.prompt[0], amp, atol=tol * amp)
    np.testing.assert_allclose(np.abs(corr.early[0]), amp / 2, atol=tol * amp)
    np.testing.assert_allclose(np.abs(corr.late[0]), amp / 2, atol=tol * amp)


def test_bad_sample_streams_are_refused_in_one_line():
    from gnssframework.errors import ConfigError

    ch = Channel.start((1, 3), 10.0, 0.0)
    codes = np.stack([GPS_L1CA.code(p) for p in (1, 2, 3)])
    with pytest.raises(ConfigError, match="samples.*2 streams for 3 channels"):
        SampleSource(np.zeros((2, 4000), np.complex64), 4e6, 0.0, codes, 1e-3).correlate(ch, 0)
    with pytest.raises(ConfigError, match="samples.*one stream"):
        SampleSource(np.zeros((1, 2, 4000), np.complex64), 4e6, 0.0, codes, 1e-3)
    # A stream per channel: channel i sees stream i only (here: silence but in stream 1).
    x = np.zeros((3, 4000), np.complex64)
    x[1] = generate_if_samples(
        2, 1e-3, 4e6, 0.0, 45.0, np.random.default_rng(0), complex_samples=True, noise=False
    ).samples
    ch = Channel.start((1, 3), 0.0, 0.0)
    corr = SampleSource(x, 4e6, 0.0, codes, 1e-3).correlate(ch, 0)
    amp = np.sqrt(2 * 10**4.5 * 1e-3)
    np.testing.assert_allclose(np.abs(corr.prompt[0]), [0.0, amp, 0.0], atol=0.02 * amp)


def test_a_vector_loop_on_a_source_of_its_own_refuses_drawn_data_bits():
    from gnssframework import registry
    from gnssframework.errors import ConfigError
    from gnssframework.experiments import get_scenario
    from gnssframework.receiver.engine.truth_samples import truth_samples
    from gnssframework.receiver.tracking.vector import run_vector_loop

    scen = get_scenario({**engine_sources.VECTOR_SCENARIO, "duration_s": 0.02})
    truth, x0, P0 = scen.truth(45.0, 1, np.random.default_rng(1))
    with pytest.raises(ConfigError, match="data_bits"):
        run_vector_loop(
            registry.create("channel_filter", "discriminator"),
            registry.create("nav_filter", "ekf-pv"),
            truth,
            x0,
            P0,
            np.random.default_rng(2),
            data_bits="known",
            source=object(),
        )
    with pytest.raises(ConfigError, match="streams"):
        truth_samples(truth, 4e6, np.ones((6, 1023)), np.zeros(6), np.random.default_rng(0), streams="two")
    # A pilot's overlay code is not in these samples: refused, not silently left out.
    import dataclasses

    from gnssframework.signal.galileo_e1 import GALILEO_E1C

    pilot = dataclasses.replace(truth, signal=GALILEO_E1C)
    with pytest.raises(ConfigError, match="truth.signal: galileo-e1c's tracked component has an overlay"):
        truth_samples(pilot, 4e6, np.ones((6, 4092)), np.zeros(6), np.random.default_rng(0))
