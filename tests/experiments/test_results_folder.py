"""A results folder reused: runs depend on the run, never on the batch; the store knows its
runs; a folder holds one configuration; failures name where they happened (issue 21)."""

from __future__ import annotations

import json
import subprocess
import sys
import types
from pathlib import Path

import numpy as np
import pytest

import gnssframework as gf
from gnssframework.errors import ConfigError, DataFileError, NumericalError, RunFailure
from gnssframework.experiments import load_config, run_comparison
from gnssframework.experiments.scenarios import BatchResult, Scenario, ScenarioParams
from gnssframework.random_streams import RunStreams, as_run_streams, name_key, run_streams

# Carrier smoothing: cheap, and its "raw" candidate's metric is a plain function of the
# run's noise, so batch invariance of the random numbers shows bit for bit.
SMOOTH = """
name = "reuse"
runs = {runs}
batch_size = 2
seed = {seed}
[executor]
workers = 1
[scenario]
kind = "carrier-smoothing"
epochs = 120
[[cases]]
name = "clean"
slip_probability = 0.0
[[cases]]
name = "slips"
slip_probability = 0.01
[[candidates]]
name = "raw"
[[candidates]]
name = "hatch"
channel_filter = {{ name = "hatch", params = {{ window = 30 }} }}
"""


def _config(tmp_path: Path, runs: int, seed: int = 4, extra: str = "", name: str = "c.toml", head: str = ""):
    path = tmp_path / name
    path.write_text(head + SMOOTH.format(runs=runs, seed=seed) + extra)
    return load_config(path)


def _summary(path: Path) -> dict:
    data = json.loads(path.read_text())
    return {"rows": data["rows"], "paired": data["paired"]}


def _raw_run_values(out: Path, case: str, cand: str, metric: str) -> dict[int, np.ndarray]:
    """Each run's stored series, by run index, from the raw files of a folder."""
    by_run = {}
    for f in sorted((out / "raw" / case / cand).glob("run*.npz")):
        with np.load(f) as data:
            first = int(data["first_run"])
            for i in range(data[metric].shape[-1]):
                by_run[first + i] = data[metric][..., i]
    return by_run


def test_run_streams_do_not_depend_on_the_batch():
    whole = run_streams(3, name_key("c"), range(5))
    parts = [run_streams(3, name_key("c"), r) for r in (range(0, 2), range(2, 5))]
    a = whole.standard_normal((7, 5, 2), run_axis=1)
    b = np.concatenate([p.standard_normal((7, len(p), 2), run_axis=1) for p in parts], axis=1)
    assert np.array_equal(a, b)
    # Children per purpose: independent of how much the parent streams were used.
    used = run_streams(3, name_key("c"), range(2))
    used.standard_normal((2, 100))
    assert np.array_equal(
        used.child("truth").random(2), run_streams(3, name_key("c"), range(2)).child("truth").random(2)
    )
    assert not np.array_equal(whole.child("truth").random(5), whole.child("receiver").random(5))
    # A case's streams depend on its name, not on its position in a list.
    assert not np.array_equal(
        run_streams(3, name_key("c"), [0]).random(1), run_streams(3, name_key("d"), [0]).random(1)
    )
    with pytest.raises(ValueError, match="needs 5 runs on that axis"):
        whole.standard_normal((5, 4), run_axis=1)
    with pytest.raises(ValueError, match="2 random streams given for a batch of 3"):
        as_run_streams(run_streams(0, (), range(2)), 3)
    with pytest.raises(TypeError, match="expected a numpy Generator, RunStreams or an int seed"):
        as_run_streams("seed", 3)
    assert isinstance(as_run_streams(np.random.default_rng(1), 3), RunStreams)


