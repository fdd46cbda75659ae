"""Scintillation, AR(1) noise, multipath, cycle slips and clocks against their definitions."""

import allantools
import numpy as np
import pytest
from scipy import optimize

import gnssframework as gf
from gnssframework.signal.correlators import Correlators
from gnssframework.signal.correlator_model import amplitude_from_cn0
from gnssframework.simulation import clock, impairments, scintillation


@pytest.mark.parametrize("s4", [0.3, 0.5, 0.9])
def test_cornell_s4_over_20_runs_of_300_s(s4):
    z = scintillation.cornell(s4, 0.8, 300.0, 50.0, np.random.default_rng(int(s4 * 10)), batch_shape=(20,))
    assert np.mean(np.abs(z) ** 2) == pytest.approx(1.0, abs=0.02)
    assert np.mean(scintillation.s4_index(z)) == pytest.approx(s4, abs=0.04)


@pytest.mark.parametrize("tau0", [0.3, 1.0])
def test_cornell_tau0_is_the_1_over_e_decorrelation_time(tau0):
    fs = 100.0
    z = scintillation.cornell(0.7, tau0, 300.0, fs, np.random.default_rng(3), batch_shape=(20,))
    xi = z - z.mean(axis=0)
    lags = np.arange(1, int(4 * tau0 * fs))
    power = np.mean(np.abs(xi) ** 2)
    rho = np.array([np.mean(xi[:-l] * np.conj(xi[l:])).real / power for l in lags])
    estimate = lags[np.argmax(rho < np.exp(-1))] / fs
    assert estimate == pytest.approx(tau0, rel=0.15)


@pytest.mark.parametrize("s4", [0.5, 0.9])
def test_aj_stanford_s4_sigma_phi_and_intensity_phase_correlation(s4):
    z = scintillation.aj_stanford(s4, 0.1, 300.0, 50.0, np.random.default_rng(7), batch_shape=(20,))
    assert np.mean(scintillation.s4_index(z)) == pytest.approx(s4, abs=0.05)
    phase = np.angle(z)
    assert np.mean(phase.std(axis=0)) == pytest.approx(0.1, rel=0.1)
    corr = np.mean([np.corrcoef(np.abs(z[:, i]) ** 2, phase[:, i])[0, 1] for i in range(20)])
    assert -0.7 < corr < -0.5


def test_scintillation_parameters_are_checked():
    with pytest.raises(gf.ConfigError, match="S4 <= 1"):
        scintillation.cornell(1.2, 1.0, 10, 50, np.random.default_rng(0))
    with pytest.raises(gf.ConfigError, match="5 samples per tau0"):
        scintillation.cornell(0.5, 0.01, 10, 50, np.random.default_rng(0))


def test_ar1_noise_has_the_stationary_variance_and_lag_one_correlation():
    v = impairments.ar1_noise(0.8, 1.0, 20000, np.random.default_rng(1), batch_shape=(8,))
    assert v.var() == pytest.approx(1 / (1 - 0.64), rel=0.05)
    assert np.mean(v[1:] * v[:-1]) / v.var() == pytest.approx(0.8, abs=0.02)
    per_element = impairments.ar1_noise(np.array([0.0, 0.9]), 1.0, 20000, np.random.default_rng(2))
    assert per_element[:, 1].var() > 4 * per_element[:, 0].var()


@pytest.mark.parametrize("alpha, delay, in_phase", [(0.5, 0.2, True), (0.3, 0.1, True), (0.5, 0.2, False)])
def test_multipath_bias_of_the_eml_dll_matches_the_closed_form(alpha, delay, in_phase):
    disc = gf.registry.create("discriminator", "eml-envelope", early_late_spacing_chips=1.0)
    A = amplitude_from_cn0(45.0, 0.001)

    def output(e):
        y = impairments.multipath_correlator_mean(
            A, e, 0.0, 0.0, 0.001, np.array([-0.5, 0.0, 0.5]), alpha, delay, 0.0 if in_phase else np.pi
        )
        return float(disc(Correlators(y[0], y[1], y[2])))

    null = optimize.brentq(output, -0.3, 0.3)  # where the DLL settles
    assert null == pytest.approx(impairments.eml_multipath_error_chips(alpha, delay, 1.0, in_phase), abs=1e-9)


def test_cycle_slips_are_integer_and_happen_at_the_given_rate():
    slips = impairments.cycle_slips(10000, 0.01, np.random.default_rng(4), max_cycles=5)
    jumps = np.diff(slips, prepend=0)
    assert np.all(jumps == np.round(jumps)) and np.abs(jumps).max() <= 5
    assert np.count_nonzero(jumps) == pytest.approx(100, rel=0.3)


@pytest.mark.parametrize("preset", ["tcxo", "ocxo"])
def test_clock_allan_variance_matches_its_h_parameters(preset):
    model = clock.PRESETS[preset]
    T = 0.01
    bias, _ = model.simulate(100_000, T, np.random.default_rng(5), batch_shape=(6,))
    taus = np.array([0.1, 1.0, 10.0])
    measured = np.mean(
        [allantools.oadev(bias[:, i], rate=1 / T, data_type="phase", taus=taus)[1] ** 2 for i in range(6)], axis=0
    )
    # The two-state model has no flicker floor (documented): compare with its own part.
    np.testing.assert_allclose(measured, model.allan_variance(taus, include_flicker=False), rtol=0.15)
    assert np.all(model.allan_variance(taus) > model.allan_variance(taus, include_flicker=False))
