"""`receive` with SBAS messages from a file (`receiver.navigation.sbas_fixes`): the project's
generated LNAV recording (five satellites of tests/data/07590920.05n seen from its station,
50 dB-Hz) with each satellite's code delayed by a known error, an SBAS stream
(`tests/sbas_streams.py`) carrying those errors, and the fixes corrected by it against the
broadcast ones on the same observables.

The delays: a clock error of 12-30 m each (both signs), the slant delay of a plane of
vertical ionosphere (1.9-4.1 m) and DO-229's MOPS troposphere. The stream carries the clock
errors as fast corrections and the plane as its grid; the broadcast fix (Klobuchar from the
file's page 18, no troposphere) keeps them."""

from __future__ import annotations

import numpy as np
import pymap3d
import pytest

from gnssframework.cli import main
from gnssframework.navigation.ephemeris import read_rinex_nav
from gnssframework.navigation.sbas_files import write_rtklib_sbs
from gnssframework.receiver.navigation.fixes import solve_epochs, write_positions_csv
from gnssframework.receiver.navigation.sbas_fixes import SbasOptions, day_of_year
from lnav_recordings import NAV, STATION, TOW0, WEEK, _strongest, write_lnav_recording
from sbas_streams import range_delays, receive_sbas, sbas_stream

DURATION_S = 10.5
CLOCK_ERRORS_M = np.array([18.0, -24.0, 12.0, -15.0, 30.0])
CN0_DBHZ = 50.0
#: The recording's code noise a satellite: test_receiver_fix's 1.7 m at 45 dB-Hz, scaled as
#: the DLL's thermal noise, 1/sqrt(C/N0).
SIGMA_M = 1.7 * 10 ** (-(CN0_DBHZ - 45.0) / 20)


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    sats = _strongest(read_rinex_nav(NAV), TOW0, 5)
    delay_m, prc_m = range_delays(sats, STATION, TOW0 + 5.0, day_of_year(WEEK, TOW0), CLOCK_ERRORS_M)
    folder = tmp_path_factory.mktemp("sbas")
    path = write_lnav_recording(
        folder / "five.sigmf-data", sats, TOW0, DURATION_S, seed=39, iono_m=delay_m, cn0_dbhz=CN0_DBHZ
    )
    n = sats.sv.size
    records = sbas_stream(sats, np.zeros((n, 3)), np.zeros(n), prc_m, WEEK, TOW0 - 120.0, TOW0 + DURATION_S, 137)
    sbs = write_rtklib_sbs(folder / "stream.sbs", records)
    rinex = read_rinex_nav(NAV)
    result = receive_sbas(path, rinex, SbasOptions(tuple(records), sigma_noise_m=SIGMA_M))
    plain = solve_epochs(result.observables, rinex)
    return result, plain, sbs, folder


@pytest.mark.slow
def test_sbas_fixes_lose_the_errors_the_broadcast_fixes_keep(run):
    result, plain, _, _ = run
    table = result.positions
    assert table is not None and len(table) >= 5
    assert np.all(table.columns["sbas_sats"] == 5) and np.all(table.columns["n_sats"] == 5)
    err = np.linalg.norm(table.ecef_m - STATION, axis=1)
    plain_err = np.linalg.norm(plain.ecef_m - STATION, axis=1)
    # The code noise through the geometry (test_receiver_fix's bound): what the corrected
    # fixes keep; the broadcast ones keep the injected errors too, several times it.
    bound = 4 * np.max(table.columns["hdop"] + table.columns["vdop"]) * SIGMA_M
    assert np.sqrt(np.mean(err**2)) < bound < np.min(plain_err)
    # The same epochs and the same observables: the rows differ by the corrections alone.
    np.testing.assert_allclose(table.sample_time_s, plain.sample_time_s)
    # With the receiver's own code noise in sigma_air, the protection levels bound the errors.
    hpl, vpl = table.columns["hpl_m"], table.columns["vpl_m"]
    enu = np.array([pymap3d.ecef2enu(*x, *pymap3d.ecef2geodetic(*STATION)) for x in table.ecef_m])
    assert np.all(np.hypot(enu[:, 0], enu[:, 1]) < hpl) and np.all(np.abs(enu[:, 2]) < vpl)
    assert np.all(vpl < 60.0)
    # Velocities are the broadcast fixes' (SBAS corrects ranges, not Dopplers).
    np.testing.assert_allclose(table.columns["vel_e_mps"], plain.columns["vel_e_mps"], atol=1e-6)


@pytest.mark.slow
def test_positions_csv_carries_the_sbas_columns(run, tmp_path):
    result, _, _, _ = run
    text = write_positions_csv(tmp_path / "positions.csv", result.positions).read_text().splitlines()
    header = text[0].split(",")
    assert header[-3:] == ["hpl_m", "vpl_m", "sbas_sats"]
    assert all(row.split(",")[-1] == "5" for row in text[1:])


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    sats = _strongest(read_rinex_nav(NAV), TOW0, 5)
    return write_lnav_recording(tmp_path_factory.mktemp("tiny") / "tiny.sigmf-data", sats, TOW0, 0.5, seed=1)


@pytest.mark.parametrize(
    ("extra", "says"),
    [
        (["--sbas-prn", "137"], "--sbas-prn: is a setting of --sbas-messages or --sbas-signal"),
        (["--sbas-signal", "--sbas-prn", "100"], "--sbas-prn: an SBAS GEO's PRN is 120-158, got 100"),
        (["--sbas-signal", "--nav-filter", "ekf-pv"], "--sbas-signal: corrects the least-squares fixes"),
        (["--sbas-signal", "--signal", "gps-l1ca,galileo-e1b-boc11"], "--sbas-signal: SBAS L1 corrects"),
        (["--sbas-messages", "{sbs}", "--sbas-prn", "120"], "--sbas-prn: no message of PRN 120"),
        (["--sbas-messages", "{sbs}", "--sbas-sigma-noise", "0"], "--sbas-sigma-noise: must be positive"),
        (["--sbas-messages", "{sbs}", "--raim"], "--sbas-messages: corrects the least-squares fixes"),
        (["--sbas-messages", "{sbs}", "--tracking", "vector"], "--sbas-messages: corrects the least-squares fixes"),
        (["--sbas-messages", "{sbs}", "--signal", "gps-l1ca,galileo-e1b-boc11"], "--sbas-messages: SBAS L1 corrects"),
        (["--sbas-messages", "{empty}"], "--sbas-messages: the file holds no SBAS message"),
        (["--sbas-messages", "{bad}"], "bad.sbs:1: not an SBAS message"),
    ],
)
def test_the_options_are_refused_in_one_line_before_any_tracking(extra, says, tiny, tmp_path, capsys):
    # The refusals come before any tracking: half a second of recording serves.
    sbs = write_rtklib_sbs(
        tmp_path / "s.sbs",
        sbas_stream(
            _strongest(read_rinex_nav(NAV), TOW0, 5),
            np.zeros((5, 3)),
            np.zeros(5),
            np.zeros(5),
            WEEK,
            TOW0,
            TOW0 + 2,
            137,
        ),
    )
    (tmp_path / "empty.sbs").write_text("")
    (tmp_path / "bad.sbs").write_text("1316 518700 137 2 : zz\n")
    names = {"sbs": str(sbs), "empty": str(tmp_path / "empty.sbs"), "bad": str(tmp_path / "bad.sbs")}
    args = [a.format(**names) for a in extra]
    code = main(["receive", str(tiny), *args, "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and says in err[0], err
    assert not (tmp_path / "out").exists()
