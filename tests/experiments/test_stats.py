"""Paired statistics: hand-computed values, paired vs unpaired SE, common random numbers in the runner."""

from __future__ import annotations

import json
import types

import numpy as np
import pytest
from pydantic import Field

import gnssframework as gf
from gnssframework.errors import ConfigError
from gnssframework.experiments import load_config, run_comparison
from gnssframework.experiments.config import ComparisonConfig
from gnssframework.experiments.report import write_report
from gnssframework.experiments.scenarios import BatchResult, Scenario, ScenarioParams
from gnssframework.experiments.stats import paired_difference
from gnssframework.experiments.store import ResultStore
from two_candidates import two_candidate_config

X = np.array([1.0, 2.0, 3.0, 4.0])
Y = np.array([0.5, 1.5, 2.0, 3.5])
# By hand: d = [0.5, 0.5, 1, 0.5]; mean 0.625; deviations [-1/8, -1/8, 3/8, -1/8], sum of squares
# 3/64 + 9/64 = 12/64, var 1/16, std 1/4, SE 1/8. t(0.975, 3) = 3.182 (Student's table).
# Ratio of means 2.5 / 1.875 = 4/3; var x = 5/3, var y = 4.6875/3 = 1.5625, cov = 4.75/3;
# var(x - R y) = 5/3 - 2 (4/3)(4.75/3) + (16/9) 1.5625 = 2/9; ratio SE = sqrt(2/9) / (1.875 * 2).


def test_paired_difference_matches_hand_computed_values():
    pd = paired_difference(X, Y)
    assert pd.n == 4
    assert pd.diff == pytest.approx(0.625)
    assert pd.se == pytest.approx(0.125)
    assert pd.ci95[0] == pytest.approx(0.625 - 3.182 * 0.125, abs=1e-3)
    assert pd.ci95[1] == pytest.approx(0.625 + 3.182 * 0.125, abs=1e-3)
    assert pd.significant
    assert pd.ratio == pytest.approx(4 / 3)
    assert pd.ratio_se == pytest.approx(np.sqrt(2 / 9) / 3.75)


def test_significance_follows_the_t_interval_not_two_se():
    # d = [1, -0.5, 1, 0.5]: mean 0.5, std sqrt(0.5), SE 0.3536; |d|/SE = 1.41 < t(0.975,3).
    pd = paired_difference(np.array([2.0, 0.5, 2.0, 1.5]), np.ones(4))
    assert pd.diff == pytest.approx(0.5) and pd.se == pytest.approx(np.sqrt(0.5) / 2)
    assert not pd.significant
    # With 100 pairs the same |d| / SE of 2.1 is significant (t(0.975, 99) = 1.984).
    d = np.tile([1.0, -1.0], 50)
    d = d + 2.1 * d.std(ddof=1) / np.sqrt(100)  # mean shifted to 2.1 SE
    assert paired_difference(d, np.zeros(100)).significant


def test_undefined_runs_are_left_out_and_reported_without_nan():
    x = np.array([1.0, np.nan, 3.0])
    y = np.array([0.0, 1.0, np.inf])
    pd = paired_difference(x, y)
    assert pd.n == 1 and pd.diff == 1.0 and pd.se is None and not pd.significant and pd.reason
    assert json.dumps(pd.to_json(), allow_nan=False)
    empty = paired_difference(np.array([np.nan]), np.array([1.0]))
    assert empty.n == 0 and empty.diff is None and empty.reason


def test_ratio_only_for_non_negative_metrics():
    assert paired_difference(np.array([-1.0, 2.0, 3.0]), np.array([1.0, 2.0, 2.5])).ratio is None


