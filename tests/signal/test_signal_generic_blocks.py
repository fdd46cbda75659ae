"""Blocks that read a SignalSpec, run on a signal other than GPS L1 C/A: the correlator
model and the IF path of a BOC(1,1) signal against its closed-form autocorrelation
(Betz 2016, ch. 12), bit synchronisation with another symbol length, the channel model's
refusal of a BOC signal."""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest

from gnssframework.errors import ConfigError
from gnssframework.receiver.channels.lock import BitSync, estimate_cn0
from gnssframework.signal.channel_model import channel_model, code_to_carrier
from gnssframework.signal.cn0 import cn0_moments
from gnssframework.signal.correlator_model import (
    amplitude_from_cn0,
    code_autocorrelation,
    correlator_mean,
    simulate_correlators,
)
from gnssframework.signal.if_samples import correlate_if, generate_if_samples
from gnssframework.signal.qzss_l1ca import QZSS_L1CA
from gnssframework.signal.spec import Component, SignalSpec, Subcarrier


@cache
def _code(prn: int) -> np.ndarray:
    return (1 - 2 * np.random.default_rng(prn).integers(0, 2, 1023)).astype(np.int8)


BOC = SignalSpec(
    "test-boc11", "X", "1X", 1575.42e6, 1.023e6, 1023, (1, 2), (Component("pilot", _code),), Subcarrier("boc", 1.0, 1.0)
)
SHORT_SYMBOLS = SignalSpec(
    "test-4ms-symbols",
    "X",
    "1X",
    1575.42e6,
    1.023e6,
    1023,
    (1,),
    (Component("data", _code, symbol_period_s=4 * 1023 / 1.023e6),),
)


def _boc11(tau):
    a = np.abs(np.asarray(tau, float))
    return np.where(a <= 0.5, 1 - 3 * a, np.where(a <= 1, a - 1, 0.0))


@pytest.mark.slow
def test_the_correlator_model_of_a_boc_signal_is_its_triangle_train():
    tau = np.linspace(-1.5, 1.5, 61)
    np.testing.assert_allclose(code_autocorrelation(tau, signal=BOC), _boc11(tau), atol=1e-12)
    # Through a front end far wider than the signal, the band-limited table tends to it.
    np.testing.assert_allclose(code_autocorrelation(tau, bandwidth_hz=200e6, signal=BOC), _boc11(tau), atol=0.02)
    # ... and a 4.092 MHz filter, which keeps the main lobes (at +-1.023 MHz) and cuts the
    # rest, lowers the peak by the power it removes, more than it removes of BPSK(1).
    assert 0.8 < code_autocorrelation(0.0, bandwidth_hz=4.092e6, signal=BOC) < code_autocorrelation(0.0, 4.092e6)
    y = correlator_mean(2.0, 0.2, 0.0, 0.0, 1e-3, np.array([-0.5, 0.0, 0.5]), signal=BOC)
    np.testing.assert_allclose(y.real, 2.0 * _boc11(0.2 - np.array([-0.5, 0.0, 0.5])), atol=1e-12)


def test_simulated_boc_tap_noise_has_the_boc_correlation():
    """Noise only: early and prompt half a chip apart correlate as R(0.5) = -0.5 (BPSK: +0.5)."""
    rng = np.random.default_rng(3)
    n = 20_000
    c = simulate_correlators(np.zeros(n), np.zeros(n), np.zeros(n), 0.0, 1e-3, rng, amplitude=np.zeros(n), signal=BOC)
    rho = np.corrcoef(c.early.real, c.prompt.real)[0, 1]
    assert rho == pytest.approx(-0.5, abs=4 * (1 - 0.25) / np.sqrt(n))  # 4 standard errors
    rho_el = np.corrcoef(c.early.real, c.late.real)[0, 1]  # one chip apart: R(1) = 0
    assert abs(rho_el) < 4 / np.sqrt(n)


@pytest.mark.parametrize("complex_samples", [True, False])
def test_noise_free_if_correlators_of_a_boc_signal_match_the_closed_form(complex_samples):
    fs, if_hz, T, cn0, doppler = 20.46e6, 4.0e6, 1e-3, 45.0, 800.0
    sig = generate_if_samples(
        2,
        0.002,
        fs,
        0.0 if complex_samples else if_hz,
        cn0,
        np.random.default_rng(1),
        doppler_hz=doppler,
        code_phase_chips=100.0,
        complex_samples=complex_samples,
        noise=False,
        signal=BOC,
    )
    assert sig.spec is BOC
    A = amplitude_from_cn0(cn0, T)
    rate = BOC.code_freq_hz(doppler)
    for code_err in (0.0, 0.15, 0.3, 0.5, 0.8):
        got = correlate_if(sig, 2, 100.0 - code_err, rate, sig.if_hz + doppler, 0.0, T)
        want = A * _boc11(code_err - np.array([-0.5, 0.0, 0.5]))
        # 10 samples a chip: the sampled waveform's correlation is within a few % of the
        # continuous one (the BOC peak's slope is 3 per chip: 0.05 chip of sampling -> 0.15 A
        # at worst on a slope; measured well below).
        np.testing.assert_allclose([got.early.real, got.prompt.real, got.late.real], want, atol=0.05 * A)
        assert np.max(np.abs([got.early.imag, got.prompt.imag, got.late.imag])) < 0.02 * A


