"""A registry nav_filter on the receiver's pseudoranges and Dopplers (`filtered`).

- On a toy with a given satellite geometry and white measurement noise, ``ekf-pv`` run by
  the harness equals a Kalman filter written out here (the model linearised at each
  prediction: the textbook EKF recursion) to rounding.
- The corrections are the least squares': on pseudoranges built from real broadcast
  records by an independent light-time loop, the corrected range minus the geometric
  range to the station is the receiver clock bias.
- Unknown and unfit names are refused naming the option.
"""

from __future__ import annotations

import numpy as np
import pytest

from gnssframework import registry
from gnssframework.errors import ConfigError
from gnssframework.navigation.ephemeris import satellite_state
from gnssframework.receiver.navigation.filtered import (
    EpochMeasurements,
    check_nav_filter,
    corrected_measurements,
    run_nav_filter,
)
from gnssframework.simulation.clock import PRESETS
from station_observables import C, L1_WAVELENGTH_M, STATION, geometry, visible


def _hand_ekf(x, P, epochs, T, q, clock_q):
    """The Kalman recursion of a constant-velocity state [r, v, b, d] with range and
    range-rate measurements linearised at the prediction; no prediction before the first
    update (the prior is at the first epoch)."""
    F = np.eye(8)
    F[:3, 3:6] = T * np.eye(3)
    F[6, 7] = T
    Q = np.zeros((8, 8))
    Q[:3, :3] = q * T**3 / 3 * np.eye(3)
    Q[:3, 3:6] = Q[3:6, :3] = q * T**2 / 2 * np.eye(3)
    Q[3:6, 3:6] = q * T * np.eye(3)
    Q[6:, 6:] = clock_q
    out = []
    for k, m in enumerate(epochs):
        if k:
            x, P = F @ x, F @ P @ F.T + Q
        los = m.sat_pos_m - x[:3]
        dist = np.linalg.norm(los, axis=1)
        e = los / dist[:, None]
        h = np.r_[dist + x[6], np.sum((m.sat_vel_m_s - x[3:6]) * e, axis=1) + x[7]]
        S = m.range_m.size
        H = np.zeros((2 * S, 8))
        H[:S, :3], H[:S, 6] = -e, 1.0
        H[S:, 3:6], H[S:, 7] = -e, 1.0
        R = np.diag(np.r_[m.range_var_m2, m.rate_var_m2_s2])
        K = P @ H.T @ np.linalg.inv(H @ P @ H.T + R)
        x = x + K @ (np.r_[m.range_m, m.rate_m_s] - h)
        P = (np.eye(8) - K @ H) @ P
        out.append(x)
    return np.array(out)


def test_ekf_pv_on_measurements_equals_a_hand_written_kalman_filter():
    rng = np.random.default_rng(7)
    T, K = 0.5, 40
    # Six satellites 2.6e7 m out in fixed directions over the receiver, moving at 3 km/s.
    az, el = np.radians([0, 60, 130, 200, 270, 320]), np.radians([70, 20, 45, 30, 15, 55])
    u = np.stack([np.cos(el) * np.sin(az), np.cos(el) * np.cos(az), np.sin(el)], axis=1)
    r0, v = np.array([10.0, -20.0, 5.0]), np.array([3.0, -1.0, 0.2])
    bias0, drift = 300.0, 2.0
    sat_vel = 3000.0 * np.cross(u, [0.0, 0.0, 1.0]) / np.linalg.norm(np.cross(u, [0.0, 0.0, 1.0]), axis=1)[:, None]
    range_var, rate_var = 4.0 / np.sin(el) ** 2, 0.04 / np.sin(el) ** 2
    epochs = []
    for k in range(K):
        t = k * T
        sat = 2.6e7 * u + sat_vel * t
        r = r0 + v * t
        los = sat - r
        e = los / np.linalg.norm(los, axis=1)[:, None]
        rho = np.linalg.norm(los, axis=1) + bias0 + drift * t + rng.standard_normal(6) * np.sqrt(range_var)
        rate = np.sum((sat_vel - v) * e, axis=1) + drift + rng.standard_normal(6) * np.sqrt(rate_var)
        epochs.append(EpochMeasurements(sat, sat_vel, rho, rate, range_var, rate_var))
    x0 = np.r_[r0 + [4.0, -3.0, 6.0], v + [0.3, 0.2, -0.1], bias0 - 5.0, drift + 0.5]
    P0 = np.diag([25.0] * 3 + [1.0] * 3 + [100.0, 1.0])
    nav = registry.create("nav_filter", "ekf-pv", accel_psd=0.05, clock="tcxo")
    got = run_nav_filter(nav, T, x0, P0, epochs)
    want = _hand_ekf(x0, P0, epochs, T, 0.05, C**2 * PRESETS["tcxo"].process_noise(T))
    assert got.shape == (K, 8)
    # Float64 rounding of a few hundred operations on ranges of 2.6e7 m: well under a micrometre.
    np.testing.assert_allclose(got[:, :6], want[:, :6], rtol=0, atol=1e-6)
    np.testing.assert_allclose(got[:, 6:], want[:, 6:], rtol=0, atol=1e-6)
    # And the filter does its job: the last position is closer to the truth than the prior.
    truth_last = r0 + v * (K - 1) * T
    assert np.linalg.norm(got[-1, :3] - truth_last) < np.linalg.norm(x0[:3] - r0)


