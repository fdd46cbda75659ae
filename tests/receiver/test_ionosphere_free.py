"""Ionosphere-free positions from an L1 C/A and an L2C recording of one front end
(`dual_observables`, `receive --ionosphere-free`), on 40 s of the five highest satellites of
real broadcast records seen from the station of 07590920.05o, both files started at the same
GPS time and both carrying an ionospheric code delay the test chooses (10 m at the zenith,
single-layer mapping at 350 km: 10.7-17.4 m on L1, γ times that on L2). 55 dB-Hz, a
strong signal: the combination's noise is three times one signal's, and the test looks for
the ionosphere under it. Truth: the station and the delays the generators were given."""

from __future__ import annotations

import csv

import numpy as np
import pymap3d
import pytest

from gnssframework import registry
from gnssframework.cli import main
from gnssframework.errors import ConfigError
from gnssframework.navigation.dual_frequency import DualFrequency
from gnssframework.navigation.ephemeris import read_rinex_nav, satellite_state
from gnssframework.receiver.channels import tracking_config
from gnssframework.receiver.frontend import open_recording
from gnssframework.receiver.navigation.dual_observables import ionosphere_free_fixes, second_observables
from gnssframework.receiver.navigation.receive import receive
from gnssframework.signal.gps_l1ca import GPS_L1CA
from gnssframework.signal.gps_l2c import GPS_L2C
from l2c_recordings import l2c_tracking_config, write_l2c_recording
from light_time import C
from lnav_recordings import NAV, STATION, TOW0, WEEK, _strongest, write_lnav_recording

pytestmark = pytest.mark.slow  # end to end (the fast lane leaves these out)

DURATION_S = 40.0
CN0_DBHZ = 55.0
FS = 2.6e6  # not 2.046 MHz: no dead band of the DLL on either signal
DUAL = DualFrequency(GPS_L1CA, GPS_L2C)


def _iono_l1_m(sats) -> np.ndarray:
    """10 m at the zenith, mapped by a single layer at 350 km (Earth radius 6371 km)."""
    los = satellite_state(sats, TOW0).position_m - STATION
    el = np.arcsin(los @ (STATION / np.linalg.norm(STATION)) / np.linalg.norm(los, axis=1))
    return 10.0 / np.sqrt(1.0 - (6371.0 / 6721.0 * np.cos(el)) ** 2)


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    sats = _strongest(read_rinex_nav(NAV), TOW0, 5)
    iono = _iono_l1_m(sats)
    d = tmp_path_factory.mktemp("dual")
    l1, l2 = d / "l1.sigmf-data", d / "l2.sigmf-data"
    write_lnav_recording(l1, sats, TOW0, DURATION_S, seed=21, sample_rate_hz=FS, iono_m=iono, cn0_dbhz=CN0_DBHZ)
    write_l2c_recording(l2, sats, TOW0, DURATION_S, seed=22, iono_l1_m=iono, cn0_dbhz=CN0_DBHZ)
    return l1, l2, sats, iono


@pytest.fixture(scope="module")
def received(recordings):
    l1, l2, sats, _ = recordings
    nav = read_rinex_nav(NAV)
    prns = tuple(int(s[1:]) for s in sats.sv)
    acq = registry.create("acquisition", "pcps")
    first = receive(
        open_recording(l1), acq, tracking_config(), prns=prns, rinex=nav, reference_week=WEEK, ionosphere=False
    )
    second = receive(
        open_recording(l2), acq, l2c_tracking_config(), prns=prns, rinex=nav, reference_week=WEEK, signal=GPS_L2C
    )
    obs2 = second_observables(second.tracking, DUAL, first.observables)
    obs, table = ionosphere_free_fixes(first.observables, obs2, DUAL, nav, reference_week=WEEK)
    return first, obs2, obs, table


def _up_m(ecef: np.ndarray) -> np.ndarray:
    lat, lon, h = pymap3d.ecef2geodetic(*STATION)
    return np.array([pymap3d.ecef2enu(*p, lat, lon, h)[2] for p in ecef])


