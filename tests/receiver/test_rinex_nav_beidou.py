"""BeiDou records in the receiver's RINEX navigation file (`rinex_nav`, RINEX 3.04 table A13).

Truth: real BDS records written by sbf2rin (tests/data/VILL00ESP_R_20181700000_06H_MN.rnx,
MEO, IGSO and GEO): written again by the project's writer, each record's epoch line (the
Toc in BDT's calendar) is sbf2rin's, its BDT week field is sbf2rin's, and the project's
reader (georinex) reads every field back to sbf2rin's values."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gnssframework.errors import ConfigError
from gnssframework.navigation.ephemeris import read_rinex_nav
from gnssframework.receiver.navigation.rinex_nav import NavRecord, write_rinex_nav
from gnssframework.signal.beidou_b1i import BEIDOU_B1I, BEIDOU_B1I_GEO
from gnssframework.signal.gps_l1ca import GPS_L1CA

VILL = Path(__file__).parents[1] / "data" / "VILL00ESP_R_20181700000_06H_MN.rnx"
GPS_WEEK = 2006  # 2018-06-19


def _firsts():
    nav = read_rinex_nav(VILL, systems="C")
    _, first = np.unique(nav.sv, return_index=True)
    return nav.subset(np.sort(first))


def _sbf2rin_record(sv: str) -> list[str]:
    lines = VILL.read_text().splitlines()
    k = next(i for i, ln in enumerate(lines) if ln.startswith(sv + " "))
    return lines[k : k + 8]


@pytest.mark.parametrize("signal", [BEIDOU_B1I, BEIDOU_B1I_GEO])
def test_bds_records_are_written_as_sbf2rin_wrote_them_and_read_back(signal, tmp_path):
    recs = _firsts()
    mine = [k for k, sv in enumerate(recs.sv) if int(str(sv)[1:]) in signal.prns]
    assert mine  # MEO/IGSO for beidou-b1i, C05 for the GEO description
    navs = []
    for k in mine:
        rec = recs.subset(np.array([k]))
        had_gps_tow = (float(rec.toc_s[0]) + 18.0 + 14.0) % 604_800  # BDT toc + 18 s, in GPS time
        navs.append(NavRecord(int(str(rec.sv[0])[1:]), rec, GPS_WEEK, had_gps_tow))
    path = write_rinex_nav(tmp_path / "navigation.rnx", navs, signal=signal)
    text = path.read_text().splitlines()
    assert text[0][20:60].strip().startswith("N: GNSS NAV DATA") and text[0][40:41] == "C"
    back = read_rinex_nav(path, systems="C")
    for k in mine:
        sv = str(recs.sv[k])
        ours = text[text.index(next(ln for ln in text if ln.startswith(sv + " "))) :][:8]
        theirs = _sbf2rin_record(sv)
        assert ours[0][:23] == theirs[0][:23]  # "C11 2018 06 19 00 00 00": the Toc in BDT
        assert float(ours[5][42:61].replace("D", "E")) == float(theirs[5][42:61])  # BDT week
        j = int(np.flatnonzero(back.sv == sv)[0])
        assert back.toc_s[j] == recs.toc_s[k] and back.health[j] == recs.health[k] and back.iode[j] == recs.iode[k]
        assert back.accuracy_m[j] == pytest.approx(recs.accuracy_m[k])
        for name, v in recs.elements.items():
            assert back.elements[name][j] == pytest.approx(v[k], rel=1e-11, abs=1e-22), (sv, name)


def test_a_gps_record_is_not_written_as_a_bds_one(tmp_path):
    gps = read_rinex_nav(VILL, systems="G").subset(np.array([0]))
    with pytest.raises(ConfigError, match="not a BeiDou record"):
        write_rinex_nav(tmp_path / "n.rnx", [NavRecord(21, gps, GPS_WEEK, 100.0)], signal=BEIDOU_B1I)
    bds = _firsts().subset(np.array([1]))
    with pytest.raises(ConfigError, match="a BeiDou record as G"):
        write_rinex_nav(tmp_path / "n.rnx", [NavRecord(5, bds, GPS_WEEK, 100.0)], signal=GPS_L1CA)


def test_d1s_klobuchar_coefficients_go_in_the_header_as_bdsa_and_bdsb(tmp_path):
    """D1 subframe 1's coefficients (GNSSTk's C06 values) as RINEX 3.04's ``BDSA``/``BDSB``
    lines, read back by georinex and by the project's header reader to the written precision
    (D12.4: 5e-5 relative); the reader offers them to a BeiDou run only."""
    import warnings

    import georinex

    from gnssframework.navigation.bds_iono import BdsKlobuchar

    iono = BdsKlobuchar(
        (6.519258e-09, 2.98023223876953125e-08, -2.98023223876953125e-07, 4.17232513427734375e-07),
        (112640.0, 180224.0, -524288.0, 458752.0),
    )
    recs = _firsts()
    rec = recs.subset(np.array([int(np.flatnonzero(recs.sv == "C11")[0])]))
    nav = NavRecord(11, rec, GPS_WEEK, (float(rec.toc_s[0]) + 32.0) % 604_800)
    path = write_rinex_nav(tmp_path / "navigation.rnx", [nav], signal=BEIDOU_B1I, bds_iono=iono)
    lines = [ln for ln in path.read_text().splitlines() if ln[60:].strip() == "IONOSPHERIC CORR"]
    assert [ln[:4] for ln in lines] == ["BDSA", "BDSB"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        hdr = georinex.rinexheader(path)
    np.testing.assert_allclose(hdr["IONOSPHERIC CORR"]["BDSA"], iono.alpha, rtol=5e-5)
    np.testing.assert_allclose(hdr["IONOSPHERIC CORR"]["BDSB"], iono.beta, rtol=5e-5)
    # The project's reader: the fallback model of a BeiDou run given this file (none for GPS's).
    from gnssframework.navigation.rinex_nav_header import read_nav_file_info

    info = read_nav_file_info(path)
    assert info.iono is None and info.bds_iono is not None
    np.testing.assert_allclose(info.bds_iono.alpha + info.bds_iono.beta, iono.alpha + iono.beta, rtol=5e-5)
    assert info.iono_for("C") is info.bds_iono and info.iono_for("GC") is None and info.iono_for("G") is None
