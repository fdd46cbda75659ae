"""The ionosphere-free combination (`gnssframework.navigation.dual_frequency`) and
`solve_position(..., dual=...)` on synthetic pseudoranges from real broadcast records
(tests/data/07590920.05n) seen from the station of 07590920.05o. Truth: the geometry (light
time iterated by the tests' own `light_time`), each signal's satellite clock as
IS-GPS-200 defines it (20.3.3.3.3.2 for LNAV's T_GD; 30.3.3.3.1.1.1 for CNAV's ISCs,
with GNSSTk's values of a real type 30) and a first-order ionosphere that goes as 1/f²."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gnssframework.errors import ConfigError
from gnssframework.navigation.cnav_records import cnav_records
from gnssframework.navigation.dual_frequency import DualFrequency
from gnssframework.navigation.ephemeris import read_rinex_nav, satellite_state
from gnssframework.navigation.pvt import solve_position
from gnssframework.signal.galileo_e1 import GALILEO_E1B
from gnssframework.signal.gps_l1ca import GPS_L1CA
from gnssframework.signal.gps_l2c import GPS_L2C
from gnsstk_cnav import gnsstk_cnav
from light_time import C, signal_flight, visible_records

DATA = Path(__file__).parents[1] / "data"
NAV = DATA / "07590920.05n"
STATION = np.array([-3976219.5082, 3382372.5671, 3652512.9849])
T_RX = 518_400.0 + 300.0
GAMMA = (1575.42 / 1227.60) ** 2  # IS-GPS-200 20.3.3.3.3.2
L1L2 = DualFrequency(GPS_L1CA, GPS_L2C)


@pytest.fixture(scope="module")
def visible():
    return visible_records(read_rinex_nav(NAV), T_RX, STATION)


def test_gamma_and_the_noise_factor_are_the_icds():
    assert L1L2.gamma == pytest.approx(GAMMA, rel=1e-12) and L1L2.gamma == pytest.approx((77 / 60) ** 2)
    assert L1L2.noise_factor == pytest.approx(np.sqrt(GAMMA**2 + 1) / (GAMMA - 1))
    assert 2.9 < L1L2.noise_factor < 3.0


def test_the_combination_removes_the_ionosphere_and_gives_the_station(visible):
    """L1 C/A and L2 pseudoranges as an LNAV user sees them: each with its own satellite
    clock (Δt_SV - T_GD and Δt_SV - γ T_GD) and an ionosphere of 5-20 m on L1, γ times that on
    L2. Combined, they give the station to a millimetre; either alone, uncorrected, does not."""
    sats, el = visible
    assert sats.sv.size >= 6
    flight = signal_flight(sats, T_RX, STATION)
    tgd = sats.elements["TGD"]
    clock_l1 = flight.clock_s  # the helper's clock: clock_l1_s, Δt_SV - T_GD
    clock_l2 = clock_l1 - (GAMMA - 1) * tgd
    iono_l1 = 5.0 + 15.0 * np.cos(el)
    bias = 2_000.0
    p1 = C * flight.tau_s + bias - C * clock_l1 + iono_l1
    p2 = C * flight.tau_s + bias - C * clock_l2 + GAMMA * iono_l1
    tx = T_RX - flight.tau_s + clock_l1
    fix = solve_position(L1L2.combine(p1, p2), tx, sats, dual=L1L2)
    assert np.linalg.norm(fix.position_ecef_m - STATION) < 1e-3
    assert fix.clock_bias_m == pytest.approx(bias, abs=1e-3)
    for p, sig in ((p1, GPS_L1CA), (p2, GPS_L2C)):
        alone = solve_position(p, tx, sats, signal=sig)
        assert np.linalg.norm(alone.position_ecef_m - STATION) > 5.0
    # Solved with one signal's clock instead of the combination's, T_GD would stay in.
    wrong = solve_position(L1L2.combine(p1, p2), tx, sats, signal=GPS_L1CA)
    assert np.linalg.norm(wrong.position_ecef_m - STATION) > 0.3


def test_with_cnav_iscs_the_clock_is_the_icds_combination():
    """IS-GPS-200 30.3.3.3.1.1.2: the L1 C/A and L2C combination's clock is
    Δt_SV - T_GD + (ISC_L2C - γ ISC_L1CA) / (1 - γ), with GNSSTk's ISCs of a real type 30."""
    msgs = gnsstk_cnav()
    rec = cnav_records([msgs[10], msgs[11], msgs[30]]).records[0][1]
    state = satellite_state(rec, np.array([rec.elements["Toe"][0] + 60.0]))
    tgd, isc1, isc2 = 5.58793545e-09, -3.49245965e-10, -3.14321369e-09
    want = state.clock_s - tgd + (isc2 - GAMMA * isc1) / (1 - GAMMA)
    assert L1L2.clock_s(rec, state) == pytest.approx(want, abs=1e-15)


@pytest.mark.parametrize(
    "first, second, why",
    [
        (GPS_L1CA, GALILEO_E1B, r"signal: galileo-e1b.*GPS or QZSS"),
        (GPS_L2C, GPS_L1CA, r"signal: gps-l2c \(1227.60 MHz\) must be on a higher carrier than gps-l1ca"),
        (GPS_L1CA, GPS_L1CA, r"must be on a higher carrier"),
    ],
)
def test_refused_in_one_line(first, second, why):
    with pytest.raises(ConfigError, match=why):
        DualFrequency(first, second)
