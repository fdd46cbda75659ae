"""Thresholds along a sweep: interpolation, Wilson interval, and bootstrap coverage of a known threshold."""

import math

import numpy as np
import pytest

from gnssframework.experiments.threshold import bootstrap_thresholds, crossing, wilson
from tests.threshold_configs import CaseOutcomeStore, OutcomeStore, constructed, tiny_threshold


def test_crossing_interpolates_from_the_top_and_marks_out_of_grid_curves():
    x = np.array([15.0, 20.0, 25.0, 30.0])
    assert crossing(x, np.array([1.0, 0.8, 0.2, 0.0]), 0.5) == pytest.approx(22.5)
    # not monotone: the highest crossing counts
    assert crossing(x, np.array([1.0, 0.2, 0.6, 0.0]), 0.5) == pytest.approx(25.0 + 5 * 0.1 / 0.6)
    assert crossing(x, np.array([0.4, 0.1, 0.0, 0.0]), 0.5) == -np.inf
    assert crossing(x, np.array([1.0, 1.0, 0.9, 0.5]), 0.5) == np.inf
    # vectorised over curves on axis 1
    both = crossing(x, np.array([[1.0, 0.4], [0.8, 0.1], [0.2, 0.0], [0.0, 0.0]]), 0.5)
    np.testing.assert_allclose(both, [22.5, -np.inf])


def test_wilson_interval_matches_its_closed_form():
    lo, hi = wilson(0.5, 100)
    z = 1.959964
    half = z * math.sqrt(0.25 / 100 + z * z / 40000) / (1 + z * z / 100)
    assert (lo, hi) == pytest.approx((0.5 - half, 0.5 + half))
    assert wilson(0.0, 20)[0] == 0.0 and 0.1 < wilson(0.0, 20)[1] < 0.2  # 0.161 for 0 of 20


def test_paired_bootstrap_interval_covers_a_known_threshold():
    """Outcomes drawn from p(x) = 1 / (1 + exp((x - 25) / 2)) (threshold 25 at level 0.5) on a
    5-point grid: the 95 % percentile interval covers the threshold of the *interpolated
    true curve* in about 95 % of 120 replications (at least 85 %: the binomial 1 % tail)."""
    x = np.array([15.0, 20.0, 25.0, 30.0, 35.0])
    p = 1 / (1 + np.exp((x - 25.0) / 2.0))
    truth = float(crossing(x, p, 0.5))
    rng = np.random.default_rng(2)
    covered = 0
    reps = 120
    for _ in range(reps):
        u = rng.random((x.size, 60))  # one uniform per run and point, shared by both candidates
        a = (u < p[:, None]).astype(float)
        shift = 1 / (1 + np.exp((x - 22.0) / 2.0))  # candidate b: 3 dB lower threshold
        b = (u < shift[:, None]).astype(float)
        out = bootstrap_thresholds(x, {"a": a, "b": b}, 0.5, 400, rng)
        est, lo, hi = out["threshold"]["a"]
        covered += lo <= truth <= hi
    assert covered >= 0.85 * reps, covered
    # paired differences: b's threshold is below a's in every resample here
    d = out["samples"]["b"] - out["samples"]["a"]
    assert np.all(d < 0)


def _config(claims, fit="linear"):
    from gnssframework.experiments.config import ComparisonConfig

    threshold = {"metric": "loss_of_lock", "level": 0.5, "bootstrap": 500, "fit": fit}
    return ComparisonConfig.model_validate(constructed(threshold=threshold, claims=claims))


def _claim(**judgement):
    """A threshold claim of candidate b against a along sweep cn0."""
    return {"candidate": "b", "reference": "a", "metric": "loss_of_lock", "sweep": "cn0", **judgement}


