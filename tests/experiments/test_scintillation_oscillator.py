"""Reference 003's receiver-oscillator option: the phase noise a case's oscillator adds to
the truth has the Allan variance of the preset's h-parameters, moves code and carrier
together, and leaves the scintillation and the ideal-clock truth as they were."""

import numpy as np
import pytest

from gnssframework.errors import ConfigError
from gnssframework.experiments import get_scenario
from gnssframework.experiments.config import load_config

F_L1_HZ, CHIP_RATE_HZ = 1575.42e6, 1.023e6
# Negligible scintillation: amplitude only, no scintillation phase in the carrier.
CASE = {"model": "aj-stanford", "s4": 0.01, "sigma_phi_rad": 0.0}
# h-parameters written out (Brown & Hwang's random-walk term; white FM as the presets
# document), not read from the code under test.
H = {"tcxo-hq": (2e-21, 2e-20), "ocxo": (2e-25, 6e-25)}


def _clock_bias_s(oscillator, runs, duration_s, T=0.01, seed=7):
    scen = get_scenario(
        {
            "kind": "scintillation",
            "duration_s": duration_s,
            "coherent_time_s": T,
            "doppler_hz": 0.0,
            "settle_s": 0.0,
            "oscillator": oscillator,
        }
    )
    truth, scint_phase = scen.truth(CASE, runs, seed)
    return -(truth.carrier_phase_rad - scint_phase) / (2 * np.pi * F_L1_HZ), truth


@pytest.mark.parametrize("oscillator", ["tcxo-hq", "ocxo"])
def test_oscillator_phase_has_the_allan_variance_of_its_h_parameters(oscillator):
    # sigma_y^2(tau) = h0 / (2 tau) + (2 pi^2 / 3) h_-2 tau (white and random-walk FM;
    # IEEE Std 1139 / Brown & Hwang), from the second difference of the clock's time error
    # x: sigma_y^2 = <(x(2 tau) - 2 x(tau) + x(0))^2> / (2 tau^2). One difference per run:
    # the runs are independent, so the estimate's relative standard error is sqrt(2 / N)
    # (a Gaussian's variance). tau = 10 ms is white-FM dominated, 1 s random-walk-FM.
    runs, T = 3000, 0.01
    bias_s, _ = _clock_bias_s(oscillator, runs, duration_s=2.0, T=T)
    h0, h_2 = H[oscillator]
    for tau_s in (0.01, 0.1, 1.0):
        m = int(round(tau_s / T))
        d = bias_s[2 * m] - 2 * bias_s[m] + bias_s[0]
        estimate = np.mean(d**2) / (2 * tau_s**2)
        expected = h0 / (2 * tau_s) + 2 * np.pi**2 / 3 * h_2 * tau_s
        assert abs(estimate / expected - 1) < 4 * np.sqrt(2 / runs), (tau_s, estimate, expected)


def test_oscillator_moves_code_and_carrier_together():
    # A clock bias b delays code and carrier alike: the code's excess over the chip rate is
    # the carrier's excess cycles times chip rate / carrier frequency.
    bias_s, truth = _clock_bias_s("tcxo-hq", 3, duration_s=3.0)
    t = np.arange(truth.epochs + 1)[:, None] * 0.01
    np.testing.assert_allclose(truth.code_phase_chips - CHIP_RATE_HZ * t, -CHIP_RATE_HZ * bias_s, rtol=1e-9, atol=1e-9)
    assert np.std(bias_s[-1]) > 0  # the clock did move


def test_no_oscillator_is_the_ideal_clock_and_the_scintillation_is_unchanged():
    case = {"model": "aj-stanford", "s4": 0.9, "sigma_phi_rad": 0.1}
    scen = get_scenario({"kind": "scintillation", "duration_s": 3.0})
    ideal, ideal_phase = scen.truth(case, 2, 5)
    none, none_phase = scen.truth({**case, "oscillator": "none"}, 2, 5)
    np.testing.assert_array_equal(ideal.carrier_phase_rad, none.carrier_phase_rad)
    # With a TCXO: the same scintillation (the clock draws from its own streams), and the
    # carrier differs from the ideal clock's by the clock alone.
    tcxo, tcxo_phase = scen.truth({**case, "oscillator": "tcxo"}, 2, 5)
    np.testing.assert_array_equal(tcxo_phase, ideal_phase)
    np.testing.assert_array_equal(tcxo.amplitude_scale, ideal.amplitude_scale)
    assert not np.allclose(tcxo.carrier_phase_rad, ideal.carrier_phase_rad)


def test_unknown_oscillator_is_refused_naming_the_case_field(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(
        'name = "x"\nruns = 2\n[scenario]\nkind = "scintillation"\nduration_s = 3.0\n'
        '[[cases]]\nname = "a"\ns4 = 0.5\noscillator = "rubidium"\n'
        '[[candidates]]\nname = "pll"\nchannel_filter = { name = "scalar" }\n'
    )
    with pytest.raises(ConfigError, match=r"cases\[0\]\.oscillator"):
        load_config(path)
