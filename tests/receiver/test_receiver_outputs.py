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
IONO = lnav.IonoUtc(
    (1.1176e-08, 7.4506e-09, -5.9605e-08, -5.9605e-08),
    (90112.0, 16384.0, -196608.0, -65536.0),
    9.3e-10,
    1.8e-15,
    405504.0,
    1316 % 256,
    14,
)


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
    from gnssframework.signal.beidou_b1c import BEIDOU_B1C
    from gnssframework.signal.galileo_e1 import GALILEO_E1B
    from gnssframework.signal.sbas_l1 import SBAS_L1

    records, _, first = decoded
    with pytest.raises(ConfigError, match="no ephemeris"):
        write_rinex_nav(tmp_path / "n.rnx", [])
    with pytest.raises(ConfigError, match="'S'"):
        write_rinex_nav(tmp_path / "n.rnx", [NavRecord(120, records[1], WEEK, first)], signal=SBAS_L1)
    # BeiDou has its own layout (test_rinex_nav_beidou), for BeiDou records only
    with pytest.raises(ConfigError, match="not a BeiDou record"):
        write_rinex_nav(tmp_path / "n.rnx", [NavRecord(1, records[1], WEEK, first)], signal=BEIDOU_B1C)
    # Galileo has its own layout (test_receive_galileo_command), for Galileo records only
    with pytest.raises(ConfigError, match="not a Galileo record"):
        write_rinex_nav(tmp_path / "n.rnx", [NavRecord(1, records[1], WEEK, first)], signal=GALILEO_E1B)


def _table(n=3, used=((3, 7, 11, 19, 28),) * 3, hdop=(0.81, 1.5, 3.0), vdop=(1.2, 2.0, 4.5)):
    from gnssframework.receiver.navigation.fixes import PositionTable

    cols = {
        "gps_week": np.full(n, 2190),
        "tow_s": 518_418.0 + np.arange(n),  # 18 leap seconds: 00:00:00 UTC
        "lat_deg": np.array([35.681298, -33.8688197, 35.9999999999][:n]),
        "lon_deg": np.array([139.766247, 151.2092955, -0.5][:n]),
        "height_m": np.array([10.0, 58.25, -20.5][:n]),
        "vel_e_mps": np.array([1.0, 0.0, np.nan][:n]),
        "vel_n_mps": np.array([1.0, -2.0, np.nan][:n]),
        "vel_u_mps": np.zeros(n),
        "clock_bias_m": np.zeros(n),
        "n_sats": np.array([len(u) for u in used]),
        "hdop": np.array(hdop[:n]),
        "vdop": np.array(vdop[:n]),
    }
    return PositionTable(cols, np.zeros((n, 3)), np.arange(n, dtype=float), list(used), np.zeros(n, int))


def test_gsa_holds_the_prns_used_and_the_dops_of_the_geometry():
    import pynmea2

    from gnssframework.navigation.pvt import dop
    from gnssframework.receiver.navigation.nmea_out import nmea_sentences

    # Five satellites at known azimuths/elevations: their DOPs by pvt.dop (the fixes' own).
    az, el = np.radians([0, 72, 144, 216, 288]), np.radians([80, 30, 45, 15, 60])
    unit = np.stack([np.cos(el) * np.sin(az), np.cos(el) * np.cos(az), np.sin(el)], axis=1)
    _, pdop, hdop, vdop = dop(unit)
    table = _table(1, used=((28, 3, 19, 7, 11),), hdop=(hdop,), vdop=(vdop,))
    lines = nmea_sentences(table, gsa=True)
    parsed = [pynmea2.parse(s, check=True) for s in lines]
    assert [p.sentence_type for p in parsed] == ["GGA", "RMC", "GSA"]
    gsa = parsed[2]
    assert lines[2].startswith("$GPGSA,A,3,03,07,11,19,28,,,,,,,,")
    assert float(gsa.pdop) == pytest.approx(pdop, abs=0.005)
    assert float(gsa.hdop) == pytest.approx(hdop, abs=0.005) and float(gsa.vdop) == pytest.approx(vdop, abs=0.005)
    assert nmea_sentences(table) == lines[:2]  # without gsa or sky: GGA and RMC alone, as before