@pytest.mark.slow
@pytest.mark.parametrize("first, second", [(3, 4), (4, 3), (2, 5)])
def test_changing_runs_in_a_folder_gives_the_numbers_of_a_fresh_comparison(tmp_path, first, second):
    out = tmp_path / "reused"
    run_comparison(_config(tmp_path, first), out, progress=False)
    reused = run_comparison(_config(tmp_path, second), out, progress=False)
    fresh = run_comparison(_config(tmp_path, second, name="fresh.toml"), tmp_path / "fresh", progress=False)
    assert _summary(reused) == _summary(fresh)
    assert all(
        r["runs"] == second
        for r in json.loads(reused.read_text())["rows"]
        if r["mean"] is not None and r["metric"] == "error_rmse"
    )
    report = (out / "report.md").read_text()
    assert f"{second} Monte Carlo runs" in report


@pytest.mark.slow
def test_a_run_gets_the_same_random_numbers_in_any_batch(tmp_path):
    """Run 2's noise as the "raw" candidate stores it: computed in a 1-run batch (3 runs,
    batches of 2) and in a 2-run batch (4 runs): the same bits."""
    run_comparison(_config(tmp_path, 3), tmp_path / "three", progress=False)
    run_comparison(_config(tmp_path, 4), tmp_path / "four", progress=False)
    three = _raw_run_values(tmp_path / "three", "slips", "raw", "range_error_m")
    four = _raw_run_values(tmp_path / "four", "slips", "raw", "range_error_m")
    assert set(three) == {0, 1, 2} and set(four) == {0, 1, 2, 3}
    for r in three:
        assert np.array_equal(three[r], four[r]), r


@pytest.mark.slow
def test_another_configuration_in_the_same_folder_is_refused(tmp_path):
    out = tmp_path / "out"
    run_comparison(_config(tmp_path, 4, seed=4), out, progress=False)
    before = sorted(p.relative_to(out) for p in out.rglob("*") if p.is_file())
    with pytest.raises(
        ConfigError,
        match=r"^out: .* holds the results of 'reuse', a different configuration "
        r"\(it differs in: seed\)",
    ):
        run_comparison(_config(tmp_path, 4, seed=5), out, progress=False)
    assert sorted(p.relative_to(out) for p in out.rglob("*") if p.is_file()) == before
    # The same configuration with other non-numeric settings is the same comparison.
    run_comparison(_config(tmp_path, 2, seed=4, head='metrics = ["error_rmse"]\n'), out, progress=False)


@pytest.mark.slow
def test_cli_refuses_another_configuration_in_one_line(tmp_path):
    out = tmp_path / "out"
    for seed, code in ((4, 0), (5, 2)):
        path = tmp_path / f"s{seed}.toml"
        path.write_text(SMOOTH.format(runs=2, seed=seed))
        proc = subprocess.run(
            [sys.executable, "-m", "gnssframework", "compare", str(path), "--out", str(out), "--quiet"],
            capture_output=True,
            text=True,
        )
        assert proc.returncode == code, proc.stderr
    assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr
    assert proc.stderr.startswith("error: --out: ") and "differs in: seed" in proc.stderr


@pytest.mark.slow
def test_a_folder_being_written_is_refused(tmp_path):
    import fcntl

    out = tmp_path / "out"
    out.mkdir()
    with open(out / ".lock", "a+") as held:  # another process's lock
        fcntl.flock(held.fileno(), fcntl.LOCK_EX)
        code = (
            "import fcntl, sys\nfrom gnssframework.experiments import load_config, run_comparison\n"
            f"run_comparison(load_config({str(tmp_path / 'c.toml')!r}), {str(out)!r}, progress=False)\n"
        )
        _config(tmp_path, 2)
        proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.returncode != 0 and "is being written by another gnssframework process" in proc.stderr
    run_comparison(_config(tmp_path, 2), out, progress=False)  # free again


@pytest.mark.slow
def test_raw_series_without_a_record_are_refused(tmp_path):
    out = tmp_path / "out"
    (out / "raw" / "x").mkdir(parents=True)
    (out / "raw" / "x" / "batch0000.npz").write_bytes(b"")
    with pytest.raises(ConfigError, match="holds time series .* but no record of their comparison"):
        run_comparison(_config(tmp_path, 2), out, progress=False)


