"""Parameter sweeps: expansion, load-time validation, schema, runs on the store, resume, report."""

from __future__ import annotations

import csv
import json
import tomllib

import numpy as np
import pytest

from gnssframework.config_schema import comparison_schema
from gnssframework.errors import ConfigError
from gnssframework.experiments import load_config, run_comparison
from gnssframework.experiments.store import ResultStore
from gnssframework.experiments.sweeps import Sweep

BASE = """
name = "sweepy"
runs = 4
batch_size = 2
seed = 5
[executor]
workers = 1
[scenario]
kind = "multipath"
epochs = 40
psi = 0.9
[[cases]]
name = "only"
[[candidates]]
name = "kf"
nav_filter = { name = "position-ca" }
estimator = { name = "kf" }
[[candidates]]
name = "ar1"
nav_filter = { name = "position-ca" }
estimator = { name = "kf" }
augmentation = { name = "colored-ar1", params = { psi = 0.9 } }
"""


def _load(tmp_path, sweeps: str, base: str = BASE):
    path = tmp_path / "s.toml"
    path.write_text(base + sweeps)
    return load_config(path)


def _strict(path):
    def refuse(token):
        raise AssertionError(f"non-JSON constant {token} in {path}")

    return json.loads(path.read_text(), parse_constant=refuse)


def test_ranges_lists_and_their_values():
    assert Sweep(path="scenario.psi", start=25, stop=50, step=5).points() == [25, 30, 35, 40, 45, 50]
    assert Sweep(path="scenario.psi", start=0.1, stop=0.3, step=0.1).points() == [0.1, 0.2, 0.3]
    assert Sweep(path="scenario.psi", start=0.0, stop=1.0, num=5).points() == [0.0, 0.25, 0.5, 0.75, 1.0]
    assert Sweep(path="scenario.psi", start=50, stop=40, step=-5).points() == [50, 45, 40]
    assert Sweep(path="x.y", values=["tcxo", "ocxo"]).points() == ["tcxo", "ocxo"]
    assert Sweep(path="cases.cn0_dbhz", values=[1]).label == "cn0_dbhz"


@pytest.mark.parametrize(
    "sweep, field, words",
    [
        ('path = "scenario.psy"\nvalues = [0.5]', "sweeps[0].path", ["scenario.psi", "allowed"]),
        ('path = "candidates.kf.estimator.params.alpha"\nvalues = [1]', "sweeps[0].path", ["'kf' has no parameter"]),
        ('path = "candidates.nope.params.psi"\nvalues = [1]', "sweeps[0].path", ["kf, ar1"]),
        ('path = "candidates.ar1.params.window"\nvalues = [1]', "sweeps[0].path", ["no plugin"]),
        ('path = "weird.psi"\nvalues = [1]', "sweeps[0].path", ["scenario, cases or candidates"]),
        ('path = "scenario.psi"\nvalues = [0.5, 1.5]', "sweeps[0].values[1]", ["scenario.psi = 1.5", "less than 1"]),
        (
            'path = "candidates.ar1.params.psi"\nvalues = ["high"]',
            "sweeps[0].values[0]",
            ["candidates.ar1.params.psi = 'high'", "psi"],
        ),
        (
            'path = "scenario.epochs"\nstart = 10\nstop = 30\nstep = 10',
            "sweeps[0].values[0]",
            ["scenario.epochs = 10", "greater than or equal to 20"],
        ),
        ('path = "scenario.psi"\nvalues = [0.5]\nstart = 0.1', "sweeps[0]", ["not both"]),
        ('path = "scenario.psi"\nstart = 0.1\nstop = 0.5', "sweeps[0]", ["exactly one of step and num"]),
        ('path = "scenario.psi"\nstart = 0.1\nstop = 0.5\nstep = -0.1', "sweeps[0]", ["does not lead"]),
        ('path = "scenario.psi"\nvalues = [0.5]\ncases = ["other"]', "sweeps[0].cases[0]", ["'other'", "only"]),
    ],
)
def test_bad_sweeps_are_refused_at_load_time_naming_the_field(tmp_path, sweep, field, words):
    with pytest.raises(ConfigError) as err:
        _load(tmp_path, "[[sweeps]]\n" + sweep + "\n")
    assert err.value.field == field, str(err.value)
    for w in words:
        assert w in str(err.value)


def test_two_sweeps_with_one_name_are_refused(tmp_path):
    with pytest.raises(ConfigError, match="repeated: psi"):
        _load(
            tmp_path,
            '[[sweeps]]\npath = "scenario.psi"\nvalues = [0.5]\n'
            '[[sweeps]]\npath = "candidates.ar1.params.psi"\nvalues = [0.5]\n',
        )


