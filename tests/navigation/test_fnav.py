"""Galileo F/NAV on E5a-I (`navigation.fnav`).

Truth: six real F/NAV pages of E01 (GST week 1014) and the values GNSSTk decodes from them
(tests/data/gnsstk_fnav_gal_e01.hex, from GNSSTk's test data): their CRC-24Q, which a wrong
bit layout would not find at bits 215-238, and every ephemeris and clock field. Then real
broadcast Galileo records (the VILL RINEX file's) sent through pages, the code
and the interleaver and read back within the ICD's scale factors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gnssframework.errors import ConfigError
from gnssframework.navigation import fnav
from gnssframework.navigation.ephemeris import read_rinex_nav

DATA = Path(__file__).parents[1] / "data"
PI = 3.1415926535898


def _gnsstk_pages() -> dict[int, np.ndarray]:
    out = {}
    for line in (DATA / "gnsstk_fnav_gal_e01.hex").read_text().splitlines():
        if line.startswith("#") or not line.strip():
            continue
        kind, _, text = line.split()
        out[int(kind)] = np.array([int(c) for c in bin(int(text, 16))[2:].zfill(fnav.PAGE_BITS)], np.uint8)
    return out


def test_gnsstks_real_pages_pass_their_crc_and_decode_to_gnsstks_values():
    pages = _gnsstk_pages()
    decoded = {}
    for kind, bits in pages.items():
        page_type, fields, crc_ok = fnav.decode_page_bits(bits)
        assert page_type == kind and crc_ok
        decoded[page_type] = fields
    rec = fnav.pages_to_ephemeris(decoded)
    e = {k: float(v[0]) for k, v in rec.elements.items()}
    expected = {
        "Cuc": 4.610046744347e-06,
        "Cus": 1.211278140545e-05,
        "Crc": 96.34375,
        "Crs": 98.28125,
        "Cis": -3.725290298462e-09,
        "Cic": -1.490116119385e-08,
        "M0": -3.0165642165792534435,
        "DeltaN": 2.529748231311e-09,
        "Eccentricity": 1.100952504203e-04,
        "sqrtA": 5440.6226139068603516,
        "Omega0": 2.9631768162768818975,
        "Io": 0.98982515960810546485,
        "omega": 0.14027684908239376749,
        "OmegaDot": -5.110570018612e-09,
        "IDOT": -1.832219176426e-10,
        "SVclockBias": -5.3351762471720576286e-04,
        "SVclockDrift": -8.0859763329499401152e-12,
        "SVclockDriftRate": 0.0,
        "TGD": -4.656613e-09,
        "Toe": 517200.0,
    }
    for name, value in expected.items():
        assert e[name] == pytest.approx(value, rel=1e-9, abs=1e-15), name
    assert rec.sv[0] == "E01" and rec.toc_s[0] == 517200.0 and rec.iode[0] == 94
    assert rec.health[0] == 0 and rec.accuracy_m[0] == pytest.approx(2.0 + 7 * 0.16)  # SISA index 107
    f1 = decoded[1]
    assert (f1["ai0_sfu"], f1["ai1_sfu_deg"], f1["ai2_sfu_deg2"]) == (45.75, 0.1640625, 0.00067138671875)
    assert [decoded[t]["tow_s"] for t in (1, 2, 3, 4)] == [518400, 518410, 518420, 518430]
    assert {decoded[t]["wn"] for t in (1, 2, 3)} == {1014}


def test_real_pages_survive_the_code_the_interleaver_noise_and_an_inverted_stream():
    """GNSSTk's six pages as symbols (with a stream offset and every symbol negated, as a
    Costas loop may leave them, and noise at 3 dB symbol SNR): every page found on its grid,
    the same bits, the record complete; one corrupted page is reported, not used."""
    pages = np.array([bits for _, bits in sorted(_gnsstk_pages().items())])
    rng = np.random.default_rng(4)
    symbols = -fnav.page_symbols(pages).reshape(-1).astype(float)
    stream = np.concatenate([rng.standard_normal(137), symbols]) + 0.7 * rng.standard_normal(137 + symbols.size)
    msg = fnav.decode_fnav(stream)
    assert [p.page_type for p in msg.pages] == [1, 2, 3, 4, 5, 6]
    assert [p.start for p in msg.pages] == [137 + 500 * k for k in range(6)] and all(p.inverted for p in msg.pages)
    assert all(np.array_equal(p.bits, b) for p, b in zip(msg.pages, pages))
    assert msg.ephemeris is not None and msg.ephemeris.iode[0] == 94 and msg.failures == []
    assert msg.gst == (137 + 1500, 1014, 518430.0)
    broken = stream.copy()
    broken[137 + 500 + 12 : 137 + 500 + 200] *= -1  # page 2's coded symbols
    bad = fnav.decode_fnav(broken)
    assert [p.page_type for p in bad.pages] == [1, 3, 4, 5, 6] and bad.ephemeris is None
    assert bad.failures == ["F/NAV page at symbol 637: CRC-24Q failed; not used"]


def test_broadcast_records_come_back_through_pages_within_their_scale_factors():
    """The VILL file's Galileo records: encoded (`fnav_symbols` from a GST
    mid-page) and decoded, each element within half its LSB and the health and IODnav kept."""
    nav = read_rinex_nav(DATA / "VILL00ESP_R_20181700000_06H_MN.rnx", systems="E")
    keep = np.flatnonzero(nav.elements["Toe"] % 60 == 0)[:3]
    assert keep.size >= 1
    lsb = {"M0": 2**-31 * PI, "Eccentricity": 2**-33, "sqrtA": 2**-19, "SVclockBias": 2**-34, "TGD": 2**-32}
    for k in keep:
        rec = nav.subset(np.array([k]))
        symbols, into = fnav.fnav_symbols(rec, 1000, 345_617.3, 2600)
        assert 0.0 <= into <= 0.02 + 1e-9  # the symbol in force started at most one symbol before
        msg = fnav.decode_fnav(symbols.astype(float))
        assert msg.ephemeris is not None
        got = msg.ephemeris
        assert got.sv[0] == rec.sv[0] and got.iode[0] == rec.iode[0] and got.toc_s[0] == rec.toc_s[0]
        assert got.health[0] == int(rec.health[0]) & 0b111000  # F/NAV sends the E5a bits (3-5)
        for name, step in lsb.items():
            assert abs(got.elements[name][0] - rec.elements[name][0]) <= step / 2 + 1e-18, name


def test_a_value_out_of_its_field_is_refused_in_one_line():
    with pytest.raises(ConfigError, match=r"fnav.page1.af2_s_s2: 1.0 does not fit 6 signed bits") as err:
        fnav.encode_page(1, {"af2_s_s2": 1.0})
    assert "\n" not in str(err.value)
    with pytest.raises(ConfigError, match="F/NAV page types"):
        fnav.encode_page(5, {})
    with pytest.raises(ConfigError, match="missing: an F/NAV ephemeris needs page types 1-4"):
        fnav.pages_to_ephemeris({1: {}})
