"""The receiver's RINEX 4.00 navigation file (`rinex4_nav_out`), against a real one: DLR's
BCEmerge records (tests/data/BRD400DLR_S_20230710000_04H_MN.rnx) written again record by
record, each written line's numbers are DLR's where the record keeps them (blank where it
does not: CNAV's URAI_NED indices and ISC_L5Q5), and the project's RINEX 4 reader reads every
field back; a CNAV record is refused in RINEX 3.04 in one line."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gnssframework.errors import ConfigError
from gnssframework.navigation.ephemeris import read_rinex_nav
from gnssframework.navigation.rinex4_nav import scan_rinex4_nav
from gnssframework.receiver.navigation.rinex4_nav_out import write_rinex4_nav
from gnssframework.receiver.navigation.rinex_nav import NavRecord, write_rinex_nav
from gnssframework.signal.gps_l1ca import GPS_L1CA

BRD4 = Path(__file__).parents[1] / "data" / "BRD400DLR_S_20230710000_04H_MN.rnx"
WEEK = 2253  # 2023-03-12 is its day 0
#: CNAV fields the receiver's record does not keep, by (orbit line, slot): written blank.
NOT_KEPT = {(5, 2), (5, 3), (6, 3), (7, 3)}


def _numbers(lines: list[str]) -> list[list[float]]:
    """Each orbit line's four fields (NaN for a blank one)."""
    out = []
    for line in lines:
        text = line.rstrip("\n").ljust(80)
        fields = [text[4 + 19 * k : 23 + 19 * k].strip() for k in range(4)]
        out.append([float(f.replace("D", "E")) if f else float("nan") for f in fields])
    return out


