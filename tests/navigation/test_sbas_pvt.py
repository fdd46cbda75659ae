"""SBAS-corrected positions (`navigation.sbas_pvt`, `navigation.sbas_iono`).

Truths, none taken from the code under test:

- the pierce point against a ray traced through the shell by vector algebra (a point on the
  sphere, a direction from azimuth and elevation, the ray's intersection with the sphere
  ``h_I`` higher), over the pole too;
- the grid's interpolation against fields it must reproduce exactly (a plane with three or
  four corners, the product ``xy`` with four) and a triangle that does not hold the point;
- the MOPS troposphere against Saastamoinen's model at the zenith (the two atmospheres
  differ by a few hPa: a few centimetres);
- the protection levels against Monte Carlo of the weighted least squares' errors;
- a whole epoch: pseudoranges built from broadcast orbits and clocks plus injected orbit,
  clock, clock-drift and ionospheric errors, and corrections that carry those errors as
  SBAS sends them: the corrected fix must lose them, the uncorrected one keeps them.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pymap3d
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gnssframework.errors import ConfigError
from gnssframework.navigation.ephemeris import read_rinex_nav, satellite_state, single_frequency_clock_s
from gnssframework.navigation.pvt import solve_position
from gnssframework.navigation.sbas_content import LongTermCorrection, PrnMask, SbasCorrections
from gnssframework.navigation.sbas_iono import (
    SBAS_EARTH_RADIUS_M,
    SBAS_SHELL_HEIGHT_M,
    grid_vertical_delay,
    mops_troposphere,
    sbas_pierce_point,
)
from gnssframework.navigation.sbas_pvt import K_H, K_V, UDRE_VARIANCE_M2, protection_levels, solve_position_sbas

DATA = Path(__file__).parents[1] / "data"
C = 299_792_458.0
OMEGA_E = 7.2921151467e-5


def _traced_pierce_point(lat_deg, lon_deg, az_deg, el_deg):
    """The ray from a point of the sphere through the shell, by vector algebra."""
    la, lo, az, el = np.radians([lat_deg, lon_deg, az_deg, el_deg])
    up = np.array([np.cos(la) * np.cos(lo), np.cos(la) * np.sin(lo), np.sin(la)])
    east = np.array([-np.sin(lo), np.cos(lo), 0.0])
    north = np.cross(up, east)
    d = np.cos(el) * (np.sin(az) * east + np.cos(az) * north) + np.sin(el) * up
    p = SBAS_EARTH_RADIUS_M * up
    r2 = SBAS_EARTH_RADIUS_M + SBAS_SHELL_HEIGHT_M
    s = -p @ d + np.sqrt((p @ d) ** 2 - p @ p + r2**2)
    q = p + s * d
    slant = 1.0 / (d @ q / r2)  # 1 / cos of the ray's zenith angle at the shell
    return np.degrees(np.arcsin(q[2] / r2)), np.degrees(np.arctan2(q[1], q[0])), slant


@settings(max_examples=200, deadline=None)
@given(
    st.floats(-85.0, 85.0),
    st.floats(-180.0, 179.9),
    st.floats(0.0, 359.9),
    st.floats(2.0, 90.0),
)
def test_pierce_point_is_where_the_ray_meets_the_shell(lat, lon, az, el):
    lat_pp, lon_pp, slant = sbas_pierce_point(lat, lon, np.array([az]), np.array([el]))
    want_lat, want_lon, want_slant = _traced_pierce_point(lat, lon, az, el)
    assert lat_pp[0] == pytest.approx(want_lat, abs=1e-7)
    # Longitude is undefined at the pole itself; elsewhere it must agree (modulo 360).
    if abs(want_lat) < 89.9:
        assert abs((lon_pp[0] - want_lon + 180.0) % 360.0 - 180.0) < 1e-6 / np.cos(np.radians(want_lat))
    assert slant[0] == pytest.approx(want_slant, rel=1e-9)


def test_pierce_point_over_the_pole_is_on_the_far_side():
    lat_pp, lon_pp, _ = sbas_pierce_point(88.0, 10.0, np.array([0.0]), np.array([20.0]))
    want_lat, want_lon, _ = _traced_pierce_point(88.0, 10.0, 0.0, 20.0)
    assert want_lon == pytest.approx(-170.0, abs=1e-6)  # the ray crosses the pole
    assert lat_pp[0] == pytest.approx(want_lat, abs=1e-7) and lon_pp[0] == pytest.approx(want_lon, abs=1e-6)


def _grid(field, lats, lons, var=0.5):
    return {(float(a), float(o)): (float(field(a, o)), var) for a in lats for o in lons}


def test_four_corners_reproduce_a_plane_and_the_bilinear_product():
    plane = lambda lat, lon: 2.0 + 0.3 * (lat - 30.0) - 0.1 * (lon - 135.0)  # noqa: E731
    lats, lons = np.array([31.3, 34.99, 30.0, 33.0]), np.array([136.2, 139.9, 135.0, 137.5])
    d, v = grid_vertical_delay(lats, lons, _grid(plane, [30.0, 35.0], [135.0, 140.0]))
    np.testing.assert_allclose(d, plane(lats, lons), atol=1e-12)
    np.testing.assert_allclose(v, 0.5, atol=1e-12)  # equal variances stay themselves
    product = lambda lat, lon: (lat - 30.0) * (lon - 135.0)  # noqa: E731
    d, _ = grid_vertical_delay(lats, lons, _grid(product, [30.0, 35.0], [135.0, 140.0]))
    np.testing.assert_allclose(d, product(lats, lons), atol=1e-12)


def test_three_corners_interpolate_inside_their_triangle_only():
    plane = lambda lat, lon: 5.0 - 0.2 * (lat - 30.0) + 0.4 * (lon - 135.0)  # noqa: E731
    igps = _grid(plane, [30.0, 35.0], [135.0, 140.0])
    del igps[(35.0, 140.0)]  # the north-east corner not monitored
    inside = (np.array([31.0, 30.5]), np.array([136.0, 139.0]))  # x + y <= 1
    d, _ = grid_vertical_delay(*inside, igps)
    np.testing.assert_allclose(d, plane(*inside), atol=1e-12)
    d, v = grid_vertical_delay(np.array([34.0]), np.array([139.0]), igps)  # x + y > 1
    assert np.isnan(d[0]) and np.isnan(v[0])
    del igps[(30.0, 135.0)]
    assert np.isnan(grid_vertical_delay(np.array([31.0]), np.array([136.0]), igps)[0][0])


def test_cells_across_the_antimeridian_and_above_55_degrees():
    plane = lambda lat, lon: 1.0 + 0.05 * lat  # noqa: E731
    igps = _grid(plane, [30.0, 35.0], [175.0, -180.0])
    d, _ = grid_vertical_delay(np.array([32.0]), np.array([178.0]), igps)
    assert d[0] == pytest.approx(plane(32.0, 0.0), abs=1e-12)
    igps = _grid(plane, [55.0, 65.0], [10.0, 20.0])  # a 10-degree cell
    d, _ = grid_vertical_delay(np.array([61.0]), np.array([14.0]), igps)
    assert d[0] == pytest.approx(plane(61.0, 0.0), abs=1e-12)
    assert np.isnan(grid_vertical_delay(np.array([80.0]), np.array([14.0]), igps)[0][0])


#: DO-229 Table A-2's mean sea-level atmospheres: latitude, pressure (hPa), temperature (K),
#: water-vapour pressure (hPa).
_MOPS_MEAN_ATMOSPHERES = [(15.0, 1013.25, 299.65, 26.31), (45.0, 1015.75, 283.15, 11.66), (75.0, 1013.00, 263.65, 4.11)]


@pytest.mark.parametrize(("lat", "pressure_hpa", "temp_k", "vapour_hpa"), _MOPS_MEAN_ATMOSPHERES)
def test_mops_troposphere_agrees_with_saastamoinen_in_the_same_atmosphere(lat, pressure_hpa, temp_k, vapour_hpa):
    # Day 119: the season's cosine is zero, the table's mean atmosphere. Saastamoinen's zenith
    # delay (1972) in that atmosphere: its hydrostatic term is MOPS's times the gravity
    # factor (0.3 % at most, 7 mm); the wet terms of the two, for the same vapour, differ by 1.5 cm
    # at 45° and 2.7 cm at 75° (MOPS's lapse-rate form against Saastamoinen's 1255/T).
    saastamoinen = (
        0.002277 / (1 - 0.00266 * np.cos(2 * np.radians(lat))) * (pressure_hpa + (1255.0 / temp_k + 0.05) * vapour_hpa)
    )
    delay, var = mops_troposphere(lat, 0.0, np.array([90.0]), 28 + 365.25 / 4)
    assert delay[0] == pytest.approx(saastamoinen, abs=0.04)
    assert var[0] == pytest.approx(0.12**2, rel=1e-3)  # m(90°) = 1.001/sqrt(1.002001) = 1
    # 1.5 km up: about exp(-1.5/8.3) of the hydrostatic delay (its scale height R_d T / g),
    # the wet one falling faster.
    high, _ = mops_troposphere(lat, 1500.0, np.array([90.0]), 28 + 365.25 / 4)
    assert 0.76 < high[0] / delay[0] < 0.86
    # Low rays: the mapping grows like 1/sin(E), a delay near 10 times the zenith's at 5°.
    low, low_var = mops_troposphere(lat, 0.0, np.array([5.0]), 119.0)
    assert 9.0 < low[0] / delay[0] < 11.5 and low_var[0] > 80 * var[0]
    # The season: in the north the atmosphere's wet delay peaks in summer (day 211).
    if lat < 70.0:
        assert (
            mops_troposphere(lat, 0.0, np.array([90.0]), 211)[0][0]
            >= mops_troposphere(lat, 0.0, np.array([90.0]), 28)[0][0]
        )


def test_protection_levels_bound_the_errors_of_the_weighted_least_squares():
    rng = np.random.default_rng(7)
    az = np.array([10.0, 80.0, 150.0, 200.0, 260.0, 320.0, 45.0])
    el = np.array([70.0, 35.0, 20.0, 50.0, 12.0, 28.0, 8.0])
    sigma = np.array([0.6, 0.8, 1.1, 0.7, 1.6, 0.9, 2.0])
    hpl, vpl = protection_levels(az, el, sigma, "pa")
    a, e = np.radians(az), np.radians(el)
    G = np.column_stack([-np.cos(e) * np.sin(a), -np.cos(e) * np.cos(a), -np.sin(e), np.ones(az.size)])
    W = np.diag(sigma**-2.0)
    S = np.linalg.solve(G.T @ W @ G, G.T @ W)
    n = 200_000
    errors = (S @ (rng.standard_normal((n, az.size)) * sigma).T).T  # east, north, up, clock
    # d_U is the up error's standard deviation: its sample variance within 4 of its sampling σ.
    d_u = vpl / K_V
    assert np.var(errors[:, 2]) == pytest.approx(d_u**2, rel=4 * np.sqrt(2 / n))
    # d_major is the largest horizontal standard deviation: that of the sample covariance.
    d_major = hpl / K_H["pa"]
    major = np.sqrt(np.linalg.eigvalsh(np.cov(errors[:, :2].T))[-1])
    assert major == pytest.approx(d_major, rel=4 * np.sqrt(1 / (2 * n)) * 2)
    # At K = 5.33 and 6.0 standard deviations, no draw of 200 000 may exceed them.
    assert np.all(np.abs(errors[:, 2]) < vpl) and np.all(np.hypot(errors[:, 0], errors[:, 1]) < hpl)
    assert protection_levels(az, el, sigma, "npa")[0] == pytest.approx(hpl * 6.18 / 6.0)
    with pytest.raises(ConfigError, match="mode"):
        protection_levels(az, el, sigma, "cat1")


# --- One epoch of pseudoranges with errors that SBAS corrections carry --------------------

TOW = 6 * 86_400.0 + 1800.0  # 2005-04-02 00:30 GPST (a Saturday)
DAY_OF_YEAR = 92
RECEIVER = np.array([-3976219.5082, 3382372.5671, 3652512.9849])  # GEONET 0759's header


def _vertical_delay_m(lat, lon):
    return 4.0 + 0.12 * (lat - 35.0) - 0.05 * (lon - 140.0)  # a plane: the grid holds it exactly


@pytest.fixture(scope="module")
def epoch():
    eph_all = read_rinex_nav(DATA / "07590920.05n", "G")
    names = sorted(set(eph_all.sv.tolist()))
    eph = eph_all.select(names, TOW)
    state = satellite_state(eph, TOW)
    lat, lon, h = pymap3d.ecef2geodetic(*RECEIVER)
    _, el, _ = pymap3d.ecef2aer(*state.position_m.T, lat, lon, h)
    eph = eph.subset(np.flatnonzero(el > 7.0))
    n = eph.sv.size
    rng = np.random.default_rng(11)
    dpos = rng.normal(0.0, 2.0, (n, 3))  # orbit errors (m)
    dclock_long_m = rng.normal(0.0, 3.0, n)  # slow clock errors (m)
    fast0_m = rng.normal(0.0, 1.5, n)  # fast clock errors at the corrections' time (m)
    drift_mps = rng.normal(0.0, 0.1, n)  # their rate (m/s)
    t_of = TOW - 4.0  # the latest fast corrections, 4 s old; the ones before 6 s earlier
    clock_rx_m = 3.0e-4 * C
    # Transmit times by the light time from true orbits (broadcast plus the errors).
    tau = np.full(n, 0.075)
    for _ in range(6):
        st_ = satellite_state(eph, TOW - tau)
        theta = OMEGA_E * tau
        p = st_.position_m + dpos
        rot = np.column_stack(
            [
                np.cos(theta) * p[:, 0] + np.sin(theta) * p[:, 1],
                -np.sin(theta) * p[:, 0] + np.cos(theta) * p[:, 1],
                p[:, 2],
            ]
        )
        tau = np.linalg.norm(rot - RECEIVER, axis=1) / C
    t_tx = TOW - tau
    st_ = satellite_state(eph, t_tx)
    true_clock_s = (
        single_frequency_clock_s(eph, st_, 1575.42e6) + (dclock_long_m + fast0_m + drift_mps * (t_tx - t_of)) / C
    )
    az, el, _ = (np.asarray(v) for v in pymap3d.ecef2aer(*rot.T, lat, lon, h))
    lat_pp, lon_pp, slant = sbas_pierce_point(lat, lon, az, el)
    iono_m = slant * _vertical_delay_m(lat_pp, lon_pp)
    tropo_m, _ = mops_troposphere(lat, h, el, DAY_OF_YEAR)
    noise_m = rng.normal(0.0, 0.05, n)
    pr = C * tau + clock_rx_m - C * true_clock_s + iono_m + tropo_m + noise_m
    transmit = t_tx + true_clock_s  # the satellite's time of transmission, as the code carries it
    corr = SbasCorrections()
    corr.mask = PrnMask(0, tuple(int(s[1:]) for s in eph.sv))
    for i, sv in enumerate(eph.sv.tolist()):
        corr.fast[sv] = (fast0_m[i], 2, t_of)
        corr.fast_previous[sv] = (fast0_m[i] - 6.0 * drift_mps[i], 2, t_of - 6.0)
        corr.long_term[sv] = LongTermCorrection(
            i + 1, int(eph.iode[i]), 0, dpos[i], np.zeros(3), dclock_long_m[i] / C, 0.0, None
        )
    for la in np.arange(15.0, 60.0, 5.0):
        for lo in np.arange(115.0, 170.0, 5.0):
            corr.iono[(0, la, lo)] = (float(_vertical_delay_m(la, lo)), 3, t_of)
    return {"eph": eph, "pr": pr, "tx": transmit, "corr": corr, "iono": iono_m, "tropo": tropo_m}


def test_corrections_take_out_what_the_broadcast_fix_keeps(epoch):
    sbas = solve_position_sbas(epoch["pr"], epoch["tx"], epoch["eph"], epoch["corr"], day_of_year=DAY_OF_YEAR)
    assert sbas is not None and sbas.fix.used.sum() == epoch["eph"].sv.size >= 6
    error = np.linalg.norm(sbas.fix.position_ecef_m - RECEIVER)
    # What is left is the 5 cm noise through the geometry, and the triangle of vertical delay
    # sampled at the fix's pierce points rather than the truth's.
    assert error < 0.3
    np.testing.assert_allclose(sbas.iono_m, epoch["iono"], atol=2e-3)
    np.testing.assert_allclose(sbas.troposphere_m, epoch["tropo"], atol=1e-3)
    plain = solve_position(epoch["pr"], epoch["tx"], epoch["eph"], troposphere=True)
    assert np.linalg.norm(plain.position_ecef_m - RECEIVER) > 10 * error + 2.0
    # The bound holds and is not vacuous: metres, not hundreds.
    lat, lon, h = pymap3d.ecef2geodetic(*RECEIVER)
    e, n, u = pymap3d.ecef2enu(*sbas.fix.position_ecef_m, lat, lon, h)
    assert np.hypot(e, n) < sbas.hpl_m < 30.0 and abs(u) < sbas.vpl_m < 50.0


def test_the_range_rate_correction_carries_the_clock_drift(epoch):
    with_rrc = solve_position_sbas(epoch["pr"], epoch["tx"], epoch["eph"], epoch["corr"], day_of_year=DAY_OF_YEAR)
    without = solve_position_sbas(
        epoch["pr"], epoch["tx"], epoch["eph"], epoch["corr"], day_of_year=DAY_OF_YEAR, range_rate=False
    )
    drift_m = (
        np.array([epoch["corr"].fast[s][0] - epoch["corr"].fast_previous[s][0] for s in epoch["eph"].sv]) / 6.0 * 4.0
    )
    # Without it each satellite misses 4 s of its drift: the residuals grow by that much.
    rms = lambda fix: np.sqrt(np.nanmean(np.square(fix.fix.residuals_m)))  # noqa: E731
    assert rms(with_rrc) < 0.1 < rms(without)
    np.testing.assert_allclose(without.fast_m - with_rrc.fast_m, -drift_m, atol=0.01)


def test_satellites_without_usable_corrections_are_left_out_and_say_why(epoch):
    corr = epoch["corr"]
    sv = epoch["eph"].sv.tolist()
    changed = SbasCorrections(
        mask=corr.mask,
        fast={**corr.fast, sv[0]: (0.0, 14, corr.fast[sv[0]][2]), sv[1]: (0.0, 2, TOW - 400.0)},
        fast_previous=dict(corr.fast_previous),
        long_term={k: v for k, v in corr.long_term.items() if k != sv[2]},
        iono=dict(corr.iono),
    )
    fix = solve_position_sbas(epoch["pr"], epoch["tx"], epoch["eph"], changed, day_of_year=DAY_OF_YEAR)
    assert fix.reason[:3] == ("not monitored", "fast correction too old", "no long-term correction of this IODE")
    assert not fix.fix.used[:3].any() and fix.fix.used[3:].all()
    assert np.linalg.norm(fix.fix.position_ecef_m - RECEIVER) < 0.5
    no_iono = SbasCorrections(mask=corr.mask, fast=dict(corr.fast), long_term=dict(corr.long_term), iono={})
    assert solve_position_sbas(epoch["pr"], epoch["tx"], epoch["eph"], no_iono, day_of_year=DAY_OF_YEAR) is None
    with pytest.raises(ConfigError, match="day_of_year"):
        solve_position_sbas(epoch["pr"], epoch["tx"], epoch["eph"], corr, day_of_year=0)


# --- DO-229 A.4.5's degradation terms, by hand ---------------------------------------------

SIGMA_UDRE4 = np.sqrt(0.4678)  # UDREI 4 (Table A-6)


def _one_satellite(t_of=100.0, prc=1.0, iodf=(1, 0), previous=None):
    """G05's record and corrections for it: mask, fast correction (UDREI 4) at ``t_of``, a
    long-term correction of its IODE sent at 0 s (velocity code 0)."""
    eph = read_rinex_nav(DATA / "07590920.05n", "G").select(["G05"], TOW)
    corr = SbasCorrections(mask=PrnMask(0, (5,)))
    corr.fast["G05"] = (prc, 4, t_of)
    corr.fast_iodf["G05"] = iodf
    if previous is not None:
        corr.fast_previous["G05"] = previous
    corr.long_term["G05"] = LongTermCorrection(1, int(eph.iode[0]), 0, np.zeros(3), np.zeros(3), 0.0, 0.0, None)
    corr.long_term_time["G05"] = 0.0
    return eph, corr


def _params(**given):
    from gnssframework.navigation.sbas_content import DEGRADATION_LAYOUT, DegradationParameters

    values = {name: 0.0 for name in DEGRADATION_LAYOUT}
    values.update(given)
    return DegradationParameters(**{k: (int(v) if k.startswith("rss") else v) for k, v in values.items()})


def test_fast_correction_degradation_and_time_out_follow_type_7():
    from gnssframework.navigation import sbas_encode as enc
    from gnssframework.navigation.sbas_content import decode_content
    from gnssframework.navigation.sbas_pvt import sbas_satellite_corrections

    eph, corr = _one_satellite()
    *_, var, why = sbas_satellite_corrections(corr, eph, np.array([110.0]))
    assert why == ("",) and var[0] == pytest.approx(0.4678)  # no type 7: sigma_UDRE alone
    # a_i 9 (a = 0.0009 m/s^2), latency 2 s, 10 s old: eps_fc = 0.0009 * 12^2 / 2 = 0.0648 m.
    corr.degradation = (90.0, decode_content(enc.fast_degradation_message(2, 0, [9])))
    *_, var, _ = sbas_satellite_corrections(corr, eph, np.array([110.0]))
    assert var[0] == pytest.approx((SIGMA_UDRE4 + 0.0648) ** 2)
    # a_i 14: precision approach's time-out is 12 s.
    corr.degradation = (90.0, decode_content(enc.fast_degradation_message(2, 0, [14])))
    assert sbas_satellite_corrections(corr, eph, np.array([111.9]))[4] == ("",)
    assert sbas_satellite_corrections(corr, eph, np.array([112.1]))[4] == ("fast correction too old",)
    # a_i 0: no range-rate correction, whatever the previous correction.
    eph, corr = _one_satellite(previous=(0.0, 4, 94.0))
    corr.degradation = (90.0, decode_content(enc.fast_degradation_message(0, 0, [0])))
    fast = sbas_satellite_corrections(corr, eph, np.array([110.0]))[2]
    assert fast[0] == 1.0
    corr.degradation = (90.0, decode_content(enc.fast_degradation_message(0, 0, [1])))
    fast = sbas_satellite_corrections(corr, eph, np.array([110.0]))[2]
    assert fast[0] == pytest.approx(1.0 + (1.0 / 6.0) * 10.0)


def test_type_10_terms_add_or_root_sum_square():
    from gnssframework.navigation import sbas_encode as enc
    from gnssframework.navigation.sbas_content import decode_content
    from gnssframework.navigation.sbas_pvt import sbas_satellite_corrections

    # Long-term, velocity code 0: C_ltc_v0 per whole I_ltc_v0 since its message (250 s: 2 x 0.304 m).
    eph, corr = _one_satellite(t_of=245.0)
    params = _params(cltc_v0_m=0.304, iltc_v0_s=100.0, brrc_m=0.108)
    corr.parameters = (0.0, decode_content(enc.degradation_parameters_message(params)))
    *_, var, _ = sbas_satellite_corrections(corr, eph, np.array([250.0]))
    assert var[0] == pytest.approx((SIGMA_UDRE4 + 0.608) ** 2)
    # RSS_UDRE = 1: the same terms root-sum-squared.
    corr.parameters = (0.0, _params(cltc_v0_m=0.304, iltc_v0_s=100.0, rss_udre=1))
    *_, var, _ = sbas_satellite_corrections(corr, eph, np.array([250.0]))
    assert var[0] == pytest.approx(0.4678 + 0.608**2)
    # Range rate after IODFs 0 then 2 (not consecutive): (a I_fc/4 + B_rrc/dt)(t - t_of),
    # a_i 4 (a = 0.00015, I_fc 90 s), dt 6 s, 5 s after: (0.003375 + 0.018) * 5 = 0.106875 m.
    eph, corr = _one_satellite(t_of=245.0, iodf=(2, 0), previous=(0.9, 4, 239.0))
    corr.degradation = (240.0, decode_content(enc.fast_degradation_message(0, 0, [4])))
    corr.parameters = (0.0, _params(brrc_m=0.108, iltc_v0_s=300.0))
    *_, var, _ = sbas_satellite_corrections(corr, eph, np.array([250.0]))
    eps_fc = 0.00015 * 5.0**2 / 2
    assert var[0] == pytest.approx((SIGMA_UDRE4 + eps_fc + 0.106875) ** 2)
    # Consecutive IODFs (1 after 0): no range-rate term.
    corr.fast_iodf["G05"] = (1, 0)
    *_, var, _ = sbas_satellite_corrections(corr, eph, np.array([250.0]))
    assert var[0] == pytest.approx((SIGMA_UDRE4 + eps_fc) ** 2)


def test_an_igps_variance_grows_with_its_age_by_type_10():
    from gnssframework.navigation.sbas_pvt import _iono_grid

    corr = SbasCorrections()
    corr.iono[(7, 35.0, 140.0)] = (3.0, 5, 0.0)  # GIVEI 5: sigma^2 0.2994
    assert _iono_grid(corr, 650.0)[(35.0, 140.0)] == (3.0, pytest.approx(0.2994))
    # 650 s old, I_iono 300 s: two steps of 0.228 m plus 650 s of a 0.0001 m/s ramp.
    corr.parameters = (0.0, _params(ciono_step_m=0.228, iiono_s=300.0, ciono_ramp_mps=0.0001))
    eps = 2 * 0.228 + 0.065
    assert _iono_grid(corr, 650.0)[(35.0, 140.0)][1] == pytest.approx((np.sqrt(0.2994) + eps) ** 2)
    corr.parameters = (0.0, _params(ciono_step_m=0.228, iiono_s=300.0, ciono_ramp_mps=0.0001, rss_iono=1))
    assert _iono_grid(corr, 650.0)[(35.0, 140.0)][1] == pytest.approx(0.2994 + eps**2)


# --- Type 28's δUDRE (A.4.5.1.2), against closed forms -------------------------------------


def _covariance_stream(e, exponent=5, c_covariance=None):
    """G05's corrections (`_one_satellite`) with a type 28 of factor ``e`` (and a type 10 of
    that C_covariance) sent at 90 s, gathered from their bits."""
    from gnssframework.navigation import sbas_encode as enc
    from gnssframework.navigation.sbas_content import decode_content

    eph, corr = _one_satellite()
    corr.add(90.0, 137, decode_content(enc.covariance_message(0, [(1, exponent, e)])))
    if c_covariance is not None:
        corr.add(90.0, 137, decode_content(enc.degradation_parameters_message(_params(ccovariance=c_covariance))))
    return eph, corr


def test_a_type_28_reads_back_its_factor_and_gives_c_as_r_transposed_r():
    from gnssframework.navigation import sbas_encode as enc
    from gnssframework.navigation.sbas_content import CovarianceMatrices, decode_content, describe

    e = np.triu(np.arange(1, 17).reshape(4, 4)) * np.array([1, -1, 1, -1])  # signs above the diagonal
    e[np.diag_indices(4)] = [511, 3, 0, 17]
    got = decode_content(enc.covariance_message(2, [(7, 3, e), (12, 6, np.diag([1, 2, 3, 4]))]))
    assert isinstance(got, CovarianceMatrices) and got.iodp == 2 and got.slots == (7, 12)
    assert got.scale_exponents == (3, 6)
    # C = R^T R, R = 2^(exponent - 5) E: element by element, C_ij = sum_k R_ki R_kj
    r = 0.25 * e
    for i in range(4):
        for j in range(4):
            assert got.covariances[0][i, j] == pytest.approx(sum(r[k, i] * r[k, j] for k in range(4)), abs=1e-12)
    np.testing.assert_allclose(got.covariances[1], np.diag([4.0, 16.0, 36.0, 64.0]))
    assert describe(got) == "clock-ephemeris covariance IODP 2: mask numbers 7 12"
    one = decode_content(enc.covariance_message(0, [(3, 5, np.eye(4))]))
    assert one.slots == (3,) and one.covariances.shape == (1, 4, 4)
    with pytest.raises(ConfigError, match="type28.E0"):
        enc.covariance_message(0, [(3, 5, np.ones((4, 4)))])
    with pytest.raises(ConfigError, match=r"type28\.e11_0"):
        enc.covariance_message(0, [(3, 5, np.diag([512, 1, 1, 1]))])


@given(
    az=st.floats(0.0, 2 * np.pi),
    el=st.floats(-np.pi / 2, np.pi / 2),
    a=st.integers(0, 511),
    b=st.integers(0, 511),
    d=st.integers(-512, 511),
    exponent=st.integers(0, 7),
)
def test_delta_udre_is_the_quadratic_form_along_the_line_of_sight(az, el, a, b, d, exponent):
    from gnssframework.navigation.sbas_pvt import delta_udre

    e = np.diag([a, a, a, b]).astype(float)
    e[0, 3] = d  # a clock-x correlation: the form depends on the direction
    eph, corr = _covariance_stream(e, exponent, c_covariance=1.5)
    u = np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
    sf = 2.0 ** (exponent - 5)
    # |R I|^2 with R I = sf (a u_x + d, a u_y, a u_z, b)
    expected = sf * np.sqrt(a**2 + 2 * a * d * u[0] + d**2 + b**2) + 1.5 * sf
    assert delta_udre(corr, np.array(["G05"]), u[None, :], 100.0)[0] == pytest.approx(expected, rel=1e-9, abs=1e-9)
    # Past its 240 s time-out, and for a satellite without one, δUDRE is 1.
    assert delta_udre(corr, np.array(["G05", "G07"]), np.array([u, u]), 90.0 + 241.0).tolist() == [1.0, 1.0]


def test_delta_udre_scales_sigma_udre_in_the_fix_weights(epoch):
    """Every satellite of the epoch given δUDRE k (an isotropic factor): each weight's σ² grows
    by exactly σ²_UDRE (k² - 1), nothing else changes."""
    from gnssframework.navigation import sbas_encode as enc
    from gnssframework.navigation.sbas_content import decode_content

    corr = epoch["corr"]
    k = 2.5  # E_44 = 5 at scale exponent 4: R = diag(0, 0, 0, 2.5)
    sats = list(range(1, epoch["eph"].sv.size + 1))
    bits = [
        enc.covariance_message(corr.mask.iodp, [(m, 4, np.diag([0.0, 0.0, 0.0, 5.0])) for m in sats[i : i + 2]])
        for i in range(0, len(sats), 2)
    ]
    inflated = SbasCorrections(**{f: getattr(corr, f) for f in ("mask", "fast", "fast_previous", "long_term", "iono")})
    for b in bits:
        inflated.add(TOW - 10.0, 137, decode_content(b))
    assert len(inflated.covariance) == len(sats)
    plain = solve_position_sbas(epoch["pr"], epoch["tx"], epoch["eph"], corr, day_of_year=DAY_OF_YEAR)
    wide = solve_position_sbas(epoch["pr"], epoch["tx"], epoch["eph"], inflated, day_of_year=DAY_OF_YEAR)
    sigma_udre2 = UDRE_VARIANCE_M2[2]  # the epoch's UDREI
    np.testing.assert_allclose(wide.sigma_m**2 - plain.sigma_m**2, sigma_udre2 * (k**2 - 1), rtol=1e-6)
    assert wide.vpl_m > plain.vpl_m and wide.hpl_m > plain.hpl_m


# --- Type 27's regional δUDRE (A.4.4.13) ------------------------------------------------------


def test_a_type_27_reads_back_and_its_regions_hold_what_their_corners_say():
    from gnssframework.navigation import sbas_encode as enc
    from gnssframework.navigation.sbas_content import ServiceMessage, decode_content, describe

    regions = [(30, 130, 40, 145, True), (-10, -20, 20, 10, False)]
    got = decode_content(enc.service_message(5, 2, 1, 3, 4, 11, regions))
    assert isinstance(got, ServiceMessage)
    assert (got.iods, got.count, got.number, got.priority, got.inside, got.outside) == (5, 2, 1, 3, 4, 11)
    assert got.regions == tuple(regions)
    assert describe(got) == "service message 2 of 2 IODS 5: 2 regions, priority 3, δUDREI 4 in, 11 out"
    # The quadrangle: its box, borders included; the triangle (-10,-20), (20,-20), (20,10):
    # the half of its box on the (20,-20) side of the diagonal.
    assert got.contains(35.0, 140.0) == [True, False] and got.contains(40.0, 130.0) == [True, False]
    assert got.contains(10.0, -15.0) == [False, True]  # near corner (20, -20)
    assert got.contains(-5.0, 5.0) == [False, False]  # in the box, beyond the diagonal
    assert got.contains(5.0, -5.0) == [False, True]  # on the diagonal
    assert got.contains(41.0, 140.0) == [False, False]
    with pytest.raises(ConfigError, match=r"type27\.lat1_0"):
        enc.service_message(0, 1, 0, 0, 0, 0, [(128, 0, 0, 0, True)])


def _service_corrections(messages, t=100.0):
    from gnssframework.navigation import sbas_encode as enc
    from gnssframework.navigation.sbas_content import decode_content

    corr = SbasCorrections()
    for m in messages:
        corr.add(t, 137, decode_content(enc.service_message(*m)))
    return corr


def test_the_regional_delta_udre_takes_priority_then_the_smaller_value():
    from gnssframework.navigation.sbas_content import DELTA_UDRE
    from gnssframework.navigation.sbas_pvt import SERVICE_TIMEOUT_S, delta_udre, service_delta_udre

    # Set 3 of three messages: a wide low-priority region (δUDREI 4: 2.0) and, inside it, a
    # small high-priority one (δUDREI 2: 1.25) beside a low-priority one of δUDREI 1 (1.1).
    wide = (3, 3, 0, 0, 4, 9, [(20, 120, 50, 160, True)])
    small = (3, 3, 1, 2, 2, 9, [(34, 138, 36, 140, True)])
    near = (3, 3, 2, 0, 1, 9, [(36, 140, 37, 141, True)])
    corr = _service_corrections([wide, small, near])
    assert service_delta_udre(corr, 35.0, 139.0, 100.0) == DELTA_UDRE[2] == 1.25  # priority 2 wins
    assert service_delta_udre(corr, 36.5, 140.5, 100.0) == DELTA_UDRE[1] == 1.1  # both priority 0: the smaller
    assert service_delta_udre(corr, 25.0, 125.0, 100.0) == 2.0
    assert service_delta_udre(corr, 0.0, 0.0, 100.0) == DELTA_UDRE[9] == 8.0  # outside every region
    # Not a whole set: two of three, or three of different IODS; nor after a day.
    assert service_delta_udre(_service_corrections([wide, small]), 35.0, 139.0, 100.0) is None
    other = (4, 3, 1, 2, 2, 9, [(34, 138, 36, 140, True)])
    assert service_delta_udre(_service_corrections([wide, other, near]), 35.0, 139.0, 100.0) is None
    assert service_delta_udre(corr, 35.0, 139.0, 100.0 + SERVICE_TIMEOUT_S + 1.0) is None
    # A satellite's type 28 takes precedence over the region; the others get the region's.
    eph, with28 = _covariance_stream(np.diag([0.0, 0.0, 0.0, 96.0]), 0)  # R = diag(0, 0, 0, 3)
    for t_m, m in corr.service.values():
        with28.service[m.number] = (t_m, m)
    u = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    got = delta_udre(with28, np.array(["G05", "G07"]), u, 100.0, (35.0, 139.0))
    assert got.tolist() == [3.0, 1.25]
    assert delta_udre(with28, np.array(["G07"]), u[:1], 100.0).tolist() == [1.0]  # no user position given


def test_a_region_holding_the_user_scales_sigma_udre_in_the_fix_weights(epoch):
    """A one-message set whose quadrangle holds the receiver (δUDREI 2: 1.25; outside 8.0):
    each weight's σ² grows by σ²_UDRE (1.25² - 1); moved away from the receiver, by the
    outside value's."""
    corr = epoch["corr"]
    lat, lon, _ = pymap3d.ecef2geodetic(*RECEIVER)
    box = (int(lat) - 2, int(lon) - 2, int(lat) + 2, int(lon) + 2, True)
    plain = solve_position_sbas(epoch["pr"], epoch["tx"], epoch["eph"], corr, day_of_year=DAY_OF_YEAR)
    for region, k in ((box, 1.25), ((-60, -60, -50, -50, True), 8.0)):
        regional = _service_corrections([(0, 1, 0, 0, 2, 9, [region])], t=TOW - 10.0)
        for f in ("mask", "fast", "fast_previous", "long_term", "iono"):
            setattr(regional, f, getattr(corr, f))
        fix = solve_position_sbas(epoch["pr"], epoch["tx"], epoch["eph"], regional, day_of_year=DAY_OF_YEAR)
        np.testing.assert_allclose(fix.sigma_m**2 - plain.sigma_m**2, UDRE_VARIANCE_M2[2] * (k**2 - 1), rtol=1e-6)