def test_corrected_ranges_are_geometry_plus_the_receiver_clock():
    t_rx = 518_700.0
    sel, _ = visible(t_rx, 10.0)
    bias = 1500.0
    pr, tx, _, _ = geometry(sel, t_rx, bias)
    # The Doppler of a static receiver with a still clock: minus the pseudorange rate over λ.
    doppler = -(geometry(sel, t_rx + 0.5, bias)[0] - geometry(sel, t_rx - 0.5, bias)[0]) / L1_WAVELENGTH_M
    meas, keep = corrected_measurements(pr, tx, doppler, sel, STATION, elevation_mask_deg=10.0)
    assert keep.all()
    geometric = np.linalg.norm(meas.sat_pos_m - STATION, axis=1)
    # Millimetres: the satellite clock evaluated at t_SV rather than t (its drift over 70 ms).
    np.testing.assert_allclose(meas.range_m - geometric, bias, atol=1e-3)
    # The corrected rate is the satellite's ECEF velocity along the line of sight; the
    # bound: the change of the Earth-rotation angle with the flight time (ω_e |s| dτ/dt,
    # about 3 mm/s) and the curvature of a range over the 1 s difference (under 1 mm/s).
    e = (meas.sat_pos_m - STATION) / geometric[:, None]
    np.testing.assert_allclose(meas.rate_m_s, np.sum(meas.sat_vel_m_s * e, axis=1), atol=0.01)


@pytest.mark.parametrize(
    "name, message",
    [
        ("ekf-p", "nav_filter: unknown nav_filter 'ekf-p'"),
        (
            "position-ca",
            "nav_filter: nav_filter 'position-ca' cannot run on pseudoranges and Dopplers: it needs "
            "position_m; those that can: ",
        ),
    ],
)
def test_a_bad_nav_filter_name_is_refused_naming_the_option(name, message):
    with pytest.raises(ConfigError) as info:
        check_nav_filter(name)
    assert str(info.value).startswith(message)  # the parameter; the CLI says --nav-filter
    assert "\n" not in str(info.value)
    if name == "ekf-p":
        assert "ekf-pv" in str(info.value)  # the closest name
    else:
        assert "ekf-pv" in str(info.value).split("those that can: ")[1]


@pytest.mark.parametrize("elevation_weights", [True, False])
def test_least_squares_weights_satisfy_their_normal_equations(elevation_weights):
    """The fix leaves residuals orthogonal to the weighted geometry: sum w r [-u, 1] = 0 with
    w = sin²(E) (the default) or 1 (``elevation_weights=False``, the RTKLIB comparison's)."""
    from gnssframework.navigation.pvt import solve_position

    t_rx = 518_700.0
    sel, _ = visible(t_rx, 10.0)
    geometric = np.linalg.norm(satellite_state(sel, t_rx - 0.07).position_m - STATION, axis=1)
    clock = satellite_state(sel, t_rx - 0.07).clock_l1_s
    rng = np.random.default_rng(3)
    pr = geometric - C * clock + 100.0 + rng.standard_normal(sel.sv.size) * 3.0
    tx = t_rx - geometric / C + clock
    fix = solve_position(
        pr, tx, sel, sigma_m=3.0, elevation_mask_deg=0.0, false_alarm=1e-12, elevation_weights=elevation_weights
    )
    el, az = np.radians(fix.elevation_deg), np.radians(fix.azimuth_deg)
    u = np.stack([np.cos(el) * np.sin(az), np.cos(el) * np.cos(az), np.sin(el)], axis=1)
    w = np.sin(el) ** 2 if elevation_weights else np.ones(el.size)
    H = np.hstack([-u, np.ones((el.size, 1))])
    normal = H.T @ (w * fix.residuals_m)
    # Gauss-Newton stops at a step under 0.1 mm: the normal equations hold to about that
    # times the weights' sum; the residuals themselves are metres.
    assert np.all(np.abs(normal) < 1e-3 * w.sum())
    assert np.max(np.abs(fix.residuals_m)) > 0.5


def test_ekf_pva_runs_through_the_same_harness():
    """ekf-pva (11 states, acceleration after the clock) takes the 8-state prior and the
    same measurements: a receiver at rest is found within the noise."""
    rng = np.random.default_rng(11)
    az, el = np.radians([0, 60, 130, 200, 270, 320]), np.radians([70, 20, 45, 30, 15, 55])
    u = np.stack([np.cos(el) * np.sin(az), np.cos(el) * np.cos(az), np.sin(el)], axis=1)
    sat = 2.6e7 * u
    epochs = [
        EpochMeasurements(
            sat,
            np.zeros((6, 3)),
            np.linalg.norm(sat, axis=1) + 50.0 + rng.standard_normal(6),
            rng.standard_normal(6) * 0.1,
            np.ones(6),
            np.full(6, 0.01),
        )
        for _ in range(30)
    ]
    x0 = np.r_[3.0, -2.0, 4.0, 0.0, 0.0, 0.0, 45.0, 0.0]
    P0 = np.diag([25.0] * 3 + [1.0] * 3 + [100.0, 1.0])
    states = run_nav_filter(registry.create("nav_filter", "ekf-pva"), 1.0, x0, P0, epochs)
    assert states.shape == (30, 8) and np.all(np.isfinite(states))
    # 30 epochs of 1 m ranges from six satellites: the position to about a metre.
    assert np.linalg.norm(states[-1, :3]) < 3.0
