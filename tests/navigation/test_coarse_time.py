"""Coarse-time navigation (`coarse_time.solve_coarse_time`) on synthetic pseudoranges from
real broadcast records (tests/data/07590920.05n) seen from the station of its header: the
truth is the geometry (light time and Earth rotation iterated by `light_time`, not by the
solver), with the transmit times all shifted by a known offset."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from gnssframework.errors import ConfigError
from gnssframework.navigation.coarse_time import solve_coarse_time
from gnssframework.navigation.ephemeris import read_rinex_nav
from gnssframework.navigation.pvt import solve_position
from light_time import C, signal_flight, visible_records

NAV = Path(__file__).parents[1] / "data" / "07590920.05n"
STATION = np.array([-3976219.5082, 3382372.5671, 3652512.9849])  # the file's header, m
T_RX = 518_400.0 + 300.0
#: The approximate position: 80 km from the station (the ambiguity resolution's range).
APPROX = STATION + np.array([50e3, -40e3, 45e3])


@pytest.fixture(scope="module")
def visible():
    return visible_records(read_rinex_nav(NAV), T_RX, STATION)[0]


def _truth(eph, bias_m: float = 3_000.0):
    flight = signal_flight(eph, T_RX, STATION)
    return C * flight.tau_s + bias_m - C * flight.clock_s, T_RX - flight.tau_s + flight.clock_s


@pytest.mark.parametrize("offset_s", [-2.0, 0.0, 1.7, 15.0])
def test_the_offset_and_the_station_come_back_exactly_without_noise(visible, offset_s):
    pr, tx = _truth(visible)
    got = solve_coarse_time(pr, tx - offset_s, visible, initial_ecef_m=APPROX)
    assert got.time_offset_s == pytest.approx(offset_s, abs=1e-6)
    assert np.linalg.norm(got.fix.position_ecef_m - STATION) < 0.01
    assert got.fix.used.all() and got.fix.excluded is None
    # The range rates it names are the satellites' (finite differences of the true ranges).
    later = signal_flight(visible, T_RX + 0.5, STATION).tau_s
    earlier = signal_flight(visible, T_RX - 0.5, STATION).tau_s
    assert np.allclose(got.range_rate_mps, C * (later - earlier), atol=0.05)


def test_the_four_state_fix_at_the_shifted_times_is_kilometres_off(visible):
    """What the fifth state is for: the same pseudoranges, the time taken as given."""
    pr, tx = _truth(visible)
    fix = solve_position(pr, tx - 1.7, visible, initial_ecef_m=APPROX, sigma_m=1e6)
    assert np.linalg.norm(fix.position_ecef_m - STATION) > 300.0


def test_the_offset_error_follows_its_stated_sigma(visible):
    """400 draws of 10 m white noise (uniform weights, as generated): the standardised
    errors of the offset have unit variance (chi-square bounds at 0.1 %), the position's
    mean error is within its noise."""
    rng = np.random.default_rng(2026)
    pr, tx = _truth(visible)
    z, err = [], []
    for _ in range(400):
        got = solve_coarse_time(
            pr + 10.0 * rng.standard_normal(pr.size),
            tx - 1.3,
            visible,
            initial_ecef_m=APPROX,
            sigma_m=10.0,
            elevation_weights=False,
            elevation_mask_deg=0.0,
        )
        z.append((got.time_offset_s - 1.3) / got.time_offset_sigma_s)
        err.append(got.fix.position_ecef_m - STATION)
    lo, hi = stats.chi2.ppf([0.0005, 0.9995], 400) / 400
    assert lo < np.mean(np.square(z)) < hi
    assert abs(np.mean(z)) < 3.3 / np.sqrt(400)
    sigma = got.time_offset_sigma_s
    assert 1e-3 < sigma < 1.0  # tens of milliseconds at 10 m: the geometry sees the time
    mean = np.mean(err, axis=0)
    assert np.linalg.norm(mean) < 3.3 * np.sqrt(np.mean(np.sum(np.square(err), axis=1)) / 400)


def test_fewer_than_five_satellites_give_none(visible):
    pr, tx = _truth(visible)
    four = visible.subset(np.arange(4))
    assert solve_coarse_time(pr[:4], tx[:4] - 1.0, four, initial_ecef_m=APPROX) is None


def test_bad_input_is_refused_in_one_line(visible):
    pr, tx = _truth(visible)
    with pytest.raises(ConfigError, match="solve_coarse_time"):
        solve_coarse_time(pr[:-1], tx, visible)
    with pytest.raises(ConfigError, match="sigma_m"):
        solve_coarse_time(pr, tx, visible, sigma_m=0.0)
