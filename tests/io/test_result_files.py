"""Result files: strict JSON summaries (no NaN) and atomic writes that survive SIGKILL."""

from __future__ import annotations

import csv
import json
import math
import signal
import sqlite3
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from gnssframework.experiments import load_config, run_comparison
from gnssframework.experiments.config_base import read_config_data
from gnssframework.io.files import atomic_open, dumps_strict, loads_strict, write_json, write_rows_csv
from gnssframework.experiments.scenarios.carrier_smoothing import CarrierSmoothingScenario

EXAMPLES = sorted((Path(__file__).resolve().parents[2] / "examples").glob("*.toml"))


def _shortened(path: Path, tmp_path: Path) -> Path:
    """The example with 2 runs, one worker and short runs (epochs / duration cut); an example
    built on another (``[base]``) as it resolves."""
    data = read_config_data(path)
    data.update(runs=2, batch_size=2, executor={"kind": "local", "workers": 1})
    # The first and the last case (the examples order them mildest to harshest): every metric of
    # every candidate is written either way; CI's main job checks its examples' whole summaries
    # strictly too. Claims at a dropped case go with it.
    cases = data.get("cases", [])
    if len(cases) > 2:
        tuning = data.get("tuning", {})  # the cases the tuning scores on stay: it names them
        tuned = set(tuning.get("cases", [])) | {c for own in tuning.get("candidate_cases", {}).values() for c in own}
        data["cases"] = [c for j, c in enumerate(cases) if j in (0, len(cases) - 1) or c["name"] in tuned]
        kept = {c["name"] for c in data["cases"]}
        for case in data["cases"]:  # streams named after a dropped case: the case's own
            if case.get("streams") not in (None, *kept):
                case.pop("streams")
        data["published"] = {k: v for k, v in data.get("published", {}).items() if k in kept}
        if "claims" in data:
            data["claims"] = [
                c
                for c in data["claims"]
                if c.get("case", next(iter(kept))) in kept and c.get("reference_case", next(iter(kept))) in kept
            ]
    if data["scenario"]["kind"] == "sample-receiver":  # a fix needs a whole subframe: fewer satellites, one case
        data["scenario"].update(duration_s=8.0, satellites=4)
        data["cases"] = data["cases"][:1]
        data.pop("claims", None)
        out = tmp_path / path.name
        out.write_text(_toml(data))
        return out
    for section in [data["scenario"], *data.get("cases", [])]:
        if "epochs" in section:
            section["epochs"] = 60
        if "duration_s" in section:
            section["duration_s"] = min(section["duration_s"], 1.5)
    for case in data.get("cases", []):  # a C/N0 fade (a channel fault, an outage) starts inside the shortened run
        for start in ("fade_start_s", "fault_start_s", "outage_start_s"):
            if start in case:
                case[start] = 0.75
        if case.get("outage_end_s") is not None:
            case["outage_end_s"] = 1.5
    if "duration_s" in data["scenario"]:
        data["scenario"]["settle_s"] = 0.5
        if "steady_state_s" in data["scenario"]:
            data["scenario"]["steady_state_s"] = 1.0
    data.pop("sweeps", None)  # sweeps have their own strict-JSON test
    if "claims" in data:  # and so do the claims at their points
        data["claims"] = [c for c in data["claims"] if "sweep" not in c]
    if "tuning" in data:  # the tuning's own tests are in test_tuning.py: the least that runs it here
        data["tuning"].update(trials=2, runs=1)
    out = tmp_path / path.name
    out.write_text(_toml(data))
    return out


def _toml(data: dict) -> str:
    """A minimal TOML writer for the example configs (tables, arrays of tables, inline values)."""

    def value(v):
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, dict):
            return "{ " + ", ".join(f"{json.dumps(k)} = {value(x)}" for k, x in v.items()) + " }"
        if isinstance(v, list):
            return "[" + ", ".join(value(x) for x in v) + "]"
        return repr(v)

    lines, tables = [], []
    for k, v in data.items():
        if isinstance(v, dict) and k in ("scenario", "executor", "published", "sweeps"):
            tables.append((f"[{k}]", v))
        elif (
            isinstance(v, list) and v and all(isinstance(x, dict) for x in v) and k in ("cases", "candidates", "sweeps")
        ):
            tables += [(f"[[{k}]]", x) for x in v]
        else:
            lines.append(f"{json.dumps(k)} = {value(v)}")
    for head, body in tables:
        lines += ["", head] + [f"{json.dumps(k)} = {value(x)}" for k, x in body.items()]
    return "\n".join(lines) + "\n"


