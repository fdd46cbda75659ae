"""Broadcast records from GPS CNAV (`gnssframework.navigation.cnav_records`) and message type 30.

Truth: GNSSTk's decoded values of five real CNAV messages of PRN 1
(tests/data/gnsstk_cnav_gps_l2_prn1.hex, LGPL 3.0, see its comments); the CNAV user
algorithm written out once more here from IS-GPS-200 Table 30-II (not the library's
`cnav_position`); IS-GPS-200 30.3.3.3.1.1.1 for an L2C user's clock; and, for the encoder
round trip, the broadcast GPS records of tests/data/07590920.05n and its header's
Klobuchar coefficients.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from gnssframework.errors import ConfigError
from gnssframework.navigation import cnav
from gnssframework.navigation.cnav_records import CNAV_LEAP_S, cnav_record, cnav_records
from gnssframework.navigation.ephemeris import (
    Ephemerides,
    read_rinex_nav,
    satellite_state,
    single_frequency_clock_s,
)
from gnssframework.navigation.rinex_nav_header import read_nav_file_info
from gnssframework.signal.gps_l1ca import GPS_L1CA
from gnssframework.signal.gps_l2c import GPS_L2C
from gnssframework.signal.gps_l5 import GPS_L5I
from gnsstk_cnav import gnsstk_cnav

DATA = Path(__file__).parents[1] / "data"
NAV = DATA / "07590920.05n"
GM = 3.986005e14
OMEGA_E = 7.2921151467e-5


def test_message_30_gives_gnsstks_group_delays_and_klobuchar_coefficients():
    d = cnav.parse_group_delays(gnsstk_cnav()[30])
    assert d.prn == 1
    expected = {
        d.tgd_s: 5.58793545e-09,
        d.isc_l1ca_s: -3.49245965e-10,
        d.isc_l2c_s: -3.14321369e-09,
        d.isc_l5i5_s: 6.43194653e-09,
        d.isc_l5q5_s: 6.54836185e-09,
    }
    for got, want in expected.items():
        assert got == pytest.approx(want, rel=1e-8)
    assert d.iono.alpha == pytest.approx((4.656612870e-09, 1.490116118e-08, -5.960464478e-08, -1.192092897e-07))
    assert d.iono.beta == (8.192e4, 8.192e4, -6.5536e4, -5.24288e5)
    with pytest.raises(ConfigError, match=r"msg: PRN 1: message type 32 carries none \(type 30 does\)"):
        cnav.parse_group_delays(gnsstk_cnav()[32])


def _cnav_truth(e: cnav.CnavEphemeris, t: np.ndarray) -> np.ndarray:
    """IS-GPS-200 Table 30-II, written out step by step (semicircles to radians by pi)."""
    pi = np.pi
    tk = t - e.toe_s
    a0 = cnav.A_REF_M + e.delta_a_m
    ak = a0 + e.a_dot_m_s * tk
    n0 = np.sqrt(GM / a0**3)
    delta_na = (e.delta_n0_sc_s + 0.5 * e.delta_n0_dot_sc_s2 * tk) * pi
    mk = e.m0_sc * pi + (n0 + delta_na) * tk
    ek = mk.copy()
    for _ in range(20):
        ek = mk + e.e * np.sin(ek)  # fixed-point iteration of Kepler's equation
    nu = 2 * np.arctan(np.sqrt((1 + e.e) / (1 - e.e)) * np.tan(ek / 2))
    phi = nu + e.omega_sc * pi
    du = e.cus_rad * np.sin(2 * phi) + e.cuc_rad * np.cos(2 * phi)
    dr = e.crs_m * np.sin(2 * phi) + e.crc_m * np.cos(2 * phi)
    di = e.cis_rad * np.sin(2 * phi) + e.cic_rad * np.cos(2 * phi)
    u, r = phi + du, ak * (1 - e.e * np.cos(ek)) + dr
    i = e.i0_sc * pi + e.i0_dot_sc_s * pi * tk + di
    xp, yp = r * np.cos(u), r * np.sin(u)
    omega_dot = (cnav.OMEGA_DOT_REF_SC_S + e.delta_omega_dot_sc_s) * pi
    om = e.omega0_sc * pi + (omega_dot - OMEGA_E) * tk - OMEGA_E * e.toe_s
    return np.stack(
        [xp * np.cos(om) - yp * np.cos(i) * np.sin(om), xp * np.sin(om) + yp * np.cos(i) * np.cos(om), yp * np.sin(i)],
        axis=-1,
    )


def test_the_record_of_real_messages_places_and_moves_the_satellite_as_the_cnav_algorithm():
    m = gnsstk_cnav()
    got = cnav_records([m[10], m[11], m[30], m[32], m[33]])
    assert [i for i, _ in got.records] == [2]  # type 30 completes it, as GNSSTk's factory says
    rec = got.records[0][1]
    e = cnav.parse_ephemeris(m[10], m[11])
    t = e.toe_s + np.linspace(-7200.0, 7200.0, 9)
    state = satellite_state(rec, t[:, None])
    assert np.max(np.linalg.norm(state.position_m[:, 0] - _cnav_truth(e, t), axis=-1)) < 1e-3
    # Velocity: the derivative of the same positions (central differences of 0.5 s).
    h = 0.5
    fd = (_cnav_truth(e, t + h) - _cnav_truth(e, t - h)) / (2 * h)
    assert np.max(np.linalg.norm(state.velocity_mps[:, 0] - fd, axis=-1)) < 1e-4
    # Without the rates the orbit would be metres off two hours out: they are applied.
    no_rates = cnav_record(
        replace(e, a_dot_m_s=0.0, delta_n0_dot_sc_s2=0.0), cnav.parse_clock(m[30]), cnav.parse_group_delays(m[30])
    )
    off = np.linalg.norm(satellite_state(no_rates, t[-1]).position_m - state.position_m[-1, 0])
    assert off > 10.0
    # Clock: af0 + af1 (t - toc) (af2 is 0) and the relativistic term.
    c = cnav.parse_clock(m[30])
    assert state.clock_s[:, 0] - state.relativistic_s[:, 0] == pytest.approx(
        c.af0_s + c.af1_s_s * (t - c.toc_s), abs=1e-15
    )
    assert rec.health[0] == 0  # L2 healthy; the L5 flag GNSSTk reports is not the L2C user's
    # ... but it is an L5 user's (the record a receiver decoding L5 I5 makes).
    assert cnav_records([m[10], m[11], m[30]], band="L5").records[0][1].health[0] == 1
    assert rec.accuracy_m[0] == 2.4  # URA_ED index 0: LNAV's URA table (RTKLIB's uravalue), 2.4 m
    assert got.week == 2060
    assert got.iono.alpha == cnav.parse_group_delays(m[30]).iono.alpha
    assert (got.iono.dt_ls_s, got.iono.wn_lsf, got.iono.dn) == (18, 1929 % 256, 7)


def test_l2c_l5_and_l1ca_users_take_tgd_and_their_isc_and_gamma_tgd_without_one():
    m = gnsstk_cnav()
    rec = cnav_records([m[10], m[11], m[30]]).records[0][1]
    t = np.array([rec.elements["Toe"][0] + 100.0])
    s = satellite_state(rec, t)
    tgd, isc = 5.58793545e-09, -3.14321369e-09
    l2 = single_frequency_clock_s(rec, s, GPS_L2C.carrier_freq_hz)
    assert l2[0] == pytest.approx(s.clock_s[0] - tgd + isc, abs=1e-17)  # IS-GPS-200 30.3.3.3.1.1.1
    l1 = single_frequency_clock_s(rec, s, GPS_L1CA.carrier_freq_hz)
    assert l1[0] == pytest.approx(s.clock_s[0] - tgd - 3.49245965e-10, abs=1e-17)  # + ISC_L1CA
    no_isc = Ephemerides(
        rec.sv,
        rec.toc_s,
        {**rec.elements, "ISC_L1CA": np.array([np.nan]), "ISC_L2C": np.array([np.nan])},
        rec.health,
        rec.iode,
    )
    assert single_frequency_clock_s(no_isc, s, GPS_L1CA.carrier_freq_hz)[0] == s.clock_s[0] - rec.elements["TGD"][0]
    gamma = (GPS_L1CA.carrier_freq_hz / GPS_L2C.carrier_freq_hz) ** 2
    assert single_frequency_clock_s(no_isc, s, GPS_L2C.carrier_freq_hz)[0] == pytest.approx(
        s.clock_s[0] - gamma * tgd, abs=1e-17
    )
    # L5 I5: Δt_SV - T_GD + ISC_L5I5 (IS-GPS-705 20.3.3.3.1.2.2), GNSSTk's ISC; without one,
    # γ T_GD with γ = (154/115)^2.
    l5 = single_frequency_clock_s(rec, s, GPS_L5I.carrier_freq_hz)
    assert l5[0] == pytest.approx(s.clock_s[0] - tgd + 6.43194653e-09, abs=1e-17)
    no_l5 = Ephemerides(rec.sv, rec.toc_s, {**rec.elements, "ISC_L5I5": np.array([np.nan])}, rec.health, rec.iode)
    assert single_frequency_clock_s(no_l5, s, GPS_L5I.carrier_freq_hz)[0] == pytest.approx(
        s.clock_s[0] - (154 / 115) ** 2 * tgd, abs=1e-17
    )


def _on_grid(nav):
    return np.flatnonzero((nav.elements["Toe"] % 300 == 0) & (nav.toc_s % 300 == 0))


def test_records_sent_as_types_10_11_and_30_come_back_within_their_scale_factors():
    nav = read_rinex_nav(NAV)
    iono = read_nav_file_info(NAV).iono
    assert iono is not None
    for k in _on_grid(nav)[:4]:
        rec = nav.subset(np.array([k]))
        prn = int(rec.sv[0][1:])
        toe = float(rec.elements["Toe"][0])
        symbols, _ = cnav.cnav_symbols(prn, toe - 36.0, 50 * 60, rec, wn=1316, iono=iono)
        msgs = cnav.decode_cnav(symbols, prn=prn).messages
        assert sorted({m.msg_type for m in msgs}) == [10, 11, 30]
        got = cnav_records(msgs)
        assert got.records and got.week == 1316
        back = got.records[0][1]
        t = toe + np.linspace(-3600.0, 3600.0, 5)
        a, b = satellite_state(rec, t[:, None]), satellite_state(back, t[:, None])
        assert np.max(np.linalg.norm(a.position_m - b.position_m, axis=-1)) < 0.05  # 2^-32 semicircle: 2 cm
        assert np.max(np.abs(a.clock_s - b.clock_s)) < 3e-11  # af0 at 2^-35 s
        assert back.elements["TGD"][0] == pytest.approx(rec.elements["TGD"][0], abs=2.0**-35)
        assert np.isnan(back.elements["ISC_L2C"][0])  # sent as not available
        assert got.iono.alpha == pytest.approx(iono.alpha, abs=2.0**-30)
        assert got.iono.dt_ls_s == CNAV_LEAP_S  # no type 33: the default, as a header without one


def test_no_record_without_type_30_or_with_orbits_of_two_uploads():
    m = gnsstk_cnav()
    assert cnav_records([m[10], m[11], m[32], m[33]]).records == []  # clock, but no group delays
    assert cnav_records([m[10], m[11], m[32], m[33]]).iono is None
    # Type 11 of another toe: no orbit.
    bits = m[11].bits.copy()
    bits[38:49] = [int(c) for c in format(int(91800 / 300) + 1, "011b")]
    other = cnav.message_from_bits(cnav.message_bits(1, 11, m[11].tow_count, bits[38:276]))
    assert cnav_records([m[10], other, m[30]]).records == []
    # A failed CRC is passed over.
    broken = replace(m[30], crc_ok=False)
    assert cnav_records([m[10], m[11], broken]).records == []


def test_concatenate_fills_the_cnav_elements_an_lnav_record_lacks():
    nav = read_rinex_nav(NAV)
    m = gnsstk_cnav()
    cnav_rec = cnav_records([m[10], m[11], m[30]]).records[0][1]
    both = Ephemerides.concatenate([nav.subset(np.array([0])), cnav_rec])
    assert both.elements["Adot"][0] == 0.0 and np.isnan(both.elements["ISC_L2C"][0])
    assert both.elements["Adot"][1] == cnav_rec.elements["Adot"][0]
    # The LNAV record's state is unchanged by the zero rates.
    t = float(nav.elements["Toe"][0]) + 600.0
    assert np.array_equal(
        satellite_state(both.subset(np.array([0])), t).position_m,
        satellite_state(nav.subset(np.array([0])), t).position_m,
    )
    broken = Ephemerides(
        cnav_rec.sv,
        cnav_rec.toc_s,
        {k: v for k, v in cnav_rec.elements.items() if k != "Cuc"},
        cnav_rec.health,
        cnav_rec.iode,
    )
    with pytest.raises(ValueError, match="ephemeris record of G01 has no element 'Cuc'"):
        Ephemerides.concatenate([nav.subset(np.array([0])), broken])
