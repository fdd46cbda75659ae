"""Integrity monitoring of the receiver's fixes and nav filter (``receive --raim``).

The observables of `test_receiver_nav_exclusion` (a static station, real broadcast records,
an independent light-time loop, white noise of the stated variances) with a 40 m step on
one satellite from epoch 20: the least squares with RAIM excludes that satellite at every
faulty epoch and its protection levels bound the true error at every epoch; the nav
filter's levels (from its covariance) bound its error too; both reach ``positions.csv``.
"""

from __future__ import annotations

import csv

import numpy as np
import pymap3d
import pytest

from gnssframework.receiver.navigation.filtered import filter_epochs
from gnssframework.receiver.navigation.fixes import (
    INTEGRITY_COLUMNS,
    POSITION_COLUMNS,
    solve_epochs,
    write_positions_csv,
)
from station_observables import STATION
from test_receiver_nav_exclusion import FAULT_EPOCH, SIGMA_M, SIGMA_RATE, _faulty, _scenario


@pytest.fixture(scope="module")
def faulty_run():
    nav, obs, _, el = _scenario()
    j = int(np.argmax(el))  # the highest satellite: the smallest noise, so 40 m is many sigmas
    faulty = _faulty(obs, j)
    common = dict(ionosphere=False, sigma_m=SIGMA_M, elevation_mask_deg=10.0, reference_week=1316)
    wls = solve_epochs(faulty, nav, raim="ss", false_alarm=1e-5, **common)
    filtered = filter_epochs(
        faulty,
        wls,
        "ekf-pv",
        {"accel_psd": 0.01},
        rinex=nav,
        sigma_rate_m_s=SIGMA_RATE,
        innovation_false_alarm=1e-4,
        integrity_risk=1e-7,
        **common,
    )
    return int(obs.prn[j]), wls, filtered


def _errors(table):
    lat, lon, h = pymap3d.ecef2geodetic(*STATION)
    e, n, u = pymap3d.ecef2enu(table.ecef_m[:, 0], table.ecef_m[:, 1], table.ecef_m[:, 2], lat, lon, h)
    return np.hypot(e, n), np.abs(u)


@pytest.mark.parametrize("which", ["wls", "filtered"])
def test_the_faulty_satellite_is_excluded_and_the_levels_bound_the_error(faulty_run, which):
    bad, wls, filtered = faulty_run
    table = wls if which == "wls" else filtered
    status = table.columns["raim"]
    assert np.all(status[FAULT_EPOCH:] == "excluded") and np.all(table.excluded_prn[FAULT_EPOCH:] == bad)
    assert np.mean(status[:FAULT_EPOCH] == "ok") >= 0.95  # P_fa 1e-5 / 1e-4: no false alarm expected
    horizontal, vertical = _errors(table)
    hpl, vpl = table.columns["hpl_m"], table.columns["vpl_m"]
    assert np.all(np.isfinite(hpl)) and np.all(horizontal < hpl) and np.all(vertical < vpl)
    assert np.all(hpl < 50.0)  # levels of a 1 m ranging error, not vacuous
    if which == "filtered":  # the filter, fusing epochs, is tighter than one epoch's least squares
        assert np.median(hpl) < np.median(wls.columns["hpl_m"])


def test_positions_csv_gets_the_integrity_columns(faulty_run, tmp_path):
    _, wls, _ = faulty_run
    with write_positions_csv(tmp_path / "positions.csv", wls).open() as fh:
        rows = list(csv.DictReader(fh))
    assert tuple(rows[0]) == POSITION_COLUMNS + INTEGRITY_COLUMNS
    assert rows[-1]["raim"] == "excluded" and float(rows[-1]["hpl_m"]) == pytest.approx(
        wls.columns["hpl_m"][-1], abs=0.005
    )


def test_rows_without_levels_after_a_hand_over_say_so(faulty_run):
    from gnssframework.receiver.navigation.fixes import PositionTable
    from gnssframework.receiver.navigation.receive import concatenate_tables

    _, wls, _ = faulty_run
    plain = PositionTable(
        {c: wls.columns[c] for c in POSITION_COLUMNS},
        wls.ecef_m,
        wls.sample_time_s + 2000.0,
        wls.used_prns,
        wls.excluded_prn,
    )
    joined = concatenate_tables(wls, plain, 1000.0)  # every row of wls before the switch
    n = len(wls)
    assert len(joined) == 2 * n
    assert list(joined.columns["raim"][:n]) == list(wls.columns["raim"])
    assert np.all(joined.columns["raim"][n:] == "unavailable") and np.all(np.isinf(joined.columns["hpl_m"][n:]))