def test_gsv_pages_hold_every_satellite_in_view_rounded_as_nmea_writes():
    import pynmea2

    from gnssframework.receiver.navigation.nmea_out import SkyView, nmea_sentences

    prn = np.array([28, 3, 19, 7, 11, 5])
    el = np.array([12.4, 85.6, 45.0, 5.2, 30.5, np.nan])
    az = np.array([359.7, 0.2, 181.49, 90.0, 270.0, 10.0])
    cn0 = np.array([38.6, 47.2, np.nan, 30.0, 44.4, 35.0])
    table = _table(1, used=((3, 7, 11, 19, 28),))
    parsed = [pynmea2.parse(s, check=True) for s in nmea_sentences(table, sky=[SkyView(prn, el, az, cn0)])]
    gsv = [p for p in parsed if p.sentence_type == "GSV"]
    assert [p.sentence_type for p in parsed[:2]] == ["GGA", "RMC"] and len(gsv) == 2  # six satellites, 4 a page
    assert all(int(p.num_messages) == 2 and int(p.num_sv_in_view) == 6 for p in gsv)
    assert [int(p.msg_num) for p in gsv] == [1, 2]
    sats = [
        (
            getattr(p, f"sv_prn_num_{i}"),
            getattr(p, f"elevation_deg_{i}"),
            getattr(p, f"azimuth_{i}"),
            getattr(p, f"snr_{i}"),
        )
        for p in gsv
        for i in range(1, 5)
        if getattr(p, f"sv_prn_num_{i}", None)
    ]
    assert sats == [
        ("03", "86", "000", "47"),
        ("05", "", "", "35"),
        ("07", "05", "090", "30"),
        ("11", "30", "270", "44"),
        ("19", "45", "181", ""),
        ("28", "12", "000", "39"),
    ]
    from gnssframework.receiver.navigation.nmea_out import gsa_gsv_sentences

    qzss = gsa_gsv_sentences(
        (193, 195),
        1.0,
        1.0,
        SkyView(np.array([193]), np.array([70.0]), np.array([10.0]), np.array([40.0])),
        talker="GQ",
    )
    assert qzss[0].startswith("$GQGSA,A,3,01,03,") and qzss[1].startswith("$GQGSV,1,1,01,01,70,010,40")
    with pytest.raises(ConfigError, match="one SkyView per fix"):
        nmea_sentences(table, sky=[])


def test_geojson_and_kml_hold_the_track_longitude_first(tmp_path):
    import json
    import xml.etree.ElementTree as ET

    from gnssframework.receiver.navigation.track_out import write_geojson, write_kml

    table = _table()
    data = json.loads(write_geojson(tmp_path / "track.geojson", table).read_text())
    assert data["type"] == "FeatureCollection"
    line, *points = data["features"]
    assert line["geometry"]["type"] == "LineString" and len(points) == 3
    c = table.columns
    expected = np.stack([c["lon_deg"], c["lat_deg"], c["height_m"]], axis=1)  # RFC 7946: lon, lat, height
    assert np.allclose(line["geometry"]["coordinates"], expected, atol=1e-9)
    assert np.allclose([p["geometry"]["coordinates"] for p in points], expected, atol=1e-9)
    assert (
        points[0]["properties"]["time_utc"] == "2022-01-01T00:00:00.000Z"
    )  # week 2190 (from 2021-12-26), tow 518418 - 18 s
    assert points[1]["properties"]["n_sats"] == 5 and points[2]["properties"]["vel_e_mps"] is None
    assert points[0]["properties"]["prns_used"] == [3, 7, 11, 19, 28]

    ns = {"k": "http://www.opengis.net/kml/2.2"}
    root = ET.parse(write_kml(tmp_path / "track.kml", table)).getroot()
    text = root.find(".//k:LineString/k:coordinates", ns).text.split()
    assert np.allclose([[float(v) for v in t.split(",")] for t in text], expected, atol=1e-9)
    when = [w.text for w in root.findall(".//k:Placemark/k:TimeStamp/k:when", ns)]
    assert when == ["2022-01-01T00:00:00.000Z", "2022-01-01T00:00:01.000Z", "2022-01-01T00:00:02.000Z"]
    empty = _table(0, used=(), hdop=(), vdop=())
    for writer in (write_geojson, write_kml):
        with pytest.raises(ConfigError, match="no fix"):
            writer(tmp_path / "empty", empty)