def test_the_two_signals_see_the_ionosphere_the_generators_put_in(recordings, received):
    """Dated on one receiver clock, the two pseudoranges of a satellite differ by its
    ionosphere times γ - 1 plus its group delay: (P2 - P1) / (γ - 1) - c T_GD is each
    satellite's L1 delay, within four standard errors of its epochs' mean (doubled: the
    tracking noise is correlated over a few epochs)."""
    _, _, sats, iono = recordings
    first, obs2, _, _ = received
    o1 = first.observables
    _, e1, e2 = np.intersect1d(np.round(o1.sample_time_s, 6), np.round(obs2.sample_time_s, 6), return_indices=True)
    assert e1.size >= 25
    for k, sv in enumerate(sats.sv):
        j1 = int(np.flatnonzero(o1.prn == int(sv[1:]))[0])
        j2 = int(np.flatnonzero(obs2.prn == int(sv[1:]))[0])
        d = obs2.pseudorange_m[e2, j2] - o1.pseudorange_m[e1, j1]
        est = d[np.isfinite(d)] / (DUAL.gamma - 1) - C * sats.elements["TGD"][k]
        assert est.size >= 25
        assert abs(est.mean() - iono[k]) < 8 * est.std() / np.sqrt(est.size), (sv, est.mean(), iono[k])


def test_the_combination_takes_the_ionosphere_out_of_the_fixes(received):
    """The L1 fixes without an ionospheric model are high by about the delays (the vertical
    takes what the clock does not); the ionosphere-free fixes' mean height error is within
    six standard errors of zero, a test the L1 fixes fail."""
    first, _, obs, table = received
    assert len(table) >= 25 and np.isfinite(obs.pseudorange_m).any()
    up_if = _up_m(table.ecef_m)
    bound = 6 * up_if.std() / np.sqrt(up_if.size)
    assert abs(up_if.mean()) < bound
    up_l1 = _up_m(first.positions.ecef_m)
    assert up_l1.mean() > bound + 5.0, (up_l1.mean(), bound)


def test_the_command_writes_the_ionosphere_free_fixes(recordings, received, tmp_path, capsys):
    l1, l2, sats, _ = recordings
    _, _, _, table = received
    out = tmp_path / "rx"
    args = ["receive", str(l1), "--ionosphere-free", str(l2), "--ephemeris", str(NAV), "--week", str(WEEK)]
    prns = [str(int(s[1:])) for s in sats.sv]
    assert main([*args, "--no-iono", "--prns", *prns, "--out", str(out), "--quiet"]) == 0
    assert "ionosphere-free: " in capsys.readouterr().out
    with open(out / "positions.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == len(table)
    ecef = np.array(
        [pymap3d.geodetic2ecef(float(r["lat_deg"]), float(r["lon_deg"]), float(r["height_m"])) for r in rows]
    )
    assert np.max(np.linalg.norm(ecef - table.ecef_m, axis=1)) < 0.01  # the file's digits


@pytest.mark.parametrize(
    "extra, why",
    [
        (
            ["--tracking", "vector"],
            r"--ionosphere-free: solves by least squares per epoch after the run: drop --tracking vector",
        ),
        (["--nav-filter", "ekf-pv"], r"drop --nav-filter"),
        (["--second-signal", "galileo-e1b"], r"signal: galileo-e1b: the ionosphere-free combination takes GPS or QZSS"),
        (["--signal", "gps-l1ca,galileo-e1b"], r"--ionosphere-free: combines one signal with --second-signal"),
    ],
)
def test_what_it_cannot_be_combined_with_is_refused_in_one_line(recordings, tmp_path, capsys, extra, why):
    l1, l2, _, _ = recordings
    args = ["receive", str(l1), "--ionosphere-free", str(l2), "--out", str(tmp_path / "rx"), "--quiet", *extra]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and ConfigError.__name__ not in err
    import re

    assert re.search(why, err), err


def test_second_signal_options_need_the_second_recording(recordings, tmp_path, capsys):
    l1, _, _, _ = recordings
    assert main(["receive", str(l1), "--second-signal", "qzss-l2c", "--out", str(tmp_path / "rx")]) == 2
    assert "--second-signal: describes the --ionosphere-free recording" in capsys.readouterr().err


def test_without_a_transmit_time_the_tracking_is_written_and_no_fix(recordings, tmp_path, capsys):
    """5 s hold no LNAV subframe: nothing to combine, said in a note; the run writes its
    tracking and report and exits 1, as any run without a position."""
    l1, l2, sats, _ = recordings
    out = tmp_path / "rx"
    args = ["receive", str(l1), "--ionosphere-free", str(l2), "--ephemeris", str(NAV), "--duration", "5"]
    assert main([*args, "--prns", str(int(sats.sv[0][1:])), "--out", str(out), "--quiet"]) == 1
    text = capsys.readouterr().out
    assert "note: ionosphere-free: no transmit time decoded from gps-l1ca; nothing to combine" in text
    assert (out / "tracking.csv").exists() and (out / "report.md").exists()
