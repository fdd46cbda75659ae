"""I/NAV word types 5, 6 and 10: NeQuick ai0-ai2, GST-UTC and GGTO (`inav_words`, `inav_params`).

Truth, independent of the project's layout table and encoder: three real RINEX navigation
headers (sbf2rin, IGS merge) whose ``GAL`` ionospheric and ``GAUT`` / ``GAGP`` (``GPGA``)
time-system lines are broadcast values. Each must be a whole number of the ICD's LSB (to
the printed digits): that checks the scale factors. The words are then built bit by bit
here from the ICD's field order and widths (OS SIS ICD 4.3.5, word types 5, 6 and 10,
typed below, not read from `WORD_LAYOUTS`) and decoded, and must give the header's values
back to the printed digits; the GGTO polynomial agrees with the project's RINEX header
reader (`rinex_nav_header`) at times around the reference.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from gnssframework.navigation import inav, inav_words
from gnssframework.navigation.ephemeris import read_rinex_nav
from gnssframework.navigation.inav_params import (
    Ggto,
    GstUtc,
    InavIonoTime,
    iono_time_from_words,
    merge_iono_time,
)
from gnssframework.navigation.rinex_nav_header import read_nav_file_info
from gnssframework.navigation.weeks import full_week

DATA = Path(__file__).parents[1] / "data"
FILES = (
    "galileo_inav_20feb2022_05h.rnx",
    "VILL00ESP_R_20181700000_06H_MN.rnx",
    "BRDC00IGS_R_20201361400_02H_EN.rnx",
)
# LSBs typed from the ICD's tables (5.1.6 ai, 5.1.7 GST-UTC, 5.1.8 GST-GPS).
AI_LSB = (2.0**-2, 2.0**-8, 2.0**-15)
A0_LSB, A1_LSB, A0G_LSB, A1G_LSB, T_LSB = 2.0**-30, 2.0**-50, 2.0**-35, 2.0**-51, 3600.0


def _half_digit(value: float, decimals: int) -> float:
    """Half a unit of the last printed digit of ``value`` in ``D.decimals`` format."""
    return 0.0 if value == 0 else 0.5 * 10.0 ** (math.floor(math.log10(abs(value))) - decimals)


def _header(name: str) -> dict[str, tuple]:
    """GAL (ai0-ai2), GAUT and GGTO (GAGP or GPGA: a0, a1, T, W) of a header, by RINEX 3.04 columns."""
    out = {}
    for line in (DATA / name).read_text().splitlines():
        label = line[60:].strip()
        if label == "IONOSPHERIC CORR" and line[:4] == "GAL ":
            out["GAL"] = tuple(float(line[5 + 12 * k : 17 + 12 * k].replace("D", "E")) for k in range(3))
        elif label == "TIME SYSTEM CORR" and line[:4] in ("GAUT", "GAGP", "GPGA"):
            key = "GAUT" if line[:4] == "GAUT" else "GGTO"
            out[key] = (float(line[5:22]), float(line[22:38]), int(line[38:45]), int(line[45:50]))
        elif label == "END OF HEADER":
            break
    return out


def _whole(value: float, lsb: float, decimals: int) -> int:
    """``value`` in LSBs, asserted whole to the printed digits."""
    q = round(value / lsb)
    assert abs(value - q * lsb) <= _half_digit(value, decimals) + 1e-30, (value, lsb)
    return q


def _pack(fields: list[tuple[int, int]]) -> np.ndarray:
    """128 bits of ``(integer, width)`` fields in order, MSB first, two's complement."""
    bits = [(value >> (width - 1 - k)) & 1 for value, width in fields for k in range(width)]
    assert len(bits) == 128
    return np.array(bits, dtype=np.uint8)


