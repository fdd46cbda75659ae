"""Single-point positioning on synthetic pseudoranges from real broadcast records
(tests/data/07590920.05n) and the station's header position: the truth is the geometry
itself (light time and Earth rotation iterated here, independently of the solver), and the
Klobuchar, troposphere and DOP functions against closed forms."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gnssframework.errors import ConfigError
from gnssframework.navigation.ephemeris import read_rinex_nav
from light_time import C, signal_flight, visible_records
from gnssframework.navigation.lnav import IonoUtc
from gnssframework.navigation.pvt import dop, klobuchar_delay_s, solve_position, troposphere_delay_m

NAV = Path(__file__).parents[1] / "data" / "07590920.05n"
STATION = np.array([-3976219.5082, 3382372.5671, 3652512.9849])  # its RINEX header, m
T_RX = 518_400.0 + 300.0  # GPS seconds of week, 5 min after the records' Toe
IONO = IonoUtc(alpha=(1.118e-08, 1.49e-08, -5.96e-08, -5.96e-08), beta=(9.011e04, 1.638e04, -1.966e05, -6.554e04))


def _truth(eph, t_rx, receiver, bias_m):
    """Pseudoranges (no atmosphere) and satellite times of transmission at true time t_rx."""
    tau, clock, _ = signal_flight(eph, t_rx, receiver)
    return C * tau + bias_m - C * clock, t_rx - tau + clock  # the satellite's clock reads t + Δt_SV


@pytest.fixture(scope="module")
def visible():
    return visible_records(read_rinex_nav(NAV), T_RX, STATION)[0]


def test_noise_free_pseudoranges_give_the_station_and_clock(visible):
    assert visible.sv.size >= 6
    pr, tx = _truth(visible, T_RX, STATION, 12_345.6)
    fix = solve_position(pr, tx, visible, iono=None)
    assert np.linalg.norm(fix.position_ecef_m - STATION) < 1e-3
    assert fix.clock_bias_m == pytest.approx(12_345.6, abs=1e-3)
    assert fix.excluded is None and fix.used.all() and np.nanmax(np.abs(fix.residuals_m)) < 1e-3
    assert 0 < fix.hdop < fix.pdop < fix.gdop and fix.vdop > 0


def test_the_klobuchar_delay_is_removed_when_switched_on(visible):
    pr, tx = _truth(visible, T_RX, STATION, 0.0)
    first = solve_position(pr, tx, visible)
    delay = C * klobuchar_delay_s(
        IONO.alpha, IONO.beta, first.lat_deg, first.lon_deg, first.azimuth_deg, first.elevation_deg, T_RX
    )
    assert delay.min() > 1.0  # metres: a test that would see a missing correction
    with_iono = solve_position(pr + delay, tx, visible, iono=IONO)
    assert np.linalg.norm(with_iono.position_ecef_m - STATION) < 0.01
    without = solve_position(pr + delay, tx, visible)
    assert np.linalg.norm(without.position_ecef_m - STATION) > 1.0


def test_a_faulty_satellite_is_excluded_and_noise_stays_within_its_dop(visible):
    rng = np.random.default_rng(25)
    pr, tx = _truth(visible, T_RX, STATION, -300.0)
    errors = []
    for _trial in range(20):
        noisy = pr + rng.standard_normal(pr.size) * 1.0
        fix = solve_position(noisy, tx, visible, sigma_m=1.0, elevation_mask_deg=0.0)
        errors.append(fix.position_ecef_m - STATION)
    rms = np.sqrt(np.mean(np.sum(np.square(errors), axis=1)))
    # 1 m noise at the zenith, larger at low elevation: a few PDOPs of metres at most.
    assert rms < 5 * fix.pdop
    bad = pr.copy()
    bad[2] += 150.0
    fix = solve_position(bad + rng.standard_normal(pr.size) * 1.0, tx, visible, sigma_m=1.0, elevation_mask_deg=0.0)
    assert fix.excluded == 2 and not fix.used[2] and np.isnan(fix.residuals_m[2])
    assert np.linalg.norm(fix.position_ecef_m - STATION) < 15.0


def test_velocity_and_clock_drift_from_dopplers(visible):
    lam = C / 1575.42e6
    h = 0.5
    drift = 40.0  # m/s
    ahead, _ = _truth(visible, T_RX + h, STATION, drift * h)
    behind, _ = _truth(visible, T_RX - h, STATION, -drift * h)
    doppler = -(ahead - behind) / (2 * h) / lam
    pr, tx = _truth(visible, T_RX, STATION, 0.0)
    fix = solve_position(pr, tx, visible, doppler_hz=doppler)
    assert np.all(np.abs(fix.velocity_enu_mps) < 0.01)
    assert fix.clock_drift_mps == pytest.approx(drift, abs=0.01)


def test_dop_of_a_zenith_and_three_horizon_satellites_is_the_closed_form():
    az = np.radians([0.0, 120.0, 240.0])
    u = np.vstack([[0.0, 0.0, 1.0], np.stack([np.sin(az), np.cos(az), np.zeros(3)], axis=1)])
    # (HᵀH): east/north block diag(3/2, 3/2); up/clock block [[1, 1], [1, 4]] -> inverse (1/3)[[4, -1], [-1, 1]].
    gdop, pdop, hdop, vdop = dop(u)
    assert hdop == pytest.approx(np.sqrt(4 / 3))
    assert vdop == pytest.approx(np.sqrt(4 / 3))
    assert pdop == pytest.approx(np.sqrt(8 / 3))
    assert gdop == pytest.approx(np.sqrt(8 / 3 + 1 / 3))


def test_klobuchar_closed_forms():
    alpha = (2.0e-8, 0.0, 0.0, 0.0)
    beta = (100_000.0, 0.0, 0.0, 0.0)
    F = 1 + 16 * (0.53 - 0.5) ** 3  # obliquity at the zenith (E = 0.5 semicircle)
    # At the zenith the pierce point is the user's; local time 14:00 at longitude 0: x = 0.
    peak = klobuchar_delay_s(alpha, beta, 10.0, 0.0, np.array([0.0]), np.array([90.0]), 50_400.0)
    assert peak[0] == pytest.approx(F * (5e-9 + 2.0e-8))
    night = klobuchar_delay_s(alpha, beta, 10.0, 0.0, np.array([0.0]), np.array([90.0]), 7_200.0)
    assert night[0] == pytest.approx(F * 5e-9)
    low = klobuchar_delay_s(alpha, beta, 10.0, 0.0, np.array([0.0]), np.array([5.0]), 7_200.0)
    assert low[0] == pytest.approx((1 + 16 * (0.53 - 5 / 180) ** 3) * 5e-9)


def test_troposphere_is_about_2_4_m_at_the_zenith_and_scales_with_1_over_sin_e():
    zenith = troposphere_delay_m(45.0, 0.0, np.array([90.0]))[0]
    assert 2.3 < zenith < 2.6
    assert troposphere_delay_m(45.0, 0.0, np.array([30.0]))[0] == pytest.approx(2 * zenith)
    assert troposphere_delay_m(45.0, 3000.0, np.array([90.0]))[0] < zenith


def test_too_few_satellites_and_mismatched_shapes(visible):
    pr, tx = _truth(visible, T_RX, STATION, 0.0)
    pr[3:] = np.nan
    assert solve_position(pr, tx, visible) is None
    with pytest.raises(ConfigError, match="solve_position"):
        solve_position(pr[:3], tx, visible)


@pytest.mark.parametrize("method", ["chi2", "ss"])
def test_raim_excludes_a_faulty_satellite_and_its_levels_bound_the_error(visible, method):
    rng = np.random.default_rng(43)
    pr, tx = _truth(visible, T_RX, STATION, 100.0)
    import pymap3d

    lat, lon, h = pymap3d.ecef2geodetic(*STATION)
    for _ in range(30):  # fault-free: the same solution as without raim, inside its levels
        noisy = pr + rng.standard_normal(pr.size) * 1.0
        plain = solve_position(noisy, tx, visible, sigma_m=1.0, elevation_mask_deg=0.0, false_alarm=1e-5)
        fix = solve_position(noisy, tx, visible, sigma_m=1.0, elevation_mask_deg=0.0, false_alarm=1e-5, raim=method)
        assert plain.raim == "" and np.isnan(plain.hpl_m)
        if fix.raim != "ok":
            continue
        assert fix.position_ecef_m == pytest.approx(plain.position_ecef_m, abs=1e-9)
        e, n, u = pymap3d.ecef2enu(*fix.position_ecef_m, lat, lon, h)
        assert np.hypot(e, n) < fix.hpl_m and abs(u) < fix.vpl_m
        assert fix.test_statistic == pytest.approx(
            np.nansum(fix.residuals_m**2 * np.sin(np.radians(np.maximum(fix.elevation_deg, 1.0))) ** 2), rel=1e-6
        )  # weights of the last iteration
    bad = pr + rng.standard_normal(pr.size) * 1.0
    bad[2] += 150.0
    fix = solve_position(bad, tx, visible, sigma_m=1.0, elevation_mask_deg=0.0, false_alarm=1e-5, raim=method)
    assert fix.fault_detected and fix.raim == "excluded" and fix.excluded == 2 and not fix.used[2]
    e, n, u = pymap3d.ecef2enu(*fix.position_ecef_m, lat, lon, h)
    assert np.hypot(e, n) < fix.hpl_m < 100 and abs(u) < fix.vpl_m < 100
    with pytest.raises(ConfigError, match="raim"):
        solve_position(pr, tx, visible, raim="both")


def test_an_l2_signal_takes_gamma_tgd_and_the_ionosphere_scaled_to_its_frequency(visible):
    """IS-GPS-200 20.3.3.3.3.2: a single-frequency user of L2 applies Δt_SV - γ T_GD,
    γ = (1575.42/1227.6)² = 1.6469, and a first-order ionospheric delay γ times L1's. The
    pseudoranges here are made that way from the records' own T_GD (not the solver's):
    solved as GPS L2C they give the station; solved with L1's corrections, not."""
    from gnssframework.signal.gps_l2c import GPS_L2C

    gamma = (1575.42 / 1227.60) ** 2
    tgd = visible.elements["TGD"]
    assert np.max(np.abs(tgd)) * C * (gamma - 1) > 1.0  # metres: a test that could fail
    flight = signal_flight(visible, T_RX, STATION)
    clock_l2 = flight.clock_s - (gamma - 1) * tgd  # the helper's clock is L1 C/A's (clock - T_GD)
    pr = C * flight.tau_s + 1_000.0 - C * clock_l2
    tx = T_RX - flight.tau_s + clock_l2
    l2 = solve_position(pr, tx, visible, signal=GPS_L2C, iono=None)
    assert np.linalg.norm(l2.position_ecef_m - STATION) < 1e-3
    as_l1 = solve_position(pr, tx, visible, iono=None)
    assert np.linalg.norm(as_l1.position_ecef_m - STATION) > 0.3
    first = solve_position(pr, tx, visible, signal=GPS_L2C)
    delay_l1 = C * klobuchar_delay_s(
        IONO.alpha, IONO.beta, first.lat_deg, first.lon_deg, first.azimuth_deg, first.elevation_deg, T_RX
    )
    with_iono = solve_position(pr + gamma * delay_l1, tx, visible, signal=GPS_L2C, iono=IONO)
    assert np.linalg.norm(with_iono.position_ecef_m - STATION) < 0.01
    l1_scaled = solve_position(pr + gamma * delay_l1, tx, visible, iono=IONO)
    assert np.linalg.norm(l1_scaled.position_ecef_m - STATION) > 1.0