def test_threshold_claims_are_checked_from_the_paired_bootstrap():
    from gnssframework.experiments.claims import evaluate_claims

    claims = [
        _claim(threshold="lower"),
        _claim(threshold_difference=[-7.0, -3.0]),
        _claim(threshold="higher"),
        _claim(threshold_difference=[-4.9, -4.8]),
    ]
    config = _config(claims)
    rng = np.random.default_rng(0)
    u = rng.random(40)
    # a: lost below 30 (every run at 20, 25; at 30 the runs with u < 0.2); b: 5 dB better
    a = {20.0: np.ones(40), 25.0: np.ones(40), 30.0: (u < 0.2) * 1.0, 35.0: np.zeros(40)}
    b = {20.0: np.ones(40), 25.0: (u < 0.2) * 1.0, 30.0: np.zeros(40), 35.0: np.zeros(40)}
    rows = evaluate_claims(config, OutcomeStore(config, {"a": a, "b": b}))
    # both crossings interpolate from 1.0 to p = mean(u < 0.2) over 5 dB on the same runs: in
    # every paired resample the difference is exactly -5 dB, so [-4.9, -4.8] fails
    assert [r["outcome"] for r in rows] == ["holds", "holds", "fails", "fails"]
    assert rows[0]["threshold_difference"] == pytest.approx(-5.0)
    assert rows[0]["threshold_ci95"] == pytest.approx([-5.0, -5.0])


def test_fitted_thresholds_reach_the_claims_and_the_report():
    """``fit = "logistic"``: the report's rows carry the fit, a separated curve's interval is
    its grid interval, and a claim against it is judged on the widened difference."""
    from gnssframework.experiments.claims import evaluate_claims
    from gnssframework.experiments.threshold import threshold_markdown, threshold_rows

    claims = [
        _claim(threshold="lower"),
        # a's curve is separated in [25, 30] and b's crosses near 25: the difference's
        # interval must reach from about -5 to 0, so a claim of [-4.9, -0.1] cannot hold
        _claim(threshold_difference=[-4.9, -0.1]),
    ]
    config = _config(claims, fit="logistic")
    u = np.random.default_rng(0).random(40)
    a = {20.0: np.ones(40), 25.0: np.ones(40), 30.0: np.zeros(40), 35.0: np.zeros(40)}
    b = {20.0: np.ones(40), 25.0: (u < 0.5) * 1.0, 30.0: np.zeros(40), 35.0: np.zeros(40)}
    store = OutcomeStore(config, {"a": a, "b": b})
    report = threshold_rows(config, store, 0)
    rows = {r["candidate"]: r for r in report["cases"][0]["rows"]}
    assert report["fit"] == "logistic"
    assert rows["a"]["fit"]["separated"] and rows["a"]["ci95"] == [25.0, 30.0]
    assert not rows["b"]["fit"]["separated"] and 20.0 < rows["b"]["threshold"] < 30.0
    lo, hi = rows["b"]["difference"]["ci95"]
    assert lo <= rows["b"]["ci95"][0] - 30.0 and hi >= rows["b"]["ci95"][1] - 25.0
    outcomes = [r["outcome"] for r in evaluate_claims(config, store)]
    assert outcomes[1] != "holds"
    text = "\n".join(threshold_markdown(config, report))
    assert "Firth-penalised logistic" in text and "separated in [25, 30]" in text


def test_the_best_link_reaches_the_report_and_the_plot(tmp_path):
    """``fit = "best"``: each row names its curve's link, every link's deviance (the chosen
    one the smallest) and the share of resamples that chose each; the markdown says so and
    the plot draws the chosen link's curve (its pixels differ from the logistic one's)."""
    from gnssframework.experiments.threshold import plot_threshold, threshold_markdown, threshold_rows
    from gnssframework.experiments.threshold_fit import LINKS

    config = _config([], fit="best")
    u = np.random.default_rng(3).random((4, 40))
    # a: a Gumbel-like fall (fast from 1, slow to 0); b: shifted down by 5 dB
    a = {20.0: (u[0] < 0.99) * 1.0, 25.0: (u[1] < 0.6) * 1.0, 30.0: (u[2] < 0.25) * 1.0, 35.0: (u[3] < 0.1) * 1.0}
    b = {20.0: (u[0] < 0.6) * 1.0, 25.0: (u[1] < 0.25) * 1.0, 30.0: (u[2] < 0.1) * 1.0, 35.0: (u[3] < 0.04) * 1.0}
    report = threshold_rows(config, OutcomeStore(config, {"a": a, "b": b}), 0)
    for row in report["cases"][0]["rows"]:
        fit = row["fit"]
        assert fit["link"] in LINKS and set(fit["deviances"]) == set(LINKS)
        assert fit["deviances"][fit["link"]] == min(fit["deviances"].values())
        assert fit["deviance"] == pytest.approx(fit["deviances"][fit["link"]])
        assert sum(fit["resample_links"].values()) == pytest.approx(1.0)
    text = "\n".join(threshold_markdown(config, report))
    assert "smallest deviance" in text and "resamples: " in text
    entry = report["cases"][0]
    sweep = {"path": "cases.cn0_dbhz", "rows": []}
    plot_threshold(tmp_path / "best.png", config, report, entry, sweep)
    for row in entry["rows"]:
        row["fit"]["link"] = "logistic" if row["fit"]["link"] != "logistic" else "cloglog"
    plot_threshold(tmp_path / "other.png", config, report, entry, sweep)
    assert (tmp_path / "best.png").read_bytes() != (tmp_path / "other.png").read_bytes()