def test_strict_parser_refuses_nan_and_the_writer_never_emits_it(tmp_path):
    with pytest.raises(ValueError, match="NaN"):
        loads_strict('{"a": NaN}')
    with pytest.raises(ValueError, match="Infinity"):
        loads_strict("[-Infinity]")
    text = dumps_strict({"a": float("nan"), "b": [np.float64("inf"), 1.5], "c": np.arange(2)})
    assert loads_strict(text) == {"a": None, "b": [None, 1.5], "c": [0, 1]}
    write_json(tmp_path / "s.json", {"x": math.nan})
    assert loads_strict((tmp_path / "s.json").read_text()) == {"x": None}


def test_atomic_open_leaves_the_old_file_on_an_exception(tmp_path):
    target = tmp_path / "out.csv"
    target.write_text("old\n")
    with pytest.raises(RuntimeError):
        with atomic_open(target) as fh:
            fh.write("half a ne")
            raise RuntimeError("killed")
    assert target.read_text() == "old\n" and sorted(p.name for p in tmp_path.iterdir()) == ["out.csv"]


def test_write_rows_csv_writes_its_columns_in_order_or_nothing(tmp_path):
    import csv

    path = write_rows_csv(
        tmp_path / "m.csv", ("prn", "text"), [{"text": "a, b", "prn": 3, "x": 0}, {"prn": 4, "text": ""}]
    )
    assert list(csv.reader(path.open())) == [["prn", "text"], ["3", "a, b"], ["4", ""]]
    with pytest.raises(KeyError):  # a row without a column: the old file stays
        write_rows_csv(path, ("prn", "text"), [{"prn": 5, "text": "c"}, {"prn": 6}])
    assert list(csv.reader(path.open()))[1:] == [["3", "a, b"], ["4", ""]]


