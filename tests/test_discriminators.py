"""Discriminators: unit slope, units, and thermal-noise variance against Monte Carlo."""

import numpy as np
import pytest

import gnssframework as gf
from gnssframework.signal.correlator_model import amplitude_from_cn0, correlator_mean, simulate_correlators

CODE = ("eml-envelope", "eml-power", "dot-product")
FREQ = ("cross-product", "atan2-fll")
PHASE = ("costas-atan", "atan2-pll")


def _noise_free(code=0.0, phase=0.0, freq=0.0, T=0.001):
    y = correlator_mean(amplitude_from_cn0(45.0, T), code, phase, freq, T, np.array([-0.5, 0.0, 0.5]))
    return gf.Correlators(y[..., 0], y[..., 1], y[..., 2])


def test_units_and_registry():
    units = {n: gf.registry.create("discriminator", n).unit for n in gf.registry.names("discriminator")}
    assert units == {**{n: "chips" for n in CODE}, **{n: "Hz" for n in FREQ}, **{n: "rad" for n in PHASE}}


@pytest.mark.parametrize("name", CODE)
def test_code_discriminators_have_unit_slope(name):
    d = gf.registry.create("discriminator", name, early_late_spacing_chips=1.0)
    e = np.array([-1e-3, -1e-4, 1e-4, 1e-3])
    np.testing.assert_allclose(d(_noise_free(code=e)), e, rtol=2e-3)
    # The S-curves inside |e| < d, from the triangle autocorrelation by hand:
    big = np.array([-0.4, -0.1, 0.3])
    expected = {"eml-envelope": big, "dot-product": big / (1 - np.abs(big)),
                "eml-power": big * 0.25 / (0.25 + big**2)}[name]
    np.testing.assert_allclose(d(_noise_free(code=big)), expected, rtol=1e-12)


@pytest.mark.parametrize("name", FREQ)
def test_frequency_discriminators_have_unit_slope_in_hz(name):
    T = 0.01
    d = gf.registry.create("discriminator", name, coherent_time_s=T)
    df = np.array([-0.1, 0.05, 0.1])
    prev = _noise_free(phase=0.3, freq=df, T=T)
    cur = _noise_free(phase=0.3 + 2 * np.pi * df * T, freq=df, T=T)
    np.testing.assert_allclose(d(cur, previous=prev), df, rtol=2e-3)
    big = np.array([-20.0, 12.0])  # S-curves: sin(2 pi df T)/(2 pi T) and linear up to 1/(2T)
    prev = _noise_free(phase=0.3, freq=big, T=T)
    cur = _noise_free(phase=0.3 + 2 * np.pi * big * T, freq=big, T=T)
    expected = np.sin(2 * np.pi * big * T) / (2 * np.pi * T) if name == "cross-product" else big
    np.testing.assert_allclose(d(cur, previous=prev), expected, rtol=1e-9)
    with pytest.raises(gf.ConfigError, match="previous"):
        d(cur)


@pytest.mark.parametrize("name", PHASE)
def test_phase_discriminators_have_unit_slope_and_costas_ignores_the_bit(name):
    d = gf.registry.create("discriminator", name)
    phi = np.array([-0.5, 0.1, 0.8])
    np.testing.assert_allclose(d(_noise_free(phase=phi)), phi, rtol=1e-12)
    flipped = _noise_free(phase=phi + np.pi)
    if name == "costas-atan":
        np.testing.assert_allclose(d(flipped), phi, rtol=1e-12)
    else:
        assert np.all(np.abs(d(flipped) - phi) > 1.0)


def _monte_carlo_variance(name, cn0, T, rng, n=60_000):
    d = gf.registry.create("discriminator", name, coherent_time_s=T)
    cur = simulate_correlators(np.zeros(n), 0.0, 0.0, cn0, T, rng)
    prev = simulate_correlators(np.zeros(n), 0.0, 0.0, cn0, T, rng)
    return np.var(d(cur, previous=prev)), float(d.noise_variance(cn0))


# Code discriminators saturate at +-(1 - d) when noise reaches their linear range: the
# formulas hold for c*T above about 30 (T = 10 ms from 35 dB-Hz, 1 ms from 45 dB-Hz).
VALID = [(name, cn0, 0.01) for name in CODE + FREQ + PHASE for cn0 in (35, 40, 45, 50)]
VALID += [(name, cn0, 0.001) for name in CODE for cn0 in (45, 50)]
VALID += [(name, cn0, 0.001) for name in FREQ + PHASE for cn0 in (35, 40, 45, 50)]


@pytest.mark.parametrize("name, cn0, T", VALID)
def test_noise_variance_matches_monte_carlo_within_25_percent(name, cn0, T):
    rng = np.random.default_rng(int(cn0 * 1000 + T * 1e4))
    mc, theory = _monte_carlo_variance(name, cn0, T, rng)
    assert mc == pytest.approx(theory, rel=0.25)


def test_formula_breakdown_is_where_the_docs_say(rng):
    # At 35 dB-Hz and 1 ms the envelope discriminator saturates: far below the formula.
    mc, theory = _monte_carlo_variance("eml-envelope", 35, 0.001, rng)
    assert mc < 0.5 * theory


@pytest.mark.parametrize("name", CODE + FREQ + PHASE)
def test_no_signal_in_the_taps_gives_zero_not_nan(name):
    d = gf.registry.create("discriminator", name)
    zero = gf.Correlators(np.zeros(3), np.zeros(3), np.zeros(3))
    out = d(zero, previous=zero)
    assert np.all(np.isfinite(out)) and np.all(out == 0)
