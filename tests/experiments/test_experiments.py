"""Comparisons: config validation, reproducibility across executors, resume, report."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

import gnssframework as gf
from gnssframework.experiments import load_config, run_comparison

TINY = """
name = "tiny"
runs = 4
batch_size = 2
seed = 7
[executor]
kind = "local"
workers = 1
[scenario]
kind = "vector-tracking"
duration_s = 0.4
channels = 5
settle_s = 0.1
[[cases]]
name = "c45"
cn0_dbhz = 45.0
[[candidates]]
name = "disc"
channel_filter = { name = "discriminator" }
nav_filter = { name = "ekf-pv", params = { clock = "ocxo" } }
[[candidates]]
name = "ckf"
channel_filter = { name = "iq-filter", params = { estimator = "ckf" } }
nav_filter = { name = "ekf-pv", params = { clock = "ocxo" } }
[published.c45.disc]
code_phase_error_rmse = 0.01
"""


def _write(tmp_path, text=TINY, name="tiny.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def _rows(path):
    return {(r["case"], r["candidate"], r["metric"]): r for r in json.loads(path.read_text())["rows"]}


@pytest.mark.slow
def test_summary_report_plots_and_published_values(tmp_path):
    summary = run_comparison(load_config(_write(tmp_path)), tmp_path / "out", progress=False)
    rows = _rows(summary)
    from gnssframework.experiments.scenarios.vector_tracking import VectorTrackingScenario

    assert len(rows) == 1 * 2 * len(VectorTrackingScenario.metrics)
    r = rows[("c45", "disc", "code_phase_error_rmse")]
    assert set(r) == {"case", "candidate", "metric", "mean", "std", "runs", "unit", "published"}
    assert r["runs"] == 4 and r["unit"] == "chips" and r["published"] == 0.01 and r["mean"] > 0
    assert rows[("c45", "ckf", "nees")]["published"] is None
    report = (tmp_path / "out" / "report.md").read_text()
    assert "| code_phase_error_rmse | chips |" in report and "(paper 0.01)" in report
    for png in ("c45-series.png", "c45-cdf.png"):
        assert (tmp_path / "out" / "plots" / png).stat().st_size > 1000
    assert len(list((tmp_path / "out" / "raw" / "c45" / "disc").glob("run*.npz"))) == 2


@pytest.mark.slow
def test_same_seed_same_numbers_on_every_executor(tmp_path):
    base = run_comparison(load_config(_write(tmp_path)), tmp_path / "a", progress=False)
    pool = run_comparison(
        load_config(_write(tmp_path, TINY.replace("workers = 1", "workers = 2"))), tmp_path / "b", progress=False
    )
    pytest.importorskip("dask.distributed")
    dask = run_comparison(
        load_config(
            _write(tmp_path, TINY.replace('kind = "local"', 'kind = "dask"').replace("workers = 1", "workers = 2"))
        ),
        tmp_path / "c",
        progress=False,
    )
    a, b, c = _rows(base), _rows(pool), _rows(dask)
    assert a == b == c
    other = run_comparison(load_config(_write(tmp_path), seed=8), tmp_path / "d", progress=False)
    assert (
        _rows(other)[("c45", "disc", "position_error_rmse")]["mean"]
        != a[("c45", "disc", "position_error_rmse")]["mean"]
    )


@pytest.mark.slow
def test_interrupted_comparison_resumes_and_loses_nothing(tmp_path):
    config = load_config(_write(tmp_path))
    done = []

    def interrupt(task):
        done.append(task)
        if len(done) == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_comparison(config, tmp_path / "out", progress=False, on_batch=interrupt)
    ran_again = []
    summary = run_comparison(config, tmp_path / "out", progress=False, on_batch=ran_again.append)
    assert len(ran_again) == 4 - 2  # only the unfinished batches
    fresh = run_comparison(config, tmp_path / "fresh", progress=False)
    assert _rows(summary) == _rows(fresh)


@pytest.mark.slow
def test_rerunning_a_finished_comparison_runs_nothing_and_rewrites_the_report(tmp_path):
    text = TINY.replace("workers = 1", "workers = 2")  # the process-pool path
    first = run_comparison(load_config(_write(tmp_path, text)), tmp_path / "out", progress=False)
    (tmp_path / "out" / "report.md").unlink()
    ran = []
    again = run_comparison(load_config(_write(tmp_path, text)), tmp_path / "out", progress=False, on_batch=ran.append)
    assert ran == [] and _rows(again) == _rows(first) and (tmp_path / "out" / "report.md").exists()


@pytest.mark.slow
def test_more_runs_reuse_the_finished_batches(tmp_path):
    config = load_config(_write(tmp_path))
    run_comparison(config, tmp_path / "out", progress=False)
    ran = []
    summary = run_comparison(
        load_config(_write(tmp_path), runs=6), tmp_path / "out", progress=False, on_batch=ran.append
    )
    assert len(ran) == 2 and {t.first_run for t in ran} == {4}
    assert _rows(summary)[("c45", "disc", "nees")]["runs"] == 6


@pytest.mark.parametrize(
    "change, field, allowed",
    [
        (
            'name = "iq-filter", params = { estimator = "ckf" }',
            "candidates[1].channel_filter.name",
            "unknown channel_filter 'iq-filtr'",
        ),
        (
            'name = "iq-filter", params = { estimator = "ckf", window = 1 }',
            "candidates[1].channel_filter.params",
            "window",
        ),
        ('name = "scalar"', "candidates[1].channel_filter.name", "channel filters that do: discriminator, iq-filter"),
    ],
)
def test_config_errors_name_the_field_and_the_allowed_values(tmp_path, change, field, allowed):
    text = TINY.replace('name = "iq-filter", params = { estimator = "ckf" }', change)
    if "iq-filtr" in allowed:
        text = TINY.replace('name = "iq-filter"', 'name = "iq-filtr"')
    with pytest.raises(gf.ConfigError) as err:
        load_config(_write(tmp_path, text))
    assert field in str(err.value) and allowed in str(err.value)


@pytest.mark.parametrize(
    "text, message",
    [
        (TINY.replace('kind = "vector-tracking"', 'kind = "vector"'), "scenario.kind: got 'vector'; allowed: "),
        (TINY.replace("duration_s = 0.4", "duration_s = -1"), "scenario.duration_s"),
        (TINY.replace("cn0_dbhz = 45.0", "cn0_dbhz = 90.0"), "cases[0].cn0_dbhz"),
        ('metrics = ["rmse"]\n' + TINY, "metrics[0]: unknown 'rmse'; allowed: code_phase_error_rmse"),
        (TINY.replace("[published.c45.disc]", "[published.c45.dsc]"), "published.c45.dsc: unknown candidate"),
        (TINY.replace('kind = "local"', 'kind = "cloud"'), "executor.kind"),
    ],
)
def test_more_config_errors(tmp_path, text, message):
    with pytest.raises(gf.ConfigError, match=message.replace("[", r"\[").replace("]", r"\]")):
        load_config(_write(tmp_path, text))


@pytest.mark.slow
def test_cli_config_error_is_one_line_without_traceback(tmp_path):
    bad = _write(tmp_path, TINY.replace('name = "discriminator"', 'name = "discriminater"'))
    proc = subprocess.run(
        [sys.executable, "-m", "gnssframework", "compare", str(bad), "--out", str(tmp_path / "o")],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert proc.stderr.startswith("error: candidates[0].channel_filter.name: unknown channel_filter 'discriminater'")
    assert "did you mean 'discriminator'" in proc.stderr


@pytest.mark.slow
def test_cli_bad_toml_names_the_file_and_line(tmp_path):
    bad = _write(tmp_path, "name = \n")
    proc = subprocess.run([sys.executable, "-m", "gnssframework", "compare", str(bad)], capture_output=True, text=True)
    assert proc.returncode == 2 and f"{bad}:1: invalid TOML" in proc.stderr


@pytest.mark.slow
def test_cli_compare_runs_and_overrides_runs_and_seed(tmp_path):
    path = _write(tmp_path)
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "gnssframework",
            "compare",
            str(path),
            "--runs",
            "2",
            "--seed",
            "3",
            "--out",
            str(tmp_path / "o"),
            "--quiet",
        ],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert summary["seed"] == 3
    # Every row over the 2 runs, but those of metrics the scenario declares optional, which are
    # undefined in both for the reason it gives (the smoothed ones: TINY leaves smoothed off).
    from gnssframework.experiments.scenarios.vector_tracking import METRICS, VectorTrackingScenario

    optional = {c.name for c in METRICS if c.optional}
    for r in summary["rows"]:
        if r["runs"] != 2:
            assert r["runs"] == 0 and r["metric"] in optional, r
            assert r["undefined"] == VectorTrackingScenario.undefined_reasons[r["metric"]], r
    assert any(r["runs"] == 0 for r in summary["rows"])
    assert sum(r["runs"] == 2 for r in summary["rows"]) > len(summary["rows"]) / 2


@pytest.mark.slow
def test_schema_validates_each_plugins_params_against_its_name():
    import tomllib
    from pathlib import Path

    import jsonschema  # test-only oracle: an independent JSON-schema validator

    out = subprocess.run(
        [sys.executable, "-m", "gnssframework", "schema"], capture_output=True, text=True, check=True
    ).stdout
    validator = jsonschema.Draft202012Validator(json.loads(out))
    validator.check_schema(validator.schema)
    from gnssframework.experiments.config_base import read_config_data

    def only_missing(error) -> bool:  # an error a field left to the base explains, at any depth
        if error.validator == "required":
            return True
        if error.validator in ("anyOf", "oneOf") and error.context:
            branches: dict = {}
            for sub in error.context:
                branches.setdefault(sub.relative_schema_path[0], []).append(sub)
            return any(all(only_missing(sub) for sub in subs) for subs in branches.values())
        return False

    for path in sorted((Path(__file__).resolve().parents[2] / "examples").glob("*.toml")):
        # A file with [base] is validated as what it resolves to, and its own keys as written
        # (a part of a config: what it leaves to its base may be missing, at any depth).
        raw = tomllib.loads(path.read_text())
        assert list(validator.iter_errors(read_config_data(path))) == [], path.name
        if "base" in raw:
            assert [e for e in validator.iter_errors(raw) if not only_missing(e)] == [], path.name
    good = tomllib.loads(TINY)
    assert validator.is_valid(good)

    def with_channel_filter(ref):
        data = json.loads(json.dumps(good))
        data["candidates"][1]["channel_filter"] = ref
        return data

    # window is an iq-filter parameter: accepted under that name, refused under another,
    # refused out of its bounds, and an unknown name is refused.
    assert validator.is_valid(with_channel_filter({"name": "iq-filter", "params": {"window": 30}}))
    assert not validator.is_valid(with_channel_filter({"name": "discriminator", "params": {"window": 30}}))
    assert not validator.is_valid(with_channel_filter({"name": "iq-filter", "params": {"window": 1}}))
    assert not validator.is_valid(with_channel_filter({"name": "iq-filtr"}))


def test_shipped_examples_validate():
    from pathlib import Path

    for path in sorted((Path(__file__).resolve().parents[2] / "examples").glob("*.toml")):
        config = load_config(path)
        assert config.candidates and config.cases