def test_parquet_opens_in_pandas_with_the_channels_rows(tmp_path):
    import pandas as pd

    from gnssframework.receiver.channels import STAGES
    from gnssframework.receiver.channels.records import RECORD_FIELDS, ChannelRecord, TrackingResult
    from gnssframework.receiver.navigation.columnar_out import write_tracking_parquet

    def rows(prn, times):
        return [
            (
                t,
                40.0 + prn + t,
                0.9,
                -1000.0 * prn,
                0.25 * prn,
                12.5 * t,
                t > 0.001,
                1 + (t > 0.002),
                100.0,
                -3.0,
                1 + 19 * (t > 0.002),
            )
            for t in times
        ]

    channels = {7: ChannelRecord(7, rows(7, [0.001, 0.002, 0.003])), 3: ChannelRecord(3, rows(3, [0.0015, 0.0025]))}
    tracking = TrackingResult(channels, [], 0.004, "scalar")
    frame = pd.read_parquet(write_tracking_parquet(tmp_path / "tracking.parquet", tracking))
    assert list(frame.columns) == ["prn", *RECORD_FIELDS]
    assert frame["time_s"].tolist() == [0.001, 0.0015, 0.002, 0.0025, 0.003]  # by time, then PRN
    assert frame["prn"].tolist() == [7, 3, 7, 3, 7]
    assert frame["cn0_dbhz"].tolist() == [47.001, 43.0015, 47.002, 43.0025, 47.003]  # no rounding
    assert frame["lock"].dtype == bool and frame["lock"].tolist() == [False, True, True, True, True]
    assert frame["stage"].astype(str).tolist() == [STAGES[1], STAGES[1], STAGES[1], STAGES[2], STAGES[2]]
    assert frame["coherent_ms"].tolist() == [1, 1, 1, 20, 20]


def test_outputs_are_parsed_and_a_missing_package_is_named_before_the_run(monkeypatch):
    import builtins

    from gnssframework.receiver.navigation.receive_outputs import DEFAULT_OUTPUTS, parse_outputs

    assert parse_outputs(None) == set(DEFAULT_OUTPUTS) == parse_outputs("default")
    assert parse_outputs("default,kml") == set(DEFAULT_OUTPUTS) | {"kml"}
    assert parse_outputs("gsa") == {"gsa"}
    with pytest.raises(ConfigError, match="unknown csv"):
        parse_outputs("gsa,csv")
    real = builtins.__import__

    def no_pyarrow(name, *args, **kwargs):
        if name.startswith("pyarrow"):
            raise ImportError(name)
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_pyarrow)
    with pytest.raises(ConfigError, match=r"pip install 'gnssframework\[columnar\]'"):
        parse_outputs("parquet")


def _msm_cells(frames):
    """pyrtcm's reading of framed MSMs (it checks each frame's CRC-24Q): per message the
    epoch (ms) and per cell (PRN, signal, DF values)."""
    import io

    from pyrtcm import RTCMReader, parse_msm

    out = []
    for _raw, msg in RTCMReader(io.BytesIO(b"".join(frames)), validate=1):
        meta, sats, cells = parse_msm(msg)
        out.append((msg.identity, meta["epoch"], sats, cells))
    return out


def _rtcm_observables(rx_time_s):
    from gnssframework.receiver.navigation.observables import Observables

    t = np.asarray(rx_time_s, float)
    E = t.size
    # Two satellites at constant range rates: the truth at any instant is linear in time.
    pr0, dop = np.array([2.1e7 + 0.1234, 2.3e7 - 17.5]), np.array([-2500.0, 1234.5])
    wavelength = 299_792_458.0 / 1575.42e6
    pr = pr0 - wavelength * dop * (t - t[0])[:, None]
    cycles = 1e6 + pr / wavelength + 0.25  # an accumulated count started anywhere
    pr[1, 1] = np.nan  # satellite 2 missing at the second epoch (a gap: its arc restarts)
    cycles[1, 1] = np.nan
    lli = np.zeros((E, 2), np.uint8)
    return (
        Observables(
            t,
            t - t[0],
            np.array([5, 12]),
            np.zeros((E, 2)),
            pr,
            np.tile(dop, (E, 1)),
            cycles,
            np.full((E, 2), 45.3),
            {},
            None,
            None,
            lli,
        ),
        pr0,
        dop,
        wavelength,
    )