def test_paired_se_is_smaller_than_unpaired_when_runs_are_correlated():
    rng = np.random.default_rng(3)
    n = 400
    common = 5.0 * rng.standard_normal(n)  # what both candidates see (common random numbers)
    x = 10 + common + 0.3 * rng.standard_normal(n)
    y = 9.8 + common + 0.3 * rng.standard_normal(n)
    pd = paired_difference(x, y)
    unpaired_se = np.sqrt(x.var(ddof=1) / n + y.var(ddof=1) / n)
    # Theory: paired SE = sqrt(2 * 0.3^2 / n) = 0.0212; unpaired = sqrt(2 (25 + 0.09) / n) = 0.354.
    assert pd.se == pytest.approx(np.sqrt(2 * 0.09 / n), rel=0.15)
    assert unpaired_se == pytest.approx(np.sqrt(2 * 25.09 / n), rel=0.15)
    assert pd.se < unpaired_se / 10
    # The 0.2 offset is found by the paired test, not by the unpaired one.
    assert pd.significant and abs(np.mean(x) - np.mean(y)) < 2 * unpaired_se


def _config(tmp_path, reference=""):
    path = tmp_path / "c.toml"
    path.write_text(two_candidate_config("synthetic", top=reference))
    return load_config(path)


def test_summary_and_report_carry_the_hand_computed_paired_statistics(tmp_path):
    config = _config(tmp_path, 'reference = "b"')
    store = ResultStore(tmp_path / "results.sqlite")
    key = config.identity()
    store.register(key, config.batch_size)
    for name, values in (("a", X), ("b", Y)):
        for batch in range(2):
            metrics = {m: values[2 * batch : 2 * batch + 2] for m in config.metric_names}
            store.add_batch(key, "only", name, 2 * batch, metrics)
    summary = json.loads(write_report(config, store, tmp_path).read_text())
    assert summary["reference"] == "b"
    row = next(r for r in summary["paired"] if r["metric"] == "lat_error_rmse")
    assert (row["candidate"], row["reference"], row["n"]) == ("a", "b", 4)
    assert row["diff"] == pytest.approx(0.625) and row["se"] == pytest.approx(0.125)
    assert row["ratio"] == pytest.approx(4 / 3) and row["significant"] is True
    assert len(summary["paired"]) == len(config.metric_names)  # the reference is not paired with itself
    report = (tmp_path / "report.md").read_text()
    # n is stated once in the paired table's header, not in every cell (all four runs paired).
    assert "Paired differences to `b`" in report and "| +0.62 ± 0.12 **\\*** |" in report
    # The ratio of means in a table of its own (4/3; delta-method SE 0.13), not in the cell.
    ratios = report.split("Ratios of means to `b`")[1]
    assert "| ×1.33 ± 0.13 |" in ratios and "(×" not in report
    assert "the n = 4 common-random-number runs" in report
    # The first table is mean ± standard error over runs (X: 2.5, standard deviation
    # sqrt(5/3) = 1.291, SE 1.291 / sqrt(4) = 0.645), and the header says so, as the docs'
    # tables do. Half-even rounding: 0.625 -> 0.62, 0.125 -> 0.12.
    assert "| 2.50 ± 0.65 |" in report and "Every ± is a standard error" in report
    assert "± 1.29" not in report


def test_reference_defaults_to_the_first_candidate_and_is_validated(tmp_path):
    assert _config(tmp_path).reference_name == "a"
    with pytest.raises(ConfigError) as err:
        _config(tmp_path, 'reference = "c"')
    assert err.value.field == "reference" and "'c'" in str(err.value) and "a, b" in str(err.value)


# -- common random numbers in the runner ----------------------------------------------------


class _DrawsParams(ScenarioParams):
    sigma: float = Field(1.0, gt=0)


class DrawsScenario(Scenario):
    """Per-run metric = the run's draws plus an offset set by the estimator's name: with
    common random numbers every candidate's draws are the same, run by run."""

    kind = "test-draws"
    Params = _DrawsParams
    CaseParams = _DrawsParams
    components = {"estimator": True}
    metrics = {"value": "-", "first_draw": "-"}

    def run_batch(self, case, plugins, runs, rng):
        z = rng.standard_normal(runs)
        offset = {"kf": 0.0, "ukf": 0.25}.get(plugins["estimator"].name, 1.0)
        return BatchResult({"value": 10 + case.get("sigma", 1.0) * z + offset, "first_draw": z})