def test_points_change_only_the_swept_parameter(tmp_path):
    config = _load(
        tmp_path,
        '[[sweeps]]\nname = "apsi"\npath = "candidates.ar1.params.psi"\nvalues = [0.5, 0.9]\n'
        '[[sweeps]]\npath = "scenario.psi"\nvalues = [0.7]\n',
    )
    (v0, p0), (v1, p1) = config.sweep_points(0)
    assert (v0, v1) == (0.5, 0.9)
    assert p0.candidates[1].augmentation.params == {"psi": 0.5} and p0.scenario["psi"] == 0.9
    assert p0.candidates[0] == config.candidates[0] and not p0.sweeps
    # The point equal to the comparison has its identity: it reuses its stored runs.
    assert p1.identity() == config.identity() != p0.identity()
    ((_, q),) = config.sweep_points(1)
    assert q.scenario["psi"] == 0.7 and q.candidates == config.candidates
    # Adding a sweep does not change the comparison's identity (its stored runs stay valid).
    assert config.identity() == load_config(tmp_path / "s.toml").identity()
    path = tmp_path / "plain.toml"
    path.write_text(BASE)
    assert load_config(path).identity() == config.identity()


SWEEPS = """
[[sweeps]]
path = "scenario.psi"
values = [0.5, 0.9, 0.99]
[[sweeps]]
name = "apsi"
path = "candidates.ar1.augmentation.params.psi"
start = 0.8
stop = 0.9
num = 2
"""


@pytest.mark.slow
def test_a_sweep_runs_every_point_on_common_random_numbers_and_reports_it(tmp_path):
    config = _load(tmp_path, SWEEPS)
    summary = _strict(run_comparison(config, tmp_path / "out", progress=False))
    psi = next(s for s in summary["sweeps"] if s["name"] == "psi")
    assert psi["values"] == [0.5, 0.9, 0.99] and psi["path"] == "scenario.psi"
    rows = {(r["value"], r["candidate"], r["metric"]): r for r in psi["rows"]}
    assert all(r["n"] == 4 and r["se"] > 0 for r in rows.values() if r["metric"] == "lat_error_rmse")
    # The point psi = 0.9 is the comparison itself: the same numbers.
    base = {(r["candidate"], r["metric"]): r for r in summary["rows"]}
    for cand in ("kf", "ar1"):
        assert rows[(0.9, cand, "lat_error_rmse")]["mean"] == pytest.approx(base[(cand, "lat_error_rmse")]["mean"])
    # Points share the comparison's random numbers: the kf candidate, which the apsi sweep
    # leaves alone, has the same per-run numbers at every apsi point as in the comparison.
    apsi = next(s for s in summary["sweeps"] if s["name"] == "apsi")
    for r in apsi["rows"]:
        if r["candidate"] == "kf":
            assert r["mean"] == base[("kf", r["metric"])]["mean"]
    # Paired differences at each point, to the reference (the first candidate).
    paired = [p for p in psi["paired"] if p["metric"] == "lat_error_rmse"]
    assert [p["value"] for p in paired] == [0.5, 0.9, 0.99] and {p["candidate"] for p in paired} == {"ar1"}
    store = ResultStore(tmp_path / "out" / "results.sqlite")
    for value, point in config.sweep_points(0):
        x = store.values(point.identity(), "only", "ar1", "lat_error_rmse", 4)
        y = store.values(point.identity(), "only", "kf", "lat_error_rmse", 4)
        p = next(p for p in paired if p["value"] == value)
        assert p["diff"] == pytest.approx(np.mean(x - y)) and p["se"] == pytest.approx(np.std(x - y, ddof=1) / 2)
    # Files: a CSV and JSON table per sweep, a plot per sweep and case, a report section.
    out = tmp_path / "out"
    with (out / "sweeps" / "apsi.csv").open() as f:
        table = list(csv.DictReader(f))
    # 2 apsi values x 2 candidates x the multipath scenario's 6 metrics
    assert len(table) == 2 * 2 * 6 and {r["apsi"] for r in table} == {"0.8", "0.9"}
    assert _strict(out / "sweeps" / "psi.json")["values"] == [0.5, 0.9, 0.99]
    assert (out / "plots" / "sweep-psi-only.png").stat().st_size > 1000
    assert (out / "plots" / "sweep-psi-only-paired.png").stat().st_size > 1000
    report = (out / "report.md").read_text()
    assert "## Sweep `psi`: scenario.psi" in report and "plots/sweep-apsi-only.png" in report


