"""Discriminators: unit slope, units, and thermal-noise variance against Monte Carlo."""

import numpy as np
import pytest

import gnssframework as gf
from conftest import builtin_names
from gnssframework.signal.correlator_model import amplitude_from_cn0, correlator_mean, simulate_correlators

CODE = ("eml-envelope", "eml-power", "dot-product")
FREQ = ("cross-product", "atan2-fll")
PHASE = ("costas-atan", "atan2-pll")
#: The BOC code discriminators (tests/signal/test_boc_tracking.py): chips too, on a BOC main peak.
BOC = ("boc-eml", "boc-vemlp", "bump-jumping")


def _noise_free(code=0.0, phase=0.0, freq=0.0, T=0.001):
    y = correlator_mean(amplitude_from_cn0(45.0, T), code, phase, freq, T, np.array([-0.5, 0.0, 0.5]))
    return gf.Correlators(y[..., 0], y[..., 1], y[..., 2])


def test_units_and_registry():
    units = {n: gf.registry.create("discriminator", n).unit for n in builtin_names("discriminator")}
    assert units == {**{n: "chips" for n in CODE + BOC}, **{n: "Hz" for n in FREQ}, **{n: "rad" for n in PHASE}}


@pytest.mark.parametrize("name", CODE)
def test_code_discriminators_have_unit_slope(name):
    d = gf.registry.create("discriminator", name, early_late_spacing_chips=1.0)
    e = np.array([-1e-3, -1e-4, 1e-4, 1e-3])
    np.testing.assert_allclose(d(_noise_free(code=e)), e, rtol=2e-3)
    # The S-curves inside |e| < d, from the triangle autocorrelation by hand:
    big = np.array([-0.4, -0.1, 0.3])
    expected = {"eml-envelope": big, "dot-product": big / (1 - np.abs(big)), "eml-power": big * 0.25 / (0.25 + big**2)}[
        name
    ]
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


# Reference 000's code column (docs/experiments/vector-tracking.md, "Absolute levels"):
# T = 10 ms, 45 and 30 dB-Hz; the paper reports 0.010 and 0.033 chips for its EML
# envelope discriminator.
PAPER_CODE_CHIPS = {45: 0.010, 30: 0.033}


def _eml_std(spacing_chips, cn0, rng, n=60_000, bandwidth_hz=None, T=0.01):
    """Monte Carlo standard deviation of eml-envelope's output at zero error, and the formula's."""
    d = gf.registry.create("discriminator", "eml-envelope", coherent_time_s=T, early_late_spacing_chips=spacing_chips)
    c = simulate_correlators(
        np.zeros(n), 0.0, 0.0, cn0, T, rng, early_late_spacing_chips=spacing_chips, bandwidth_hz=bandwidth_hz
    )
    return float(np.std(d(c))), float(np.sqrt(d.noise_variance(cn0)))


@pytest.mark.parametrize("spacing", [0.5, 0.2, 0.1])
@pytest.mark.parametrize("cn0", [40, 45])
def test_eml_envelope_variance_follows_the_spacing(spacing, cn0):
    # The early and late noises are correlated by R(D) = 1 - D, so the variance falls
    # with D: the normalised EML envelope form of the docstring (Kaplan and Hegarty, 3rd
    # ed., DLL thermal noise, for one interval and an infinite front-end bandwidth).
    rng = np.random.default_rng(int(cn0 * 100 + spacing * 10))
    mc, theory = _eml_std(spacing, cn0, rng)
    # Standard error of a standard deviation from 60 000 draws: 0.3 %.
    assert mc == pytest.approx(theory, rel=0.03)


def test_eml_envelope_at_the_papers_points_with_one_chip_spacing():
    # At 45 dB-Hz (c T = 316) the formula holds: 0.0282 chips. At 30 dB-Hz (c T = 10)
    # noise reaches the linear range (+-0.5 chip) and the output saturates, so the
    # standard deviation falls below the formula's 0.166 chips.
    rng = np.random.default_rng(451)
    mc45, th45 = _eml_std(1.0, 45, rng)
    mc30, th30 = _eml_std(1.0, 30, rng)
    assert th45 == pytest.approx(np.sqrt(1 / (4 * 10**4.5 * 0.01) * (1 + 1 / 10**2.5)), rel=1e-12)
    assert mc45 == pytest.approx(th45, rel=0.03)
    assert 0.8 * th30 < mc30 < 0.95 * th30
    # Both are about 3 and 4 times the paper's values.
    assert mc45 / PAPER_CODE_CHIPS[45] > 2.5 and mc30 / PAPER_CODE_CHIPS[30] > 3.5


@pytest.mark.parametrize("bandwidth_hz", [None, 4e6, 8e6])
def test_no_spacing_gives_the_papers_ratio_between_30_and_45_dbhz(bandwidth_hz):
    # Thermal noise alone makes the variance at least proportional to 1/(C/N0): the
    # standard deviation at 30 dB-Hz is at least sqrt(10**1.5) = 5.6 times that at
    # 45 dB-Hz, less only where the output saturates. The paper's 0.033 / 0.010 = 3.3 is
    # out of reach of every spacing and front-end bandwidth (a constant slope cancels).
    rng = np.random.default_rng(2026)
    paper = PAPER_CODE_CHIPS[30] / PAPER_CODE_CHIPS[45]
    for spacing in (1.0, 0.5, 0.2, 0.1, 0.05):
        ratio = (
            _eml_std(spacing, 30, rng, bandwidth_hz=bandwidth_hz)[0]
            / _eml_std(spacing, 45, rng, bandwidth_hz=bandwidth_hz)[0]
        )
        assert ratio > 1.5 * paper, (spacing, ratio)


def test_the_spacing_that_fits_one_column_misses_the_other():
    # Solving the formula for D at each C/N0 separately: about 0.126 chips at 45 dB-Hz and
    # 0.04 at 30 dB-Hz. At the first the discriminator's 30 dB-Hz output is ~1.6 times
    # the paper's; at the second its 45 dB-Hz output is ~0.6 times.
    from scipy.optimize import brentq

    def formula(spacing, cn0):
        return float(
            np.sqrt(
                gf.registry.create(
                    "discriminator", "eml-envelope", coherent_time_s=0.01, early_late_spacing_chips=spacing
                ).noise_variance(cn0)
            )
        )

    fit = {cn0: brentq(lambda s, cn0=cn0, v=v: formula(s, cn0) - v, 1e-4, 1.0) for cn0, v in PAPER_CODE_CHIPS.items()}
    assert fit[45] > 2.5 * fit[30]
    rng = np.random.default_rng(30)
    assert _eml_std(fit[45], 30, rng)[0] > 1.4 * PAPER_CODE_CHIPS[30]
    assert _eml_std(fit[30], 45, rng)[0] < 0.7 * PAPER_CODE_CHIPS[45]