@pytest.fixture
def draws_scenario(scratch_registry):
    module = types.SimpleNamespace(register_scenario=gf.hookimpl(lambda register: register(DrawsScenario)))
    scratch_registry.register_module(module, "test-draws")
    return DrawsScenario


DRAWS = """
runs = 6
batch_size = 4
seed = 11
[executor]
workers = 1
[scenario]
kind = "test-draws"
[[cases]]
name = "x"
sigma = 3.0
[[cases]]
name = "y"
[[candidates]]
name = "kf"
estimator = { name = "kf" }
[[candidates]]
name = "ukf"
estimator = { name = "ukf" }
[[candidates]]
name = "ckf"
estimator = { name = "ckf" }
"""


@pytest.mark.slow
def test_runner_gives_every_candidate_the_same_draws_run_by_run(tmp_path, draws_scenario):
    path = tmp_path / "d.toml"
    path.write_text(DRAWS)
    config = load_config(path)
    summary = json.loads(run_comparison(config, tmp_path / "out", progress=False).read_text())
    store = ResultStore(tmp_path / "out" / "results.sqlite")
    key = config.identity()
    for case in ("x", "y"):
        draws = [store.values(key, case, c, "first_draw", 6) for c in ("kf", "ukf", "ckf")]
        assert draws[0].size == 6 and np.array_equal(draws[0], draws[1]) and np.array_equal(draws[0], draws[2])
    # ... and different cases, batches and runs draw differently.
    x, y = (store.values(key, c, "kf", "first_draw", 6) for c in ("x", "y"))
    assert np.unique(np.concatenate([x, y])).size == 12
    paired = {(r["case"], r["candidate"], r["metric"]): r for r in summary["paired"]}
    ukf = paired[("x", "ukf", "value")]
    # The same difference in every run: no spread, so no t-test and nothing called significant.
    assert ukf["diff"] == pytest.approx(0.25) and ukf["se"] == 0.0 and not ukf["significant"]
    assert "no spread" in ukf["reason"]
    assert paired[("y", "ckf", "value")]["diff"] == pytest.approx(1.0)


