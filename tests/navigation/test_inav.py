"""Galileo I/NAV on E1-B (gnssframework.navigation.inav, inav_words): real broadcast
I/NAV records (tests/data: galileo-sdr-sim's 2022-02-20 file, 21 satellites, and the VILL
station's 2018 file, 3) encoded into pages,
sent through noise, decoded, and compared field by field within half the ICD's LSB and
in satellite position within what that quantisation can move it; the page layout against
the ICD's bit allocation; CRC failures and bad input reported in one line."""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gnssframework.errors import ConfigError
from gnssframework.navigation import fec, inav, inav_words
from gnssframework.navigation.ephemeris import Ephemerides, gps_seconds_of_week, read_rinex_nav, satellite_state

DATA = Path(__file__).parents[1] / "data"
PI = 3.1415926535898  # Galileo OS SIS ICD 5.1.1
# LSB of every RINEX field, typed from the ICD's parameter tables of 5.1 (angles x pi).
LSB = {
    "M0": 2.0**-31 * PI,
    "DeltaN": 2.0**-43 * PI,
    "Eccentricity": 2.0**-33,
    "sqrtA": 2.0**-19,
    "Omega0": 2.0**-31 * PI,
    "Io": 2.0**-31 * PI,
    "omega": 2.0**-31 * PI,
    "OmegaDot": 2.0**-43 * PI,
    "IDOT": 2.0**-43 * PI,
    "Cuc": 2.0**-29,
    "Cus": 2.0**-29,
    "Crc": 2.0**-5,
    "Crs": 2.0**-5,
    "Cic": 2.0**-29,
    "Cis": 2.0**-29,
    "Toe": 60.0,
    "SVclockBias": 2.0**-34,
    "SVclockDrift": 2.0**-46,
    "SVclockDriftRate": 2.0**-59,
    "TGD": 2.0**-32,
}
# Per file: name, the header's GAL IONOSPHERIC CORR (ai0, ai1, ai2), the GAL week of its
# records (continuous with GPS's) as GST's 12-bit count, how many satellites have I/NAV records.
FILES = {
    "galileo-sdr-sim": ("galileo_inav_20feb2022_05h.rnx", (81.25, -0.24609, 0.0037537), 2198 - 1024, 21),
    "VILL00ESP": ("VILL00ESP_R_20181700000_06H_MN.rnx", (34.0, 0.11719, 0.012848), 2006 - 1024, 3),
}


@dataclass(frozen=True)
class Case:
    records: list[tuple[Ephemerides, float]]  # (one record, its BGD(E1,E5a))
    ai: tuple[float, float, float]
    week: int


@pytest.fixture(scope="module", params=sorted(FILES))
def case(request) -> Case:
    """The first I/NAV record (RINEX data source bit 9: clock for E5b,E1) of each
    satellite, with its BGD(E1,E5a), which an Ephemerides record does not keep."""
    import georinex

    name, ai, week, n_sats = FILES[request.param]
    eph = read_rinex_nav(DATA / name, systems="E")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        raw = georinex.load(DATA / name, use="E")
    bgd = {}
    for sv in raw.sv.values.astype(str):
        src = raw["DataSrc"].sel(sv=sv).values
        for t in np.flatnonzero(np.isfinite(src) & (np.nan_to_num(src).astype(int) & 512 > 0)):
            key = (sv.split("_")[0], float(gps_seconds_of_week(raw.time.values[t])))
            bgd[key] = (float(raw["BGDe5a"].sel(sv=sv).values[t]), float(raw["BGDe5b"].sel(sv=sv).values[t]))
    out, seen = [], set()
    for k in range(eph.sv.size):
        key = (str(eph.sv[k]), float(eph.toc_s[k]))
        if key in bgd and key[0] not in seen and eph.elements["TGD"][k] == bgd[key][1]:
            seen.add(key[0])
            out.append((eph.subset(np.array([k])), bgd[key][0]))
    assert len(out) == n_sats
    return Case(out, ai, week)


def _noisy(symbols: np.ndarray, sigma: float, seed: int) -> np.ndarray:
    return symbols + np.random.default_rng(seed).normal(0, sigma, symbols.size)


