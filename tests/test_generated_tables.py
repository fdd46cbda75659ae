"""The experiment pages' generated tables: the generators' output and the committed files.

The committed ``docs/experiments/generated/*.md`` must be what the generators write (CI
regenerates them from its runs), so their rows must follow the metric lists
``docs/make_experiment_plots.py`` hands the generators.
"""

from __future__ import annotations

import math
import re
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
GENERATED = ROOT / "docs" / "experiments" / "generated"
sys.path.insert(0, str(ROOT / "docs"))

import make_experiment_plots  # noqa: E402
import published_tables  # noqa: E402
import sweep_tables  # noqa: E402


def _first_table_metrics(text: str) -> list[str]:
    """Metric names (first column) of the first results table of a generated page."""
    table = text.split("| --- |", 1)[1].split("\n\n", 1)[0]
    return [m.group(1) for m in re.finditer(r"^\| (\w+) \|", table, re.M)]


@pytest.mark.parametrize("name", ["vector_tracking", "vector_tracking_static", "vector_tracking_moving"])
def test_committed_vector_tracking_tables_hold_the_generators_rows(name):
    # make_experiment_plots renders these with TABLES[name]: every row of the committed file
    # is one of those metrics, in that order, and no listed metric of the example is missing.
    rows = _first_table_metrics((GENERATED / f"{name}.md").read_text())
    listed = make_experiment_plots.TABLES[name]
    assert rows == [m for m in listed if m in rows]
    assert rows == listed, f"{name}.md: rows {rows} differ from make_experiment_plots' {listed}"


def test_committed_sweep_table_holds_the_generators_rows():
    text = (GENERATED / "vector_tracking_sweep.md").read_text()
    for metric in make_experiment_plots.SWEEP_TABLES["vector_tracking_sweep"]:
        assert f"| {metric} (" in text, metric


def _sweep_summary() -> dict:
    rows, paired = [], []
    for value in (25.0, 30.0):
        for cand, a in (("ref", 2.0), ("cand", 1.0)):
            rows.append({"value": value, "case": "c", "candidate": cand, "metric": "err", "mean": a * value,
                         "se": 0.1, "n": 4, "unit": "m"})
            rows.append({"value": value, "case": "c", "candidate": cand, "metric": "bound", "mean": 0.5,
                         "se": 1e-17, "n": 4, "unit": "m"})
        paired.append({"value": value, "case": "c", "candidate": "cand", "metric": "err", "reference": "ref",
                       "diff": -value, "se": 0.05, "ratio": 0.5, "ratio_se": 0.01})
        paired.append({"value": value, "case": "c", "candidate": "cand", "metric": "bound", "reference": "ref",
                       "diff": 0.0, "se": 0.0, "ratio": 1.0, "ratio_se": 0.0})
    return {"name": "s", "seed": 1, "runs": 4, "reference": "ref",
            "sweeps": [{"name": "cn0", "path": "cases.cn0", "values": [25.0, 30.0], "cases": ["c"],
                        "rows": rows, "paired": paired}]}


def test_sweep_table_gives_means_and_paired_differences():
    text = sweep_tables.render(_sweep_summary())
    assert "| | cn0 = 25 | 30 |" in text
    assert "| err (m), `cand` | 25 ± 0.1 | 30 ± 0.1 |" in text
    assert "| err (m), `ref` | 50 ± 0.1 | 60 ± 0.1 |" in text
    assert "| err (m) | -25 ± 0.05 | -30 ± 0.05 |" in text
    assert "| err, ratio | 0.5 ± 0.01 | 0.5 ± 0.01 |" in text
    # A bound every candidate shares: one row, no spread at rounding level, no paired row.
    assert "| bound (m), every candidate | 0.5 | 0.5 |" in text
    assert "| bound (m) |" not in text and "bound, ratio" not in text
    assert "`ref` − `ref`" not in text


def test_sweep_table_lists_the_claims_at_their_points():
    summary = _sweep_summary()
    at = {"claim": 0, "statement": "cand: err lower than ref's", "case": "c", "sweep": "cn0", "candidate": "cand",
          "metric": "err", "reference": "ref", "se": 0.05, "n": 4, "outcome": "holds"}
    summary["claims"] = [{**at, "point": 25.0, "diff": -25.0}, {**at, "point": 30.0, "diff": -30.0},
                         {**at, "point": "all", "points": [25.0, 30.0], "held": 2, "corrected_level": 0.975,
                          "failed_corrected": []}]
    text = sweep_tables.render(summary)
    assert "**Claims**: 3 of 3 hold" in text
    assert "| holds | c cn0=25.0 | cand: err lower than ref's | difference -25" in text
    assert "| holds | c cn0=25.0,30.0 (all) | cand: err lower than ref's | holds at 2 of 2 points;" in text


def test_sweep_table_refuses_a_summary_without_sweeps(tmp_path):
    (tmp_path / "summary.json").write_text('{"name": "x", "seed": 1, "rows": []}')
    with pytest.raises(SystemExit, match="no sweeps"):
        sweep_tables.write(tmp_path, "x")


def _published_summary() -> dict:
    def row(case, cand, metric, mean, std, published):
        return {"case": case, "candidate": cand, "metric": metric, "mean": mean, "std": std, "runs": 4,
                "unit": "m", "published": published}
    return {"name": "p", "seed": 3, "runs": 4, "rows": [
        row("a", "x", "pos", 1.0, 0.2, 4.7), row("a", "y", "pos", 2.0, 0.4, 5.8),
        row("a", "x", "other", 9.0, 1.0, None), row("a", "y", "other", 9.0, 1.0, None),
        row("b", "x", "pos", 1.0, 0.2, None), row("b", "y", "pos", 2.0, 0.4, None)]}


def test_published_table_sets_the_papers_values_beside_ours():
    text = published_tables.render(_published_summary(), ["x", "y"])
    se_x, se_y = 0.2 / math.sqrt(4), 0.4 / math.sqrt(4)
    assert f"| pos | m | 4.7 | 1 ± {se_x:.2g} | 5.8 | 2 ± {se_y:.2g} |" in text
    assert "**a**" in text and "**b**" not in text  # no published value in case b
    assert "| other |" not in text  # no published value for that metric


def test_published_table_refuses_an_unknown_candidate(tmp_path):
    import json

    (tmp_path / "summary.json").write_text(json.dumps(_published_summary()))
    with pytest.raises(SystemExit, match="no candidate z"):
        published_tables.write(tmp_path, "p", ["x", "z"])


# Reference 001 (carrier smoothing): make_experiment_plots renders these with its TABLES /
# SWEEP_TABLES entries; the committed files hold exactly those rows.
def test_committed_carrier_smoothing_tables_hold_the_generators_rows():
    text = (GENERATED / "carrier_smoothing.md").read_text()
    listed = make_experiment_plots.TABLES["carrier_smoothing"]
    for case in ("slips", "isolated-slips"):
        assert _first_table_metrics(text.split(f"**{case}**", 1)[1]) == listed, case
    assert "**Assumptions**" in text and "| channel_filter | noise-equivalent window | s |" in text


def test_committed_carrier_smoothing_sweep_table_holds_the_generators_rows():
    text = (GENERATED / "carrier_smoothing_sweep.md").read_text()
    listed = make_experiment_plots.SWEEP_TABLES["carrier_smoothing_sweep"]
    found = set(re.findall(r"^\| (\w+) \(", text, re.M))
    assert found == set(listed), f"rows {sorted(found)} differ from make_experiment_plots' {listed}"