@pytest.mark.slow
def test_common_random_numbers_in_the_vector_tracking_scenario(tmp_path):
    """Two candidates identical but for their name get identical numbers run by run (the
    scenario draws nothing that depends on the candidate)."""
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
name = "one"
channel_filter = { name = "discriminator" }
nav_filter = { name = "ekf-pv" }
[[candidates]]
name = "two"
channel_filter = { name = "discriminator" }
nav_filter = { name = "ekf-pv" }
"""
    path = tmp_path / "v.toml"
    path.write_text(text)
    config = load_config(path)
    summary = json.loads(run_comparison(config, tmp_path / "out", progress=False).read_text())
    # A metric without pairs must be one the scenario declares optional, undefined in every
    # run for the reason it gives (the smoothed ones here: smoothed = false); the rest pair.
    from gnssframework.experiments.scenarios.vector_tracking import METRICS, VectorTrackingScenario

    optional = {c.name for c in METRICS if c.optional}
    runs = {(r["candidate"], r["metric"]): r for r in summary["rows"]}
    unpaired = {r["metric"] for r in summary["paired"] if r["n"] == 0}
    assert unpaired and unpaired <= optional
    for name in unpaired:
        for candidate in ("one", "two"):
            row = runs[(candidate, name)]
            assert row["runs"] == 0 and row["undefined"] == VectorTrackingScenario.undefined_reasons[name], row
    for r in summary["paired"]:
        if r["metric"] not in unpaired:
            assert r["n"] == 2 and r["diff"] == 0.0 and r["significant"] is False


def test_comparison_config_has_reference_in_schema():
    assert "reference" in ComparisonConfig.model_json_schema()["properties"]


def test_paired_difference_agrees_with_scipys_paired_t_test():
    """scipy.stats.ttest_rel as an independent oracle: same interval, and significant
    exactly when its two-sided p-value is below 0.05."""
    from scipy import stats as sps

    rng = np.random.default_rng(8)
    seen = set()
    for _trial in range(200):
        n = int(rng.integers(2, 40))
        common = rng.standard_normal(n) * 3
        x = 5 + common + rng.standard_normal(n)
        y = 5 + common + rng.standard_normal(n) + rng.uniform(-1, 1) * 2 / np.sqrt(n)
        pd = paired_difference(x, y)
        test = sps.ttest_rel(x, y)
        lo, hi = test.confidence_interval(0.95)
        assert pd.ci95 == pytest.approx((lo, hi), rel=1e-9, abs=1e-12)
        assert pd.significant == (test.pvalue < 0.05)
        seen.add(pd.significant)
    assert seen == {True, False}  # both outcomes were exercised


def test_swapping_candidate_and_reference_negates_the_difference():
    rng = np.random.default_rng(9)
    x, y = rng.random(7), rng.random(7)
    a, b = paired_difference(x, y), paired_difference(y, x)
    assert a.diff == pytest.approx(-b.diff) and a.se == pytest.approx(b.se) and a.significant == b.significant
    assert a.ratio == pytest.approx(1 / b.ratio)


class ForgetfulScenario(DrawsScenario):
    kind = "test-forgetful"
    metrics = {"value": "-", "declared_only": "-"}


@pytest.mark.slow
def test_a_scenario_that_does_not_return_a_declared_metric_is_named(tmp_path, scratch_registry):
    from gnssframework.errors import GnssFrameworkError

    module = types.SimpleNamespace(register_scenario=gf.hookimpl(lambda register: register(ForgetfulScenario)))
    scratch_registry.register_module(module, "test-forgetful")
    path = tmp_path / "f.toml"
    path.write_text(DRAWS.replace('"test-draws"', '"test-forgetful"'))
    with pytest.raises(
        GnssFrameworkError, match="'test-forgetful': run_batch did not return the declared metrics declared_only"
    ):
        run_comparison(load_config(path), tmp_path / "out", progress=False)


def test_the_significance_rule_marks_five_percent_of_null_differences():
    """Monte Carlo: with no true difference, the 95 % t-interval rule marks 5 % of the
    comparisons, also with few runs (where |d| > 2 SE alone would mark about 12 % at n = 5)."""
    rng = np.random.default_rng(10)
    reps, n = 4000, 5
    common = rng.standard_normal((reps, 1)) * 4
    x = common + rng.standard_normal((reps, n))
    y = common + rng.standard_normal((reps, n))
    out = [paired_difference(x[i], y[i]) for i in range(reps)]
    rate = np.mean([p.significant for p in out])
    assert abs(rate - 0.05) < 3 * np.sqrt(0.05 * 0.95 / reps)
    two_se = np.mean([abs(p.diff) > 2 * p.se for p in out])  # P(|t_4| > 2) = 0.116
    assert abs(two_se - 0.116) < 3 * np.sqrt(0.116 * 0.884 / reps)


def test_ratio_se_matches_the_spread_of_the_ratio_over_replications():
    """Monte Carlo check of the delta-method SE of the ratio of means on correlated runs."""
    rng = np.random.default_rng(11)
    reps, n = 1500, 40
    common = rng.gamma(4.0, 1.0, (reps, n))
    x = 1.2 * common + rng.gamma(2.0, 0.3, (reps, n))
    y = common + rng.gamma(2.0, 0.3, (reps, n))
    out = [paired_difference(x[i], y[i]) for i in range(reps)]
    ratios = np.array([p.ratio for p in out])
    se = np.array([p.ratio_se for p in out])
    # The spread of the estimates and the typical predicted SE agree within 10 %
    # (the SE of a std estimate from 1500 replications is about 2 %).
    assert np.mean(se) == pytest.approx(np.std(ratios, ddof=1), rel=0.10)