def test_bit_sync_counts_the_code_periods_of_the_signal_symbol():
    """A symbol of 4 code periods, edges at period 3 mod 4: the histogram has 4 bins and finds 3."""
    rng = np.random.default_rng(2)
    bits = 1 - 2 * rng.integers(0, 2, 60)
    prompts = np.concatenate([np.full(3, bits[0])] + [np.full(4, b) for b in bits]) * (5.0 + 0j)
    sync = BitSync(min_votes=8, signal=SHORT_SYMBOLS)
    edge = None
    for k, p in enumerate(prompts):
        edge = sync.add(k, p)
    assert sync.votes.size == 4 and edge == 3
    with pytest.raises(ConfigError, match="no data symbols"):
        BitSync(signal=BOC)


def test_cn0_of_a_pilot_falls_back_to_moments():
    rng = np.random.default_rng(4)
    p = 6.0 + rng.standard_normal(400) + 1j * rng.standard_normal(400)
    assert estimate_cn0(p, "nwpr", 0, signal=BOC) == pytest.approx(float(cn0_moments(p, 1e-3)))


def test_cn0_of_a_symbol_of_one_code_period_is_the_moments_estimate_not_nan():
    # Galileo E1-B: a 4 ms symbol of one 4 ms code period, so a narrow-wide block of one
    # prompt compares a power with itself (0/0: the tracker's C/N0 column was NaN).
    from gnssframework.receiver.channels.lock import cn0_nwpr_bits, nwpr_block
    from gnssframework.signal.cn0 import cn0_nwpr
    from gnssframework.signal.galileo_e1 import GALILEO_E1B_BOC11
    from gnssframework.signal.gps_l1ca import GPS_L1CA

    assert (GALILEO_E1B_BOC11.code_periods_per_symbol, nwpr_block(GALILEO_E1B_BOC11)) == (1, None)
    assert nwpr_block(GPS_L1CA) == 20
    T = GALILEO_E1B_BOC11.code_period_s
    rng = np.random.default_rng(9)
    a = np.sqrt(2 * 10 ** (40.0 / 10) * T)  # |P|^2 = 2 c T + 2 (unit-variance I and Q noise): 40 dB-Hz
    p = a * rng.choice([-1.0, 1.0], 500) + rng.standard_normal(500) + 1j * rng.standard_normal(500)
    cn0 = estimate_cn0(p, "nwpr", 0, signal=GALILEO_E1B_BOC11)
    assert cn0 == pytest.approx(float(cn0_moments(p, T))) and abs(cn0 - 40.0) < 1.0
    for refused in (lambda: cn0_nwpr(p, T, m=1), lambda: cn0_nwpr_bits(p[None], np.array([0]), T, m=1)):
        with pytest.raises(ConfigError, match="at least 2 prompts"):
            refused()


def test_the_channel_model_takes_a_bpsk_signal_and_refuses_a_boc_one():
    assert code_to_carrier(QZSS_L1CA) == pytest.approx(1 / 1540, rel=1e-15)
    q = np.eye(5)
    channel_model(1e-3, 0.5, q, np.eye(6), signal=QZSS_L1CA)
    with pytest.raises(ConfigError, match="boc sub-carrier"):
        channel_model(1e-3, 0.5, q, np.eye(6), signal=BOC)
    # GPS L2C is BPSK, but CM's chips sit in one of two time slots: its correlation is a
    # half-chip triangle, not the model's one-chip one.
    from gnssframework.signal.gps_l2c import GPS_L2C

    with pytest.raises(ConfigError, match="gps-l2c's chip pulse is in one of 2 time slots"):
        channel_model(1e-2, 0.5, q, np.eye(6), signal=GPS_L2C)


