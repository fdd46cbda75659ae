"""Carrier smoothing of recorded files arc by arc (issue 26): the smoother restarts at every
loss-of-lock flag and gap, on a Hatanaka multi-GNSS RINEX 3 excerpt and a RINEX 2 file."""

from __future__ import annotations

import csv
import dataclasses
from pathlib import Path

import numpy as np
import pytest

from gnssframework import registry
from gnssframework.cli import main
from gnssframework.interfaces import RunContext
from gnssframework.io.observations import arc_starts, read_observations
from gnssframework.io.smoothing import default_max_gap_s, smooth_observations

pytestmark = pytest.mark.slow  # end to end (issue 37: the fast lane leaves these out)

DATA = Path(__file__).resolve().parents[1] / "data"
CEBR = DATA / "CEBR00ESP_R_20182002200_01H_30S_MO.crx.gz"
RINEX2 = DATA / "07590920.05o"


@pytest.fixture(scope="module")
def cebr_gps():
    return read_observations(CEBR, "G")


@pytest.mark.parametrize("name, params", [("hatch", {"window": 100}), ("kf-smoother", {"q": 1e-3, "r": 1.0})])
def test_arc_start_restarts_from_the_code(name, params):
    rng = np.random.default_rng(1)
    rho = 2.2e7 + np.cumsum(rng.normal(0, 1, 50)) + rng.normal(0, 1, 50)
    phi = rho - 3.0 + rng.normal(0, 0.01, 50)
    phi[30:] += 19.0  # a carrier jump the receiver flagged
    f = registry.create("channel_filter", name, **params)
    f.reset((), RunContext(epoch_interval_s=1.0))
    out = [
        f.checked_step({"pseudorange_m": np.asarray(r), "carrier_m": np.asarray(c), "arc_start": np.asarray(k == 30)})
        for k, (r, c) in enumerate(zip(rho, phi))
    ]
    smoothed = np.array([float(o["smoothed_m"]) for o in out])
    assert smoothed[30] == rho[30]  # n = 1 (Hatch) or the prior discarded (KF): the code alone
    assert np.all(np.abs(smoothed[31:] - rho[31:]) < 10.0)  # the 19 m jump did not leak into the arc
    assert not any(bool(o["slip_detected"]) for o in out)  # no threshold: the filter detected nothing itself


def test_every_flag_and_gap_restarts_the_smoother_on_real_data(cebr_gps):
    result = smooth_observations(cebr_gps, lambda: registry.create("channel_filter", "hatch", window=100))
    expected = arc_starts(cebr_gps.time_s, cebr_gps.valid, cebr_gps.lli, 45.0)
    np.testing.assert_array_equal(result.arc_start, expected)
    k, j = np.nonzero(expected)
    np.testing.assert_array_equal(result.smoothed_m[k, j], cebr_gps.pseudorange_m[k, j])
    flagged = (cebr_gps.lli & 1) != 0
    assert flagged.sum() >= 5 and np.all(expected[flagged & cebr_gps.valid])
    # Septentrio writes its flags at the first epoch after a loss of tracking: in this file
    # every flag falls on a gap too. A flag set inside an arc (a copy of the data) restarts
    # the smoother, unless the flags are ignored.
    k0, j0 = 60, int(np.flatnonzero(cebr_gps.valid[55:66].all(axis=0))[0])
    lli = cebr_gps.lli.copy()
    lli[k0, j0] = 1
    edited = dataclasses.replace(cebr_gps, lli=lli)
    hatch = lambda: registry.create("channel_filter", "hatch", window=100)  # noqa: E731
    assert not result.arc_start[k0, j0]
    assert smooth_observations(edited, hatch).smoothed_m[k0, j0] == cebr_gps.pseudorange_m[k0, j0]
    ignoring = smooth_observations(edited, hatch, reset_at_lli=False)
    assert not ignoring.arc_start[k0, j0] and ignoring.smoothed_m[k0, j0] != cebr_gps.pseudorange_m[k0, j0]


def test_default_gap_is_one_and_a_half_intervals(cebr_gps):
    assert default_max_gap_s(cebr_gps.interval_s) == 45.0
    assert smooth_observations(cebr_gps, lambda: registry.create("channel_filter", "hatch")).max_gap_s == 45.0


@pytest.mark.parametrize("path, select", [(CEBR, "all"), (RINEX2, "G")])
def test_cli_smooths_real_files_end_to_end(tmp_path, capsys, path, select):
    out = tmp_path / "s.csv"
    assert main(["smooth", str(path), "--prn", select, "--out", str(out), "--filter", "kf"]) == 0
    obs = read_observations(path, select)
    with open(out, newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == int(obs.valid.sum())
    starts = arc_starts(obs.time_s, obs.valid, obs.lli, default_max_gap_s(obs.interval_s))
    assert sum(int(r["arc_start"]) for r in rows) == int(starts.sum())
    for r in rows:
        if r["arc_start"] == "1":
            assert r["smoothed_m"] == f"{float(r['pseudorange_m']):.4f}"
    assert {r["sv"][0] for r in rows} == {sv[0] for sv in obs.sv}
    summary = capsys.readouterr().out
    assert f"{starts.sum()} arcs" in summary and "loss-of-lock flags" in summary


def test_a_phone_carrier_that_does_not_follow_its_code_is_not_smoothed(tmp_path, capsys):
    phone = read_observations(DATA / "pixel6.23o", "G")
    result = smooth_observations(phone, lambda: registry.create("channel_filter", "hatch", window=100))
    # The drift, by numpy's own least-squares fit on each satellite's data.
    for sv, row, rate in result.inconsistent:
        j = phone.satellite(sv)
        ok = phone.valid[:, j] & (np.cumsum(result.arc_start[:, j]) == np.cumsum(result.arc_start[:, j])[row])
        slope = np.polyfit(phone.time_s[ok], phone.pseudorange_m[ok, j] - phone.carrier_m[ok, j], 1)[0]
        assert rate == pytest.approx(abs(slope), rel=1e-9) and rate > 10.0
        assert np.all(np.isnan(result.smoothed_m[ok, j]))
    assert len(result.inconsistent) >= 10  # every GPS satellite: tens of m/s, not the < 0.1 m/s of the ionosphere
    # A geodetic receiver's arcs are all consistent.
    cebr = read_observations(CEBR, "G")
    assert smooth_observations(cebr, lambda: registry.create("channel_filter", "hatch")).inconsistent == []
    out = tmp_path / "p.csv"
    assert main(["smooth", str(DATA / "pixel6.23o"), "--prn", "G", "--out", str(out)]) == 3
    assert "its carrier does not follow the code" in capsys.readouterr().out


def test_the_filters_detections_are_reported_beside_the_receivers_flags(tmp_path, capsys):
    out = tmp_path / "s.csv"
    assert main(["smooth", str(CEBR), "--prn", "G", "--out", str(out), "--slip-threshold", "4"]) == 0
    with open(out, newline="") as fh:
        rows = list(csv.DictReader(fh))
    detected = sum(r["slip_detected"] == "1" for r in rows)
    at_flags = sum(r["slip_detected"] == "1" and int(r["lli"]) & 1 for r in rows)
    assert (
        f"{detected} slips detected by the filter ({at_flags} of them at a receiver's flag)" in capsys.readouterr().out
    )