def test_an_unknown_fit_is_refused_naming_the_field():
    with pytest.raises(Exception, match="fit"):
        _config([], fit="weibull")


def test_threshold_claims_refuse_a_sweep_without_a_threshold_table():
    from gnssframework.errors import ConfigError

    with pytest.raises(ConfigError, match="claims\\[0\\].metric"):
        _config(
            [{"candidate": "b", "reference": "a", "metric": "cycle_slip_rate", "sweep": "cn0", "threshold": "lower"}]
        )
    with pytest.raises(Exception, match="reference"):
        _config([{"candidate": "b", "metric": "loss_of_lock", "sweep": "cn0", "threshold": "lower"}])


@pytest.mark.slow
def test_a_comparison_writes_its_thresholds_plot_and_claims(tmp_path):
    import json

    from gnssframework.experiments.config import ComparisonConfig
    from gnssframework.experiments.runner import run_comparison

    threshold = {
        "metric": "loss_of_lock",
        "level": 0.5,
        "bootstrap": 200,
        "time_metric": "time_to_loss_s",
        "plot_metrics": ["cycle_slip_rate"],
    }
    claim = {"candidate": "narrow", "reference": "wide", "metric": "loss_of_lock", "sweep": "cn0"}
    config = ComparisonConfig.model_validate(
        tiny_threshold(threshold) | {"claims": [claim | {"threshold_difference": [-20.0, 20.0]}]}
    )
    summary = json.loads(run_comparison(config, tmp_path / "out", progress=False).read_text())
    thr = summary["sweeps"][0]["threshold"]
    rows = {r["candidate"]: r for r in thr["cases"][0]["rows"]}
    # every run loses lock at 15 dB-Hz and none at 45: both thresholds lie inside the grid
    for row in rows.values():
        assert row["curve"][0]["p"] == 1.0 and row["curve"][-1]["p"] == 0.0
        assert 15.0 < row["threshold"] < 45.0
        assert row["curve"][-1]["km_restricted_mean"] == pytest.approx(1.5)  # never lost: the span
    assert (tmp_path / "out" / "plots" / "threshold-cn0-static.png").stat().st_size > 0
    assert (tmp_path / "out" / "sweeps" / "cn0-threshold.json").is_file()
    assert "Thresholds along sweep" in (tmp_path / "out" / "report.md").read_text()
    assert [c["outcome"] for c in summary["claims"]] == ["holds"]


def _two_case_config(claims):
    from gnssframework.experiments.config import ComparisonConfig

    cases = [
        {"name": "one", "cn0_dbhz": 30.0},
        {"name": "three", "cn0_dbhz": 30.0, "streams": "one", "cn0_lock_consecutive": 3},
    ]
    threshold = {"metric": "loss_of_lock_by_cn0", "level": 0.5, "bootstrap": 500}
    return ComparisonConfig.model_validate(constructed(threshold=threshold, cases=cases, claims=claims))


