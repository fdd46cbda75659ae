"""LNAV (IS-GPS-200 20.3): parity against the ICD's equations in their published hex-mask
form, encode -> decode round trips of real broadcast records (tests/data/07590920.05n)
within half the spec's LSB of each field, both polarities, corrupted bits, legal IODC/IODE
pairs, page 18, and a generated IF recording carrying LNAV that tracks and decodes."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gnssframework.errors import ConfigError
from gnssframework.navigation import lnav
from gnssframework.navigation.ephemeris import read_rinex_nav, satellite_state
from pathlib import Path

from lnav_lsb import ALPHA_LSB, BETA_LSB, LSB

NAV = Path(__file__).parents[1] / "data" / "07590920.05n"
# Klobuchar of the same file's header (ION ALPHA / ION BETA lines).
IONO = lnav.IonoUtc(
    alpha=(1.118e-08, 1.49e-08, -5.96e-08, -5.96e-08),
    beta=(9.011e04, 1.638e04, -1.966e05, -6.554e04),
    a0_s=-2.793967723846e-09,
    a1_s_s=-1.509903313490e-14,
    tot_s=503808,
    wnt=1316,
    dt_ls_s=13,
)


@pytest.fixture(scope="module")
def records():
    return read_rinex_nav(NAV)


def test_parity_equations_are_the_icd_hex_masks():
    # Table 20-XIV as the 32-bit masks used throughout GPS software (D29*, D30*, d1..d24 in
    # bits 31..6): an independent statement of the same equations.
    masks = [0xBB1F3480, 0x5D8F9A40, 0xAEC7CD00, 0x5763E680, 0x6BB1F340, 0x8B7A89C0]
    rng = np.random.default_rng(5)
    for _ in range(200):
        d = rng.integers(0, 2, 24)
        d29, d30 = rng.integers(0, 2, 2)
        word = (int(d29) << 31) | (int(d30) << 30) | sum(int(b) << (29 - k) for k, b in enumerate(d))
        expected = [bin(word & m).count("1") % 2 for m in masks]
        assert list(lnav.parity_bits(d, d29, d30)) == expected


def test_words_2_and_10_end_in_two_zeros_and_a_d30_of_one_complements_the_next_word():
    bits = lnav.encode_subframe(2, 1234, {"iode": 77, "crs_m": -3.0, "toe_s": 7200.0}, 1, 1)
    words = bits.reshape(10, 30)
    assert not words[1, 28:].any() and not words[9, 28:].any()
    # The TLM after a word ending in D30 = 1 goes out complemented: its preamble reads 01110100.
    assert list(words[0, :8]) == [0, 1, 1, 1, 0, 1, 0, 0]


def test_every_real_record_round_trips_within_half_an_lsb(records):
    for k in range(records.sv.size):
        rec = records.subset(np.array([k]))
        tow = 6.0 * 5 * 100  # a frame start: subframes 1..5
        bits = lnav.encode_lnav(rec, 1316, tow, 5, IONO)
        msg = lnav.decode_lnav(1 - 2 * bits.astype(float), int(rec.sv[0][1:]))
        assert [s.subframe_id for s in msg.subframes] == [1, 2, 3, 4, 5]
        assert [s.tow_s for s in msg.subframes] == [tow + 6 * j for j in range(5)]
        assert msg.week == 1316 % 1024
        got = msg.ephemeris
        assert got is not None and got.sv[0] == rec.sv[0]
        for name, lsb in LSB.items():
            assert abs(got.elements[name][0] - rec.elements[name][0]) <= lsb / 2 * (1 + 1e-9), name
        assert got.toc_s[0] == rec.toc_s[0] and got.iode[0] == rec.iode[0] and got.health[0] == rec.health[0]
        # The decoded record positions the satellite as the original: the LSBs move it by centimetres.
        t = rec.elements["Toe"][0] + 900.0
        a, b = satellite_state(rec, t), satellite_state(got, t)
        assert np.linalg.norm(a.position_m - b.position_m) < 0.5
        assert abs(a.clock_l1_s - b.clock_l1_s)[0] < 2e-9


def test_page_18_carries_klobuchar_and_utc(records):
    bits = lnav.encode_lnav(records.subset(np.array([0])), 1316, 18.0, 1, IONO)  # subframe 4
    msg = lnav.decode_lnav(1 - 2 * bits.astype(float), 20)
    iono = msg.iono_utc
    assert np.all(np.abs(np.array(iono.alpha) - IONO.alpha) <= ALPHA_LSB / 2)
    assert np.all(np.abs(np.array(iono.beta) - IONO.beta) <= BETA_LSB / 2)
    assert abs(iono.a0_s - IONO.a0_s) <= 2.0**-31 and abs(iono.a1_s_s - IONO.a1_s_s) <= 2.0**-51
    assert (iono.tot_s, iono.wnt, iono.dt_ls_s) == (503808, 1316 % 256, 13)


def test_an_inverted_stream_decodes_the_same_and_says_so(records):
    rec = records.subset(np.array([3]))
    bits = lnav.encode_lnav(rec, 1316, 600.0, 6, IONO)
    symbols = 1 - 2 * bits.astype(float)
    up, down = lnav.decode_lnav(symbols[137:], 7), lnav.decode_lnav(-symbols[137:], 7)
    assert [s.inverted for s in up.subframes] == [False] * 5
    assert [s.inverted for s in down.subframes] == [True] * 5
    assert [s.start for s in up.subframes] == [300 - 137 + 300 * j for j in range(5)]
    for name in LSB:
        assert down.ephemeris.elements[name][0] == up.ephemeris.elements[name][0]


def test_soft_symbols_with_noise_decode_and_a_flipped_bit_is_caught_by_parity(records):
    rec = records.subset(np.array([1]))
    bits = lnav.encode_lnav(rec, 1316, 0.0, 3, None)
    rng = np.random.default_rng(3)
    soft = (1 - 2 * bits.astype(float)) * 5.0 + rng.standard_normal(bits.size)
    assert [s.subframe_id for s in lnav.find_subframes(soft)] == [1, 2, 3]
    for position in (45, 300 + 170, 600 + 299):  # HOW of sf 1, a data bit of sf 2, the last parity bit of sf 3
        flipped = soft.copy()
        flipped[position] *= -1
        kept = [s.subframe_id for s in lnav.find_subframes(flipped)]
        assert kept == [k for k in (1, 2, 3) if k != position // 300 + 1]
    assert lnav.decode_lnav(soft[:599], 24).ephemeris is None  # subframe 3 incomplete


def test_iodc_differing_from_iode_in_its_upper_bits_is_legal_and_a_mismatch_is_not(records):
    rec = records.subset(np.array([0]))
    sf1, sf2, sf3 = lnav.ephemeris_to_fields(rec, 1316)

    def stream(iodc, iode3):
        parts, prev = [], (0, 0)
        for sid, tow_count, values in ((1, 1, sf1 | {"iodc": iodc}), (2, 2, sf2), (3, 3, sf3 | {"iode": iode3})):
            b = lnav.encode_subframe(sid, tow_count, values, *prev)
            prev = (int(b[-2]), int(b[-1]))
            parts.append(b)
        return 1 - 2 * np.concatenate(parts).astype(float)

    iode = int(sf2["iode"])
    legal = lnav.decode_lnav(stream(iode + 512, iode), 20)
    assert legal.ephemeris is not None and legal.ephemeris.iode[0] == iode
    assert lnav.decode_lnav(stream(iode, (iode + 1) % 256), 20).ephemeris is None


@settings(max_examples=60, deadline=None)
@given(
    st.integers(-(2**31), 2**31 - 1),
    st.integers(-(2**15), 2**15 - 1),
    st.integers(0, 2**32 - 1),
    st.integers(0, 100_799),
)
def test_any_in_range_integer_field_round_trips_exactly(m0, crs, ecc, tow_count):
    values = {"m0_sc": m0 * 2.0**-31, "crs_m": crs * 2.0**-5, "e": ecc * 2.0**-33, "iode": 1}
    bits = lnav.encode_subframe(2, (tow_count + 1) % 100_800, values)  # the week's last subframe: count 0
    (sub,) = lnav.find_subframes(1 - 2 * bits.astype(float))
    names = ("m0_sc", "crs_m", "e")
    assert [sub.fields[k] for k in names] == [values[k] for k in names]
    assert sub.tow_s == tow_count * 6.0


def test_values_that_do_not_fit_their_bits_and_bad_streams_are_refused(records):
    with pytest.raises(ConfigError, match=r"lnav.subframe2.crs_m: 1100.0 does not fit 16 signed bits"):
        lnav.encode_subframe(2, 1, {"crs_m": 1100.0})
    with pytest.raises(ConfigError, match="first_tow_s"):
        lnav.encode_lnav(records.subset(np.array([0])), 1316, 7.0, 1)
    with pytest.raises(ConfigError, match="symbols: must be finite"):
        lnav.find_subframes(np.array([1.0, np.nan] * 200))
    assert lnav.find_subframes(np.ones(299)) == []


def test_lnav_symbols_start_at_the_bit_in_force(records):
    rec = records.subset(np.array([0]))
    symbols, into = lnav.lnav_symbols(rec, 1316, 6.0 * 7 + 0.4567, 400)
    assert into == pytest.approx(0.4567 - 0.44)
    full = 1 - 2 * lnav.encode_lnav(rec, 1316, 42.0, 2).astype(np.int8)
    assert np.array_equal(symbols, full[22:422])