def _gps_records():
    """DLR's GPS records with the time each was sent (its t_tm), as `NavRecord`s."""
    eph = read_rinex_nav(BRD4, "G")
    sent = [r for r in scan_rinex4_nav(BRD4)[1] if r.kind == "EPH" and r.sv[0] == "G"]
    assert len(sent) == eph.sv.size  # every GPS record of the excerpt is read (file order)
    navs = []
    for k, rec in enumerate(sent):
        t_tm = rec.values[3 + (28 if rec.message == "CNAV" else 24)]  # ORBIT 7 / ORBIT 8's first field
        navs.append(NavRecord(int(rec.sv[1:]), eph.subset(np.array([k])), WEEK + int(t_tm // 604800), t_tm % 604800))
    return eph, sent, navs


def _record_lines(lines: list[str], head: str, epoch: str) -> list[str]:
    k = next(i for i, ln in enumerate(lines) if ln.startswith(head) and lines[i + 1][4:23] == epoch)
    stop = next((i for i in range(k + 1, len(lines)) if lines[i].startswith(">")), len(lines))
    return lines[k + 1 : stop]


def test_gps_lnav_and_cnav_records_are_written_as_dlr_wrote_them_and_read_back(tmp_path):
    eph, sent, navs = _gps_records()
    path = write_rinex4_nav(tmp_path / "navigation.rnx", navs, signal=GPS_L1CA)
    ours = path.read_text().splitlines()
    assert ours[0][:9].strip() == "4.00" and ours[0][20:60].rstrip() == "N: GNSS NAV DATA    G: GPS"
    theirs = BRD4.read_text().splitlines()
    cnav_seen = 0
    for rec in sent:
        head = f"> EPH {rec.sv} {rec.message}"
        epoch = str(np.datetime_as_string(rec.epoch, unit="s")).replace("-", " ").replace("T", " ").replace(":", " ")
        mine, dlr = _record_lines(ours, head, epoch), _record_lines(theirs, head, epoch)
        assert mine[0][:23] == dlr[0][:23]  # satellite and epoch
        assert _numbers([mine[0][19:]])[0][:3] == pytest.approx(_numbers([dlr[0][19:]])[0][:3], rel=1e-12)  # af0-af2
        a, b = _numbers(mine[1:]), _numbers(dlr[1:])
        assert len(a) == len(b), head
        for line, (x, y) in enumerate(zip(a, b), 1):
            for slot in range(4):
                if rec.message == "CNAV" and (line, slot) in NOT_KEPT:
                    assert np.isnan(x[slot]), (head, line, slot)  # not kept: left blank
                elif rec.message == "LNAV" and (line, slot) in ((5, 1), (5, 3), (6, 3), (7, 0), (7, 1)):
                    continue  # L2 codes, L2 P flag, IODC, t_tm, fit: as the RINEX 3 writer writes them
                elif not (np.isnan(x[slot]) and np.isnan(y[slot])):
                    assert x[slot] == pytest.approx(y[slot], rel=1e-12, abs=1e-300), (head, line, slot)
        cnav_seen += rec.message == "CNAV"
    assert cnav_seen == 9
    back = read_rinex_nav(path, "G")
    order = np.lexsort((back.elements["CNAV"], back.toc_s, back.sv))
    source = np.lexsort((eph.elements["CNAV"], eph.toc_s, eph.sv))
    back, eph = back.subset(order), eph.subset(source)
    np.testing.assert_array_equal(back.sv, eph.sv)
    for name, values in eph.elements.items():
        np.testing.assert_allclose(back.elements[name], values, rtol=1e-12, atol=1e-300, err_msg=name)
    np.testing.assert_array_equal(back.health, eph.health)
    np.testing.assert_array_equal(back.iode, eph.iode)
    np.testing.assert_allclose(back.accuracy_m, eph.accuracy_m, rtol=1e-12)


def test_a_cnav_record_is_refused_in_rinex3(tmp_path):
    _, _, navs = _gps_records()
    cnav = [n for n in navs if n.record.elements["CNAV"][0] == 1.0]
    with pytest.raises(ConfigError, match="G01: a CNAV record has no RINEX 3.04 layout"):
        write_rinex_nav(tmp_path / "n.rnx", cnav, signal=GPS_L1CA)
    from gnssframework.receiver.channels.records import TrackingResult
    from gnssframework.receiver.navigation.receive import ReceiveResult
    from gnssframework.receiver.navigation.receive_outputs import write_extra_outputs

    result = ReceiveResult(TrackingResult({}, [], 3.0, "scalar"), None, None, None)
    with pytest.raises(ConfigError, match="'4.01': one of 3.04, 4.00"):
        write_extra_outputs(tmp_path, result, None, frozenset({"rinex-nav"}), WEEK, 18, GPS_L1CA, "4.01")


def test_receive_outputs_write_cnav_records_as_rinex4_unless_told_3(tmp_path):
    """``receive``'s navigation.rnx: RINEX 4.00 where a record is from CNAV (with a note),
    none and a note naming ``--rinex-version 4`` where RINEX 3.04 was asked for."""
    from gnssframework.receiver.channels.records import TrackingResult
    from gnssframework.receiver.navigation.observables import Observables
    from gnssframework.receiver.navigation.receive import ReceiveResult
    from gnssframework.receiver.navigation.receive_outputs import write_extra_outputs

    eph, _, navs = _gps_records()
    cnav = [n for n in navs if n.record.elements["CNAV"][0] == 1.0]
    ephemeris = {n.prn: [(1.0, n.record)] for n in cnav}  # the last CNAV record of each satellite
    t = 5400.0 + np.arange(3.0)
    keys = np.array(sorted(ephemeris))
    nan = np.full((t.size, keys.size), np.nan)
    obs = Observables(t, t - t[0], keys, nan, nan, nan, nan, nan, ephemeris, None, WEEK % 1024)
    result = ReceiveResult(TrackingResult({}, [], 3.0, "scalar"), obs, None, None)
    asked = frozenset({"rinex-nav"})
    written, notes = write_extra_outputs(tmp_path, result, None, asked, WEEK, 18, GPS_L1CA)
    assert [p.name for p in written] == ["navigation.rnx"]
    assert notes == ["CNAV records: navigation.rnx is written as RINEX 4.00"]
    back = read_rinex_nav(written[0], "G")
    assert sorted(back.sv) == sorted(f"G{p:02d}" for p in ephemeris) and np.all(back.elements["CNAV"] == 1.0)
    (tmp_path / "v3").mkdir()
    written, notes = write_extra_outputs(tmp_path / "v3", result, None, asked, WEEK, 18, GPS_L1CA, "3.04")
    assert written == [] and notes == [
        "CNAV records have no RINEX 3.04 layout (Adot, Delta n0 rate, ISC): no navigation.rnx "
        "(--rinex-version 4 writes them)"
    ]
