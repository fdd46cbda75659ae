"""BeiDou D1 (`navigation.d1nav`): three real subframes of C06 decoded to the values GNSSTk
decodes from them, the BCH(15,11,1) code against the ICD's own decoder and correction table,
and a generated stream decoded back to its record through noise, bit errors and inversion.

Truths: tests/data/gnsstk_d1_bds_c06.hex (real words, GNSSTk's expected values in its
comments); BDS-SIS-ICD-B1I 3.0 Table 5-2, which maps each syndrome (the received word
modulo g(x), by long division here, not the module's matrix) to the error it corrects."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gnssframework.errors import ConfigError
from gnssframework.navigation import d1nav
from gnssframework.navigation.ephemeris import read_rinex_nav

DATA = Path(__file__).parents[1] / "data"
HEX = DATA / "gnsstk_d1_bds_c06.hex"
PI = 3.1415926535898

#: GNSSTk's decoded values of the file (radians); its test writes some with 9 significant
#: digits, hence a relative tolerance of 1e-8.
GNSSTK = {
    "Cus": 2.102460712194442749e-05,
    "Cuc": -4.5062042772769927979e-06,
    "Crc": -4.04640625e02,
    "Crs": -1.43203125e02,
    "Cic": 7.91624188e-08,
    "Cis": -3.39932740e-08,
    "M0": -8.5672685685526606125e-02,
    "DeltaN": 1.20183578e-09,
    "Eccentricity": 1.1284291860647499561e-02,
    "Omega0": -1.9160860634641034839e00,
    "Io": 9.450732988963341796e-01,
    "omega": -2.1772769963262814663e00,
    "OmegaDot": -1.78078846e-09,
    "IDOT": 4.37518224e-10,
    "SVclockBias": 6.2543887179344892502e-04,
    "SVclockDrift": 4.82804907e-11,
    "SVclockDriftRate": 0.0,
    "TGD": 8.2e-9,
    "TGD2": -1.9e-9,
    "Toe": 345600.0,
}


def _subframes() -> dict[int, tuple[int, np.ndarray]]:
    out = {}
    for line in HEX.read_text().splitlines():
        if line.startswith("#") or not line.strip():
            continue
        fraid, stamp, *words = line.split()
        bits = np.array([(int(w, 16) >> (29 - i)) & 1 for w in words for i in range(30)], np.uint8)
        out[int(fraid)] = (int(stamp), bits)
    return out


def test_the_real_words_are_codewords_of_the_bch_code():
    for _, logical in _subframes().values():
        sent = d1nav.interleave_subframe(logical)
        np.testing.assert_array_equal(d1nav.deinterleave_subframe(sent), logical)
        _, _, _, corrected = d1nav.decode_subframe_bits(sent)
        assert corrected == 0  # nineteen codewords, every syndrome zero


def test_the_real_subframes_decode_to_gnsstks_values():
    decoded = {}
    for fraid, (stamp, logical) in _subframes().items():
        got_id, sow, fields, _ = d1nav.decode_subframe_bits(d1nav.interleave_subframe(logical))
        assert got_id == fraid and sow == stamp - 14  # GNSSTk stamps the subframe 14 s late (BDT + 14)
        decoded[fraid] = fields
    f1 = decoded[1]
    assert (f1["wn"], f1["toc_s"], f1["sath1"], f1["aodc"], f1["aode"], f1["urai"]) == (810, 345600, 0, 0, 1, 0)
    np.testing.assert_allclose(
        [f1[k] for k in ("alpha0_s", "alpha1_s_sc", "alpha2_s_sc2", "alpha3_s_sc3")],
        [6.519258e-09, 2.98023223876953125e-08, -2.98023223876953125e-07, 4.17232513427734375e-07],
        rtol=1e-7,
    )
    assert [f1[k] for k in ("beta0_s", "beta1_s_sc", "beta2_s_sc2", "beta3_s_sc3")] == [112640, 180224, -524288, 458752]
    eph = d1nav.subframes_to_ephemeris(decoded, 6)
    assert eph.sv.tolist() == ["C06"] and eph.toc_s[0] == 345600.0 and eph.iode[0] == 1 and eph.health[0] == 0
    for name, value in GNSSTK.items():
        assert eph.elements[name][0] == pytest.approx(value, rel=1e-8, abs=1e-20), name
    assert np.sqrt(4.2170134522822760046e07) == pytest.approx(eph.elements["sqrtA"][0], rel=1e-15)


def _remainder(cw: np.ndarray) -> int:
    """The received word's polynomial (first bit the highest power) modulo g(x) = x^4 + x + 1,
    by long division: the syndrome Table 5-2 is indexed by (x^3 ... x^0 as bits 3 ... 0)."""
    r = int("".join(map(str, cw.tolist())), 2)
    for k in range(14, 3, -1):
        if (r >> k) & 1:
            r ^= 0b10011 << (k - 4)
    return r


#: ICD Table 5-2: the error pattern (15 bits, first bit the most significant) for each
#: register value 0-15.
ICD_TABLE_5_2 = (
    0b000000000000000, 0b000000000000001, 0b000000000000010, 0b000000000010000,
    0b000000000000100, 0b000000100000000, 0b000000000100000, 0b000010000000000,
    0b000000000001000, 0b100000000000000, 0b000001000000000, 0b000000010000000,
    0b000000001000000, 0b010000000000000, 0b000100000000000, 0b001000000000000,
)  # fmt: skip


@settings(max_examples=60, deadline=None)
@given(info=st.lists(st.integers(0, 1), min_size=11, max_size=11), error_at=st.integers(-1, 14))
def test_one_error_a_codeword_is_corrected_as_the_icds_table_says(info, error_at):
    cw = d1nav.bch_encode(np.array(info, np.uint8))
    assert _remainder(cw) == 0  # a codeword
    received = cw.copy()
    if error_at >= 0:
        received[error_at] ^= 1
    pattern = np.array([(ICD_TABLE_5_2[_remainder(received)] >> (14 - i)) & 1 for i in range(15)], np.uint8)
    np.testing.assert_array_equal(received ^ pattern, cw)  # the table corrects it
    got, corrected = d1nav.bch_decode(received)
    np.testing.assert_array_equal(got, info)
    assert bool(corrected) == (error_at >= 0)


def test_a_real_subframe_with_one_error_in_each_codeword_is_restored():
    _, logical = _subframes()[2]
    sent = d1nav.interleave_subframe(logical)
    reference = d1nav.decode_subframe_bits(sent)[2]
    rng = np.random.default_rng(3)
    hit = sent.copy()
    hit[15 + rng.integers(0, 15)] ^= 1  # word 1's codeword
    for w in range(1, 10):  # one bit of each interleaved codeword
        hit[30 * w + 2 * rng.integers(0, 15)] ^= 1
        hit[30 * w + 1 + 2 * rng.integers(0, 15)] ^= 1
    fraid, sow, fields, corrected = d1nav.decode_subframe_bits(hit)
    assert (fraid, sow, corrected) == (2, 345606, 19) and fields == reference


def _bds_record():
    nav = read_rinex_nav(DATA / "VILL00ESP_R_20181700000_06H_MN.rnx", systems="C")
    return nav.subset(np.flatnonzero(nav.sv == "C11")[:1])


def test_a_generated_stream_decodes_to_its_record_through_noise_errors_and_inversion():
    """A real C11 record (VILL) sent as 40 subframes from an odd bit, inverted, with white
    noise at a bit error rate of about 1e-4 and one forced error in a codeword of every
    subframe: every subframe is kept, and the record comes back to the ICD's quantisation."""
    rec = _bds_record()
    wn = 650  # 2018-06-19 is GPS week 2006, BDT week 650
    sow0 = int(rec.toc_s[0]) - 60
    bits = d1nav.encode_d1(rec, wn, sow0, 40).astype(float)
    rng = np.random.default_rng(11)
    stream = -np.concatenate([rng.choice([-1.0, 1.0], 137), bits])
    stream += rng.normal(0.0, 0.27, stream.size)  # Q(1/0.27) ~ 1e-4: a few errors
    for k in range(40):
        stream[137 + 300 * k + 40 + (k % 20)] *= -1  # one more error in word 2
    msg = d1nav.decode_d1(stream, 11)
    assert len(msg.subframes) == 40 and not msg.failures
    assert all(sf.inverted for sf in msg.subframes) and msg.subframes[0].start == 137
    assert msg.bdt == (137 + 39 * 300, wn, sow0 + 39 * 6)
    eph = msg.ephemeris
    assert eph is not None and eph.sv.tolist() == ["C11"] and eph.iode[0] == rec.iode[0] % 32
    half_lsb = {"sqrtA": 2.0**-20, "Eccentricity": 2.0**-34, "Crc": 2.0**-7, "Crs": 2.0**-7, "TGD": 0.5e-10}
    for name in ("sqrtA", "Eccentricity", "Crc", "Crs", "TGD", "Toe"):
        assert abs(eph.elements[name][0] - rec.elements[name][0]) <= half_lsb.get(name, 0.0) * 1.0001, name
    for name in ("M0", "Omega0", "omega", "Io"):
        assert abs(eph.elements[name][0] - rec.elements[name][0]) <= PI * 2.0**-32 * 1.0001, name
    gps = msg.gst
    assert gps is not None and gps[1] == wn + 1356 and gps[2] == sow0 + 39 * 6 + 14


def test_bad_input_is_refused_in_one_line():
    with pytest.raises(ConfigError, match="subframe 2 starts"):
        d1nav.encode_subframe(2, 345600, {})
    with pytest.raises(ConfigError, match="300 bits"):
        d1nav.decode_subframe_bits(np.zeros(299, np.uint8))
    with pytest.raises(ConfigError, match="d1.subframe1.tgd1_s"):
        d1nav.encode_subframe(1, 345600, {"tgd1_s": 1e-6})
    with pytest.raises(ConfigError, match="subframes 1-3"):
        d1nav.subframes_to_ephemeris({1: {}, 2: {}}, 6)
