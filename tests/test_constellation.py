"""Constellation geometry against orbital mechanics and finite differences."""

import numpy as np
import pytest

import gnssframework as gf
from gnssframework.simulation.constellation import GM_EARTH, OMEGA_EARTH, load_almanac, nominal_constellation


def test_orbits_have_the_gps_radius_and_a_half_sidereal_day_period():
    c = nominal_constellation()
    assert c.prn.shape == (24,)
    pos, vel, acc = c.state(np.array([0.0, 1234.5]))
    np.testing.assert_allclose(np.linalg.norm(pos, axis=-1), 26_559_700.0, rtol=1e-12)
    period_s = 2 * np.pi / c.mean_motion_rad_s
    assert period_s == pytest.approx(86164.09 / 2, rel=2e-4)  # half a sidereal day
    # In the inertial frame the acceleration is -GM r / |r|^3; in ECEF add the centrifugal
    # and Coriolis terms: a_ecef = a_i - 2 w x v - w x (w x r).
    w = np.array([0.0, 0.0, OMEGA_EARTH])
    r, v, a = pos[1], vel[1], acc[1]
    gravity = -GM_EARTH * r / np.linalg.norm(r, axis=-1, keepdims=True) ** 3
    expected = gravity - 2 * np.cross(w, v) - np.cross(w, np.cross(w, r))
    np.testing.assert_allclose(a, expected, rtol=1e-9, atol=1e-9)


def test_velocity_and_acceleration_are_the_derivatives_of_position():
    c = nominal_constellation()
    h = 1e-3
    p1, v1, _ = c.state(500.0 + h)
    p0, v0, _ = c.state(500.0 - h)
    _, v, a = c.state(500.0)
    np.testing.assert_allclose((p1 - p0) / (2 * h), v, atol=1e-4)
    np.testing.assert_allclose((v1 - v0) / (2 * h), a, atol=1e-6)


def test_visible_picks_the_highest_satellites_and_refuses_too_many_channels():
    c = nominal_constellation()
    idx = c.visible(37800.0, 34.23, 108.3576, 590.6, 10.0, 8)
    el = c.elevation_deg(37800.0, 34.23, 108.3576, 590.6)
    assert np.all(el[idx] > 10) and np.all(np.diff(el[idx]) <= 0)
    with pytest.raises(gf.ConfigError, match="scenario.channels.*at most"):
        c.visible(0.0, 34.23, 108.3576, 590.6, 10.0, 12)


def test_almanac_errors_name_the_file_and_line(tmp_path):
    f = tmp_path / "alm.csv"
    f.write_text("# comment\nprn,raan_deg,arg_lat_deg\n1,10.0,20.0\n2,abc,30.0\n")
    with pytest.raises(gf.DataFileError, match=r"alm.csv:4: bad almanac row"):
        load_almanac(f)
    f.write_text("prn,raan\n1,2\n")
    with pytest.raises(gf.DataFileError, match=r"alm.csv:1: header lacks arg_lat_deg, raan_deg"):
        load_almanac(f)