@pytest.mark.parametrize("name", FILES)
def test_broadcast_header_values_are_whole_icd_lsbs_and_hand_built_words_decode_to_them(name):
    h = _header(name)
    ai = [_whole(v, lsb, 4) for v, lsb in zip(h["GAL"], AI_LSB)]
    a0, a1, tot, wnt = h["GAUT"]
    a0g, a1g, t0g, wn0g = h["GGTO"]
    q = dict(
        a0=_whole(a0, A0_LSB, 10),
        a1=_whole(a1, A1_LSB, 9),
        a0g=_whole(a0g, A0G_LSB, 10),
        a1g=_whole(a1g, A1G_LSB, 9),
    )
    assert tot % 3600 == 0 and t0g % 3600 == 0
    # Word type 5 (ICD 4.3.5): type 6, ai0 11, ai1 11, ai2 14, regions 5x1, BGD 10+10, HS 2+2,
    # DVS 1+1, WN 12, TOW 20, spare 23.
    w5 = _pack(
        [(5, 6), (ai[0], 11), (ai[1], 11), (ai[2], 14), (0b10101, 5), (0, 20), (0, 6), (1174, 12), (3601, 20), (0, 23)]
    )
    # Word type 6: type 6, A0 32, A1 24, dtLS 8, t0t 8, WN0t 8, WN_LSF 8, DN 3, dtLSF 8, TOW 20, spare 3.
    w6 = _pack(
        [(6, 6), (q["a0"], 32), (q["a1"], 24), (18, 8), (tot // 3600, 8), (wnt % 256, 8)]
        + [(wnt % 256, 8), (7, 3), (-3, 8), (604799, 20), (0, 3)]
    )
    # Word type 10: type 6, IODa 4, SVID3's Omega0 16, Omega-dot 11, M0 16, af0 16, af1 13,
    # E5b HS 2, E1-B HS 2, A0G 16, A1G 12, t0G 8, WN0G 6.
    w10 = _pack(
        [(10, 6), (9, 4), (-1, 16), (-1, 11), (-1, 16), (-1, 16), (-1, 13), (2, 2), (1, 2)]
        + [(q["a0g"], 16), (q["a1g"], 12), (t0g // 3600, 8), (wn0g % 64, 6)]
    )
    words = {}
    for bits in (w5, w6, w10):
        word_type, fields = inav_words.decode_word(bits)
        words[word_type] = fields
    assert sorted(words) == [5, 6, 10]
    got = iono_time_from_words(words)
    for v, want in zip(got.ai_sfu, h["GAL"]):
        assert abs(v - want) <= _half_digit(want, 4)
    u, g = got.utc, got.ggto
    assert abs(u.a0_s - a0) <= _half_digit(a0, 10) and abs(u.a1_s_s - a1) <= _half_digit(a1, 9)
    assert (u.dt_ls_s, u.tot_s, u.dn, u.dt_lsf_s) == (18, tot, 7, -3)
    assert full_week(u.wnt, 8, wnt + 100) == wnt and full_week(u.wn_lsf, 8, wnt - 100) == wnt
    assert abs(g.a0g_s - a0g) <= _half_digit(a0g, 10) and abs(g.a1g_s_s - a1g) <= _half_digit(a1g, 9)
    assert g.t0g_s == t0g and full_week(g.wn0g, 6, wn0g + 20) == wn0g
    assert (words[10]["iod_a"], words[10]["e5b_hs"], words[10]["e1b_hs"]) == (9, 2, 1)
    assert (words[6]["tow_s"], words[5]["tow_s"], words[5]["wn"]) == (604799, 3601, 1174)
    assert [words[5][f"region{k}"] for k in range(1, 6)] == [1, 0, 1, 0, 1]
    # The polynomial agrees with the project's RINEX header reader over +-3 days of t0G.
    info = read_nav_file_info(DATA / name)
    for dt in (-259200.0, 0.0, 3600.0, 259200.0):
        week, tow = wn0g + int((t0g + dt) // 604800), (t0g + dt) % 604800
        bound = _half_digit(a0g, 10) + _half_digit(a1g, 9) * abs(dt) + 1e-20
        assert abs(g.offset_s(week, tow) - info.ggto_s(week, tow)) <= bound


def test_encode_inav_sends_words_6_and_10_that_decode_to_the_same_values():
    rec = read_rinex_nav(DATA / FILES[0], systems="E").subset(np.array([0]))
    truth = InavIonoTime(
        (81.25, -63 * 2.0**-8, 123 * 2.0**-15),
        GstUtc(-(2.0**-30), 2.0**-50, 18, 0.0, 2198 % 256, 1929 % 256, 7, 18),
        Ggto(203 * 2.0**-35, 8 * 2.0**-51, 86400.0, 2198 % 64),
    )
    symbols = inav.encode_inav(rec, 1174, 1, 15, iono_time=truth)  # one 30 s sub-frame
    msg = inav.decode_inav(symbols)
    assert [p.word_type for p in msg.pages] == [2, 4, 6, 0, 10, 0, 0, 0, 0, 0, 1, 3, 5, 0, 0]
    assert msg.iono_time == truth
    assert msg.words[6]["tow_s"] == 5  # the page at GST 5 s carries word 6
    # Without the parameters the slots stay word type 0, as before.
    assert [p.word_type for p in inav.decode_inav(inav.encode_inav(rec, 1174, 1, 5)).pages] == [2, 4, 0, 0, 0]


def test_out_of_range_values_are_refused_naming_the_field():
    from gnssframework.errors import ConfigError

    with pytest.raises(ConfigError, match=r"inav\.word10\.a0g_s"):
        inav_words.encode_word(10, {"a0g_s": 2.0**-35 * 40000})


def test_merge_keeps_the_newer_parts_and_the_older_where_the_newer_has_none():
    a = InavIonoTime((1.0, 0.0, 0.0), None, Ggto(0.0, 0.0, 0.0, 1))
    b = InavIonoTime(None, GstUtc(0.0, 0.0, 18, 0.0, 0, 0, 1, 18), Ggto(1e-9, 0.0, 3600.0, 2))
    m = merge_iono_time(a, b)
    assert m.ai_sfu == a.ai_sfu and m.utc == b.utc and m.ggto == b.ggto
    assert merge_iono_time(None, b) is b and merge_iono_time(a, None) is a
