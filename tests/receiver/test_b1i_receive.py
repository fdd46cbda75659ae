"""`receive --signal beidou-b1i`: positions from BeiDou B1I alone, each channel dated from its
D1 SOW on 1 ms rows under NH20 (`inav_stream.channel_inav`; BDT taken to GPS time) and
solved with the B1I user's clock (clock - T_GD1) and BeiDou's ionosphere model from D1's
subframe 1 (`bds_iono`), on the five highest satellites of the 2022-02-20 records seen from
VILL, relabelled as BeiDou D1 ones (`inav_recordings.write_b1i_recording`), every signal
delayed by that model (`IONO`: 5 to 14 m at 04:45 local). Truth: the station, and each
satellite's B1I time at every dated row (the delay included)."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from gnssframework.cli import main
from gnssframework.signal.beidou_b1i import BEIDOU_B1I
from gnssframework.navigation.bds_iono import BdsKlobuchar
from gnssframework.receiver.navigation.fixes import solve_epochs
from inav_recordings import (
    GPS_WEEK,
    STATION,
    bds_records,
    highest,
    ionosphere_delayed,
    satellite_time,
    write_b1i_recording,
)
from light_time import assert_one_signal_fixes

pytestmark = pytest.mark.slow  # end to end (the fast lane leaves these out)

#: A D1 frame (subframe 1) starts on BDT 18030 s = GPS 18044 s, about 0.7 s in.
TOW0 = 18_044.0 - 0.6
#: Subframe 1 whole after the pull-in, then a few fixes.
DURATION_S = 8.0
#: The ionosphere sent (in subframe 1) and applied to the signals: a day's coefficients,
#: whole LSBs of D1's fields (so that the receiver's are the generator's), the period near
#: its 172800 s cap, so that 04:45 local time at VILL is day.
IONO = BdsKlobuchar((32 * 2.0**-30, 2 * 2.0**-27, -2 * 2.0**-24, 0.0), (84 * 2.0**11, 0.0, 0.0, 0.0))


@pytest.fixture(scope="module")
def b1i(tmp_path_factory):
    sats = highest(bds_records(), TOW0, 5)
    assert sats.sv.size == 5
    path = tmp_path_factory.mktemp("b1i") / "b1i.sigmf-data"
    write_b1i_recording(path, sats, TOW0, DURATION_S, seed=8, iono=IONO)
    return path, sats


def _prns(sats) -> list[int]:
    return [int(s[1:]) for s in sats.sv]


def test_receive_positions_from_b1i_alone(b1i):
    """Every satellite dated from its first subframe and used in every fix; each row's
    transmit time (GPS time) is the generator's B1I time within a few hundredths of a chip,
    and the fixes are on the station within three PDOPs of that error: the ionosphere the
    signals carry is removed by D1's own coefficients. The same observables solved without
    the model are metres further off, and high (a common delay goes to the clock, its growth
    with the zenith angle into the height: the low satellites' longer ranges push the fix up,
    as the assisted start's missing coefficients did in issue 41)."""
    path, sats = b1i
    *_, rms, _, result = assert_one_signal_fixes(
        path,
        sats,
        BEIDOU_B1I,
        bds_records(),
        GPS_WEEK,
        TOW0,
        ionosphere_delayed(satellite_time, IONO),
        STATION,
        fixes=int(DURATION_S) - 2,
        chip_fraction=0.05,
    )
    obs = result.observables
    assert obs.bds_iono == IONO
    bare = solve_epochs(obs, bds_records(), ionosphere=False, reference_week=GPS_WEEK, signal=BEIDOU_B1I)
    err = bare.ecef_m - STATION
    assert np.sqrt(np.mean(np.sum(err**2, axis=1))) > rms + 3.0, (rms, err)
    up = STATION / np.linalg.norm(STATION)
    assert np.mean(err @ up) > 3.0  # measured 8.2 m


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