@pytest.mark.slow
def test_an_older_store_is_refused_not_misread(tmp_path):
    import sqlite3

    out = tmp_path / "out"
    out.mkdir()
    with sqlite3.connect(out / "results.sqlite") as con:
        con.execute("CREATE TABLE batches (config TEXT, case_name TEXT, candidate TEXT, batch INTEGER, runs INTEGER)")
    with pytest.raises(DataFileError, match=r"results.sqlite: a result store of an earlier gnssframework"):
        run_comparison(_config(tmp_path, 2), out, progress=False)


@pytest.mark.slow
def test_a_sweep_over_some_cases_keeps_each_cases_random_numbers(tmp_path):
    """The sweep's point at the base value runs only case "slips" (the second case): it
    must equal the main table's "slips" rows (it used other numbers when cases were
    numbered by position)."""
    extra = (
        '\n[[sweeps]]\npath = "candidates.hatch.channel_filter.params.window"\nvalues = [30, 60]\ncases = ["slips"]\n'
    )
    summary = json.loads(
        run_comparison(_config(tmp_path, 4, extra=extra), tmp_path / "out", progress=False).read_text()
    )
    main = {(r["candidate"], r["metric"]): r["mean"] for r in summary["rows"] if r["case"] == "slips"}
    sweep = summary["sweeps"][0]
    at_base = {(r["candidate"], r["metric"]): r["mean"] for r in sweep["rows"] if r["value"] == 30}
    assert at_base and at_base == {k: v for k, v in main.items() if k in at_base}


class _Failing(Scenario):
    """A scenario whose filter fails numerically in the second batch."""

    kind = "test-failing"
    Params = ScenarioParams
    CaseParams = ScenarioParams
    components: dict = {}
    metrics = {"x": "m"}

    def run_batch(self, case, plugins, runs, rng) -> BatchResult:
        rng = as_run_streams(rng, runs)
        if rng.runs[0] >= 2:
            raise NumericalError("ukf", [(1, 0)], 7, "innovation covariance is not positive definite")
        return BatchResult({"x": np.zeros(runs)})


@pytest.fixture()
def failing_scenario(scratch_registry):
    module = types.SimpleNamespace(register_scenario=gf.hookimpl(lambda register: register(_Failing)))
    scratch_registry.register_module(module, name="test-failing-scenario")
    yield


@pytest.mark.slow
@pytest.mark.parametrize("workers", [1, 2])
def test_a_failure_names_the_candidate_case_runs_and_sweep_point(tmp_path, failing_scenario, workers):
    path = tmp_path / "f.toml"
    path.write_text(
        f'runs = 4\nbatch_size = 2\n[executor]\nworkers = {workers}\n[scenario]\nkind = "test-failing"\n'
        '[[cases]]\nname = "hard"\n[[candidates]]\nname = "mine"\n'
    )
    with pytest.raises(RunFailure) as err:
        run_comparison(load_config(path), tmp_path / "out", progress=False)
    assert str(err.value) == (
        "candidate 'mine', case 'hard', runs 2-3: ukf: numerical failure at batch element (1, 0), "
        "step 7: innovation covariance is not positive definite"
    )
    assert err.value.cause == "NumericalError"


def test_a_scenario_revision_makes_an_old_store_another_configuration(tmp_path, monkeypatch):
    """A scenario whose code or defaults changed its numbers raises its ``revision``: a
    store written before is refused in one line saying so, never read with the old
    numbers; revision 0 leaves every identity as it was."""
    from gnssframework.experiments.folder import claim_folder
    from gnssframework.experiments.scenarios.carrier_smoothing import CarrierSmoothingScenario

    (tmp_path / "c.toml").write_text(SMOOTH.format(runs=2, seed=1))
    config = load_config(tmp_path / "c.toml")
    before = config.identity()
    with claim_folder(tmp_path / "out", config):
        pass
    monkeypatch.setattr(CarrierSmoothingScenario, "revision", 1)
    after = load_config(tmp_path / "c.toml")
    assert after.identity() != before
    with pytest.raises(ConfigError, match="nothing written differs, so the scenario's code changed the numbers"):
        with claim_folder(tmp_path / "out", after):
            pass
    monkeypatch.setattr(CarrierSmoothingScenario, "revision", 0)
    assert load_config(tmp_path / "c.toml").identity() == before
