"""Fixes at every epoch of observables (synthetic, from real broadcast records and a known
station), positions.csv, the causal use of decoded ephemerides, the 10-bit week, and the
`position` command's refusals and its "no position" message."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from gnssframework.cli import main
from gnssframework.navigation.ephemeris import read_rinex_nav, satellite_state
from light_time import C, signal_flight
from gnssframework.receiver.navigation.fixes import POSITION_COLUMNS, full_week, solve_epochs, write_positions_csv
from gnssframework.receiver.navigation.observables import Observables
from gnssframework.receiver.frontend import SatelliteSignal, synthesize_samples, write_recording

DATA = Path(__file__).parents[1] / "data"
STATION = np.array([-3976219.5082, 3382372.5671, 3652512.9849])  # 07590920.05o header, m


def _pseudoranges(eph, t_rx, bias_m):
    tau, clock, _ = signal_flight(eph, t_rx, STATION)
    return C * tau + bias_m - C * clock, t_rx - tau + clock


@pytest.fixture(scope="module")
def synthetic():
    nav = read_rinex_nav(DATA / "07590920.05n")
    t0 = 518_700.0
    names = np.unique(nav.sv)
    sel = nav.select(names, t0)
    up = STATION / np.linalg.norm(STATION)
    los = satellite_state(sel, t0).position_m - STATION
    sel = sel.subset(np.flatnonzero(los @ up / np.linalg.norm(los, axis=1) > np.sin(np.radians(10))))
    epochs = t0 + np.arange(5.0)
    bias = 1500.0
    pr, tx = zip(*(_pseudoranges(sel, t, bias) for t in epochs))
    prn = np.array([int(s[1:]) for s in sel.sv])
    # Decoded ephemerides: every satellite's known from the start but one, known from epoch 3 on.
    ready = {int(p): [(0.0 if k else 2.5, sel.subset(np.array([k])))] for k, p in enumerate(prn)}
    obs = Observables(
        epochs + bias / C,
        epochs - t0,
        prn,
        np.array(tx),
        np.array(pr),
        np.zeros((5, prn.size)),
        np.zeros((5, prn.size)),
        np.full((5, prn.size), 45.0),
        ready,
        None,
        292,
    )
    return obs, sel


def test_every_epoch_is_solved_with_the_ephemerides_known_at_its_time(synthetic, tmp_path):
    obs, sel = synthetic
    table = solve_epochs(obs, ionosphere=False)
    assert len(table) == 5
    assert np.all(np.linalg.norm(table.ecef_m - STATION, axis=1) < 1e-3)
    n = obs.prn.size
    assert list(table.columns["n_sats"]) == [n - 1, n - 1, n - 1, n, n]  # the late record joins at epoch 3
    assert obs.prn[0] not in table.used_prns[0] and obs.prn[0] in table.used_prns[3]
    # The solution's time is the receiver clock minus its bias: the true epochs.
    assert np.allclose(table.columns["tow_s"], 518_700.0 + np.arange(5.0), atol=1e-9)
    assert np.all(table.columns["gps_week"] == 2048 + 292)
    path = write_positions_csv(tmp_path / "positions.csv", table)
    with path.open() as fh:
        rows = list(csv.reader(fh))
    assert tuple(rows[0]) == POSITION_COLUMNS and len(rows) == 6
    assert float(rows[1][POSITION_COLUMNS.index("clock_bias_m")]) == pytest.approx(1500.0, abs=1e-3)


def test_full_week_places_the_10_bit_week_in_its_era():
    assert full_week(292, reference_week=1316) == 1316
    assert full_week(1023, reference_week=2049) == 2047
    assert full_week(5) == 2053 and full_week(None) == -1


def test_full_week_of_a_13_bit_week_needs_no_reference():
    """CNAV's type 10 sends 13 bits (IS-GPS-200 30.3.3.1.1.1): weeks 0-8191 are whole, where
    the 10-bit era would move a 2005 week by 1024; Galileo's GST sends 12 (the GPS week's
    low 12 bits once shifted by 1024)."""
    assert full_week(1316, bits=13) == 1316 and full_week(2400, bits=13) == 2400
    assert full_week(1316 % 1024) == 2340
    assert full_week(8191, reference_week=8200, bits=13) == 8191
    assert full_week((1174 + 1024) % 4096, bits=12) == 2198


def test_rinex_records_give_the_early_epochs_their_satellite(synthetic):
    obs, sel = synthetic
    table = solve_epochs(obs, read_rinex_nav(DATA / "07590920.05n"), ionosphere=False)
    assert np.all(table.columns["n_sats"] == obs.prn.size)


@pytest.fixture(scope="module")
def short_recording(tmp_path_factory):
    x = synthesize_samples(
        [SatelliteSignal(11, 44.0, -1730.0, 517.2, first_bit_code_period=9)], 1.5, 2.6e6, 0.0, np.random.default_rng(25)
    )
    return write_recording(tmp_path_factory.mktemp("pos") / "short.sigmf-data", x, "ci16_le", 2.6e6, 0.0, scale=300.0)


@pytest.mark.slow
def test_position_on_a_recording_without_a_whole_subframe_says_why(short_recording, tmp_path, capsys):
    assert main(["position", str(short_recording), "--out", str(tmp_path / "p")]) == 1
    out = capsys.readouterr().out  # the most basic reason first (issue 41): too few satellites
    assert "no position: only 1 satellite found (PRN 11): a position needs 4" in out
    assert not (tmp_path / "p" / "positions.csv").exists()


@pytest.mark.slow
@pytest.mark.parametrize(
    "options, message",
    [
        (["--truth", "35.6,139.7"], "--truth: LAT,LON,H in degrees and metres, got '35.6,139.7'"),
        (["--rate", "0"], "--rate: must be > 0 Hz, got 0"),
        (["--ephemeris", "missing.rnx"], "missing.rnx: no such file"),
    ],
)
def test_position_refuses_bad_options_with_one_line(short_recording, tmp_path, capsys, options, message):
    assert main(["position", str(short_recording), "--out", str(tmp_path / "p"), *options]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1
