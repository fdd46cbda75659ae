"""Correlator model: amplitude, correlated tap noise, C/N0 estimators."""

import numpy as np
import pytest

from gnssframework.signal.cn0 import cn0_moments, cn0_nwpr
from gnssframework.signal.correlator_model import (
    amplitude_from_cn0,
    code_autocorrelation,
    simulate_correlators,
    tap_noise_cov,
)


def test_noise_is_unit_variance_and_correlated_as_the_autocorrelation(rng):
    n = 200_000
    c = simulate_correlators(
        np.zeros(n), 0.0, 0.0, 45.0, 0.001, rng, early_late_spacing_chips=1.0, amplitude=np.zeros(n)
    )
    taps = np.stack([c.early, c.prompt, c.late])
    for part in (taps.real, taps.imag):
        cov = np.cov(part)
        np.testing.assert_allclose(cov, [[1, 0.5, 0.0], [0.5, 1, 0.5], [0.0, 0.5, 1]], atol=0.01)
    assert abs(np.mean(taps.real[1] * taps.imag[1])) < 0.01  # I and Q independent


def test_signal_amplitude_and_s_curve_follow_the_model(rng):
    n = 50_000
    T = 0.001
    c = simulate_correlators(np.full(n, 0.2), 0.3, 0.0, 45.0, T, rng)
    A = amplitude_from_cn0(45.0, T)
    assert A == pytest.approx(np.sqrt(2 * 10**4.5 * T))
    np.testing.assert_allclose(np.mean(c.prompt), 0.8 * A * np.exp(0.3j), rtol=0.01)
    np.testing.assert_allclose(abs(np.mean(c.late)), 0.7 * A, rtol=0.01)  # R(0.2 - 0.5)
    np.testing.assert_allclose(abs(np.mean(c.early)), 0.3 * A, rtol=0.02)  # R(0.2 + 0.5)


def test_frequency_error_rotates_and_attenuates(rng):
    T, df = 0.01, 20.0
    c = simulate_correlators(np.zeros(20000), 0.0, df, 50.0, T, rng)
    expected = amplitude_from_cn0(50.0, T) * np.sinc(df * T) * np.exp(1j * np.pi * df * T)
    np.testing.assert_allclose(np.mean(c.prompt), expected, rtol=0.01)


def test_band_limited_autocorrelation_loses_the_filtered_power():
    r0 = code_autocorrelation(0.0, bandwidth_hz=2.046e6)
    # Fraction of BPSK(1) power within +-1 chip rate: 0.903 (a textbook value).
    assert r0 == pytest.approx(0.903, abs=0.003)
    wide = code_autocorrelation(np.linspace(-1.5, 1.5, 31), bandwidth_hz=100e6)
    np.testing.assert_allclose(wide, code_autocorrelation(np.linspace(-1.5, 1.5, 31)), atol=0.01)
    cov = tap_noise_cov([-0.5, 0.0, 0.5], bandwidth_hz=2.046e6)
    assert np.all(np.linalg.eigvalsh(cov) > 0) and cov[0, 0] == pytest.approx(r0)


@pytest.mark.parametrize("cn0", [30.0, 35.0, 40.0, 45.0, 50.0])
def test_nwpr_recovers_cn0_within_half_a_db_over_one_second(rng, cn0):
    T = 0.001
    runs = 200
    c = simulate_correlators(np.zeros((1000, runs)), rng.uniform(0, 6, runs), 0.0, cn0, T, rng)
    est = cn0_nwpr(c.prompt, T, m=20)
    # Every 1-s estimate of 200 independent runs within 0.5 dB at the 95th percentile.
    assert np.percentile(np.abs(est - cn0), 95) < 0.5


def test_moment_estimator_is_unbiased_at_moderate_cn0(rng):
    c = simulate_correlators(np.zeros((1000, 200)), 0.0, 0.0, 35.0, 0.001, rng)
    assert np.median(cn0_moments(c.prompt, 0.001)) == pytest.approx(35.0, abs=0.3)
