"""Clock presets and the channel filter's clock process noise from h-parameters."""

import numpy as np
import pytest
from scipy.linalg import expm

import gnssframework as gf
from gnssframework.simulation.clock import PRESETS

F_L1, F_CODE, T = 1575.42e6, 1.023e6, 0.01


def van_loan_clock_q(model, T):
    # Independent oracle: discretise db = d dt + w_f, dd = w_g (PSDs h0/2 and 2 pi^2 h_-2)
    # with Van Loan's matrix exponential instead of the closed form.
    A = np.array([[0.0, 1.0], [0.0, 0.0]])
    W = np.diag([model.h0 / 2, 2 * np.pi**2 * model.h_2])
    M = np.block([[-A, W], [np.zeros((2, 2)), A.T]]) * T
    E = expm(M)
    Phi = E[2:, 2:].T
    return Phi @ E[:2, 2:]


@pytest.mark.parametrize("preset", sorted(PRESETS))
def test_tracking_process_noise_is_the_two_state_clock_q_in_tracking_units(preset):
    model = PRESETS[preset]
    Qc = van_loan_clock_q(model, T)
    np.testing.assert_allclose(model.process_noise(T), Qc, rtol=1e-9)
    Qt = model.tracking_process_noise(T, F_L1, F_CODE)
    # code phase error (chips) = -f_code b (the code is delayed), phase (rad) = -2 pi f_L1 b,
    # frequency (Hz) = -f_L1 d.
    scale = np.array([-F_CODE, -2 * np.pi * F_L1])
    np.testing.assert_allclose(Qt[:2, :2], np.outer(scale, scale) * Qc[0, 0], rtol=1e-9)
    np.testing.assert_allclose(Qt[2, 2], F_L1**2 * Qc[1, 1], rtol=1e-9)
    np.testing.assert_allclose(Qt[1, 2], 2 * np.pi * F_L1**2 * Qc[0, 1], rtol=1e-9)


def test_good_tcxo_preset_has_the_allan_deviation_of_a_gnss_grade_tcxo():
    adev = np.sqrt(PRESETS["tcxo-hq"].allan_variance(np.array([0.01, 0.1])))
    assert np.all((1e-10 < adev) & (adev < 4e-10))
    # Brown and Hwang's TCXO is ten times worse at 10 ms.
    assert np.sqrt(PRESETS["tcxo"].allan_variance(0.01)) > 9 * adev[0]


def test_iq_filter_adds_the_clock_noise_to_its_q():
    base = gf.registry.create("channel_filter", "iq-filter")
    clocked = gf.registry.create("channel_filter", "iq-filter", clock="tcxo-hq")
    dQ = clocked.process_noise(T) - base.process_noise(T)
    np.testing.assert_allclose(dQ[1:4, 1:4], PRESETS["tcxo-hq"].tracking_process_noise(T, F_L1, F_CODE))
    assert np.all(dQ[0] == 0) and np.all(dQ[4] == 0)


def test_iq_filter_refuses_an_unknown_clock():
    with pytest.raises(gf.errors.ConfigError, match="tcxo-hq"):
        gf.registry.create("channel_filter", "iq-filter", clock="quartz")
