"""Which report figures a comparison draws: every one by default, those a filter accepts,
none with ``compare --no-plots`` (the docs' figure script and CI use this)."""

from __future__ import annotations

import hashlib
import json

import pytest

from gnssframework.cli import main
from gnssframework.experiments import load_config, run_comparison
from tests.two_candidates import two_candidate_config

SWEEP = """
[[sweeps]]
path = "scenario.epochs"
values = [30, 40]
"""


def _pngs(out):
    return sorted(p.name for p in (out / "plots").glob("*.png"))


def _digest(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.mark.slow
def test_a_filter_draws_only_the_figures_it_accepts(tmp_path):
    path = tmp_path / "c.toml"
    path.write_text(two_candidate_config("figs", sweeps=SWEEP))
    config = load_config(path)
    every = run_comparison(config, tmp_path / "all", progress=False)
    drawn = _pngs(every.parent)
    # The case's series and CDF, the sweep's plot and its paired plot.
    assert drawn == ["only-cdf.png", "only-series.png", "sweep-epochs-only-paired.png", "sweep-epochs-only.png"]
    asked = []
    some = run_comparison(
        config, tmp_path / "some", progress=False, figures=lambda name: asked.append(name) or name.endswith("-cdf.png")
    )
    assert _pngs(some.parent) == ["only-cdf.png"] and sorted(asked) == drawn  # every figure is asked about
    # The filter changes no number and no report line.
    assert json.loads(some.read_text())["rows"] == json.loads(every.read_text())["rows"]
    assert (some.parent / "report.md").read_text() == (every.parent / "report.md").read_text()


@pytest.mark.slow
def test_compare_no_plots_then_plots_from_the_store(tmp_path, capsys):
    path = tmp_path / "c.toml"
    path.write_text(two_candidate_config("noplots"))
    out = tmp_path / "o"
    assert main(["compare", str(path), "--out", str(out), "--quiet", "--no-plots"]) == 0
    assert capsys.readouterr().out.splitlines()[-1].endswith("report.md")  # no plots/ announced
    assert (out / "summary.json").exists() and (out / "report.md").exists() and _pngs(out) == []
    store = _digest(out / "results.sqlite")
    assert main(["compare", str(path), "--out", str(out), "--quiet"]) == 0
    assert _pngs(out) == ["only-cdf.png", "only-series.png"]
    assert _digest(out / "results.sqlite") == store  # resumed: no batch rerun, the store unchanged
