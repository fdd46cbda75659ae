"""examples/vector_tracking_smoothed.toml (``scenario.smoothed = true``), run shortened: the
RTS-smoothed estimates of the vector loop's nav filter against its filtered ones on the same
runs, a paired difference run by run.

The smoothed estimate conditions on every measurement, the filtered one on those up to its
epoch, so for a filter whose model is the truth's the smoothed mean square error is the
lower in expectation (the smoothed covariance is at most the filtered, Särkkä 2013, ch. 8).
The example states it as claims between two metrics of its candidate (``versus_metric``):
the paired 95 % t-interval of (smoothed - filtered) position and velocity RMSE below zero.
The test judges those claims with the library's claim checker (what ``compare --check``
runs) in each case, holds their evidence to the paired differences computed here from the
store, and the smoothed NEES finite. 3 s instead of 8, 12 runs (the example's count).
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

from gnssframework.experiments import load_config, run_comparison
from gnssframework.experiments.stats import paired_difference
from gnssframework.experiments.store import ResultStore
from gnssframework.io.files import loads_strict

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "vector_tracking_smoothed.toml"


@pytest.mark.slow
def test_the_smoothed_example_beats_its_filtered_estimates_run_by_run(tmp_path):
    scenario = tomllib.loads(EXAMPLE.read_text())["scenario"]
    runs = 12
    config = load_config(
        EXAMPLE, runs=runs, batch_size=runs, scenario={**scenario, "duration_s": 3.0, "steady_state_s": 2.0}
    )
    assert config.scenario["smoothed"] is True
    out = tmp_path / "out"
    summary = loads_strict(run_comparison(config, out, progress=False).read_text())
    assert {r["runs"] for r in summary["rows"]} == {runs}  # every metric defined in every run
    store = ResultStore(out / "results.sqlite")
    candidate, key = config.candidates[0].name, config.identity()
    claims = summary["claims"]
    cases = [c.name for c in config.cases]
    pairs = [
        ("position_smoothed_error_rmse", "position_error_rmse"),
        ("velocity_smoothed_error_rmse", "velocity_error_rmse"),
    ]
    assert [(c.metric, c.versus_metric, c.direction) for c in config.claims] == [(*p, "lower") for p in pairs]
    assert [(c["case"], c["metric"], c["versus_metric"]) for c in claims] == [
        (case, *p) for p in pairs for case in cases
    ]
    for row in claims:
        case, smoothed, filtered = row["case"], row["metric"], row["versus_metric"]
        f = store.values(key, case, candidate, filtered, runs)
        s = store.values(key, case, candidate, smoothed, runs)
        assert f.shape == s.shape == (runs,)
        d = paired_difference(s, f)
        lo, hi = d.ci95
        assert row["n"] == d.n == runs and row["diff"] == pytest.approx(d.diff) and row["se"] == pytest.approx(d.se)
        assert row["outcome"] == "holds" and hi < 0, (
            f"{case}: {smoothed} - {filtered} = {d.diff:.3g} [{lo:.3g}, {hi:.3g}] -> {row['outcome']}"
        )
    for case in cases:
        assert np.all(np.isfinite(store.values(key, case, candidate, "nees_position_smoothed", runs)))