def test_threshold_claims_between_cases_pair_the_same_runs():
    """A candidate's threshold in one case against its own (or another candidate's) in a
    reference case: the resamples pair run by run, so a curve shifted by exactly one grid
    step on the same runs differs by exactly -5 dB in every resample."""
    from gnssframework.experiments.claims import evaluate_claims

    claims = [
        {"candidate": "a", "metric": "loss_of_lock_by_cn0", "sweep": "cn0", "case": "three"}
        | {"reference_case": "one", "threshold": "lower", "threshold_difference": [-5.5, -4.5]},
        {"candidate": "a", "metric": "loss_of_lock_by_cn0", "sweep": "cn0", "case": "three"}
        | {"reference_case": "one", "threshold_difference": [-4.9, -4.8]},
        {"candidate": "a", "reference": "b", "metric": "loss_of_lock_by_cn0", "sweep": "cn0"}
        | {"case": "three", "reference_case": "one", "threshold": "higher"},
    ]
    config = _two_case_config(claims)
    u = np.random.default_rng(0).random(40)
    one = {20.0: np.ones(40), 25.0: np.ones(40), 30.0: (u < 0.6) * 1.0, 35.0: np.zeros(40)}
    three = {20.0: np.ones(40), 25.0: (u < 0.6) * 1.0, 30.0: np.zeros(40), 35.0: np.zeros(40)}
    low = {20.0: np.ones(40), 25.0: np.zeros(40), 30.0: np.zeros(40), 35.0: np.zeros(40)}  # crosses at 22.5
    store = CaseOutcomeStore(config, {"one": {"a": one, "b": low}, "three": {"a": three, "b": low}})
    rows = evaluate_claims(config, store)
    assert [r["outcome"] for r in rows] == ["holds", "fails", "holds"]
    assert rows[0]["threshold_difference"] == pytest.approx(-5.0)
    assert rows[0]["threshold_ci95"] == pytest.approx([-5.0, -5.0])
    assert rows[0]["reference"] == "a" and rows[0]["reference_case"] == "one"
    assert "threshold of loss_of_lock_by_cn0 along cn0 lower than a's in one" in rows[0]["statement"]
    # a in three against b in one (22.5)
    x = np.array([20.0, 25.0, 30.0, 35.0])
    a_three = float(crossing(x, np.array([three[v].mean() for v in x]), 0.5))
    assert 20.0 < a_three < 30.0 and rows[2]["threshold_difference"] == pytest.approx(a_three - 22.5)


def test_threshold_claims_between_cases_are_refused_where_they_cannot_be_read():
    with pytest.raises(Exception, match="case and reference_case are both 'one'"):
        _two_case_config(
            [
                {"candidate": "a", "metric": "loss_of_lock_by_cn0", "sweep": "cn0", "case": "one"}
                | {"reference_case": "one", "threshold": "lower"}
            ]
        )
    with pytest.raises(Exception, match="reference_case"):
        _two_case_config(
            [
                {"candidate": "a", "metric": "loss_of_lock_by_cn0", "sweep": "cn0", "reference_case": "nowhere"}
                | {"threshold": "lower"}
            ]
        )
    with pytest.raises(Exception, match="the reference must be another candidate"):
        _two_case_config(
            [
                {
                    "candidate": "a",
                    "reference": "a",
                    "metric": "loss_of_lock_by_cn0",
                    "sweep": "cn0",
                    "threshold": "lower",
                }
            ]
        )


def test_a_threshold_difference_between_cases_of_other_runs_is_refused():
    """Two cases whose common runs differ cannot pair resample by resample: refused."""
    from gnssframework.experiments.threshold import difference_interval, threshold_rows

    config = _two_case_config([])
    u = np.random.default_rng(0).random(40)
    curve = {20.0: np.ones(40), 25.0: (u < 0.6) * 1.0, 30.0: np.zeros(40), 35.0: np.zeros(40)}

    class _Fewer(CaseOutcomeStore):
        def run_values(self, key, case, candidate, metric, runs):
            values = super().run_values(key, case, candidate, metric, runs)
            return {r: v for r, v in values.items() if case == "one" or r < 30}  # case three: 30 runs

    store = _Fewer(config, {"one": {"a": curve, "b": curve}, "three": {"a": curve, "b": curve}})
    report = threshold_rows(config, store, 0)
    with pytest.raises(ValueError, match="between cases 'three' and 'one': their runs differ \\(30 against 40"):
        difference_interval(report, "three", "a", "a", "one")
