"""Issue 38: a results store whose finished batch lost metric rows is not trusted: the
batch is recomputed, the report's numbers are those of a fresh comparison (on main the
rerun averaged one candidate over 11 runs while the report said 12)."""

from __future__ import annotations

import pytest
import json
import sqlite3
from pathlib import Path

from gnssframework.experiments import load_config, run_comparison
from gnssframework.experiments.store import ResultStore

CONFIG = """
name = "rows"
runs = 4
batch_size = 2
seed = 3
[executor]
workers = 1
[scenario]
kind = "carrier-smoothing"
epochs = 60
[[cases]]
name = "clean"
slip_probability = 0.0
[[candidates]]
name = "raw"
[[candidates]]
name = "hatch"
channel_filter = { name = "hatch", params = { window = 20 } }
"""


def _rows(summary: Path) -> list:
    return json.loads(summary.read_text())["rows"]


@pytest.mark.slow
def test_deleted_metric_rows_of_a_finished_batch_are_recomputed(tmp_path, capsys):
    path = tmp_path / "c.toml"
    path.write_text(CONFIG)
    config = load_config(path)
    out = tmp_path / "out"
    first = _rows(run_comparison(config, out, progress=False))
    store = ResultStore(out / "results.sqlite")
    key = config.identity()
    assert len(store.finished_batches(key)) == 4  # 1 case x 2 candidates x 2 batches
    with sqlite3.connect(out / "results.sqlite") as con:  # one run's row of one metric of one batch
        deleted = con.execute(
            "DELETE FROM metrics WHERE candidate = 'hatch' AND run = 3 AND metric = "
            "(SELECT metric FROM metrics LIMIT 1)"
        ).rowcount
    assert deleted == 1
    assert ("clean", "hatch", 2, 2) not in store.finished_batches(key)
    assert len(store.finished_batches(key)) == 3
    assert store.damaged_batches(key) == {("clean", "hatch", 2, 2)}
    capsys.readouterr()
    again = _rows(run_comparison(config, out, progress=False))
    assert again == first
    assert len(store.finished_batches(key)) == 4 and not store.damaged_batches(key)
    said = capsys.readouterr().err  # the repair is said, not silent
    assert "lacks metric rows of 1 finished batch: case 'clean', candidate 'hatch', runs 2-3; recomputing it" in said, (
        said
    )


def test_a_batch_with_every_metric_row_gone_is_not_finished(tmp_path):
    store = ResultStore(tmp_path / "s.sqlite")
    store.register("k", 2)
    store.add_batch("k", "c", "a", 0, {"m1": [1.0, 2.0], "m2": [3.0, 4.0]})
    store.add_batch("k", "c", "a", 2, {"m1": [1.0, 2.0], "m2": [3.0, 4.0]})
    assert store.finished_batches("k") == {("c", "a", 0, 2), ("c", "a", 2, 2)}
    with sqlite3.connect(tmp_path / "s.sqlite") as con:
        con.execute("DELETE FROM metrics WHERE first_run = 2 AND metric = 'm2'")
    assert store.finished_batches("k") == {("c", "a", 0, 2)}  # m2 lost entirely in that batch
    assert store.damaged_batches("k") == {("c", "a", 2, 2)}
    with sqlite3.connect(tmp_path / "s.sqlite") as con:
        con.execute("DELETE FROM metrics WHERE first_run = 2")
    assert store.finished_batches("k") == {("c", "a", 0, 2)}


def test_a_metric_only_one_case_defines_does_not_damage_the_others(tmp_path):
    """The main vector-tracking example's PCRB metrics exist on its static cases only: its
    moving cases' batches were once counted damaged for lacking them, and recomputed on
    every resume (36 batches each time the figure script reused the main job's store)."""
    store = ResultStore(tmp_path / "s.sqlite")
    store.register("k", 2)
    store.add_batch("k", "static", "a", 0, {"m1": [1.0, 2.0], "pcrb": [3.0, 4.0]})
    store.add_batch("k", "moving", "a", 0, {"m1": [1.0, 2.0]})
    store.add_batch("k", "moving", "a", 2, {"m1": [1.0, 2.0]})
    assert store.finished_batches("k") == {("static", "a", 0, 2), ("moving", "a", 0, 2), ("moving", "a", 2, 2)}
    assert not store.damaged_batches("k")
    with sqlite3.connect(tmp_path / "s.sqlite") as con:  # a metric the case's other batch holds is still missed
        con.execute("DELETE FROM metrics WHERE \"case\" = 'moving' AND first_run = 2")
    store.add_batch("k", "moving", "a", 2, {"m2": [1.0, 2.0]})
    assert store.damaged_batches("k") == {("moving", "a", 0, 2), ("moving", "a", 2, 2)}
