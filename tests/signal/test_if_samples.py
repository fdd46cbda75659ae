"""IF-sample path against the analytic correlator model."""

import numpy as np
import pytest

import gnssframework as gf
from gnssframework.signal.constants import CA_CHIP_RATE_HZ, L1_FREQ_HZ
from gnssframework.signal.correlator_model import amplitude_from_cn0, correlator_mean
from gnssframework.signal.if_samples import correlate_if, generate_if_samples
from gnssframework.signal.navdata import bit_at, random_nav_bits, wipe_off

FS, IF = 5.0e6, 1.25e6


@pytest.mark.parametrize(
    "complex_samples, sample_type", [(False, "float64"), (True, "float64"), (False, "int8"), (True, "int16")]
)
def test_noise_free_if_correlators_match_the_analytic_model(rng, complex_samples, sample_type):
    T, cn0, doppler = 0.001, 45.0, 1200.0
    sig = generate_if_samples(
        5,
        0.002,
        FS,
        0.0 if complex_samples else IF,
        cn0,
        rng,
        doppler_hz=doppler,
        code_phase_chips=100.0,
        carrier_phase_rad=0.4,
        complex_samples=complex_samples,
        sample_type=sample_type,
        noise=False,
    )
    code_err = np.array([-0.3, 0.0, 0.2])  # replica delays: true minus replica
    freq_err, phase_err = 30.0, -0.7
    code_rate = CA_CHIP_RATE_HZ * (1 + doppler / L1_FREQ_HZ)
    got = correlate_if(sig, 5, 100.0 - code_err, code_rate, sig.if_hz + doppler - freq_err, 0.4 - phase_err, T)
    want = correlator_mean(amplitude_from_cn0(cn0, T), code_err, phase_err, freq_err, T, np.array([-0.5, 0, 0.5]))
    A = amplitude_from_cn0(cn0, T)
    tol = 0.03 * A if sample_type.startswith("int") else 0.01 * A  # sampling and quantisation
    for i, tap in enumerate((got.early, got.prompt, got.late)):
        np.testing.assert_allclose(tap, want[..., i], atol=tol)


def test_if_noise_is_unit_variance_and_tap_correlated(rng):
    sig = generate_if_samples(3, 0.2, FS, IF, 40.0, rng)
    starts = np.arange(0, 195) * 5000
    out = [correlate_if(sig, 3, 512.0, CA_CHIP_RATE_HZ, IF, 0.0, 0.001, start_sample=s) for s in starts]
    taps = np.array([[c.early, c.prompt, c.late] for c in out])
    assert np.var(taps.real, axis=0).mean() == pytest.approx(1.0, rel=0.12)
    assert np.corrcoef(taps[:, 0].real, taps[:, 1].real)[0, 1] == pytest.approx(0.5, abs=0.15)


def test_data_bits_modulate_and_wipe_off_restores(rng):
    bits = random_nav_bits(5, rng)
    sig = generate_if_samples(9, 0.1, FS, IF, 50.0, rng, data_bits=bits, noise=False)
    T = 0.001
    starts = (np.arange(0, 100) * 0.001 * FS).astype(int)
    prompts = np.array([correlate_if(sig, 9, 0.0, CA_CHIP_RATE_HZ, IF, 0.0, T, start_sample=s).prompt for s in starts])
    t = starts / FS
    b = bit_at(t, bits)
    np.testing.assert_array_equal(np.sign(prompts.real), b)
    clean = wipe_off(gf.Correlators(prompts, prompts, prompts), b)
    assert np.all(clean.prompt.real > 0)


def test_bad_sample_type_and_if_are_config_errors(rng):
    with pytest.raises(gf.ConfigError, match="allowed: float64"):
        generate_if_samples(1, 0.001, FS, IF, 45, rng, sample_type="uint4")
    with pytest.raises(gf.ConfigError, match="if_hz"):
        generate_if_samples(1, 0.001, FS, 3e6, 45, rng)


@pytest.mark.parametrize("n", [1, 7, 4096, 4097, 1_000_003])
@pytest.mark.parametrize("hz", [0.0, 1234.5, -4.1e6])
def test_the_factored_carrier_is_the_direct_exponential(n, hz):
    from gnssframework.signal.if_samples import carrier_phasor

    fs, theta0 = 10.5e6, 0.7
    w = 2 * np.pi * hz / fs
    k = np.arange(n)
    direct = np.exp(1j * (theta0 + w * k))
    # Each form rounds its phase to about eps |phase| (the direct one once, the factored one in
    # its two tables); their product adds a few eps.
    tol = 8 * np.finfo(float).eps * (abs(theta0) + abs(w) * n + 1.0)
    got = carrier_phasor(theta0, w, n)
    assert got.shape == (n,)
    assert np.max(np.abs(got - direct)) <= tol


def _signals():
    from gnssframework.signal.beidou_b1i import BEIDOU_B1I
    from gnssframework.signal.galileo_e1 import GALILEO_E1B, GALILEO_E1C
    from gnssframework.signal.galileo_e5a import GALILEO_E5AI
    from gnssframework.signal.gps_l1ca import GPS_L1CA
    from gnssframework.signal.gps_l2c import GPS_L2C
    from gnssframework.signal.gps_l5 import GPS_L5I

    return [GPS_L1CA, GALILEO_E1B, GALILEO_E1C, GALILEO_E5AI, GPS_L5I, GPS_L2C, BEIDOU_B1I]


@pytest.mark.parametrize("signal", _signals(), ids=lambda s: s.name)
@pytest.mark.parametrize("complex_samples", [True, False])
def test_the_compiled_signal_is_the_numpy_reference(signal, complex_samples):
    from gnssframework.signal.if_samples import signal_samples

    if not gf.backend.available():
        pytest.fail("numba is a dependency: the compiled path must be available")
    prn = signal.prns[3]
    fs = 4.0 * signal.chip_rate_hz * signal.subchips_per_chip + 1.0e5  # no ratio of small integers
    n = int(0.05 * fs)  # several symbols and overlay chips
    bits = None if signal.symbol_period_s is None else np.sign(np.random.default_rng(2).standard_normal(200))
    doppler = -2345.6
    args = (
        signal,
        prn,
        n,
        fs,
        0.01,
        signal.code_length_chips - 7.3,  # a code period starts within the run
        signal.chip_rate_hz * (1 + doppler / signal.carrier_freq_hz),
        0.4,
        2 * np.pi * (1.1e6 + doppler) / fs,
        bits,
        0.0031,  # the first symbol edge after the start: samples before it take symbol 0 (the clip)
        complex_samples,
    )
    ref = signal_samples(*args, backend_override="numpy")
    got = signal_samples(*args, backend_override="numba")
    assert got.dtype == ref.dtype and got.shape == ref.shape == (n,)
    # The same operations in the same order: every chip, overlay chip and symbol in force at
    # the same sample (a flip would differ by 0.02), the carrier product within a few eps.
    assert np.max(np.abs(got - ref)) <= 8 * np.finfo(float).eps * 0.01
    assert np.ptp(ref.real) > 0.015  # the signal compared is there
