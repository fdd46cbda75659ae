"""A threshold sweep refined around its thresholds: which points are added (from a
constructed store), the refusals, and a comparison that runs them, paired and resumable."""

import json

import numpy as np
import pytest

from gnssframework.errors import ConfigError
from gnssframework.experiments.config import ComparisonConfig
from gnssframework.experiments.sweeps import refined_values
from tests.threshold_configs import OutcomeStore, constructed, tiny_threshold


def _config(refine=None, threshold=True):
    spec = {"metric": "loss_of_lock", "level": 0.5, "bootstrap": 300} if threshold else None
    sweep = {} if refine is None else {"refine": refine}
    return ComparisonConfig.model_validate(constructed(threshold=spec, **sweep))


def test_points_fill_the_cells_each_threshold_interval_reaches():
    config = _config(refine={"step": 1.0})
    u = np.random.default_rng(0).random(40)
    # a: every run lost at 20 and 25, half at 30, none at 35: its interval lies in the
    # cells [25, 30] and [30, 35]; b: separated between 20 and 25 (an interval of zero
    # width at 22.5, the cell [20, 25])
    a = {20.0: np.ones(40), 25.0: np.ones(40), 30.0: (u < 0.5) * 1.0, 35.0: np.zeros(40)}
    b = {20.0: np.ones(40), 25.0: np.zeros(40), 30.0: np.zeros(40), 35.0: np.zeros(40)}
    added = refined_values(config, OutcomeStore(config, {"a": a, "b": b}), 0)
    assert added == [21.0, 22.0, 23.0, 24.0, 26.0, 27.0, 28.0, 29.0, 31.0, 32.0, 33.0, 34.0]
    # added to the sweep's points, in order; the grid's points keep their identities
    grid = {v: p.identity() for v, p in config.sweep_points(0)}
    refined = config.with_refinement(0, added)
    points = refined.sweep_points(0)
    assert [v for v, _ in points] == sorted([*grid, *added])
    assert all(p.identity() == grid[v] for v, p in points if v in grid)
    assert len({p.identity() for _, p in points}) == len(points)
    assert refined.refinement(0) == added
    # the config refined is a copy: the one it came from keeps its grid
    assert config.refinement(0) == [] and [v for v, _ in config.sweep_points(0)] == list(grid)


def test_a_threshold_beyond_the_grid_adds_nothing_and_too_many_points_are_refused():
    config = _config(refine={"step": 1.0})
    never = {v: np.zeros(40) for v in (20.0, 25.0, 30.0, 35.0)}
    always = {v: np.ones(40) for v in (20.0, 25.0, 30.0, 35.0)}
    assert refined_values(config, OutcomeStore(config, {"a": never, "b": always}), 0) == []
    tight = _config(refine={"step": 0.5, "max_points": 5})
    a = {20.0: np.ones(40), 25.0: np.ones(40), 30.0: np.zeros(40), 35.0: np.zeros(40)}
    with pytest.raises(ConfigError, match=r"sweeps\[0\].refine: 9 points .* exceed max_points = 5"):
        refined_values(tight, OutcomeStore(tight, {"a": a, "b": a}), 0)


def test_refine_needs_a_threshold_and_a_step_below_the_grid_spacing():
    with pytest.raises(Exception, match="refine adds points around a threshold"):
        _config(refine={"step": 1.0}, threshold=False)
    with pytest.raises(Exception, match=r"refine.step = 5 must be smaller than the grid's spacing \(5\)"):
        _config(refine={"step": 5.0})
    with pytest.raises(Exception, match="step"):
        _config(refine={"step": -1.0})


@pytest.mark.slow
def test_a_comparison_runs_the_added_points_for_every_candidate_and_resumes(tmp_path):
    """A tiny refined sweep: the added points are in the report and the tables, every
    candidate ran them on the same runs, and the same command again runs nothing and adds
    the same points."""
    from gnssframework.experiments.runner import run_comparison

    threshold = {"metric": "loss_of_lock", "level": 0.5, "bootstrap": 200}
    config = ComparisonConfig.model_validate(tiny_threshold(threshold, refine={"step": 2.5}))
    batches = []
    summary = json.loads(run_comparison(config, tmp_path / "out", progress=False, on_batch=batches.append).read_text())
    sweep = summary["sweeps"][0]
    added = sweep["refined"]
    assert added and all(15.0 < v < 45.0 and v % 2.5 == 0 for v in added)
    assert sweep["values"] == sorted([15.0, 30.0, 45.0, *added])
    # every added point ran every candidate: 2 candidates x (3 grid + added) points (the
    # comparison itself, at 30 dB-Hz, is the grid's point 30: the same runs, run once)
    assert len(batches) == 2 * (3 + len(added))
    for cand in (0, 1):
        ran = {t.point for t in batches if t.candidate_index == cand}
        assert {f"cn0={v}" for v in added} <= ran, ran
    thr = sweep["threshold"]
    assert thr["values"] == sweep["values"]
    for row in thr["cases"][0]["rows"]:
        assert len(row["curve"]) == len(sweep["values"]) and all(c is not None for c in row["curve"])
    assert "Refined: " in (tmp_path / "out" / "report.md").read_text()
    # the same command again: nothing runs, the same points are added (the config passed in
    # was not changed by the first run: it is refined again from the store)
    assert config.refinement(0) == []
    again = []
    summary2 = json.loads(run_comparison(config, tmp_path / "out", progress=False, on_batch=again.append).read_text())
    assert again == [] and summary2["sweeps"][0]["refined"] == added
    assert summary2["sweeps"][0]["threshold"] == thr
