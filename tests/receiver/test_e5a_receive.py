"""`receive --signal galileo-e5ai`: positions from Galileo E5a-I alone, each channel dated
from its F/NAV GST on 1 ms rows under CS20_1 (`inav_stream.channel_inav`) and solved with
the E5a user's clock (`ephemeris.single_frequency_clock_s`: F/NAV's clock less
(f_E1/f_E5a)^2 BGD(E1,E5a)), on the five highest satellites of the 2022-02-20 records seen
from VILL, relabelled as F/NAV records (`inav_recordings.write_e5a_recording`, their E5a
time computed by the test). Truth: the station, and each satellite's E5a time at every
dated row."""

from __future__ import annotations

import csv

import pytest

from gnssframework.cli import main
from gnssframework.signal.galileo_e5a import GALILEO_E5AI
from light_time import assert_one_signal_fixes
from inav_recordings import (
    GPS_WEEK,
    NAV,
    STATION,
    e5a_satellite_time,
    fnav_records,
    highest,
    write_e5a_recording,
)

pytestmark = pytest.mark.slow  # end to end (the fast lane leaves these out)

#: A 10 s page (type 4: a TOW and no week) starts on GST 18030 s, about 0.5 s in.
TOW0 = 18_030.0 - 0.4
#: One whole page after the pull-in, and a few fixes.
DURATION_S = 11.0
C = 299_792_458.0


@pytest.fixture(scope="module")
def e5a(tmp_path_factory):
    sats = highest(fnav_records(), TOW0, 5)
    assert sats.sv.size == 5
    path = tmp_path_factory.mktemp("e5a") / "e5a.sigmf-data"
    write_e5a_recording(path, sats, TOW0, DURATION_S, seed=8)
    return path, sats


def _prns(sats) -> list[int]:
    return [int(s[1:]) for s in sats.sv]


def test_receive_positions_from_e5a_alone(e5a):
    """Every satellite dated from its first page and used in every fix; each row's transmit
    time is the generator's E5a time within a few hundredths of a chip, and the fixes are
    on the station within three PDOPs of that error."""
    path, sats = e5a
    assert_one_signal_fixes(
        path,
        sats,
        GALILEO_E5AI,
        fnav_records(),
        GPS_WEEK,
        TOW0,
        e5a_satellite_time,
        STATION,
        fixes=int(DURATION_S) - 2,
        chip_fraction=0.03,
    )


def test_the_command_tracks_decodes_and_refuses_a_file_without_fnav_records(e5a, tmp_path, capsys):
    """What a user types: ``track`` writes each channel's F/NAV pages (``fnav.csv``: the one
    whole page, type 4, with its TOW and no week, as type 4 sends none); ``receive
    --ephemeris`` with the I/NAV file (records whose clock is for E1,E5b: no E5a user's
    clock) is refused in one line naming the file and what it lacks."""
    path, sats = e5a
    prns = [str(p) for p in _prns(sats)]
    out = tmp_path / "trk"
    assert main(["track", str(path), "--signal", "galileo-e5ai", "--prns", *prns, "--out", str(out), "--quiet"]) == 0
    with open(out / "fnav.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 5
    assert all((r["word_types"], r["gst_tow_s"], r["gst_wn"]) == ("4", "18030", "") for r in rows)
    args = ["receive", str(path), "--signal", "galileo-e5ai", "--ephemeris", str(NAV), "--out", str(tmp_path / "rx")]
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "holds no Galileo F/NAV record" in err[0] and NAV.name in err[0]
