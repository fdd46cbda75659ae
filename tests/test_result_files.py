"""Result files: strict JSON summaries (no NaN) and atomic writes that survive SIGKILL."""

from __future__ import annotations

import json
import math
import os
import signal
import sqlite3
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import numpy as np
import pytest

from gnssframework.experiments import load_config, run_comparison
from gnssframework.experiments.files import atomic_open, dumps_strict, loads_strict, write_json

EXAMPLES = sorted((Path(__file__).resolve().parents[1] / "examples").glob("*.toml"))


def _shortened(path: Path, tmp_path: Path) -> Path:
    """The example with 2 runs, one worker and short runs (epochs / duration cut)."""
    data = tomllib.loads(path.read_text())
    data.update(runs=2, batch_size=2, executor={"kind": "local", "workers": 1})
    for section in [data["scenario"], *data.get("cases", [])]:
        if "epochs" in section:
            section["epochs"] = 60
        if "duration_s" in section:
            section["duration_s"] = min(section["duration_s"], 1.5)
    if "duration_s" in data["scenario"]:
        data["scenario"]["settle_s"] = 0.5
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
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v) and k in ("cases", "candidates",
                                                                                          "sweeps"):
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
        loads_strict('[-Infinity]')
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


@pytest.mark.parametrize("example", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_every_example_writes_a_strict_json_summary(example, tmp_path):
    config = load_config(_shortened(example, tmp_path))
    summary = run_comparison(config, tmp_path / "out", progress=False)
    doc = loads_strict(summary.read_text())  # raises on a bare NaN or Infinity
    report = (tmp_path / "out" / "report.md").read_text()
    assert "nan" not in report.lower().replace("nanoseconds", "")
    for row in doc["rows"]:
        if row["mean"] is None:  # undefined in every run: says why, in the summary and the report
            assert row["undefined"] and row["undefined"] in report


def test_a_metric_undefined_in_every_run_is_null_with_its_reason(tmp_path):
    config = tmp_path / "noslips.toml"
    config.write_text(KILL_CONFIG.replace("slip_probability = 0.01", "slip_probability = 0.0"))
    summary = run_comparison(load_config(config, runs=2), tmp_path / "out", progress=False)
    rows = {(r["candidate"], r["metric"]): r for r in loads_strict(summary.read_text())["rows"]}
    assert rows[("raw", "slip_recovery_epochs")] | {"unit": None} == {
        "case": "c", "candidate": "raw", "metric": "slip_recovery_epochs", "mean": None, "std": None, "runs": 0,
        "unit": None, "published": None, "undefined": "no slips"}
    assert rows[("hatch", "error_rmse")]["mean"] > 0 and "undefined" not in rows[("hatch", "error_rmse")]
    report = (tmp_path / "out" / "report.md").read_text()
    assert "| slip_recovery_epochs | epochs | no slips | no slips |" in report and "nan" not in report


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


def _compare(config: Path, out: Path) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "gnssframework", "compare", str(config), "--out", str(out),
                             "--quiet"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)


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
        elif path.suffix == ".md":
            assert path.read_text().endswith("\n"), path
        elif path.suffix == ".sqlite":
            con = sqlite3.connect(path)
            try:
                assert con.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
                # Every batch the store calls finished has all its metric rows.
                for config, case, cand, batch, runs in con.execute("SELECT * FROM batches"):
                    n = con.execute("SELECT COUNT(*) FROM metrics WHERE config = ? AND case_name = ? AND "
                                    "candidate = ? AND run >= ? AND run < ?",
                                    (config, case, cand, batch, batch + runs)).fetchone()[0]
                    assert n == 2 * runs, (case, cand, batch)  # two metrics per run
            finally:
                con.close()


def test_runs_killed_while_writing_resume_to_the_uninterrupted_results(tmp_path):
    config = tmp_path / "killed.toml"
    config.write_text(KILL_CONFIG)
    start = time.monotonic()
    proc = _compare(config, tmp_path / "whole")
    assert proc.wait(timeout=120) == 0, proc.stderr.read()
    whole = time.monotonic() - start
    expected = loads_strict((tmp_path / "whole" / "summary.json").read_text())

    out = tmp_path / "killed"
    kills = 0
    # A chain of runs into one folder, each killed at a later point of its own run: early
    # ones die in imports or the first batches, later ones amid batch writes and the report.
    for fraction in (0.5, 0.7, 0.85, 1.0):
        proc = _compare(config, out)
        time.sleep(fraction * whole)
        if proc.poll() is None:
            os.kill(proc.pid, signal.SIGKILL)
            kills += 1
        proc.wait(timeout=60)
        if out.exists():
            _check_every_file_parses(out)
    assert kills >= 2
    proc = _compare(config, out)
    assert proc.wait(timeout=120) == 0, proc.stderr.read()
    _check_every_file_parses(out)
    assert loads_strict((out / "summary.json").read_text()) == expected
    assert (out / "report.md").read_text() == (tmp_path / "whole" / "report.md").read_text()