def test_the_coherent_time_of_a_pilot_with_an_overlay_spans_the_overlay():
    """A 4 ms pilot with a 25-chip overlay (E1-C's shape): T from 4 ms to 100 ms, in 4 ms steps."""
    from pydantic import TypeAdapter, ValidationError

    from gnssframework.experiments.limits import coherent_time

    pilot = SignalSpec(
        "test-pilot",
        "X",
        "1X",
        1575.42e6,
        1.023e6,
        4092,
        (1,),
        (Component("pilot", lambda prn: np.ones(4092, np.int8), secondary_code=(1,) * 25),),
        Subcarrier("boc", 1.0, 1.0),
    )
    t = TypeAdapter(coherent_time(pilot))
    assert t.validate_python(0.004) == 0.004 and t.validate_python(0.1) == 0.1
    for bad in (0.002, 0.006, 0.104):
        with pytest.raises(ValidationError):
            t.validate_python(bad)


def test_the_compiled_correlator_runs_a_boc_signal_from_its_sub_chip_table():
    """The kernels know no signal: a BOC(1,1) table of sub-chips, phases in sub-chips, gives
    the closed-form BOC correlation (and agrees with correlate_if, an independent NumPy path)."""
    from gnssframework.receiver.channels.correlator import correlate_channels, replica_codes, to_table_units

    fs, T, cn0, doppler = 20.46e6, 1e-3, 45.0, 1500.0
    sig = generate_if_samples(
        1,
        0.003,
        fs,
        0.0,
        cn0,
        np.random.default_rng(6),
        doppler_hz=doppler,
        code_phase_chips=100.0,
        complex_samples=True,
        noise=False,
        signal=BOC,
    )
    rate = BOC.code_freq_hz(doppler)
    n = int(T * fs)
    A = amplitude_from_cn0(cn0, T)
    norm = np.sqrt(n * sig.noise_std**2)
    codes = replica_codes(BOC, [1])
    assert codes.shape == (1, 2046)
    taps = np.array([-0.5, -0.25, 0.0, 0.25, 0.5])
    phase_cycles = (sig.if_hz + doppler) * 1000 / fs  # the signal's carrier at sample 1000
    for code_err in (0.0, 0.2, -0.35):
        cp = 100.0 + rate * 1000 / fs - code_err  # the replica at sample 1000, code_err chips behind
        raw = (
            correlate_channels(
                sig.samples.astype(np.complex64),
                np.array([1000]),
                np.array([n]),
                to_table_units(np.array([cp]), BOC),
                to_table_units(np.array([rate / fs]), BOC),
                np.array([phase_cycles]),
                np.array([(sig.if_hz + doppler) / fs]),
                codes,
                to_table_units(taps, BOC),
            )[0]
            / norm
        )
        np.testing.assert_allclose(raw.real, A * _boc11(code_err - taps), atol=0.05 * A)
        ref = correlate_if(
            sig,
            1,
            np.array(cp),
            np.array(rate),
            np.array(sig.if_hz + doppler),
            np.array(2 * np.pi * phase_cycles),
            T,
            start_sample=1000,
            extra_taps={"e2": -0.25, "l2": 0.25},
        )
        np.testing.assert_allclose(
            raw[[0, 2, 4]], [complex(ref.early), complex(ref.prompt), complex(ref.late)], atol=1e-3 * A
        )
    cboc = SignalSpec(
        "test-cboc",
        "X",
        "1X",
        1575.42e6,
        1.023e6,
        1023,
        (1,),
        (Component("pilot", _code),),
        Subcarrier("cboc", 1.0, 1.0, 6.0, (np.sqrt(10 / 11), np.sqrt(1 / 11))),
    )
    with pytest.raises(ConfigError, match="not ±1"):
        replica_codes(cboc, [1])


def test_the_if_generator_applies_a_pilots_overlay_code_period_by_period():
    """A pilot with a 5-chip overlay: the prompt of code period k carries overlay chip k mod 5."""
    overlay = (1, -1, -1, 1, -1)
    pilot = SignalSpec(
        "test-overlay", "X", "1X", 1575.42e6, 1.023e6, 1023, (1,), (Component("pilot", _code, secondary_code=overlay),)
    )
    fs, cn0 = 4.092e6, 50.0
    # 4 samples a chip, a quarter chip in: no sample sits on a chip edge (no rounding of the floor).
    sig = generate_if_samples(
        1,
        0.012,
        fs,
        0.0,
        cn0,
        np.random.default_rng(0),
        code_phase_chips=0.125,
        complex_samples=True,
        noise=False,
        signal=pilot,
    )
    n = int(round(pilot.code_period_s * fs))
    prompts = [
        complex(
            correlate_if(
                sig,
                1,
                np.array(0.125),
                np.array(pilot.chip_rate_hz),
                np.array(0.0),
                np.array(0.0),
                pilot.code_period_s,
                start_sample=k * n,
            ).prompt
        )
        for k in range(12)
    ]
    A = amplitude_from_cn0(cn0, pilot.code_period_s)
    np.testing.assert_allclose(np.real(prompts), A * np.array([overlay[k % 5] for k in range(12)]), atol=1e-6 * A)
