"""The files `receive` writes for several signals (``--signal gps-l1ca,galileo-e1b-boc11``)
beside positions.csv, without a recording: the mixed RINEX navigation file of GPS records
sent as LNAV and Galileo records sent as I/NAV, each decoded by the receiver's own decoders
(read back by the project's reader and by georinex against the broadcast files' values),
and the per-system NMEA GSA/GSV (parsed by pynmea2). The end-to-end run is in
test_receive_gps_galileo."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pynmea2
import pytest

from gnssframework.navigation import inav, lnav
from gnssframework.navigation.ephemeris import read_rinex_nav
from gnssframework.navigation.inav_params import Ggto, GstUtc, InavIonoTime
from gnssframework.navigation.rinex_nav_header import read_nav_file_info
from gnssframework.receiver.navigation.multi_receive import SignalSet
from gnssframework.signal.galileo_e1 import GALILEO_E1B_BOC11
from gnssframework.signal.gps_l1ca import GPS_L1CA
from lnav_recordings import NAV as GPS_NAV, TOW0 as GPS_TOW0

GAL_NAV = Path(__file__).parents[1] / "data" / "galileo_inav_20feb2022_05h.rnx"
SIGNALS = SignalSet((GPS_L1CA, GALILEO_E1B_BOC11))
WEEK = 2198
WN_GST = WEEK - 1024
#: Page 18 as broadcast (IS-GPS-200 20.3.3.5.1.7 scales: A0 and A1 whole LSBs, 2^-30 s and
#: 2^-50 s/s; the Klobuchar terms within the header's D12.4 of whole LSBs).
IONO = lnav.IonoUtc(
    (1.1176e-08, 7.4506e-09, -5.9605e-08, -5.9605e-08),
    (90112.0, 16384.0, -196608.0, -65536.0),
    -7 * 2.0**-30,
    3 * 2.0**-50,
    405504.0,
    WEEK % 256,
    18,
)
#: Words 5, 6, 10 of the sbf2rin header of GAL_NAV in the ICD's LSBs (test_rinex_nav_galileo's).
GALILEO = InavIonoTime(
    (325 * 2.0**-2, -63 * 2.0**-8, 123 * 2.0**-15),
    GstUtc(-1 * 2.0**-30, 1 * 2.0**-50, 18, 0.0, WEEK % 256, 1929 % 256, 7, 18),
    Ggto(203 * 2.0**-35, 8 * 2.0**-51, 86400.0, WEEK % 64),
)
#: Orbit elements checked record by record.
ELEMENTS = ("sqrtA", "Eccentricity", "M0", "Omega0", "Io", "omega", "Crs", "Cuc", "SVclockBias", "SVclockDrift")


@pytest.fixture(scope="module")
def decoded():
    """Two GPS records sent as LNAV (with page 18) and two Galileo records sent as I/NAV (with
    words 5, 6 and 10), each decoded by the receiver's decoders; keyed as a `SignalSet` run
    keys them (GPS PRN p is p, Galileo E p is 1000 + p); and the broadcast source records."""
    gps = read_rinex_nav(GPS_NAV)
    gps = gps.select(np.unique(gps.sv)[:2], GPS_TOW0)
    first = (int(GPS_TOW0) // 30 + 1) * 30
    out, source = {}, {}
    iono = galileo = None
    for k in range(gps.sv.size):
        rec = gps.subset(np.array([k]))
        symbols, _ = lnav.lnav_symbols(rec, WEEK, first, 50 * 30, IONO)
        message = lnav.decode_lnav(symbols, int(rec.sv[0][1:]))
        out[SIGNALS.key(0, int(rec.sv[0][1:]))] = [(1.0, message.ephemeris)]
        source[str(rec.sv[0])] = rec
        iono = message.iono_utc
    gal = read_rinex_nav(GAL_NAV, systems="E")
    _, one = np.unique(gal.sv, return_index=True)
    for k in np.sort(one)[:2]:
        rec = gal.subset(np.array([k]))
        # One 30 s sub-frame of pages from GST 18001 s: words 1-6 and 10 all in it.
        message = inav.decode_inav(inav.encode_inav(rec, WN_GST, 18001, 15, iono_time=GALILEO).astype(float))
        out[SIGNALS.key(1, int(rec.sv[0][1:]))] = [(2.0, message.ephemeris)]
        source[str(rec.sv[0])] = rec
        galileo = message.iono_time
    return out, iono, galileo, source


def _observables(ephemeris, iono, galileo):
    from gnssframework.receiver.navigation.observables import Observables

    t = 18_000.0 + np.arange(3.0)
    keys = np.array(sorted(ephemeris))
    nan = np.full((t.size, keys.size), np.nan)
    return Observables(t, t - t[0], keys, nan, nan, nan, nan, nan, ephemeris, iono, WEEK % 1024, None, galileo)


def _georinex(path):
    import georinex

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return georinex.rinexheader(path), georinex.load(path)


def test_the_mixed_navigation_file_holds_both_systems_decoded_records_and_corrections(decoded, tmp_path):
    from gnssframework.receiver.channels.records import TrackingResult
    from gnssframework.receiver.navigation.receive import ReceiveResult
    from gnssframework.receiver.navigation.receive_outputs import write_extra_outputs

    ephemeris, iono, galileo, source = decoded
    assert iono is not None and galileo == GALILEO  # the decoders kept page 18 and words 5, 6, 10
    obs = _observables(ephemeris, iono, galileo)
    result = ReceiveResult(TrackingResult({}, [], 3.0, "scalar"), obs, None, None)
    written, notes = write_extra_outputs(tmp_path, result, None, frozenset({"rinex-nav"}), WEEK, 18, SIGNALS)
    assert [p.name for p in written] == ["navigation.rnx"] and notes == []
    path = written[0]
    lines = path.read_text().splitlines()
    assert lines[0][20:60].rstrip() == "N: GNSS NAV DATA    M: MIXED"
    labels = [ln[60:].strip() for ln in lines[: lines.index(next(ln for ln in lines if "END OF HEADER" in ln))]]
    assert labels.count("LEAP SECONDS") == 1  # page 18's and word 6's are the same 18 s: one line
    assert {ln[:4] for ln in lines if ln[60:].strip() == "TIME SYSTEM CORR"} == {"GPUT", "GAUT", "GAGP"}

    # The project's reader: two records per system, each the decoded one and the broadcast source's.
    nav = read_rinex_nav(path, systems="GE")
    assert sorted(nav.sv) == sorted(source)
    assert sum(s.startswith("G") for s in nav.sv) == 2 and sum(s.startswith("E") for s in nav.sv) == 2
    for key, [(_, rec)] in ephemeris.items():
        sv = SIGNALS.rinex_satellite(key)
        k = int(np.flatnonzero(nav.sv == sv)[0])
        assert nav.toc_s[k] == rec.toc_s[0] and nav.iode[k] == rec.iode[0]
        for name in ELEMENTS:  # D19.12: 13 significant digits of the decoded value
            assert nav.elements[name][k] == pytest.approx(rec.elements[name][0], rel=1e-12, abs=1e-300), (sv, name)
        # ... which is the broadcast file's within the message's quantization (sqrtA: 2^-19 m^1/2)
        assert nav.elements["sqrtA"][k] == pytest.approx(source[sv].elements["sqrtA"][0], abs=2.0**-19)
        assert nav.elements["Eccentricity"][k] == pytest.approx(source[sv].elements["Eccentricity"][0], abs=2.0**-33)
    info = read_nav_file_info(path)
    assert info.iono is not None and info.iono.alpha == pytest.approx(IONO.alpha, rel=5e-5)
    g = GALILEO.ggto
    assert info.ggto == pytest.approx((g.a0g_s, g.a1g_s_s, 86400.0, WEEK), rel=5e-11)

    # georinex: the same satellites, both systems' header lines and values.
    hdr, data = _georinex(path)
    assert sorted(str(s) for s in data.sv.values) == sorted(source)
    for sv, rec in source.items():
        got = float(data["sqrtA"].sel(sv=sv).dropna("time").values[0])
        assert got == pytest.approx(rec.elements["sqrtA"][0], abs=2.0**-19), sv
    corr = hdr["IONOSPHERIC CORR"]
    np.testing.assert_allclose(corr["GPSA"], IONO.alpha, rtol=5e-5)
    np.testing.assert_allclose(corr["GPSB"], IONO.beta, rtol=5e-5)
    np.testing.assert_allclose(corr["GAL"], GALILEO.ai_sfu, rtol=5e-5)
    tsc = hdr["TIME SYSTEM CORR"]
    np.testing.assert_allclose(tsc["GPUT"][:2], (IONO.a0_s, IONO.a1_s_s), rtol=5e-10)
    assert tsc["GPUT"][2:] == [405504, WEEK] and tsc["GAGP"][2:] == [86400, WEEK]
    np.testing.assert_allclose(tsc["GAUT"][:2], (GALILEO.utc.a0_s, GALILEO.utc.a1_s_s), rtol=5e-10)


def test_the_mixed_rinex4_file_holds_the_same_records_and_corrections_as_records(decoded, tmp_path):
    """``--rinex-version 4``: the RINEX 3.04 file's records and header lines, read back from
    RINEX 4.00's EPH, ION and STO records by the project's RINEX 4 reader."""
    from gnssframework.receiver.channels.records import TrackingResult
    from gnssframework.receiver.navigation.receive import ReceiveResult
    from gnssframework.receiver.navigation.receive_outputs import write_extra_outputs

    ephemeris, iono, galileo, source = decoded
    result = ReceiveResult(TrackingResult({}, [], 3.0, "scalar"), _observables(ephemeris, iono, galileo), None, None)
    out3, out4 = tmp_path / "v3", tmp_path / "v4"
    out3.mkdir(), out4.mkdir()
    [v3], _ = write_extra_outputs(out3, result, None, frozenset({"rinex-nav"}), WEEK, 18, SIGNALS)
    [v4], notes = write_extra_outputs(out4, result, None, frozenset({"rinex-nav"}), WEEK, 18, SIGNALS, "4.00")
    assert notes == []
    lines = v4.read_text().splitlines()
    assert lines[0][:9].strip() == "4.00" and lines[0][20:60].rstrip() == "N: GNSS NAV DATA    M: MIXED"
    heads = [ln for ln in lines if ln.startswith(">")]
    assert sorted(h for h in heads if h.startswith("> EPH")) == sorted(
        f"> EPH {sv} {'LNAV' if sv[0] == 'G' else 'INAV'}" for sv in source
    )
    # page 18 (ION, STO GPUT) and words 5, 6, 10 (ION, STO GAUT, STO GAGP), before the records
    assert [h.split()[1] + " " + h.split()[3] for h in heads[:5]] == [
        "ION LNAV",
        "STO LNAV",
        "ION IFNV",
        "STO IFNV",
        "STO IFNV",
    ]
    # The STO lines' columns (type, SBAS id, UTC id: 1X,A18 each) as DLR's BCEmerge writes them.
    dlr = (Path(__file__).parents[1] / "data" / "BRD400DLR_S_20230710000_04H_MN.rnx").read_text().splitlines()
    for code in ("GPUT", "GAUT", "GAGP"):
        ours = next(ln for ln in lines if ln[24:28] == code and lines[lines.index(ln) - 1].startswith("> STO"))
        theirs = next(ln for ln in dlr if ln[24:28] == code and dlr[dlr.index(ln) - 1].startswith("> STO"))
        assert ours[23:].rstrip() == theirs[23:].rstrip(), code
    a, b = read_rinex_nav(v3, systems="GE"), read_rinex_nav(v4, systems="GE")
    a, b = a.subset(np.argsort(a.sv)), b.subset(np.argsort(b.sv))
    np.testing.assert_array_equal(a.sv, b.sv)
    np.testing.assert_array_equal(a.toc_s, b.toc_s)
    for name in ELEMENTS + ("TGD", "Toe", "IDOT", "FNAV"):
        np.testing.assert_array_equal(a.elements[name], b.elements[name], err_msg=name)
    np.testing.assert_array_equal(a.health, b.health)
    np.testing.assert_array_equal(a.iode, b.iode)
    info3, info4 = read_nav_file_info(v3), read_nav_file_info(v4)
    # D19.12 records hold the decoded page 18 (RINEX 3's D12.4 header lines round it).
    assert info4.iono.alpha == pytest.approx(iono.alpha, rel=1e-12)
    assert info4.iono.beta == pytest.approx(iono.beta, rel=1e-12)
    assert info4.iono.alpha == pytest.approx(info3.iono.alpha, rel=5e-5)
    assert info4.iono.dt_ls_s == info3.iono.dt_ls_s == 18
    assert info4.ggto == pytest.approx(info3.ggto, rel=1e-12)  # GGTO from STO GAGP
    assert (info4.first_s, info4.last_s) == (info3.first_s, info3.last_s)


def test_a_record_of_the_wrong_system_for_its_key_is_refused(decoded, tmp_path):
    from gnssframework.errors import ConfigError
    from gnssframework.receiver.navigation.rinex_nav import NavRecord, write_rinex_nav

    ephemeris, *_ = decoded
    gps_rec = ephemeris[min(ephemeris)][0][1]
    with pytest.raises(ConfigError, match="not a Galileo record") as exc:
        write_rinex_nav(tmp_path / "n.rnx", [NavRecord(SIGNALS.key(1, 11), gps_rec, WEEK, 0.0)], signal=SIGNALS)
    assert len(str(exc.value).splitlines()) == 1


def test_gsa_and_gsv_of_a_two_system_fix_go_per_system():
    from gnssframework.receiver.navigation.nmea_out import SkyView, nmea_sentences

    from test_receiver_outputs import _table

    used = (3, 7, 19, 1011, 1024)  # G03, G07, G19 and E11, E24 used
    table = _table(n=1, used=(used,))
    # In view: the used ones and E30 (not used), in no particular order.
    keys = np.array([1030, 19, 1011, 3, 1024, 7])
    sky = SkyView(keys, np.array([5.0, 40.0, 61.6, 12.0, 33.0, 70.0]), np.arange(6) * 50.0, np.full(6, 44.0))
    parsed = [pynmea2.parse(s, check=True) for s in nmea_sentences(table, 18, "GN", [sky], True, SIGNALS)]
    assert [p.talker + p.sentence_type for p in parsed[:2]] == ["GNGGA", "GNRMC"]
    gsa = [p for p in parsed if p.sentence_type == "GSA"]
    assert [p.talker for p in gsa] == ["GN", "GN"]
    # NMEA 4.10 system ID (the field after VDOP): 1 GPS, 3 Galileo; each its own satellites' IDs.
    assert [p.data[-1] for p in gsa] == ["1", "3"]
    assert [[s for s in p.data[2:14] if s] for p in gsa] == [["03", "07", "19"], ["11", "24"]]
    gsv = {t: [p for p in parsed if p.sentence_type == "GSV" and p.talker == t] for t in ("GP", "GA")}
    assert int(gsv["GP"][0].num_sv_in_view) == 3 and int(gsv["GA"][0].num_sv_in_view) == 3
    ga_ids = [p.data[i] for p in gsv["GA"] for i in range(3, len(p.data), 4) if p.data[i]]
    assert ga_ids == ["11", "24", "30"]  # Galileo SVIDs 1-36 under GA (NMEA 4.10/4.11)
    assert {p.talker for p in parsed if p.sentence_type == "GSV"} == {"GP", "GA"}


def test_gsa_and_gsv_list_b1is_d1_and_geo_satellites_as_one_system():
    """BeiDou B1I from D1 satellites and GEOs (a `SignalSet` of one observable): one GSA
    (system ID 4) with both signals' satellites used, one GB GSV group counting all in view."""
    from gnssframework.receiver.navigation.multi_receive import SignalSet
    from gnssframework.receiver.navigation.nmea_out import SkyView, nmea_sentences
    from gnssframework.signal.beidou_b1i import BEIDOU_B1I, BEIDOU_B1I_GEO

    from test_receiver_outputs import _table

    b1i = SignalSet((BEIDOU_B1I, BEIDOU_B1I_GEO))
    used = (21, 24, 1001, 1005)  # C21, C24 (D1) and C01, C05 (GEO) used
    keys = np.array([1005, 21, 33, 1001, 24])  # and C33 in view, not used
    sky = SkyView(keys, np.array([11.0, 40.0, 8.0, 33.0, 61.0]), np.arange(5) * 60.0, np.full(5, 44.0))
    table = _table(n=1, used=(used,))
    parsed = [pynmea2.parse(s, check=True) for s in nmea_sentences(table, 18, "GB", [sky], True, b1i)]
    gsa = [p for p in parsed if p.sentence_type == "GSA"]
    assert len(gsa) == 1 and gsa[0].data[-1] == "4"
    assert [s for s in gsa[0].data[2:14] if s] == ["01", "05", "21", "24"]
    gsv = [p for p in parsed if p.sentence_type == "GSV"]
    assert {p.talker for p in gsv} == {"GB"} and {int(p.num_messages) for p in gsv} == {len(gsv)} == {2}
    assert [p.data[i] for p in gsv for i in range(3, len(p.data), 4) if p.data[i]] == ["01", "05", "21", "24", "33"]