@pytest.mark.slow
@pytest.mark.parametrize("example", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_every_example_writes_a_strict_json_summary(example, tmp_path):
    config = load_config(_shortened(example, tmp_path))
    summary = run_comparison(config, tmp_path / "out", progress=False, figures=lambda name: False)
    doc = loads_strict(summary.read_text())  # raises on a bare NaN or Infinity
    report = (tmp_path / "out" / "report.md").read_text()
    assert "nan" not in report.lower().replace("nanoseconds", "")
    for row in doc["rows"]:
        if row["mean"] is None:  # undefined in every run: says why, in the summary and the report
            assert row["undefined"] and row["undefined"] in report


@pytest.mark.slow
def test_a_metric_undefined_in_every_run_is_null_with_its_reason(tmp_path):
    config = tmp_path / "noslips.toml"
    config.write_text(KILL_CONFIG.replace("slip_probability = 0.01", "slip_probability = 0.0"))
    summary = run_comparison(load_config(config, runs=2), tmp_path / "out", progress=False)
    rows = {(r["candidate"], r["metric"]): r for r in loads_strict(summary.read_text())["rows"]}
    assert rows[("raw", "slip_recovery_epochs")] | {"unit": None} == {
        "case": "c",
        "candidate": "raw",
        "metric": "slip_recovery_epochs",
        "mean": None,
        "std": None,
        "runs": 0,
        "unit": None,
        "published": None,
        "undefined": "no isolated slips",
    }
    assert rows[("hatch", "error_rmse")]["mean"] > 0 and "undefined" not in rows[("hatch", "error_rmse")]
    report = (tmp_path / "out" / "report.md").read_text()
    assert "| slip_recovery_epochs | epochs | no isolated slips | no isolated slips |" in report and "nan" not in report


KILL_CONFIG = """
name = "killed"
runs = 8
batch_size = 1
seed = 3
[executor]
kind = "local"
workers = 1
[scenario]
kind = "carrier-smoothing"
epochs = 300
slip_probability = 0.01
[[cases]]
name = "c"
[[candidates]]
name = "raw"
[[candidates]]
name = "hatch"
channel_filter = { name = "hatch", params = { window = 100 } }
"""


def _check_every_file_parses(out: Path) -> None:
    """What a later run or another tool would read is whole: JSON, PNG, npz and the store."""
    for path in out.rglob("*"):
        if path.is_dir():
            continue
        if path.name.startswith(".") and path.name.endswith(".tmp"):
            continue  # an atomic write cut by the kill: never read, replaced by the next one
        if path.suffix == ".json":
            loads_strict(path.read_text())
        elif path.suffix == ".png":
            data = path.read_bytes()
            assert data[:8] == b"\x89PNG\r\n\x1a\n" and data[-8:-4] == b"IEND", path
        elif path.suffix == ".npz":
            with np.load(path) as npz:
                for key in npz.files:
                    npz[key]
        elif path.suffix == ".csv":  # whole: every row has the header's columns
            with path.open(newline="") as fh:
                rows = list(csv.reader(fh))
            assert rows and all(len(r) == len(rows[0]) for r in rows), path
        elif path.suffix == ".md":
            assert path.read_text().endswith("\n"), path
        elif path.suffix == ".sqlite":
            con = sqlite3.connect(path)
            try:
                assert con.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
                # Every batch the store calls finished has all its metric rows.
                for config, case, cand, first, runs in con.execute("SELECT * FROM batches"):
                    n = con.execute(
                        'SELECT COUNT(*) FROM metrics WHERE config = ? AND "case" = ? AND '
                        "candidate = ? AND first_run = ? AND batch_runs = ?",
                        (config, case, cand, first, runs),
                    ).fetchone()[0]
                    n_metrics = len(CarrierSmoothingScenario.metrics)  # the kill config's scenario
                    assert n == n_metrics * runs, (case, cand, first)  # every metric of every run
            finally:
                con.close()


# `gnssframework compare`, SIGKILLing itself at a chosen write: inside the atomic write of
# a named file (its bytes written, before the rename), or inside the store's transaction of
# the n-th batch (metric rows inserted, batch row not yet committed). A kill at a chosen
# write, rather than at a chosen time, hits the write every time.
_KILL_AT = r"""
import os, signal, sqlite3, sys
import gnssframework.io.files as files
import gnssframework.experiments.store as store
from gnssframework.cli import main

config, out, target = sys.argv[1:4]
real_fsync, real_connect, batches = os.fsync, sqlite3.connect, []

def fsync(fd):
    if target in os.readlink(f"/proc/self/fd/{fd}"):
        os.kill(os.getpid(), signal.SIGKILL)
    real_fsync(fd)

class Connection:
    def __init__(self, con):
        self.con = con
    def __getattr__(self, name):
        return getattr(self.con, name)
    def __enter__(self):
        self.con.__enter__()
        return self
    def __exit__(self, *exc):
        return self.con.__exit__(*exc)
    def execute(self, sql, *args):
        if sql.startswith("INSERT OR REPLACE INTO batches"):
            batches.append(1)
            if target == f"store-batch-{len(batches)}":
                os.kill(os.getpid(), signal.SIGKILL)
        return self.con.execute(sql, *args)

files.os.fsync = fsync
store.sqlite3 = type("sqlite3", (), {"connect": staticmethod(lambda *a, **k: Connection(real_connect(*a, **k)))})
main(["compare", config, "--out", out, "--quiet"])
"""


@pytest.mark.slow
def test_compare_killed_inside_each_kind_of_write_resumes_to_the_uninterrupted_results(tmp_path):
    config = tmp_path / "killed.toml"
    config.write_text(KILL_CONFIG.replace("runs = 8", "runs = 3"))
    expected = loads_strict(run_comparison(load_config(config), tmp_path / "whole", progress=False).read_text())
    out = tmp_path / "killed"
    # One folder, one run per write site, each killed there; the next run resumes.
    for target in ("run000001-000001.npz", "store-batch-2", "summary.json", "-cdf.png"):
        before = {p: p.read_bytes() for p in out.rglob(f"*{target}")} if out.exists() else {}
        proc = subprocess.run(
            [sys.executable, "-c", _KILL_AT, str(config), str(out), target], capture_output=True, text=True, timeout=120
        )
        assert proc.returncode == -signal.SIGKILL, (target, proc.stderr)  # it did die at that write
        _check_every_file_parses(out)
        # The file being written when the process died is as it was before: absent or whole.
        assert {p: p.read_bytes() for p in out.rglob(f"*{target}")} == before, target
    assert loads_strict(run_comparison(load_config(config), out, progress=False).read_text()) == expected
    assert (out / "report.md").read_text() == (tmp_path / "whole" / "report.md").read_text()


# -- the outputs merged from other issues: sweeps (CSV, JSON, plots) and paired rows -------------

SWEEP = """
[[sweeps]]
path = "candidates.hatch.channel_filter.params.window"
values = [50, 100]
"""


def _no_slips_with_a_sweep(tmp_path: Path, runs: int) -> Path:
    config = tmp_path / "sweep.toml"
    config.write_text(
        KILL_CONFIG.replace("runs = 8", f"runs = {runs}").replace("slip_probability = 0.01", "slip_probability = 0.0")
        + SWEEP
    )
    return config


@pytest.mark.slow
def test_sweep_tables_and_paired_rows_are_strict_with_null_and_a_reason(tmp_path):
    """A metric undefined in every run (no slips) goes through summary rows, paired rows and
    the sweep's JSON and CSV as null/empty with a reason, never as NaN."""
    out = tmp_path / "out"
    summary = loads_strict(
        run_comparison(load_config(_no_slips_with_a_sweep(tmp_path, 2)), out, progress=False).read_text()
    )
    undefined = [p for p in summary["paired"] if p["metric"] == "slip_recovery_epochs"]
    assert undefined and all(p["diff"] is None and p["se"] is None and p["reason"] for p in undefined)
    defined = [p for p in summary["paired"] if p["metric"] == "error_rmse"]
    assert defined and all(isinstance(p["diff"], float) for p in defined)
    sweep = loads_strict((out / "sweeps" / "window.json").read_text())
    assert sweep["values"] == [50, 100] and summary["sweeps"][0] == sweep
    rows = [r for r in sweep["rows"] if r["metric"] == "slip_recovery_epochs"]
    assert len(rows) == 4 and all(r["mean"] is None and r["se"] is None and r["n"] == 0 for r in rows)
    assert all(p["diff"] is None and p["reason"] for p in sweep["paired"] if p["metric"] == "slip_recovery_epochs")
    with (out / "sweeps" / "window.csv").open(newline="") as fh:
        table = list(csv.DictReader(fh))
    assert len(table) == 2 * 2 * len(CarrierSmoothingScenario.metrics)
    for row in table:  # every cell is a number, empty, text or a boolean: never nan/inf
        for value in row.values():
            assert value.strip().lower() not in ("nan", "inf", "-inf", "infinity"), row
        if row["metric"] == "slip_recovery_epochs":
            assert row["mean"] == "" and row["se"] == "" and row["n"] == "0"
        else:
            assert math.isfinite(float(row["mean"]))
    for png in (out / "plots").glob("sweep-window-*.png"):
        assert png.read_bytes()[-8:-4] == b"IEND"


@pytest.mark.slow
def test_compare_killed_inside_each_sweep_write_resumes_to_the_uninterrupted_results(tmp_path):
    config = _no_slips_with_a_sweep(tmp_path, 2)
    whole = tmp_path / "whole"
    expected = loads_strict(run_comparison(load_config(config), whole, progress=False).read_text())
    out = tmp_path / "killed"
    for target in ("window.csv", "window.json", "sweep-window-c-paired.png"):
        before = {p: p.read_bytes() for p in out.rglob(f"*{target}")} if out.exists() else {}
        proc = subprocess.run(
            [sys.executable, "-c", _KILL_AT, str(config), str(out), target], capture_output=True, text=True, timeout=120
        )
        assert proc.returncode == -signal.SIGKILL, (target, proc.stderr)
        _check_every_file_parses(out)
        assert {p: p.read_bytes() for p in out.rglob(f"*{target}")} == before, target
    assert loads_strict(run_comparison(load_config(config), out, progress=False).read_text()) == expected
    for name in ("sweeps/window.csv", "sweeps/window.json", "report.md"):
        assert (out / name).read_text() == (whole / name).read_text(), name
