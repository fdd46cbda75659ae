"""BeiDou's Klobuchar model (`navigation.bds_iono`, BDS-SIS-ICD-B1I 3.0 5.2.4.7) against
truths of its own parts: the pierce point and slant factor against a ray cast through the
shell in ECEF vectors; the vertical delay at the zenith against the ICD's cosine evaluated by
hand (peak, a quarter of the way down, night, the clamps of A4, |latitude|); D1's decoded
coefficients carried to a fix; and a fix on pseudoranges delayed by the model, solved with it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gnssframework.navigation import d1nav
from gnssframework.navigation.bds_iono import (
    BDS_EARTH_RADIUS_M,
    BDS_SHELL_HEIGHT_M,
    BdsKlobuchar,
    bds_klobuchar_delay_s,
    bds_pierce_point,
)
from gnssframework.navigation.ephemeris import read_rinex_nav
from gnssframework.navigation.pvt import broadcast_iono_delay_s, klobuchar_delay_s, solve_position
from gnssframework.signal.beidou_b1i import BEIDOU_B1I

DATA = Path(__file__).parents[1] / "data"
R, H = BDS_EARTH_RADIUS_M, BDS_SHELL_HEIGHT_M
C = 299_792_458.0


def _ray_pierce(lat_deg, lon_deg, az_deg, el_deg):
    """The pierce point and the ray's zenith angle there, by vectors: the user on the
    sphere of radius R, the ray from it along (az, el), met with the sphere of R + H."""
    la, lo = np.radians(lat_deg), np.radians(lon_deg)
    up = np.array([np.cos(la) * np.cos(lo), np.cos(la) * np.sin(lo), np.sin(la)])
    east = np.array([-np.sin(lo), np.cos(lo), 0.0])
    north = np.cross(up, east)
    az, el = np.radians(az_deg), np.radians(el_deg)
    d = np.cos(el) * (np.sin(az) * east + np.cos(az) * north) + np.sin(el) * up
    u = R * up
    b = u @ d
    s = -b + np.sqrt(b * b - (u @ u - (R + H) ** 2))  # |u + s d| = R + H, s > 0
    p = u + s * d
    lat = np.arcsin(p[2] / np.linalg.norm(p))
    lon = np.arctan2(p[1], p[0])
    cos_zenith = d @ p / np.linalg.norm(p)
    return lat, lon, 1.0 / cos_zenith


@pytest.mark.parametrize(
    "lat, lon, az, el",
    [(40.0, -4.0, 30.0, 15.0), (30.5, 114.3, 200.0, 5.0), (-33.4, -70.6, 300.0, 45.0), (10.0, 100.0, 90.0, 80.0)],
)
def test_the_pierce_point_and_slant_are_a_ray_through_the_shell(lat, lon, az, el):
    phi, lam, slant = bds_pierce_point(lat, lon, np.array([az]), np.array([el]))
    lat_r, lon_r, slant_r = _ray_pierce(lat, lon, az, el)
    assert phi[0] == pytest.approx(lat_r, abs=1e-12)
    assert np.angle(np.exp(1j * (lam[0] - lon_r))) == pytest.approx(0.0, abs=1e-12)
    assert slant[0] == pytest.approx(slant_r, rel=1e-12)


def test_the_zenith_delay_is_the_icds_cosine():
    """At the zenith the pierce point is the user and the slant factor 1: the delay is
    5 ns + A2 cos(2 pi (t - 50400) / A4), A2 = sum alpha_n |phi/pi|^n (the same north and
    south: GPS's model takes a signed geomagnetic latitude), A4 held within 72000-172800 s."""
    alpha, beta = np.array([2e-8, 3e-8, 0.0, 0.0]), np.array([110_000.0, 0.0, 0.0, 0.0])
    zen = np.array([90.0])

    def at(lat, t, b=beta):
        return float(bds_klobuchar_delay_s(alpha, b, lat, 0.0, np.zeros(1), zen, 2 * 86_400.0 + t)[0])

    a2 = 2e-8 + 3e-8 * (30.0 / 180.0)
    assert at(30.0, 50_400.0) == pytest.approx(5e-9 + a2, rel=1e-12)
    assert at(-30.0, 50_400.0) == pytest.approx(5e-9 + a2, rel=1e-12)
    assert at(30.0, 50_400.0 + 110_000.0 / 8) == pytest.approx(5e-9 + a2 * np.cos(np.pi / 4), rel=1e-12)
    assert at(30.0, 50_400.0 - 110_000.0 / 4 - 1.0) == pytest.approx(5e-9, rel=1e-12)  # night
    # A4 clamped: 200000 -> 172800, 50000 -> 72000 (the eighth of a period then differs).
    for b0, a4 in ((200_000.0, 172_800.0), (50_000.0, 72_000.0)):
        b = np.array([b0, 0.0, 0.0, 0.0])
        assert at(30.0, 50_400.0 + a4 / 8, b) == pytest.approx(5e-9 + a2 * np.cos(np.pi / 4), rel=1e-12)
    # Local time from the pierce point's longitude: 90 deg E is 6 h later.
    east = float(
        bds_klobuchar_delay_s(alpha, beta, 30.0, 90.0, np.zeros(1), zen, 2 * 86_400.0 + 50_400.0 - 21_600.0)[0]
    )
    assert east == pytest.approx(5e-9 + a2, rel=1e-12)
    # A negative amplitude is 0: night's 5 ns all day.
    assert float(bds_klobuchar_delay_s(-alpha, beta, 30.0, 0.0, np.zeros(1), zen, 50_400.0)[0]) == 5e-9


def test_the_model_takes_gps_time_to_bdt_and_gives_b1is_delay():
    """`BdsKlobuchar.delay_s` at GPS time t is the model at BDT t - 14 s; its reference is
    B1I, and a fix's scale to another carrier is (f_B1I / f)^2 (`broadcast_iono_delay_s`)."""
    iono = BdsKlobuchar((2e-8, 0.0, 0.0, 0.0), (110_000.0, 0.0, 0.0, 0.0))
    zen, north = np.array([90.0]), np.zeros(1)
    peak = iono.delay_s(0.0, 0.0, north, zen, 50_400.0 + 14.0)
    assert peak[0] == pytest.approx(2.5e-8, rel=1e-12)
    assert iono.reference is BEIDOU_B1I
    assert broadcast_iono_delay_s(iono, 0.0, 0.0, north, zen, 50_414.0)[0] == peak[0]
    # GPS's page 18 keeps IS-GPS-200's model (a different number for the same coefficients).
    from gnssframework.navigation.lnav import IonoUtc

    gps = IonoUtc(iono.alpha, iono.beta)
    assert broadcast_iono_delay_s(gps, 40.0, 0.0, north, np.array([20.0]), 50_400.0)[0] == pytest.approx(
        klobuchar_delay_s(gps.alpha, gps.beta, 40.0, 0.0, north, np.array([20.0]), 50_400.0)[0]
    )


def test_d1s_coefficients_come_from_subframe_1():
    """The real C06 subframes 1-3 (GNSSTk's data) sent in turn: `D1Message.iono` holds the
    eight coefficients GNSSTk decodes from subframe 1 (listed in the file's header)."""
    sent = []
    for line in (DATA / "gnsstk_d1_bds_c06.hex").read_text().splitlines():
        if line.startswith("#") or not line.strip():
            continue
        words = line.split()[2:]
        logical = np.array([(int(w, 16) >> (29 - i)) & 1 for w in words for i in range(30)], np.uint8)
        sent.append(d1nav.interleave_subframe(logical))
    msg = d1nav.decode_d1(1.0 - 2.0 * np.concatenate(sent), 6)
    assert msg.iono is not None
    alpha = (6.519258e-09, 2.98023223876953125e-08, -2.98023223876953125e-07, 4.17232513427734375e-07)
    np.testing.assert_allclose(msg.iono.alpha, alpha, rtol=1e-7)  # GNSSTk writes the first to 7 digits
    assert msg.iono.beta == (112640.0, 180224.0, -524288.0, 458752.0)


def test_a_fix_on_pseudoranges_the_model_delayed_is_exact_with_it():
    """Pseudoranges of the VILL file's BeiDou satellites in view from New Delhi (the tests'
    light time, `light_time.signal_flight`; group delays set to 0, so that no clock
    convention enters) delayed by the model with a day's coefficients and solved with it: the station within a
    centimetre; solved without it, metres off."""
    import pymap3d

    from light_time import signal_flight

    nav = read_rinex_nav(DATA / "VILL00ESP_R_20181700000_06H_MN.rnx", systems="C")
    # GPS time 04:00 seen from New Delhi (about 09:10 local: the pierce points' day, so that
    # the alphas count), where C05, C10, C11 and C14 are in view.
    t = 172_800.0 + 4 * 3_600.0 + 14.0
    sel = nav.select([sv for sv in np.unique(nav.sv) if sv != "C16"], t)  # C16: SatH1 1, not healthy
    elements = {k: (np.zeros_like(v) if k in ("TGD", "TGD2") else v) for k, v in sel.elements.items()}
    sel = type(sel)(sel.sv, sel.toc_s, elements, sel.health, sel.iode, sel.accuracy_m)
    lat, lon, h = 28.6, 77.2, 200.0
    station = np.array(pymap3d.geodetic2ecef(lat, lon, h))
    az, el, _ = pymap3d.ecef2aer(*signal_flight(sel, t, station).position_m.T, lat, lon, h)
    sel = sel.subset(np.flatnonzero(np.asarray(el) > 5.0))
    assert sel.sv.size >= 4
    flight = signal_flight(sel, t, station)
    az, el, _ = pymap3d.ecef2aer(*flight.position_m.T, lat, lon, h)
    iono = BdsKlobuchar((2.3e-8, 1.2e-8, -6e-8, 0.0), (120_000.0, 16_384.0, -65_536.0, 0.0))
    night = BdsKlobuchar((0.0,) * 4, iono.beta).delay_s(lat, lon, np.asarray(az), np.asarray(el), t)
    delay_m = C * iono.delay_s(lat, lon, np.asarray(az), np.asarray(el), t)
    assert np.all(delay_m > 1.0) and np.all(delay_m > 1.5 * C * night)  # the day's part counts
    pr = C * (flight.tau_s - flight.clock_s) + delay_m
    tx = t - flight.tau_s + flight.clock_s
    fix = solve_position(pr, tx, sel, iono=iono, signal=BEIDOU_B1I, elevation_mask_deg=0.0)
    bare = solve_position(pr, tx, sel, iono=None, signal=BEIDOU_B1I, elevation_mask_deg=0.0)
    assert fix is not None and bare is not None
    assert np.linalg.norm(fix.position_ecef_m - station) < 0.01
    assert np.linalg.norm(bare.position_ecef_m - station) > 1.0


def test_d1_sends_the_coefficients_it_is_given():
    """`d1nav.encode_d1` with an ``iono``: subframe 1 decodes to it within half an LSB of each
    field (2^-30 s ... 2^16 s); without, to zeros."""
    nav = read_rinex_nav(DATA / "VILL00ESP_R_20181700000_06H_MN.rnx", systems="C")
    rec = nav.subset(np.flatnonzero(nav.sv == "C11")[:1])
    iono = BdsKlobuchar((6.519258e-09, 2.98e-08, -2.98e-07, 4.17e-07), (112_640.0, 180_224.0, -524_288.0, 458_752.0))
    lsb_a, lsb_b = (2.0**-30, 2.0**-27, 2.0**-24, 2.0**-24), (2.0**11, 2.0**14, 2.0**16, 2.0**16)
    for sent, want in ((iono, iono), (None, BdsKlobuchar((0.0,) * 4, (0.0,) * 4))):
        bits = d1nav.encode_d1(rec, 650, 172_800, 3, sent).astype(float)
        got = d1nav.decode_d1(bits, 11).iono
        assert got is not None
        assert np.all(np.abs(np.subtract(got.alpha, want.alpha)) <= 0.5 * np.array(lsb_a))
        assert np.all(np.abs(np.subtract(got.beta, want.beta)) <= 0.5 * np.array(lsb_b))
