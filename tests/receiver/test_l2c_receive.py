"""`receive --signal gps-l2c`: positions from GPS L2C alone, each channel dated from its
CNAV TOW (`cnav_stream.cnav_channel_timing`) and solved with an L2 user's clock and
ionosphere (`ephemeris.single_frequency_clock_s`), on the five satellites of
`l2c_recordings` (real broadcast records seen from the station of 07590920.05o, their L2
time computed by the test, not by the library). Truth: the station, and each satellite's
L2 SV time at every dated row."""

from __future__ import annotations

import csv

import numpy as np
import pymap3d
import pytest

from gnssframework.cli import main
from gnssframework.navigation.ephemeris import read_rinex_nav
from gnssframework.navigation.pvt import dop
from gnssframework.receiver.navigation.receive import receive
from gnssframework.signal.gps_l2c import GPS_L2C
from l2c_recordings import FS, TOW0, WEEK, l2_satellite_time, l2c_tracking_config, write_l2c_recording
from lnav_recordings import NAV, STATION, _strongest

pytestmark = pytest.mark.slow  # end to end (the fast lane leaves these out)

DURATION_S = 14.0
C = 299_792_458.0


@pytest.fixture(scope="module")
def l2c(tmp_path_factory):
    sats = _strongest(read_rinex_nav(NAV), TOW0, 5)
    path = tmp_path_factory.mktemp("l2c") / "l2c.sigmf-data"
    write_l2c_recording(path, sats, TOW0, DURATION_S, seed=4)
    return path, sats


def test_receive_positions_from_l2c_alone(l2c, tmp_path, capsys):
    """What a user types. Every satellite is dated and used in every fix once a CNAV message
    has arrived (one starts about 0.5 s in and ends 12 s later). Each fix is within three
    PDOPs of the pseudoranges' own error, measured here against the generator's L2 time."""
    path, sats = l2c
    prns = [str(int(s[1:])) for s in sats.sv]
    out = tmp_path / "rx"
    args = ["receive", str(path), "--signal", "gps-l2c", "--ephemeris", str(NAV), "--week", str(WEEK)]
    assert main([*args, "--prns", *prns, "--out", str(out), "--quiet"]) == 0
    with open(out / "positions.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) >= int(DURATION_S) - 2
    assert all(int(r["n_sats"]) == 5 for r in rows)
    ecef = np.array(
        [pymap3d.geodetic2ecef(float(r["lat_deg"]), float(r["lon_deg"]), float(r["height_m"])) for r in rows]
    )
    err = np.linalg.norm(ecef - STATION, axis=1)
    # The pseudoranges' error against the truth (the generator's L2 time at each epoch).
    result = _receive(path)
    obs = result.observables
    pr_err = []
    for j, prn in enumerate(obs.prn):
        k = [int(s[1:]) for s in sats.sv].index(int(prn))
        ok = np.isfinite(obs.transmit_s[:, j])
        truth = np.array(
            [l2_satellite_time(sats.subset(np.array([k])), np.array(TOW0 + t))[0] for t in obs.sample_time_s[ok]]
        )
        pr_err.append((obs.transmit_s[ok, j] - truth) * C)
    sigma_pr = float(np.std(np.concatenate(pr_err)))
    assert sigma_pr < 0.03 * GPS_L2C.chip_length_m  # tracked: a few hundredths of a chip
    lat, lon, h = pymap3d.ecef2geodetic(*STATION)
    up = np.array([pymap3d.ecef2enu(*p, lat, lon, h) for p in sats_positions(sats)])
    pdop = dop(up / np.linalg.norm(up, axis=1)[:, None])[1]
    assert np.sqrt(np.mean(err**2)) < 3 * pdop * sigma_pr, (err, pdop, sigma_pr)
    text = capsys.readouterr().out
    assert "fixes" in text


def sats_positions(sats) -> np.ndarray:
    from gnssframework.navigation.ephemeris import satellite_state

    return satellite_state(sats, TOW0 + 6.0).position_m


def _receive(path):
    from gnssframework import registry
    from gnssframework.receiver.frontend import open_recording

    acq = registry.create("acquisition", "pcps")
    sats = _strongest(read_rinex_nav(NAV), TOW0, 5)
    prns = tuple(int(s[1:]) for s in sats.sv)
    rinex = read_rinex_nav(NAV)
    rec = open_recording(path)
    return receive(rec, acq, l2c_tracking_config(), prns=prns, rinex=rinex, signal=GPS_L2C, reference_week=WEEK)


def test_without_a_navigation_file_14_s_are_too_short_for_a_cnav_record(l2c, tmp_path, capsys):
    """A CNAV record takes types 10, 11 and 30 (36 s); this file holds one message of each
    satellite: no position, exit 1, the tracking written, and each satellite's reason."""
    path, sats = l2c
    out = tmp_path / "rx"
    args = ["receive", str(path), "--signal", "gps-l2c", "--week", str(WEEK), "--out", str(out), "--quiet"]
    assert main([*args, "--prns", *[str(int(s[1:])) for s in sats.sv]]) == 1
    assert capsys.readouterr().out.startswith("no position: fewer than 4 satellites with a pseudorange and a decoded")
    assert (out / "tracking.csv").exists()
    report = (out / "report.md").read_text()
    assert report.count("no healthy ephemeris (none decoded, no --ephemeris file)") == 5


def test_the_fine_search_takes_whole_symbols(l2c):
    """One CNAV symbol per 20 ms CM period: a fine-search block that starts at sample 0
    straddles a symbol edge, and its Doppler was pulled 21.5 Hz off on PRN 11 (which then
    locked 25 Hz off, at 1/(2T)). From the code epoch on (`pcps`'s ``_symbol_blocks``), every
    satellite's Doppler is within two fine steps (5 Hz) of the generator's."""
    from gnssframework import registry
    from gnssframework.receiver.acquisition.report import acquire_recording
    from gnssframework.receiver.frontend import open_recording

    path, sats = l2c
    acq = registry.create("acquisition", "pcps")
    prns = tuple(int(s[1:]) for s in sats.sv)
    found = acquire_recording(open_recording(path), acq, prns, signal=GPS_L2C)
    assert acq._symbol_blocks(GPS_L2C, False)
    for k, r in enumerate(found):
        one = sats.subset(np.array([k]))
        t_mid = TOW0 + 0.5 * acq.samples_needed(FS, GPS_L2C) / FS
        rate = (l2_satellite_time(one, np.array(t_mid + 0.005)) - l2_satellite_time(one, np.array(t_mid - 0.005)))[0]
        truth_hz = GPS_L2C.carrier_freq_hz * (rate / 0.01 - 1.0)
        assert r.detected and abs(r.doppler_hz - truth_hz) < 5.0, (r.prn, r.doppler_hz, truth_hz)