@pytest.mark.slow
def test_an_interrupted_sweep_resumes_with_identical_numbers(tmp_path):
    config = _load(tmp_path, SWEEPS)
    done = []

    def interrupt(task):
        done.append(task)
        if len(done) == 7:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_comparison(config, tmp_path / "out", progress=False, on_batch=interrupt)
    resumed = []
    summary = run_comparison(config, tmp_path / "out", progress=False, on_batch=resumed.append)
    # The comparison and 3 + 2 points, two of which (psi = 0.9, apsi = 0.9) are the comparison
    # itself: 4 distinct configs x 2 candidates x 2 batches = 16 batches, each run once (the
    # interrupted one was stored before the interruption).
    assert len(done) == 7 and len(resumed) == 16 - 7
    fresh = run_comparison(config, tmp_path / "fresh", progress=False)
    assert _strict(summary)["sweeps"] == _strict(fresh)["sweeps"]
    assert _strict(summary)["rows"] == _strict(fresh)["rows"]


def test_the_schema_validates_sweeps(tmp_path):
    import jsonschema  # test-only oracle

    validator = jsonschema.Draft202012Validator(comparison_schema())
    data = tomllib.loads(BASE + SWEEPS)
    assert list(validator.iter_errors(data)) == []
    for bad in (
        {"path": "scenario.psi"},
        {"path": "scenario.psi", "values": [1], "start": 0.1},
        {"path": "scenario.psi", "start": 0, "stop": 1, "step": 0.5, "num": 3},
        {"values": [1]},
        {"path": "scenario.psi", "values": [1], "colour": 2},
    ):
        data["sweeps"] = [bad]
        assert not validator.is_valid(data), bad


@pytest.mark.slow
def test_a_sweep_over_a_non_numeric_parameter_is_drawn_as_categories(tmp_path):
    text = """
runs = 2
batch_size = 2
[executor]
workers = 1
[scenario]
kind = "vector-tracking"
duration_s = 0.2
channels = 4
settle_s = 0.05
[[cases]]
name = "c"
cn0_dbhz = 40.0
[[candidates]]
name = "disc"
channel_filter = { name = "discriminator" }
nav_filter = { name = "ekf-pv" }
[[sweeps]]
path = "scenario.clock"
values = ["ocxo", "tcxo"]
"""
    path = tmp_path / "v.toml"
    path.write_text(text)
    with pytest.raises(ConfigError, match=r"sweeps\[0\].values\[1\]: scenario.clock = 'rubidium'"):
        bad = tmp_path / "bad.toml"
        bad.write_text(text.replace('"tcxo"', '"rubidium"'))
        load_config(bad)
    summary = _strict(run_comparison(load_config(path), tmp_path / "out", progress=False))
    rows = {(r["value"], r["metric"]): r for r in summary["sweeps"][0]["rows"]}
    # The clock changes the numbers (a TCXO's frequency jitter is larger than an OCXO's).
    assert rows[("tcxo", "carrier_freq_error_rmse")]["mean"] != rows[("ocxo", "carrier_freq_error_rmse")]["mean"]
    assert (tmp_path / "out" / "plots" / "sweep-clock-c.png").stat().st_size > 1000


def test_a_nested_plugin_parameter_can_be_swept_and_is_validated_by_its_model(tmp_path):
    base = """
runs = 2
[scenario]
kind = "vector-tracking"
duration_s = 0.2
channels = 4
settle_s = 0.05
[[cases]]
name = "c"
cn0_dbhz = 40.0
[[candidates]]
name = "iq"
channel_filter = { name = "iq-filter", params = { estimator = "ukf" } }
nav_filter = { name = "ekf-pv" }
"""
    config = _load(
        tmp_path,
        '[[sweeps]]\npath = "candidates.iq.channel_filter.params.estimator.params.alpha"\nvalues = [0.5, 1.0]\n',
        base,
    )
    (_, p0), (_, p1) = config.sweep_points(0)
    assert p0.candidates[0].channel_filter.params["estimator"] == {"name": "ukf", "params": {"alpha": 0.5}}
    assert p1.candidates[0].channel_filter.params["estimator"]["params"]["alpha"] == 1.0
    with pytest.raises(ConfigError) as err:
        _load(
            tmp_path,
            '[[sweeps]]\npath = "candidates.iq.channel_filter.params.estimator.params.alpha"\nvalues = [0.5, -1.0]\n',
            base,
        )
    assert err.value.field == "sweeps[0].values[1]" and "alpha" in str(err.value)
    with pytest.raises(ConfigError) as err:
        _load(
            tmp_path,
            '[[sweeps]]\npath = "candidates.iq.channel_filter.params.estimator.params.alfa"\nvalues = [0.5]\n',
            base,
        )
    assert err.value.field == "sweeps[0].values[0]" and "alfa" in str(err.value)


