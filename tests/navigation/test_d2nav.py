"""BeiDou D2 (`navigation.d2nav`): the ten subframe-1 pages of a real GEO satellite (C01)
decoded to the values GNSSTk decodes from them, and a generated stream of a real GEO record
decoded back to it through noise, bit errors and inversion.

Truths: tests/data/gnsstk_d2_bds_c01.hex (real words; GNSSTk's expected values in its
comments); the real GEO record C05 of the VILL file, sent and decoded back."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gnssframework.errors import ConfigError
from gnssframework.navigation import d1nav, d2nav
from gnssframework.navigation.ephemeris import read_rinex_nav

DATA = Path(__file__).parents[1] / "data"
PI = 3.1415926535898

#: GNSSTk's decoded values of the file (radians); some written with 9 significant digits.
GNSSTK = {
    "Cus": -7.9278834164142608643e-06,
    "Cuc": -1.6712117940187454224e-05,
    "Crc": 2.45484375e02,
    "Crs": -5.05640625e02,
    "Cic": -2.10944563e-07,
    "Cis": 8.05594027e-08,
    "M0": -1.916523214107468176e00,
    "DeltaN": -6.54670127e-10,
    "Eccentricity": 6.1676383484154939651e-04,
    "Omega0": -3.1259749468667630268e00,
    "Io": 8.6141192515002310004e-02,
    "omega": 1.3510960489050376498e00,
    "OmegaDot": 1.69721355e-09,
    "IDOT": 3.9573076900000001079e-10,
    "SVclockBias": -2.7373037301003932953e-04,
    "SVclockDrift": 3.71924713e-11,
    "SVclockDriftRate": 0.0,
    "TGD": -5.6e-9,
    "TGD2": -1.01e-8,
    "Toe": 345600.0,
}


def _pages() -> list[tuple[int, int, np.ndarray]]:
    out = []
    for line in (DATA / "gnsstk_d2_bds_c01.hex").read_text().splitlines():
        if line.startswith("#") or not line.strip():
            continue
        page, stamp, *words = line.split()
        bits = np.array([(int(w, 16) >> (29 - i)) & 1 for w in words for i in range(30)], np.uint8)
        out.append((int(page), int(stamp), d1nav.interleave_subframe(bits)))
    return out


def test_the_real_pages_decode_to_gnsstks_values():
    decoded = {}
    for page, stamp, sent in _pages():
        fraid, sow, pnum, fields, corrected = d2nav.decode_subframe_bits(sent)
        assert (fraid, pnum, corrected) == (1, page, 0)
        assert sow == stamp - 14  # GNSSTk stamps the page at its start in BDT + 14 s
        decoded[pnum] = fields
    p1 = decoded[1]
    assert (p1["wn"], p1["toc_s"], p1["sath1"], p1["aodc"], p1["urai"]) == (810, 345600, 0, 0, 0)
    eph = d2nav.pages_to_ephemeris(decoded, 1)
    assert eph.sv.tolist() == ["C01"] and eph.toc_s[0] == 345600.0 and eph.iode[0] == 1
    for name, value in GNSSTK.items():
        assert eph.elements[name][0] == pytest.approx(value, rel=1e-8, abs=1e-20), name
    assert eph.elements["sqrtA"][0] ** 2 == pytest.approx(4.2164428143935076892e07, rel=1e-15)
    # Page 2: the Klobuchar coefficients GNSSTk decodes from it (PNBBDSD2NavDataFactory_T,
    # the iono test: alpha 6.519258e-09 ... beta ... 458752).
    p2 = decoded[2]
    alpha = [p2[k] for k in ("alpha0_s", "alpha1_s_sc", "alpha2_s_sc2", "alpha3_s_sc3")]
    np.testing.assert_allclose(
        alpha, [6.519258e-09, 2.98023223876953125e-08, -2.98023223876953125e-07, 4.17232513427734375e-07], rtol=1e-7
    )
    assert [p2[k] for k in ("beta0_s", "beta1_s_sc", "beta2_s_sc2", "beta3_s_sc3")] == [112640, 180224, -524288, 458752]


def test_a_missing_page_or_a_page_out_of_its_frame_is_refused():
    decoded = {}
    for page, _, sent in _pages():
        decoded[page] = d2nav.decode_subframe_bits(sent)[3]
    with pytest.raises(ConfigError, match="d2.page7"):
        d2nav.pages_to_ephemeris({p: f for p, f in decoded.items() if p != 7}, 1)
    with pytest.raises(ConfigError, match="multiple of 3 s"):
        d2nav.encode_subframe(1, 345601, {})


def _geo_record():
    nav = read_rinex_nav(DATA / "VILL00ESP_R_20181700000_06H_MN.rnx", systems="C")
    return nav.subset(np.flatnonzero(nav.sv == "C05")[:1])


def test_a_generated_stream_decodes_to_its_record_through_noise_errors_and_inversion():
    """The GEO record C05 (VILL) sent as 12 frames (36 s: one page cycle whole) from an odd
    bit, inverted, with white noise and one forced error in page 1's word 2 of every frame:
    every subframe kept, the record back within half an LSB of each field, and the last
    subframe dated in BDT and in GPS time."""
    rec = _geo_record()
    wn = 650  # 2018-06-19 is GPS week 2006, BDT week 650
    sow0 = int(rec.toc_s[0]) - 6  # two frames before a cycle starts (page 1 at SOW / 3 mod 10 = 0)
    bits = d2nav.encode_d2(rec, wn, sow0, 12).astype(float)
    rng = np.random.default_rng(12)
    stream = -np.concatenate([rng.choice([-1.0, 1.0], 77), bits])
    stream += rng.normal(0.0, 0.27, stream.size)
    for k in range(12):
        stream[77 + 1500 * k + 31 + (k % 25)] *= -1
    msg = d2nav.decode_d2(stream, 5)
    assert len(msg.subframes) == 60 and not msg.failures
    assert all(sf.inverted for sf in msg.subframes)
    last = msg.subframes[-1]
    assert (last.fraid, last.sow) == (5, sow0 + 33) and msg.bdt == (77 + 59 * 300, wn, sow0 + 33 + 2.4)
    assert msg.gst == (77 + 59 * 300, wn + 1356, sow0 + 33 + 2.4 + 14)
    eph = msg.ephemeris
    assert eph is not None and eph.sv.tolist() == ["C05"] and eph.iode[0] == rec.iode[0] % 32
    for name, lsb in (("sqrtA", 2.0**-19), ("Eccentricity", 2.0**-33), ("Crc", 2.0**-6), ("TGD", 1e-10)):
        assert abs(eph.elements[name][0] - rec.elements[name][0]) <= 0.5001 * lsb, name
    for name in ("M0", "Omega0", "omega", "Io"):
        assert abs(eph.elements[name][0] - rec.elements[name][0]) <= 0.5001 * PI * 2.0**-31, name
    assert eph.elements["Toe"][0] == rec.elements["Toe"][0]


def test_the_generators_bits_are_the_frames_from_the_bit_in_force():
    """`d2_symbols` from BDT 4.0031 s after a frame start: the stream `encode_d2` sends from
    that frame on, cut at the bit in force (the 501st of its frame, 2 ms each), and the time
    from that bit's start, 1.1 ms; at the end of a week, the next week's frames follow."""
    rec = _geo_record()
    wn, sow0 = 650, int(rec.toc_s[0]) - 6
    stream = d2nav.encode_d2(rec, wn, sow0, 4)
    bits, into = d2nav.d2_symbols(rec, wn, sow0 + 4.0031, 2000)
    np.testing.assert_array_equal(bits, stream[1500 + 501 : 1500 + 501 + 2000])
    assert into == pytest.approx(0.0011, abs=1e-9)  # the times as doubles near 1e5 s: 1e-11
    end = 604_800 - 3
    bits, into = d2nav.d2_symbols(rec, wn, end + 2.9991, 600)
    rolled = np.concatenate([d2nav.encode_d2(rec, wn, end, 1), d2nav.encode_d2(rec, wn + 1, 0, 1)])
    np.testing.assert_array_equal(bits, rolled[1499 : 1499 + 600])
    assert into == pytest.approx(0.0011, abs=1e-9)


def test_page_2_sends_and_returns_the_coefficients_given():
    """`encode_d2` with an ``iono``: a whole page cycle decodes (`D2Message.iono`) to it
    within half an LSB of each field; without, to zeros."""
    from gnssframework.navigation.bds_iono import BdsKlobuchar

    rec = _geo_record()
    iono = BdsKlobuchar((6.5e-09, 2.98e-08, -2.98e-07, 4.17e-07), (112_640.0, 180_224.0, -524_288.0, 458_752.0))
    lsb = np.array([2.0**-30, 2.0**-27, 2.0**-24, 2.0**-24, 2.0**11, 2.0**14, 2.0**16, 2.0**16])
    sow0 = int(rec.toc_s[0]) - 6
    for sent, want in ((iono, iono), (None, BdsKlobuchar((0.0,) * 4, (0.0,) * 4))):
        msg = d2nav.decode_d2(d2nav.encode_d2(rec, 650, sow0, 12, sent).astype(float), 5)
        assert msg.iono is not None
        got = np.r_[msg.iono.alpha, msg.iono.beta]
        assert np.all(np.abs(got - np.r_[want.alpha, want.beta]) <= 0.5 * lsb)