def test_msm7_decodes_through_pyrtcm_to_the_observables_within_its_resolution():
    from gnssframework.receiver.navigation.rtcm_out import msm7_frames

    # Epochs off the whole millisecond (a receiver clock grid): each goes to the nearest.
    t = 345_600.0 + np.array([0.0, 1.0, 2.0, 3.0]) + 0.0004
    obs, pr0, dop, wavelength = _rtcm_observables(t)
    messages = _msm_cells(msm7_frames(obs))
    assert [m[0] for m in messages] == ["1077"] * 4
    c_ms = 299_792.458
    for e, (_, epoch_ms, sats, cells) in enumerate(messages):
        assert epoch_ms == round(t[e] * 1e3)
        t_msg = epoch_ms * 1e-3
        expected_prns = ["005", "012"] if e != 1 else ["005"]
        assert [c["CELLPRN"] for c in cells] == expected_prns and {c["CELLSIG"] for c in cells} == {"1C"}
        for sat, cell in zip(sats, cells):
            j = int(int(cell["CELLPRN"]) == 12)
            truth = pr0[j] - wavelength * dop[j] * (t_msg - t[0])  # the range at the message's instant
            rough_ms = sat["DF397"] + sat["DF398"]
            assert (rough_ms + cell["DF405"]) * c_ms == pytest.approx(truth, abs=2.0**-30 * c_ms)  # half an LSB
            # The phase range: the pseudorange's within whole cycles (offset at the arc's start).
            phase_m = (rough_ms + cell["DF406"]) * c_ms
            cycles = (phase_m - truth) / wavelength
            # (the count's quarter cycle kept; 2^-31 ms is 7e-4 cycle)
            assert cycles - round(cycles) == pytest.approx(0.25, abs=1e-3)
            rate = sat["DF399"] + cell["DF404"]
            assert rate == pytest.approx(-wavelength * dop[j], abs=0.5e-4)
            assert cell["DF408"] == pytest.approx(45.3, abs=1 / 32)
    # Lock time: satellite 5 locked from the first epoch (3 s by the last: indicator of
    # table 3.5-79, 3000 ms in [2048, 4096) by 64 ms steps from 224: (3000 + 12288) // 64 =
    # 238); satellite 12's arc restarted at the third epoch (1 s: (1000 + 2048) // 16 = 190).
    last = messages[-1][3]
    assert [c["DF407"] for c in last] == [238, 190]


def test_beidou_b1is_d1_and_geo_satellites_go_in_one_1127_dated_in_bdt():
    """B1I from a D1 satellite (C06) and a GEO (C01), a `SignalSet` of one observable: one
    BeiDou MSM7 (1127) an epoch holding both on signal 2I (table 3.5-108), its DF427 epoch
    in BDT (GPS time - 14 s)."""
    from dataclasses import replace

    from gnssframework.receiver.navigation.multi_receive import SignalSet
    from gnssframework.receiver.navigation.rtcm_out import msm7_frames
    from gnssframework.signal.beidou_b1i import BEIDOU_B1I, BEIDOU_B1I_GEO

    b1i = SignalSet((BEIDOU_B1I, BEIDOU_B1I_GEO))
    t = 345_600.0 + np.array([0.0, 1.0]) + 0.0004
    obs = replace(_rtcm_observables(t)[0], prn=np.array([b1i.key(0, 6), b1i.key(1, 1)]))
    messages = _msm_cells(msm7_frames(obs, b1i))  # type: ignore[arg-type]
    assert [(m[0], m[1]) for m in messages] == [("1127", round(x * 1e3) - 14_000) for x in t]
    assert [c["CELLPRN"] for c in messages[0][3]] == ["001", "006"]
    assert {c["CELLSIG"] for m in messages for c in m[3]} == {"2I"}


def test_lock_time_indicator_follows_the_table_and_crc_matches_the_spec_example():
    from gnssframework.receiver.navigation.rtcm_out import crc24q, lock_time_indicator

    # RTCM 10403.3 table 3.5-79 (DF407): indicator ranges and the lock times they start at.
    assert [lock_time_indicator(t) for t in (0, 63, 64, 66, 127, 128, 255, 256, 2048, 67_108_863, 10**9)] == [
        0,
        63,
        64,
        65,
        95,
        96,
        127,
        128,
        224,
        703,
        704,
    ]
    # CRC-24Q (the 0x864CFB polynomial) of b"123456789": the catalogue value 0xCDE703.
    assert crc24q(b"123456789") == 0xCDE703


