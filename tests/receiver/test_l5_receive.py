"""`receive --signal gps-l5i`: positions from GPS L5 I5 alone, each channel dated from its
CNAV TOW on 1 ms rows under NH10 (`cnav_stream.cnav_channel_timing`) and solved with the L5
I5 user's clock and ionosphere scale (`ephemeris.single_frequency_clock_s`), on the five
satellites of `l2c_recordings.write_cnav_recording` (real broadcast records seen from the
station of 07590920.05o, their L5 time computed by the test, not by the library). Truth:
the station, and each satellite's L5 SV time at every dated row."""

from __future__ import annotations

import csv

import pytest

from gnssframework.cli import main
from gnssframework.navigation.ephemeris import read_rinex_nav
from gnssframework.signal.gps_l5 import GPS_L5I
from l2c_recordings import TOW0_L5, WEEK, l5_satellite_time, write_cnav_recording
from light_time import assert_one_signal_fixes
from lnav_recordings import NAV, STATION, _strongest

pytestmark = pytest.mark.slow  # end to end (the fast lane leaves these out)

#: A 6 s L5 message starts about 0.5 s in (SV time 518706 s), so 8 s hold one whole.
DURATION_S = 8.0
C = 299_792_458.0


@pytest.fixture(scope="module")
def l5(tmp_path_factory):
    sats = _strongest(read_rinex_nav(NAV), TOW0_L5, 5)
    path = tmp_path_factory.mktemp("l5") / "l5.sigmf-data"
    write_cnav_recording(path, sats, TOW0_L5, DURATION_S, seed=6, signal=GPS_L5I)
    return path, sats


def _prns(sats) -> list[int]:
    return [int(s[1:]) for s in sats.sv]


def test_receive_positions_from_l5_alone(l5):
    """Every satellite is dated from its first message and used in every fix; each row's
    transmit time is the generator's L5 SV time within a few hundredths of a chip, and the
    fixes are on the station within three PDOPs of that error."""
    path, sats = l5
    assert_one_signal_fixes(
        path,
        sats,
        GPS_L5I,
        read_rinex_nav(NAV),
        WEEK,
        TOW0_L5,
        l5_satellite_time,
        STATION,
        fixes=int(DURATION_S) - 2,
        chip_fraction=0.03,
    )


def test_the_command_positions_from_l5(l5, tmp_path):
    """What a user types: the fixes, with the observations written under L5 I5's RINEX codes."""
    path, sats = l5
    out = tmp_path / "rx"
    args = ["receive", str(path), "--signal", "gps-l5i", "--ephemeris", str(NAV), "--week", str(WEEK)]
    assert main([*args, "--prns", *map(str, _prns(sats)), "--out", str(out), "--quiet"]) == 0
    with open(out / "positions.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) >= int(DURATION_S) - 2 and all(int(r["n_sats"]) == 5 for r in rows)
    assert "C5I" in (out / "observations.rnx").read_text()
