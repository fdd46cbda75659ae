"""The files `receive` writes beside positions.csv for other GNSS tools: the RINEX 3.04
navigation file of the decoded ephemerides (read back by georinex), NMEA GSA/GSV (parsed by
pynmea2), the GeoJSON and KML track, the per-channel Parquet table (pandas) and the progress
lines off a terminal."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from gnssframework.errors import ConfigError
from gnssframework.navigation import lnav
from gnssframework.navigation.ephemeris import read_rinex_nav
from gnssframework.receiver.navigation.rinex_nav import NavRecord, decoded_records, write_rinex_nav
from lnav_recordings import NAV, TOW0

WEEK = 1316
#: Page 18 as broadcast (IS-GPS-200 20.3.3.5.1.7 scales: the encoder quantizes them).
IONO = lnav.IonoUtc((1.1176e-08, 7.4506e-09, -5.9605e-08, -5.9605e-08), (90112.0, 16384.0, -196608.0, -65536.0),
                    9.3e-10, 1.8e-15, 405504.0, 1316 % 256, 14)


@pytest.fixture(scope="module")
def decoded():
    """Two satellites' records of the test navigation file, sent as LNAV and decoded (the
    receiver's own decoder: the values a receive run holds), with the decoded page 18."""
    nav = read_rinex_nav(NAV)
    sel = nav.select(np.unique(nav.sv)[:2], TOW0)
    first = (int(TOW0) // 30 + 1) * 30
    out = {}
    iono = None
    for k in range(sel.sv.size):
        rec = sel.subset(np.array([k]))
        symbols, _ = lnav.lnav_symbols(rec, WEEK, first, 50 * 30, IONO)
        message = lnav.decode_lnav(symbols, int(rec.sv[0][1:]))
        out[int(rec.sv[0][1:])] = message.ephemeris
        iono = message.iono_utc
    return out, iono, first


def _read_back(path):
    import georinex

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        return georinex.load(path)


def test_georinex_reads_the_navigation_file_back_to_the_decoded_values(decoded, tmp_path):
    records, iono, first = decoded
    navs = [NavRecord(prn, rec, WEEK, first + 30.0) for prn, rec in records.items()]
    path = write_rinex_nav(tmp_path / "navigation.rnx", navs, iono)
    data = _read_back(path)
    assert sorted(data.sv.values) == sorted(f"G{p:02d}" for p in records)
    for prn, rec in records.items():
        one = data.sel(sv=f"G{prn:02d}").dropna("time", how="all")
        assert one.time.size == 1
        # Toc as a date: GPS week 1316 plus the record's Toc (s of week), no leap seconds.
        toc = np.datetime64("1980-01-06") + np.timedelta64(int(WEEK * 604800 + rec.toc_s[0]), "s")
        assert one.time.values[0] == toc
        for name, values in rec.elements.items():
            # D19.12: 13 significant digits, so within half a unit of the 13th.
            assert float(one[name].values[0]) == pytest.approx(float(values[0]), rel=5e-13, abs=1e-300), name
        assert float(one["IODE"].values[0]) == rec.iode[0] == float(one["IODC"].values[0])
        assert float(one["health"].values[0]) == rec.health[0]
        assert float(one["SVacc"].values[0]) == rec.accuracy_m[0]
        assert float(one["GPSWeek"].values[0]) == WEEK
        assert float(one["TransTime"].values[0]) == first + 30.0
    # The header's Klobuchar coefficients (D12.4: 5 significant digits) as decoded.
    corr = data.attrs["ionospheric_corr_GPS"]
    assert np.allclose(corr, np.concatenate([iono.alpha, iono.beta]), rtol=5e-5, atol=0)
    text = path.read_text()
    assert "    14" + " " * 54 + "LEAP SECONDS" in text


def test_the_files_records_give_the_satellites_positions_of_the_decoded_ones(decoded, tmp_path):
    from gnssframework.navigation.ephemeris import satellite_state

    records, iono, first = decoded
    path = write_rinex_nav(tmp_path / "navigation.rnx", [NavRecord(p, r, WEEK, first) for p, r in records.items()])
    back = read_rinex_nav(path)
    for prn, rec in records.items():
        t = np.array([first, first + 3600.0])
        again = back.select([f"G{prn:02d}"], first)
        assert np.abs(satellite_state(again, t).position_m - satellite_state(rec, t).position_m).max() < 1e-3
    assert "IONOSPHERIC CORR" not in path.read_text()  # no page 18 given, no header line


def test_decoded_records_are_deduplicated_and_dated_by_the_receiver_clock(decoded):
    records, _, _ = decoded
    prn, rec = next(iter(records.items()))
    # Epochs every 0.1 s of recording time from GPS tow 604799.5: the week rolls over.
    sample = np.arange(0, 2.0, 0.1)
    rx = (604_799.5 + sample) % 604_800.0
    navs = decoded_records({prn: [(0.3, rec), (1.7, rec)]}, sample, rx, WEEK)
    assert len(navs) == 1  # the same Toc and IODE decoded twice: one record
    assert navs[0].week == WEEK and navs[0].tow_s == pytest.approx(604_799.8)
    late = decoded_records({prn: [(1.7, rec)]}, sample, rx, WEEK)[0]
    assert late.week == WEEK + 1 and late.tow_s == pytest.approx(1.2)
    with pytest.raises(ConfigError, match="week"):
        decoded_records({prn: [(0.3, rec)]}, sample, rx, -1)


def test_no_record_or_another_systems_layout_is_refused(decoded, tmp_path):
    from gnssframework.signal.galileo_e1 import GALILEO_E1B

    records, _, first = decoded
    with pytest.raises(ConfigError, match="no ephemeris"):
        write_rinex_nav(tmp_path / "n.rnx", [])
    with pytest.raises(ConfigError, match="'E'"):
        write_rinex_nav(tmp_path / "n.rnx", [NavRecord(1, records[1], WEEK, first)], signal=GALILEO_E1B)
