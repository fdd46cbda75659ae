"""Issue 38: a navigation file's record is used only within the 4-hour fit of its Toe
(IS-GPS-200 20.3.4.4); on main the nearest record by seconds of week was used however far
(another day's orbits gave wrong positions, or the wrong reason for none)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gnssframework.navigation.ephemeris import read_rinex_nav
from gnssframework.receiver.navigation.fixes import MAX_EPHEMERIS_AGE_S, _ephemeris_for

NAV = Path(__file__).parents[1] / "data" / "07590920.05n"


def test_a_record_far_from_the_epoch_is_not_used():
    rinex = read_rinex_nav(NAV)
    gps = [str(s) for s in rinex.sv if str(s).startswith("G")]
    assert gps, "the file holds GPS records"
    prn = int(gps[0][1:])
    toe = float(rinex.select([gps[0]], 0.0).elements["Toe"][0])
    near = _ephemeris_for(np.array([prn]), None, rinex, toe + 3600.0, 0.0)
    assert near[0] is not None
    nearest = min(abs(toe_k - (toe + 12 * 3600.0)) for toe_k in rinex.elements["Toe"][rinex.sv == gps[0]])
    far = _ephemeris_for(np.array([prn]), None, rinex, toe + 12 * 3600.0, 0.0)
    assert nearest > MAX_EPHEMERIS_AGE_S and far[0] is None


def test_the_no_position_line_says_the_navigation_file_is_of_another_time():
    from types import SimpleNamespace

    from gnssframework.cli import _ephemeris_distance

    rinex = read_rinex_nav(NAV)
    gps = rinex.sv.astype(str) == rinex.sv.astype(str)
    toes = rinex.elements["Toe"][gps]
    inside = SimpleNamespace(rx_time_s=np.array([float(toes[0]) + 600.0]))
    assert _ephemeris_distance(rinex, inside) == ""
    # the time of week farthest from every record (the file covers part of a day)
    grid = np.arange(0.0, 604800.0, 600.0)
    far_t = grid[np.argmax([np.min(np.abs((t - toes + 302400) % 604800 - 302400)) for t in grid])]
    said = _ephemeris_distance(rinex, SimpleNamespace(rx_time_s=np.array([far_t])))
    assert "--ephemeris file's nearest GPS record is" in said and "give the navigation file" in said
