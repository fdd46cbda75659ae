"""End to end on the project's own generator: five satellites of real broadcast records
(tests/data/07590920.05n) seen from the station of 07590920.05o, each signal carrying its
LNAV with the code phase, Doppler and data timing of the geometry (light time, Earth
rotation, satellite clock; updated every 0.5 s); acquisition, tracking, LNAV TOW, observables
and fixes (`receive`, with the RINEX records as `--ephemeris` does) put the receiver
within a few metres of the station, and the `position` command writes its files."""

from __future__ import annotations

import numpy as np
import pytest

from gnssframework import registry
from gnssframework.cli import main
from gnssframework.navigation.ephemeris import read_rinex_nav
from gnssframework.receiver.navigation.receive import receive
from gnssframework.receiver.channels import tracking_config
from gnssframework.receiver.frontend import open_recording

# The generator's constants and helpers, used here and, through this module, by the vector tests.
from lnav_recordings import (
    CHUNK_S,
    FS,
    NAV,
    STATION,
    TOW0,
    _satellite_time,
    _strongest,  # noqa: F401
    write_lnav_recording,
)

DURATION_S = 9.5


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    sats = _strongest(read_rinex_nav(NAV), TOW0, 5)
    path = write_lnav_recording(tmp_path_factory.mktemp("fix") / "five.sigmf-data", sats, TOW0, DURATION_S, seed=2025)
    return path, sats


@pytest.mark.slow
def test_receive_positions_the_generated_recording_at_the_station(recording):
    path, sats = recording
    result = receive(
        open_recording(path),
        registry.create("acquisition", "pcps"),
        tracking_config(),
        rate_hz=5.0,
        rinex=read_rinex_nav(NAV),
    )
    table = result.positions
    assert table is not None and len(table) >= 3
    assert np.all(table.columns["n_sats"] == 5)
    err = np.linalg.norm(table.ecef_m - STATION, axis=1)
    # 45 dB-Hz, a 2 Hz DLL with 1-chip spacing: about 1.7 m of code noise per satellite; PDOP-scaled.
    assert np.sqrt(np.mean(err**2)) < 4 * np.max(table.columns["hdop"] + table.columns["vdop"]) * 1.7
    # The receiver clock is GPS time here: the solution's time is each epoch's sample time after TOW0.
    assert np.allclose(table.columns["tow_s"], TOW0 + table.sample_time_s, atol=30e-9)
    speed = np.linalg.norm(np.stack([table.columns[k] for k in ("vel_e_mps", "vel_n_mps", "vel_u_mps")], 1), axis=1)
    assert np.all(speed < 0.5)


@pytest.mark.slow
def test_position_command_writes_positions_rinex_and_nmea(recording, tmp_path, capsys):
    path, _ = recording
    lat, lon, h = (float(v) for v in __import__("pymap3d").ecef2geodetic(*STATION))
    code = main(
        [
            "position",
            str(path),
            "--out",
            str(tmp_path / "pos"),
            "--ephemeris",
            str(NAV),
            "--rate",
            "5",
            "--truth",
            f"{lat},{lon},{h}",
        ]
    )
    out = capsys.readouterr().out
    assert code == 0, out
    assert "against --truth: horizontal RMS" in out
    assert (tmp_path / "pos" / "positions.csv").read_text().count("\n") >= 4
    # No subframe 1 in the file: the week is the --ephemeris file's (its records are of GPS week 1316,
    # 2005-03-27 to 2005-04-02, as RTKLIB and GNSS-SDR take it), so positions.csv carries it and
    # the RINEX and NMEA files are written.
    assert "GPS week 1316 from the --ephemeris file's records" in out
    rows = (tmp_path / "pos" / "positions.csv").read_text().splitlines()
    assert {line.split(",")[0] for line in rows[1:]} == {"1316"}
    assert (tmp_path / "pos" / "nmea.txt").exists()
    first_epoch = next(
        line for line in (tmp_path / "pos" / "observations.rnx").read_text().splitlines() if line.startswith("> ")
    )
    assert first_epoch.startswith("> 2005 04 02 ")  # Saturday of week 1316: TOW0 is 6 d 0 h 5 min in
