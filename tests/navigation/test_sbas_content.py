"""SBAS message contents (`navigation.sbas_content`).

Truth: 80 s of real MSAS messages from both its GEOs (RTKLIB's GW-10 log, every message
whose CRC holds, `tests/data/README.md`) against what is known without the decoder: the
GEOs' published orbital slots (MTSAT-1R, PRN 129, at 140° E; MTSAT-2, PRN 137, at 145° E),
the almanac (type 17) against the navigation message (type 9) of the same GEOs, and the
issues of data the system keeps equal across types; DO-229's IGP band sizes; and messages
built bit by bit from the field positions of the module's table."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pymap3d
import pytest

from gnssframework.navigation.sbas_content import (
    FastCorrections,
    FastDegradation,
    GeoAlmanac,
    GeoNavigation,
    IgpMask,
    IonoDelays,
    PrnMask,
    SbasCorrections,
    decode_content,
    igp_band_grid,
    mask_satellite,
)
from gnssframework.navigation.sbas_message import message_bits, messages_from_hex, parse_message

LOG = Path(__file__).parents[1] / "data" / "sbas_msas_gw10_20110121_80s.txt"
#: Geostationary orbit radius (m): (GM / ω_E²)^(1/3) with WGS 84's GM and ω_E.
GEO_RADIUS_M = (3.986004418e14 / 7.2921151467e-5**2) ** (1 / 3)


@pytest.fixture(scope="module")
def log():
    rows = [line.split() for line in LOG.read_text().splitlines() if not line.startswith("#")]
    bits = messages_from_hex([r[2] for r in rows])
    return [(int(r[0]) / 1000.0, int(r[1]), b) for r, b in zip(rows, bits)]


def _of_type(log, mtype, prn=None):
    return [(t, p, decode_content(b)) for t, p, b in log if parse_message(b)[1] == mtype and prn in (None, p)]


def test_geo_navigation_puts_each_msas_geo_on_its_slot(log):
    slots = {129: 140.0, 137: 145.0}
    navs = _of_type(log, 9)
    assert {p for _, p, _ in navs} == set(slots)
    for _, prn, nav in navs:
        assert isinstance(nav, GeoNavigation)
        lat, lon, _ = pymap3d.ecef2geodetic(*nav.position_m)
        # Station keeping holds a GEO within about 0.1 degree of its slot.
        assert abs(lon - slots[prn]) < 0.1 and abs(lat) < 0.1, (prn, lat, lon)
        assert abs(np.linalg.norm(nav.position_m) - GEO_RADIUS_M) < 30e3  # eccentricity: tens of km
        assert np.linalg.norm(nav.velocity_mps) < 10.0  # a GEO nearly still in ECEF
        assert abs(nav.af0_s) < 1e-6


def test_the_almanac_places_both_geos_where_their_navigation_messages_do(log):
    [(_, _, almanac)] = _of_type(log, 17)
    assert isinstance(almanac, GeoAlmanac)
    navs = {p: nav for _, p, nav in _of_type(log, 9)}
    assert sorted(e[1] for e in almanac.entries) == sorted(navs)
    for _, prn, _, position_m, _ in almanac.entries:
        nav = navs[prn]
        dt = almanac.t0_s - nav.t0_s
        at_t0 = nav.position_m + nav.velocity_mps * dt + 0.5 * nav.acceleration_mps2 * dt**2
        # Within half the almanac's resolution per axis (2600 m in X and Y, 26 km in Z).
        assert np.all(np.abs(position_m - at_t0) <= np.array([1300.0, 1300.0, 13000.0])), prn


def test_masks_and_corrections_carry_the_same_issues_of_data(log):
    masks = [m for _, _, m in _of_type(log, 1)]
    assert masks and all(isinstance(m, PrnMask) for m in masks)
    iodp = {m.iodp for m in masks}
    assert len(iodp) == 1
    fast = [c for mtype in (2, 3, 4, 5) for _, _, c in _of_type(log, mtype)]
    assert {c.iodp for c in fast} == iodp and {_of_type(log, 7)[0][2].iodp} == iodp
    long_term = [c for _, _, cs in _of_type(log, 25) for c in cs]
    assert long_term and {c.iodp for c in long_term} == iodp
    # Types 2-4 are sent and 5 is not: the mask holds 27 to 39 satellites.
    assert {c.message_type for c in fast} == {2, 3, 4} and 27 <= len(masks[0].slots) <= 39
    igp_masks = {m.band: m for _, _, m in _of_type(log, 18)}
    delays = [d for _, _, d in _of_type(log, 26)]
    # Three bands are masked (7, 8 and one whose type 18 these 80 s do not hold).
    assert {m.n_bands for m in igp_masks.values()} == {3}
    known = [d for d in delays if d.band in igp_masks]
    assert len(known) >= 4 and all(d.iodi == igp_masks[d.band].iodi for d in known)
    assert all(d.block * 15 < len(igp_masks[d.band].igps) for d in known)


def test_corrections_gathered_per_satellite(log):
    for prn in (129, 137):
        own = [m for m in log if m[1] == prn]
        gathered = SbasCorrections.from_messages(own)
        first_mask = min(t for t, p, b in own if parse_message(b)[1] == 1)
        before = sum(1 for t, _, b in own if t < first_mask and parse_message(b)[1] in (2, 3, 4, 25))
        assert gathered.ignored >= before > 0  # corrections before the mask: not applied
        monitored = {sv: v for sv, v in gathered.fast.items() if v[1] < 14}  # UDREI 14: not monitored
        assert sum(sv.startswith("G") for sv in monitored) >= 4
        # A fast correction is metres (a clock or orbit error left after the broadcast one).
        assert all(abs(prc) < 5.0 for prc, _, _ in monitored.values())
        # The correction each replaced (for the range-rate term) is an earlier message's, and
        # a clock's correction moves centimetres a second, not metres.
        previous = {sv: gathered.fast_previous[sv] for sv in monitored if sv in gathered.fast_previous}
        assert len(previous) >= 4
        for sv, (prc0, _, t0) in previous.items():
            prc, _, t = monitored[sv]
            assert 0 < t - t0 <= 60.0 and abs(prc - prc0) / (t - t0) < 0.1
        assert all(abs(c.daf0_s) * 299_792_458.0 < 20.0 for c in gathered.long_term.values())
        assert all(np.linalg.norm(c.dpos_m) < 30.0 for c in gathered.long_term.values())
        lats = [lat for (_, lat, _), (delay, givei, _) in gathered.iono.items() if givei < 15]
        # MSAS monitors the ionosphere around Japan (20-50 degrees north).
        assert lats and all(15.0 <= lat <= 55.0 for lat in lats)


def test_igp_bands_have_their_sizes_and_corners():
    sizes = [len(igp_band_grid(b)) for b in range(11)]
    assert sizes == [201] * 8 + [200, 192, 192]  # DO-229 A.4.4.9
    b0 = igp_band_grid(0)
    assert tuple(b0[0]) == (-75, -180) and tuple(b0[27]) == (85, -180) and tuple(b0[28]) == (-55, -175)
    assert tuple(igp_band_grid(3)[50]) == (-85, -50)  # -50: one of the four columns with -85
    assert tuple(igp_band_grid(9)[-1]) == (85, 150) and tuple(igp_band_grid(10)[-1]) == (-85, 160)
    grid = np.vstack([igp_band_grid(b) for b in range(9)])
    assert len({tuple(p) for p in grid}) == grid.shape[0]  # no IGP in two bands
    with pytest.raises(ValueError, match="bands are 0-10"):
        igp_band_grid(11)


def _with(data: np.ndarray, first0: int, n: int, value: int) -> None:
    """Write ``value`` (two's complement) into message bits ``first0 .. first0 + n - 1``,
    ``data`` being the 212 bits after the preamble and type (message bit 14 is data bit 0)."""
    for k in range(n):
        data[first0 - 14 + k] = (value >> (n - 1 - k)) & 1


def test_fields_where_the_table_puts_them():
    data = np.zeros(212, np.uint8)
    _with(data, 14, 2, 3)  # IODF
    _with(data, 16, 2, 2)  # IODP
    _with(data, 18, 12, -1)  # PRC 0: -1 LSB
    _with(data, 18 + 12 * 12, 12, 2047)  # PRC 12: the largest
    _with(data, 174 + 4 * 5, 4, 13)  # UDREI 5
    fast = decode_content(message_bits(1, 3, data))
    assert isinstance(fast, FastCorrections) and (fast.iodf, fast.iodp, fast.first) == (3, 2, 13)
    assert fast.prc_m[0] == -0.125 and fast.prc_m[12] == 255.875 and fast.prc_m[1] == 0.0
    assert fast.udrei[5] == 13 and fast.udrei.sum() == 13

    data = np.zeros(212, np.uint8)
    _with(data, 14, 4, 8)  # band 8
    _with(data, 18, 4, 2)  # block 2
    _with(data, 22 + 13 * 1, 9, 511)  # IGP 1: not monitored
    _with(data, 22 + 13 * 2, 9, 100)
    _with(data, 31 + 13 * 2, 4, 7)
    _with(data, 217, 2, 1)  # IODI
    iono = decode_content(message_bits(0, 26, data))
    assert isinstance(iono, IonoDelays) and (iono.band, iono.block, iono.iodi) == (8, 2, 1)
    assert np.isnan(iono.delay_m[1]) and iono.delay_m[2] == 12.5 and iono.givei[2] == 7

    data = np.zeros(212, np.uint8)  # type 25, first half with velocity code 1
    _with(data, 14, 1, 1)
    _with(data, 15, 6, 5)  # mask number
    _with(data, 21, 8, 77)  # IODE
    _with(data, 29, 11, -8)  # dx: -1 m
    _with(data, 62, 11, 4)  # daf0: 4 x 2^-31 s
    _with(data, 73 + 16, 8, -2)  # ddz: -2 x 2^-11 m/s
    _with(data, 97, 8, 3)  # daf1
    _with(data, 105, 13, 100)  # t0: 1600 s
    _with(data, 118, 2, 1)  # IODP
    [lt] = decode_content(message_bits(2, 25, data))
    assert (lt.slot, lt.iode, lt.iodp, lt.t0_s) == (5, 77, 1, 1600.0)
    assert lt.dpos_m.tolist() == [-1.0, 0.0, 0.0] and lt.dvel_mps.tolist() == [0.0, 0.0, -2 * 2.0**-11]
    assert lt.daf0_s == 4 * 2.0**-31 and lt.daf1_s_s == 3 * 2.0**-39

    data = np.zeros(212, np.uint8)
    _with(data, 14, 4, 1)  # latency
    _with(data, 18, 2, 3)  # IODP
    _with(data, 22 + 4 * 50, 4, 9)  # a_i of mask number 50
    degradation = decode_content(message_bits(0, 7, data))
    assert isinstance(degradation, FastDegradation) and degradation.ai[50] == 9 and degradation.iodp == 3


def test_mask_slots_name_their_satellites_and_bad_bits_are_refused():
    assert [mask_satellite(s) for s in (1, 37, 38, 61, 120, 158, 193, 70)] == [
        "G01", "G37", "R01", "R24", "S20", "S58", "J01", "slot 70"
    ]  # fmt: skip
    bits = message_bits(0, 63, np.zeros(212, np.uint8))
    assert decode_content(bits) is None  # the null message
    bits[100] ^= 1
    with pytest.raises(ValueError, match="CRC holds"):
        decode_content(bits)
    mask = IgpMask(1, 8, 0, (1, 2, 28))
    assert mask.grid().tolist() == [[-75.0, 140.0], [-65.0, 140.0], [-55.0, 145.0]]


def test_each_type_read_is_described_in_one_line(log):
    from gnssframework.navigation.sbas_content import describe

    seen = {}
    for _, _, bits in log:
        seen.setdefault(parse_message(bits)[1], describe(decode_content(bits)))
    assert seen[1] == "mask IODP 3: 33 satellites"  # G02-G32, S29 and S37
    assert seen[4].endswith("mask numbers 27-39") and seen[9].startswith("GEO navigation t0 1600 s")
    assert seen[17] == "GEO almanac t0 1600 s: PRN 129 137"
    assert seen[25].startswith("long-term corrections: mask numbers")
    assert seen[10].startswith("degradation parameters: B_rrc 0.108 m")
    assert seen[28] == "clock-ephemeris covariance IODP 3: mask numbers 18 31"
    assert seen[63] == ""  # the null message
    assert all(text for mtype, text in seen.items() if mtype in (2, 3, 4, 7, 18, 26))


def test_msas_type_28_covariances_never_shrink_a_udre(log):
    """MSAS's 10 type 28 messages (five pairs, one from each GEO; 20 satellites' matrices,
    scale exponents 0, 1, 2 and 5) under the mask's IODP: every relative covariance C = RᵀR
    read has its smallest eigenvalue at 0.5 (within 0.01: the quantised factor), so along
    any line of sight IᵀCI >= 0.5 |I|² = 1 (I = [u, 1]) and δUDRE >= 1, as an inflation
    factor must be. The check fails if the off-diagonal signs, the field order or the scale
    are misread (measured: 0.28-0.72 and 2.0 instead)."""
    from gnssframework.navigation.sbas_content import CovarianceMatrices

    got = _of_type(log, 28)
    assert len(got) == 10 and all(isinstance(c, CovarianceMatrices) and c.iodp == 3 for _, _, c in got)
    assert {e for _, _, c in got for e in c.scale_exponents} == {0, 1, 2, 5}
    smallest = np.array([np.linalg.eigvalsh(m)[0] for _, _, c in got for m in c.covariances])
    assert smallest.size == 20 and np.all(np.abs(smallest - 0.5) < 0.01)
    # The two GEOs send the same satellites' matrices, equal to within a few LSBs.
    by_geo = {p: [c for _, q, c in got if q == p] for p in (129, 137)}
    for c129, c137 in zip(by_geo[129], by_geo[137]):
        assert c129.slots == c137.slots
        np.testing.assert_allclose(
            np.sqrt(np.diag(c129.covariances[0])), np.sqrt(np.diag(c137.covariances[0])), atol=0.2
        )


def test_both_geos_send_the_same_degradation_parameters(log):
    # Type 10 describes the network's error model, not the GEO: MSAS's two GEOs must agree,
    # and every value lies inside its field (a misplaced field would read past one).
    from gnssframework.navigation.sbas_content import DEGRADATION_LAYOUT, DegradationParameters

    found = {p: c for t, p, c in _of_type(log, 10)}
    assert set(found) == {129, 137} and found[129] == found[137]
    params = found[129]
    assert isinstance(params, DegradationParameters)
    for name, (_, n, scale, _) in DEGRADATION_LAYOUT.items():
        assert 0 <= getattr(params, name) <= ((1 << n) - 1) * scale
    # MSAS's time-outs and steps are seconds to minutes, its C_er metres (A.4.5.1.4).
    assert 60 <= params.iltc_v0_s <= 511 and 60 <= params.iiono_s <= 511 and 0 < params.cer_m <= 31.5
    degradation = _of_type(log, 7)
    assert {p for _, p, _ in degradation} == {129, 137}
    assert all(0 <= c.latency_s <= 15 and c.ai.size == 51 and c.ai.max() <= 15 for _, _, c in degradation)