def test_page_parts_follow_the_icd_bit_allocation():
    # ICD 4.3.2.2: even = E/O 0, page type 0, data 112, tail 6; odd = E/O 1, page type, data 16,
    # OSNMA 40, SAR 22, spare 2, CRC 24, SSP 8, tail 6; CRC over the 196 bits before it.
    rng = np.random.default_rng(1)
    word = rng.integers(0, 2, 128).astype(np.uint8)
    osnma, sar, ssp = rng.integers(0, 2, 40), rng.integers(0, 2, 22), np.array([0, 0, 1, 0, 1, 0, 1, 1])
    even, odd = inav.page_part_bits(word[None], osnma=osnma, sar=sar, ssp=ssp)[0]
    assert even[0] == 0 and even[1] == 0 and np.array_equal(even[2:114], word[:112]) and not even[114:].any()
    assert odd[0] == 1 and odd[1] == 0 and np.array_equal(odd[2:18], word[112:])
    assert np.array_equal(odd[18:58], osnma) and np.array_equal(odd[58:80], sar) and not odd[80:82].any()
    covered = np.concatenate([even[:114], odd[:82]])
    assert covered.size == 196
    crc = int("".join(map(str, odd[82:106])), 2)
    assert crc == fec.crc24q_bits(covered)
    assert np.array_equal(odd[106:114], ssp) and not odd[114:].any()
    symbols = inav.encode_pages(word[None], osnma=osnma, sar=sar, ssp=ssp)[0]
    # Both parts start with the sync pattern 0101100000 (bit 0 as +1); ICD 5.1.9.5: the odd
    # part's last 16 coded symbols (the last of its interleaved block) are SSP2's "0110110001001110".
    assert list(symbols[:10]) == list(symbols[250:260]) == [1, -1, 1, -1, -1, 1, 1, 1, 1, 1]
    odd_coded = fec.deinterleave((1 - symbols[260:]) // 2)
    assert "".join(map(str, odd_coded[-16:])) == "0110110001001110"


def test_word_layouts_fill_128_bits_without_overlap():
    for word_type, layout in inav_words.WORD_LAYOUTS.items():
        used = np.zeros(129, int)
        used[1:7] += 1
        for first, n, _, _ in layout.values():
            used[first : first + n] += 1
        assert used.max() == 1, word_type
        # Reserved/spare bits left free (ICD 4.3.5): type 0's 88 spare, 1, 2, 4: 2; 3: none; 5: 23;
        # 6: 3 spare; 10: the 72 bits of SVID3's almanac not read (Omega0 16, Omega-dot 11, M0 16,
        # af0 16, af1 13).
        assert 128 - used.sum() == {0: 88, 1: 2, 2: 2, 3: 0, 4: 2, 5: 23, 6: 3, 10: 72}[word_type]


def test_sisa_index_table():
    # The ICD's SISA index table (5.1): the file's 3.12 m is index 107.
    assert [inav_words.sisa_m(k) for k in (0, 49, 50, 74, 75, 99, 100, 107, 125, 126, 255)] == [
        0.0,
        0.49,
        0.5,
        0.98,
        1.0,
        1.96,
        2.0,
        3.12,
        6.0,
        -1.0,
        -1.0,
    ]
    assert inav_words.sisa_index(3.12) == 107 and inav_words.sisa_index(-1.0) == 255


def test_real_records_round_trip_through_noisy_pages_within_half_an_lsb(case):
    # Seven pages from GST 18021 s (mod 30 = 21): words 1, 3, 5, 0, 0, 2, 4 (ICD 4.3.3's E1-B order).
    # Noise sigma 0.5 on ±1 symbols (Es/N0 = 3 dB): about 2.3 % of the symbols arrive with the wrong sign.
    flipped = 0
    total = 0
    for k, (rec, bgd_e5a) in enumerate(case.records):
        sent = inav.encode_inav(rec, case.week, 18021, 7, bgd_e1e5a_s=bgd_e5a, ai_sfu=case.ai)
        received = -_noisy(sent, 0.5, k)  # and inverted, as a Costas loop may leave it
        flipped += int(np.sum(np.sign(received) != -sent))
        total += sent.size
        msg = inav.decode_inav(np.concatenate([np.random.default_rng(k).normal(0, 1, 37 + k), received]))
        assert msg.failures == [] and len(msg.pages) == 7 and all(p.inverted for p in msg.pages)
        got = msg.ephemeris
        assert got is not None and got.sv[0] == rec.sv[0]
        for name, lsb in LSB.items():
            err = abs(got.elements[name][0] - rec.elements[name][0])
            assert err <= 0.5 * lsb * (1 + 1e-9) + 1e-15 * abs(rec.elements[name][0]), (rec.sv[0], name, err / lsb)
        assert got.toc_s[0] == rec.toc_s[0] and got.iode[0] == rec.iode[0] and got.health[0] == rec.health[0]
        assert got.accuracy_m[0] == rec.accuracy_m[0]
        w5 = msg.words[5]
        assert abs(w5["bgd_e1e5a_s"] - bgd_e5a) <= 2.0**-33 * (1 + 1e-9)
        for name, value in zip(("ai0_sfu", "ai1_sfu_deg", "ai2_sfu_deg2"), case.ai):
            assert abs(w5[name] - value) <= 0.5 * inav_words.LSB[name]
        # GST: word 5 sent in the third page (GST 18025 s); the last page word 4 at 18033 s,
        # the last GST-carrying page word 0 at 18029 s, page 5 of the stream.
        assert w5["wn"] == case.week and w5["tow_s"] == 18025
        assert msg.gst == (37 + k + 4 * inav.PAGE_SYMBOLS, case.week, 18029.0)
    assert 0.015 < flipped / total < 0.035  # the channel did corrupt symbols (Q(2) = 2.3 %)


def test_decoded_position_and_clock_within_the_quantisations_effect(case):
    # The file's values are broadcast ones (whole LSBs), which decode exactly; each field is
    # moved off its grid by a random fraction of its LSB first, so quantisation acts. The
    # bound: sum over fields of |d state / d field| x half an LSB (finite differences of
    # satellite_state on the moved record), first order, over +-2 h of Toe. Toe (60 s LSB)
    # stays a whole minute, sent exactly.
    rng = np.random.default_rng(7)
    worst = 0.0
    for k, (rec0, bgd_e5a) in enumerate(case.records[:8]):
        moved_elements = {
            name: v + (rng.uniform(-0.5, 0.5) * LSB[name] if name in LSB and name != "Toe" else 0.0)
            for name, v in rec0.elements.items()
        }
        rec = Ephemerides(rec0.sv, rec0.toc_s, moved_elements, rec0.health, rec0.iode, rec0.accuracy_m)
        msg = inav.decode_inav(_noisy(inav.encode_inav(rec, case.week, 18021, 7, bgd_e5a, case.ai), 0.5, 100 + k))
        assert msg.ephemeris.elements["Toe"][0] == rec.elements["Toe"][0]
        t = rec.elements["Toe"][0] + np.array([-7200.0, -3600.0, 0.0, 3600.0, 7200.0])
        ref = satellite_state(rec, t[:, None])
        got = satellite_state(msg.ephemeris, t[:, None])
        bound_pos = np.zeros(t.size)
        bound_clk = np.zeros(t.size)
        for name, lsb in LSB.items():
            if name == "Toe":
                continue
            step = {**rec.elements, name: rec.elements[name] + 0.5 * lsb}
            moved = satellite_state(Ephemerides(rec.sv, rec.toc_s, step, rec.health, rec.iode), t[:, None])
            bound_pos += np.linalg.norm(moved.position_m - ref.position_m, axis=-1)[:, 0]
            bound_clk += np.abs(moved.clock_s - ref.clock_s)[:, 0]
        err_pos = np.linalg.norm(got.position_m - ref.position_m, axis=-1)[:, 0]
        assert np.all(err_pos <= 1.01 * bound_pos + 1e-6), (rec.sv[0], err_pos, bound_pos)
        assert np.all(np.abs(got.clock_s - ref.clock_s)[:, 0] <= 1.01 * bound_clk + 1e-15)
        assert np.all(bound_pos < 0.5)  # the quantisation's whole effect: centimetres to decimetres at +-2 h
        worst = max(worst, float(err_pos.max()))
    assert worst > 1e-3  # the quantisation did move the satellite (a few mm to cm)


def test_four_symbol_errors_in_each_part_still_decode():
    rng = np.random.default_rng(2)
    words = rng.integers(0, 2, (20, 128)).astype(np.uint8)
    symbols = inav.encode_pages(words).astype(float)
    for page in symbols:
        for part in (0, 1):
            page[part * 250 + 10 + rng.choice(240, 4, replace=False)] *= -1
    decoded = inav.decode_pages(symbols)
    assert all(np.array_equal(p.word, w) for p, w in zip(decoded, words))


def _page_with_bad_crc(word: np.ndarray) -> np.ndarray:
    parts = inav.page_part_bits(word[None])
    parts[0, 0, 40] ^= 1  # a data bit changed after the CRC was computed
    coded = fec.interleave(fec.conv_encode(parts))
    bits = np.concatenate([np.broadcast_to(inav.SYNC, (1, 2, 10)), coded], axis=-1)
    return (1 - 2 * bits.astype(np.int8)).reshape(-1)


def test_a_crc_failure_is_reported_and_its_word_not_used(case):
    rec, bgd_e5a = case.records[0]
    good = inav.encode_inav(rec, case.week, 18021, 7, bgd_e5a, case.ai).reshape(7, 500)
    bad = _page_with_bad_crc(
        np.concatenate([np.zeros(112, np.uint8), np.zeros(16, np.uint8)]) | inav_words.encode_word(1, {"iodnav": 30})
    )
    stream = np.concatenate([good[:6].reshape(-1), bad, good[6]])  # word 4 (last page) still arrives
    msg = inav.decode_inav(stream)
    assert msg.failures == ["I/NAV page at symbol 3000: CRC-24Q failed; not used"]
    assert [p.word_type for p in msg.pages] == [1, 3, 5, 0, 0, 2, 4]
    assert msg.ephemeris is not None and msg.words[1]["toe_s"] == rec.elements["Toe"][0]
    with pytest.raises(
        inav.InavCrcError,
        match=r"^I/NAV page 1 \(symbols 500-999\): CRC-24Q failed; its word "
        r"\(type 1 as read\) is not used$",
    ):
        inav.decode_pages(np.stack([good[0], bad]))


def test_bad_input_is_refused_in_one_line(case):
    with pytest.raises(ConfigError, match=r"symbols: I/NAV pages are 500 finite symbols each .*\(499,\)"):
        inav.decode_pages(np.ones(499))
    with pytest.raises(ConfigError, match="1-D"):
        inav.decode_inav(np.ones((2, 500)))
    with pytest.raises(ConfigError, match="first_tow_s"):
        inav.encode_inav(case.records[0][0], case.week, 18020, 3)
    words = inav_words.ephemeris_to_words(case.records[0][0], case.week, 18025)
    words[3]["iodnav"] += 1
    decoded = {t: inav_words.decode_word(inav_words.encode_word(t, v))[1] for t, v in words.items()}
    iod = int(words[1]["iodnav"])
    with pytest.raises(ConfigError, match=rf"^inav.word3.iodnav: {iod + 1} differs from word 1's {iod} "):
        inav_words.words_to_ephemeris(decoded)
    with pytest.raises(ConfigError, match=r"inav.word1.sqrt_a_sqrtm: .* does not fit 32 bits"):
        inav_words.encode_word(1, {"sqrt_a_sqrtm": 9000.0})
    with pytest.raises(ConfigError, match="inav.word5: missing"):
        inav_words.words_to_ephemeris({t: decoded[t] for t in (1, 2, 3, 4)})


def test_inav_symbols_start_at_the_symbol_in_force_and_cross_the_week(case):
    rec = case.records[0][0]
    symbols, lead_s = inav.inav_symbols(rec, case.week, 18020.501, 600)
    # The page in force started at 18019 s; 18020.501 s is 1 ms into its 376th symbol.
    assert lead_s == pytest.approx(0.001, abs=1e-9)
    assert np.array_equal(symbols, inav.encode_inav(rec, case.week, 18019, 2)[375:975])
    symbols, lead_s = inav.inav_symbols(rec, case.week, 0.3, 100)  # the page began at 604799 s of the week before
    assert lead_s == pytest.approx(0.0, abs=1e-9)
    assert np.array_equal(symbols, inav.encode_inav(rec, case.week - 1, 604_799, 1)[325:425])


@settings(max_examples=60, deadline=None)
@given(st.sampled_from(sorted(inav_words.WORD_LAYOUTS)), st.data())
def test_any_word_field_values_round_trip_exactly(word_type, data):
    values = {}
    for name, (_, n, scale, signed) in inav_words.WORD_LAYOUTS[word_type].items():
        lo, hi = (-(1 << (n - 1)), (1 << (n - 1)) - 1) if signed else (0, (1 << n) - 1)
        values[name] = data.draw(st.integers(lo, hi)) * scale
    got_type, got = inav_words.decode_word(inav_words.encode_word(word_type, values))
    assert got_type == word_type and got == values
