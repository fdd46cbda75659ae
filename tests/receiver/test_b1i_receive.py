"""`receive --signal beidou-b1i`: positions from BeiDou B1I alone, each channel dated from its
D1 SOW on 1 ms rows under NH20 (`inav_stream.channel_inav`; BDT taken to GPS time) and
solved with the B1I user's clock (clock - T_GD1), on the five highest satellites of the
2022-02-20 records seen from VILL, relabelled as BeiDou D1 ones
(`inav_recordings.write_b1i_recording`). Truth: the station, and each satellite's B1I time
at every dated row."""

from __future__ import annotations

import csv

import pytest

from gnssframework.cli import main
from gnssframework.signal.beidou_b1i import BEIDOU_B1I
from inav_recordings import GPS_WEEK, STATION, bds_records, highest, satellite_time, write_b1i_recording
from light_time import assert_one_signal_fixes

pytestmark = pytest.mark.slow  # end to end (the fast lane leaves these out)

#: A D1 frame (subframe 1) starts on BDT 18030 s = GPS 18044 s, about 0.7 s in.
TOW0 = 18_044.0 - 0.6
#: Subframe 1 whole after the pull-in, then a few fixes.
DURATION_S = 8.0


@pytest.fixture(scope="module")
def b1i(tmp_path_factory):
    sats = highest(bds_records(), TOW0, 5)
    assert sats.sv.size == 5
    path = tmp_path_factory.mktemp("b1i") / "b1i.sigmf-data"
    write_b1i_recording(path, sats, TOW0, DURATION_S, seed=8)
    return path, sats


def _prns(sats) -> list[int]:
    return [int(s[1:]) for s in sats.sv]


def test_receive_positions_from_b1i_alone(b1i):
    """Every satellite dated from its first subframe and used in every fix; each row's
    transmit time (GPS time) is the generator's B1I time within a few hundredths of a chip,
    and the fixes are on the station within three PDOPs of that error."""
    path, sats = b1i
    assert_one_signal_fixes(
        path,
        sats,
        BEIDOU_B1I,
        bds_records(),
        GPS_WEEK,
        TOW0,
        satellite_time,
        STATION,
        fixes=int(DURATION_S) - 2,
        chip_fraction=0.05,
    )


def test_the_track_command_writes_each_channels_d1(b1i, tmp_path):
    """What a user types: ``track`` writes each channel's D1 subframes (``d1.csv``: subframe
    1, its SOW 18030 s read as GPS 18044 s of GPS week 2198, the AODE of the record)."""
    path, sats = b1i
    out = tmp_path / "trk"
    prns = [str(p) for p in _prns(sats)]
    assert main(["track", str(path), "--signal", "beidou-b1i", "--prns", *prns, "--out", str(out), "--quiet"]) == 0
    with open(out / "d1.csv", newline="") as f:
        rows = {int(r["prn"]): r for r in csv.DictReader(f)}
    assert sorted(rows) == sorted(_prns(sats))
    for k, prn in enumerate(_prns(sats)):
        r = rows[prn]
        assert (r["word_types"], r["gst_tow_s"], r["gst_wn"]) == ("1", "18044", str(GPS_WEEK))
        assert r["iodnav"] == str(int(sats.iode[k]) % 32) and r["crc_failures"] == "0"