@pytest.mark.slow
def test_the_vector_tracking_examples_cn0_sweep_resumes_with_identical_numbers(tmp_path, monkeypatch):
    # examples/vector_tracking_sweep.toml as shipped (its candidates, its [[sweeps]] over
    # cases.cn0_dbhz), shrunk to 0.6-s runs, two runs and the sweep's two end points.
    # Plots are drawn by the tests above; here they would take most of the time.
    from pathlib import Path

    from gnssframework.experiments import report, sweeps
    from gnssframework.experiments.config import ComparisonConfig

    monkeypatch.setattr(report, "_plots", lambda *a, **k: None)
    monkeypatch.setattr(sweeps, "_plot", lambda *a, **k: None)

    data = tomllib.loads((Path(__file__).resolve().parents[2] / "examples" / "vector_tracking_sweep.toml").read_text())
    (sweep,) = data["sweeps"]
    assert sweep["path"] == "cases.cn0_dbhz" and (sweep["start"], sweep["stop"]) == (25.0, 50.0)
    data.update(runs=2, batch_size=2, executor={"workers": 1})
    data["scenario"].update(duration_s=0.6, settle_s=0.2, steady_state_s=0.4)
    data["sweeps"] = [{"name": sweep["name"], "path": sweep["path"], "values": [sweep["start"], sweep["stop"]]}]
    data["claims"] = []  # the example's claims name points (45 dB-Hz) this shrunk sweep leaves out
    config = ComparisonConfig.model_validate(data)
    n_cand = len(config.candidates)
    done = []

    def interrupt(task):
        done.append(task)
        if len(done) == n_cand + 1:  # the comparison and one batch of the first point
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_comparison(config, tmp_path / "out", progress=False, on_batch=interrupt)
    resumed = []
    summary = _strict(run_comparison(config, tmp_path / "out", progress=False, on_batch=resumed.append))
    # Comparison (45 dB-Hz) + 2 points, one batch per candidate each, each batch run once.
    assert len(resumed) == 3 * n_cand - len(done)
    fresh = _strict(run_comparison(config, tmp_path / "fresh", progress=False))
    assert summary["sweeps"] == fresh["sweeps"] and summary["rows"] == fresh["rows"]
    (cn0,) = summary["sweeps"]
    assert cn0["values"] == [25.0, 50.0]
    rows = {(r["value"], r["candidate"], r["metric"]): r for r in cn0["rows"]}
    for value in (25.0, 50.0):
        for cand in ("ackf", "ackf-literal", "discriminator", "discriminator-fixed-r"):
            assert rows[(value, cand, "freq_output_rmse")]["n"] == 2
    # Every candidate is paired with the example's reference at every point.
    paired = {(p["value"], p["candidate"]) for p in cn0["paired"] if p["metric"] == "velocity_error_rmse"}
    assert paired == {(v, c) for v in (25.0, 50.0) for c in ("ackf", "ackf-literal", "discriminator-fixed-r")}
    # Lower C/N0, larger FLL output error: the point's C/N0 reached the simulation.
    assert (
        rows[(25.0, "discriminator", "freq_output_rmse")]["mean"]
        > 3 * rows[(50.0, "discriminator", "freq_output_rmse")]["mean"]
    )


def test_a_value_is_one_key_whether_written_as_an_integer_or_a_float(tmp_path):
    # multipath_std_m is a float field: 3 and 3.0 are one simulation, so one store key, in
    # the scenario table and in a case; another value is another key.
    def identity(scenario_line: str, case_line: str) -> str:
        base = BASE.replace(
            'psi = 0.9\n[[cases]]\nname = "only"\n',
            f'psi = 0.9\n{scenario_line}\n[[cases]]\nname = "only"\n{case_line}\n',
        )
        return _load(tmp_path, "", base).identity()

    assert identity("multipath_std_m = 3", "") == identity("multipath_std_m = 3.0", "")
    assert identity("multipath_std_m = 3", "") != identity("multipath_std_m = 2", "")
    assert identity("", "psi_training_epochs = 500") != identity("", "psi_training_epochs = 400")
    assert identity("", "psi = 0.5") != identity("", "psi = 0.6")
    # A sweep's point written as a float reuses the case's runs written as an integer.
    config = _load(
        tmp_path,
        '[[sweeps]]\npath = "scenario.multipath_std_m"\nvalues = [2.0, 3.0]\n',
        BASE.replace("psi = 0.9\n", "psi = 0.9\nmultipath_std_m = 3\n", 1),
    )
    (_, p2), (_, p3) = config.sweep_points(0)
    assert p3.identity() == config.identity() != p2.identity()