def test_no_msm_for_a_signal_without_one_and_no_file_without_a_pseudorange(tmp_path):
    from gnssframework.receiver.navigation.rtcm_out import msm7_frames, write_rtcm
    from gnssframework.signal.beidou_b1c import BEIDOU_B1C

    obs = _rtcm_observables(np.array([1.0, 2.0]))[0]
    with pytest.raises(ConfigError, match="no MSM7 signal for"):
        msm7_frames(obs, BEIDOU_B1C)
    empty = type(obs)(
        obs.rx_time_s,
        obs.sample_time_s,
        obs.prn,
        obs.transmit_s,
        np.full_like(obs.pseudorange_m, np.nan),
        obs.doppler_hz,
        obs.carrier_cycles,
        obs.cn0_dbhz,
        {},
        None,
        None,
        obs.lli,
    )
    with pytest.raises(ConfigError, match="no epoch holds a pseudorange"):
        write_rtcm(tmp_path / "o.rtcm3", empty)


def test_write_extra_outputs_writes_what_is_asked_and_notes_what_it_cannot(decoded, tmp_path):
    import json

    import pandas as pd

    from gnssframework.receiver.channels.records import ChannelRecord, TrackingResult
    from gnssframework.receiver.navigation.receive import ReceiveResult
    from gnssframework.receiver.navigation.receive_outputs import OUTPUTS, write_extra_outputs

    records, iono, first = decoded
    obs, _, _, _ = _rtcm_observables(first + 1.0 + np.arange(3.0))
    obs = type(obs)(
        *(
            getattr(obs, f)
            for f in (
                "rx_time_s",
                "sample_time_s",
                "prn",
                "transmit_s",
                "pseudorange_m",
                "doppler_hz",
                "carrier_cycles",
                "cn0_dbhz",
            )
        ),
        {prn: [(0.5, rec)] for prn, rec in records.items()},
        iono,
        WEEK % 1024,
        obs.lli,
    )
    tracking = TrackingResult(
        {5: ChannelRecord(5, [(0.001, 45.0, 0.9, -2500.0, 10.0, 0.5, True, 1, 1.0, 0.0, 1)])}, [], 3.0, "scalar"
    )
    table = _table()
    result = ReceiveResult(tracking, obs, table, table)
    written, notes = write_extra_outputs(tmp_path, result, table, frozenset(OUTPUTS), WEEK)
    assert (
        sorted(p.name for p in written)
        == ["navigation.rnx", "observations.rtcm3", "track.geojson", "track.kml", "tracking.parquet"]
        and notes == []
    )
    assert sorted(_read_back(tmp_path / "navigation.rnx").sv.values) == sorted(f"G{p:02d}" for p in records)
    assert len(_msm_cells([(tmp_path / "observations.rtcm3").read_bytes()])) == 3
    assert len(json.loads((tmp_path / "track.geojson").read_text())["features"]) == 4
    assert pd.read_parquet(tmp_path / "tracking.parquet")["prn"].tolist() == [5]
    # Without observables (an assisted start's vector positions alone) or a known week: notes.
    bare = ReceiveResult(tracking, None, table, table)
    written, notes = write_extra_outputs(tmp_path / "b", bare, table, frozenset({"rinex-nav", "rtcm"}), WEEK)
    assert written == [] and notes == [
        "no ephemeris decoded from LNAV: no navigation.rnx",
        "no pseudoranges dated in a known week: no observations.rtcm3",
    ]
    written, notes = write_extra_outputs(tmp_path / "c", result, table, frozenset({"rinex-nav"}), -1)
    assert written == [] and notes == ["the GPS week is unknown: no navigation.rnx"]


def test_a_qzss_navigation_file_names_its_system_and_writes_the_fit_flag(decoded, tmp_path):
    from gnssframework.signal.qzss_l1ca import QZSS_L1CA

    records, iono, first = decoded
    rec = next(iter(records.values()))
    path = write_rinex_nav(tmp_path / "navigation.rnx", [NavRecord(193, rec, WEEK, first)], iono, QZSS_L1CA)
    assert path.read_text().splitlines()[0][40:60].rstrip() == "J: QZSS"
    data = _read_back(path)
    assert list(data.sv.values) == ["J01"]
    one = data.sel(sv="J01").dropna("time", how="all")
    assert float(one["sqrtA"].values[0]) == pytest.approx(float(rec.elements["sqrtA"][0]), rel=5e-13)
    # RINEX 3.04 table A14: QZSS's BROADCAST ORBIT 7 holds the fit interval flag (0: 2 hours).
    fit = [v for v in one.data_vars if v.lower().startswith("fit")]
    assert fit and float(one[fit[0]].values[0]) == 0.0
