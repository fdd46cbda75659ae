"""`receive --signal gps-l2c` with no navigation file: positions from the records CNAV
itself carries (types 10, 11 and 30, `cnav_records`), on 41 s of the L2C recordings of
`l2c_recordings` (five real broadcast records on CNAV's 300 s grid, seen from the station of
07590920.05o). Truth: the station; and the same pseudoranges solved with the navigation
file's own records (RINEX, not decoded), which the CNAV records must reproduce within their
scale factors."""

from __future__ import annotations

import csv
import dataclasses

import numpy as np
import pymap3d
import pytest

from gnssframework.cli import main
from gnssframework.navigation.ephemeris import read_rinex_nav, satellite_state
from gnssframework.navigation.pvt import dop
from gnssframework.receiver.navigation.fixes import solve_epochs
from gnssframework.receiver.navigation.receive import receive
from gnssframework.signal.gps_l2c import GPS_L2C
from l2c_recordings import TOW0, WEEK, l2c_tracking_config, write_l2c_recording
from lnav_recordings import NAV, STATION, _strongest

pytestmark = pytest.mark.slow  # end to end (the fast lane leaves these out)

#: Three 12 s messages (10, 11, 30 in turn) from about 0.5 s in, the pull-in and a few fixes.
DURATION_S = 41.0


@pytest.fixture(scope="module")
def l2c_long(tmp_path_factory):
    nav = read_rinex_nav(NAV)
    sats = _strongest(nav, TOW0, 7)
    sats = sats.subset(np.flatnonzero(sats.elements["Toe"] % 300 == 0))  # CNAV can carry these
    assert sats.sv.size >= 5
    sats = sats.subset(np.arange(5))
    path = tmp_path_factory.mktemp("l2c_long") / "l2c.sigmf-data"
    write_l2c_recording(path, sats, TOW0, DURATION_S, seed=11)
    return path, sats


def _prns(sats) -> list[int]:
    return [int(s[1:]) for s in sats.sv]


def test_cnav_records_position_as_the_navigation_files_own(l2c_long):
    """The fixes from the decoded records equal, epoch by epoch, those of the same
    observables solved with the navigation file's records (within 5 cm: the CNAV scale
    factors move a satellite by about 2 cm and its clock by under 1 cm; the Klobuchar
    coefficients at their own resolution), and are on the station within what the
    pseudoranges allow."""
    from gnssframework import registry
    from gnssframework.receiver.frontend import open_recording

    path, sats = l2c_long
    result = receive(
        open_recording(path),
        registry.create("acquisition", "pcps"),
        l2c_tracking_config(),
        prns=tuple(_prns(sats)),
        signal=GPS_L2C,
        reference_week=WEEK,
    )
    obs, table = result.observables, result.positions
    assert table is not None and len(table) >= 3
    assert set(obs.ephemeris) == set(_prns(sats))
    # Nothing before three messages (36 s) have arrived: a record needs types 10, 11 and 30.
    assert table.sample_time_s[0] > 36.0
    assert obs.iono_utc is not None  # the Klobuchar coefficients of type 30
    rinex = read_rinex_nav(NAV)
    own = solve_epochs(
        dataclasses.replace(obs, ephemeris={}), rinex, iono=obs.iono_utc, reference_week=WEEK, signal=GPS_L2C
    )
    common, a, b = np.intersect1d(table.sample_time_s, own.sample_time_s, return_indices=True)
    assert common.size == len(table)
    assert np.max(np.linalg.norm(table.ecef_m[a] - own.ecef_m[b], axis=1)) < 0.05
    lat, lon, h = pymap3d.ecef2geodetic(*STATION)
    up = np.array([pymap3d.ecef2enu(*p, lat, lon, h) for p in satellite_state(sats, TOW0 + 38.0).position_m])
    pdop = dop(up / np.linalg.norm(up, axis=1)[:, None])[1]
    err = np.linalg.norm(table.ecef_m - STATION, axis=1)
    assert np.sqrt(np.mean(err**2)) < 3 * pdop * 0.03 * GPS_L2C.chip_length_m  # a few hundredths of a chip


def test_the_command_positions_without_a_navigation_file(l2c_long, tmp_path, capsys):
    """What a user types: no ``--ephemeris`` and no ``--week``. The fixes come once the
    records are complete, in the records' week (2005's 1316, which type 10's 13 bits carry
    and no 10-bit week places: that reads as 2340); the report says when each satellite's
    was decoded; navigation.rnx is written as RINEX 4.00 (RINEX 3.04 has no CNAV record,
    the note says so), and its records place each satellite where the navigation file's
    own record does (within the CNAV scale factors' 2 cm)."""
    path, sats = l2c_long
    out = tmp_path / "rx"
    args = ["receive", str(path), "--signal", "gps-l2c", "--out", str(out)]
    assert main([*args, "--prns", *map(str, _prns(sats)), "--quiet", "--outputs", "rinex-nav"]) == 0
    with open(out / "positions.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) >= 3 and all(int(r["n_sats"]) == 5 for r in rows)
    assert {int(r["gps_week"]) for r in rows} == {WEEK}
    assert "CNAV records: navigation.rnx is written as RINEX 4.00" in capsys.readouterr().out
    written = read_rinex_nav(out / "navigation.rnx")
    assert sorted(written.sv) == sorted(sats.sv) and np.all(written.elements["CNAV"] == 1.0)
    t = TOW0 + 38.0
    gap_m = np.linalg.norm(
        satellite_state(written.select(sats.sv, t), t).position_m - satellite_state(sats, t).position_m, axis=1
    )
    assert np.max(gap_m) < 0.05
    report = (out / "report.md").read_text().splitlines()
    cells = [c.strip() for c in next(line for line in report if line.startswith("| PRN")).split("|")]
    col = cells.index("ephemeris")
    sat_rows = [line.split("|") for line in report if line.startswith("| ") and line[2:3].isdigit()]
    assert len(sat_rows) == 5
    for row in sat_rows:
        decoded_at = float(row[col].strip().removeprefix("decoded at ").removesuffix(" s"))
        assert 36.0 < decoded_at < float(rows[0]["tow_s"]) - TOW0 + 0.1  # known before the first fix
