"""Claims between two metrics of one candidate (``versus_metric``): the candidate's value of
``metric`` in run ``r`` paired with its value of ``versus_metric`` in the same run.

The expected outcomes come from per-run values written into the store by hand, whose
paired differences have a sign, mean and SE known in closed form, and from scipy; the
last test runs a real comparison where the ordering holds in every run by an inequality
(an RMS is at least the mean of the absolute values)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy import stats

from gnssframework.cli import _report_claims
from gnssframework.errors import ConfigError
from gnssframework.experiments import load_config
from gnssframework.experiments.claims import claim_line, evaluate_claims
from gnssframework.experiments.report import write_report
from gnssframework.experiments.store import ResultStore
from two_candidates import claim_toml, compare_check, two_candidate_config

# Candidate a's per-run values of two metrics in metres (lat_error_rmse, lon_error_rmse):
# d = LAT - LON = (0.5, 0.5, 1.0, 0.5): mean 0.625, SD 0.25, SE 0.125, t = 5 with 3 dof,
# t(0.975, 3) = 3.182 -> 95 % interval (0.227, 1.023): lat is higher, significantly. Unpaired,
# the runs' spread (SD 1.29 and 1.25) dwarfs the difference: Welch's interval includes 0.
LAT = np.array([1.0, 2.0, 3.0, 4.0])
LON = np.array([0.5, 1.5, 2.0, 3.5])
# Candidate b's values of both metrics: far above a's, so a claim that paired a's metric with
# b's (or b's metric with a's) would come out the other way.
B = np.array([10.0, 11.0, 12.0, 13.0])


def _store(tmp_path, claims: str, lat=LAT, lon=LON):
    """``(rows, config, store)``: ``claims`` evaluated on a store holding a's ``lat`` and ``lon``
    as its lat_error_rmse and lon_error_rmse (``B`` for b, and for every other metric)."""
    path = tmp_path / "c.toml"
    path.write_text(two_candidate_config("claims", claims=claims))
    config = load_config(path)
    store = ResultStore(tmp_path / "results.sqlite")
    key = config.identity()
    store.register(key, config.batch_size)
    for name in ("a", "b"):
        own = {"lat_error_rmse": lat, "lon_error_rmse": lon} if name == "a" else {}
        for first in (0, 2):
            store.add_batch(
                key,
                "only",
                name,
                first,
                {m: np.asarray(own.get(m, B), float)[first : first + 2] for m in config.metric_names},
            )
    return evaluate_claims(config, store), config, store


def _versus(**fields) -> str:
    return claim_toml(candidate="a", metric="lat_error_rmse", versus_metric="lon_error_rmse", **fields)


def test_the_unpaired_runs_could_not_tell():
    # The premise of the pairing: Welch's 95 % interval of the difference of the two means straddles 0.
    welch = stats.ttest_ind(LAT, LON, equal_var=False)
    assert welch.pvalue > 0.05


@pytest.mark.parametrize("direction, outcome", [("higher", "holds"), ("lower", "fails")])
def test_an_ordering_between_metrics_is_decided_by_the_paired_differences(tmp_path, direction, outcome):
    (row,), _, _ = _store(tmp_path, _versus(direction=direction))
    assert row["outcome"] == outcome
    assert (row["reference"], row["versus_metric"], row["metric"]) == ("a", "lon_error_rmse", "lat_error_rmse")
    assert row["diff"] == pytest.approx(0.625) and row["se"] == pytest.approx(0.125) and row["n"] == 4
    # The one-sided p on the claimed side, doubled (capped at 1): t.sf(5) for higher, t.cdf(5) for lower.
    one_sided = stats.t.sf(5.0, 3) if direction == "higher" else stats.t.cdf(5.0, 3)
    assert row["p_value"] == pytest.approx(min(1.0, 2 * one_sided))
    assert row["statement"] == f"a: lat_error_rmse {direction} than its lon_error_rmse"


def test_an_ordering_between_metrics_the_runs_cannot_tell_is_not_significant(tmp_path):
    noisy = np.array([0.0, 2.5, 1.0, 4.4])  # d = (1.0, -0.5, 2.0, -0.4): mean 0.525, SE 0.59
    (row,), _, _ = _store(tmp_path, _versus(direction="higher"), lon=noisy)
    assert row["outcome"] == "not significant"
    assert row["diff"] == pytest.approx(0.525) and row["se"] == pytest.approx(np.std(LAT - noisy, ddof=1) / 2)


def test_a_ratio_of_the_two_metrics_uses_the_ratio_interval(tmp_path):
    # Ratio of means 2.5 / 1.75 with its delta-method SE from the paired covariance.
    c = np.cov(LAT, LON, ddof=1)
    r = LAT.mean() / LON.mean()
    se = np.sqrt(c[0, 0] - 2 * r * c[0, 1] + r**2 * c[1, 1]) / (LON.mean() * 2)
    half = stats.t.ppf(0.975, 3) * se
    for bound, outcome in ((r + 1.01 * half, "holds"), (r - 1.01 * half, "fails"), (r, "not significant")):
        (row,), _, _ = _store(tmp_path, _versus(ratio_max=float(bound)))
        assert row["outcome"] == outcome, bound
        assert row["ratio"] == pytest.approx(r) and row["ratio_se"] == pytest.approx(se)
    assert row["statement"] == f"a: lat_error_rmse / its lon_error_rmse < {r:g}"


@pytest.mark.parametrize(
    "margin, outcome",
    [
        (1.0, "holds"),  # 90 % interval 0.625 +- 2.353 * 0.125 = (0.331, 0.919) inside (-1, 1)
        (0.5, "not significant"),  # neither inside nor is the 95 % interval (0.227, 1.023) outside [-0.5, 0.5]
        (0.2, "fails"),  # the 95 % interval lies above 0.2
    ],
)
def test_an_equivalence_of_two_metrics_by_two_one_sided_tests(tmp_path, margin, outcome):
    (row,), _, _ = _store(tmp_path, _versus(equivalence_margin=margin))
    assert row["outcome"] == outcome
    d = LAT - LON
    p_tost = max(
        stats.ttest_1samp(d, margin, alternative="less").pvalue,
        stats.ttest_1samp(d, -margin, alternative="greater").pvalue,
    )
    assert row["p_value"] == pytest.approx(p_tost)
    assert row["statement"] == f"a: lat_error_rmse equivalent to its lon_error_rmse within ±{margin:g}"


@pytest.mark.parametrize("bounds, outcome", [([0.4, 1.1], "holds"), ([0.6, 1.1], "fails")])
def test_every_runs_difference_of_the_two_metrics(tmp_path, bounds, outcome):
    (row,), _, _ = _store(tmp_path, _versus(every_run_within=bounds))
    assert row["outcome"] == outcome  # d = (0.5, 0.5, 1.0, 0.5): inside [0.4, 1.1]; 0.5 is below 0.6
    assert row["statement"] == f"a: lat_error_rmse minus its lon_error_rmse in [{bounds[0]:g}, 1.1] in every run"


@pytest.mark.parametrize("test", ["bootstrap", "wilcoxon"])
def test_the_other_tests_read_the_same_pairs(tmp_path, test):
    # Every d is positive: every resample's mean is positive (bootstrap holds); Wilcoxon's exact
    # one-sided p with all 4 ranks positive is 1/16 = 0.0625 > 0.025, so it cannot hold with 4 runs,
    # and its other side (p = 1) cannot fail.
    (row,), _, _ = _store(tmp_path, _versus(direction="higher", test=test))
    assert row["outcome"] == ("holds" if test == "bootstrap" else "not significant")
    if test == "wilcoxon":
        assert row["p_value"] == pytest.approx(2 / 16)  # the one-sided 1/16, doubled to the two-sided scale


def test_the_same_values_in_every_run_are_refused_naming_the_metrics(tmp_path):
    (row,), _, _ = _store(tmp_path, _versus(direction="higher"), lon=LAT - 0.5)
    assert row["outcome"] == "refused"
    assert "lat_error_rmse minus lon_error_rmse is the same in all 4 runs" in row["reason"]


def test_a_claim_between_metrics_joins_the_examples_adjustment(tmp_path):
    # b's lat_error_rmse is LON, so a's lat minus b's lat is the same d as a's lat minus a's lon:
    # both rows have t = 5 with 3 dof, p = 2 t.sf(5, 3) = 0.0150; Holm over two equal p-values
    # adjusts both to 2 p = 0.030 < 0.05.
    claims = _versus(direction="higher") + claim_toml(
        candidate="a", reference="b", metric="lat_error_rmse", direction="higher"
    )
    path = tmp_path / "c.toml"
    path.write_text(two_candidate_config("claims", claims=claims))
    config = load_config(path)
    store = ResultStore(tmp_path / "results.sqlite")
    key = config.identity()
    store.register(key, config.batch_size)
    for name, lat, lon in (("a", LAT, LON), ("b", LON, B)):
        for first in (0, 2):
            store.add_batch(
                key,
                "only",
                name,
                first,
                {
                    m: {"lat_error_rmse": lat, "lon_error_rmse": lon}.get(m, B)[first : first + 2]
                    for m in config.metric_names
                },
            )
    rows = evaluate_claims(config, store)
    p = 2 * stats.t.sf(5.0, 3)
    for row in rows:
        assert row["p_value"] == pytest.approx(p) and row["family_size"] == 2
        assert row["p_adjusted"] == pytest.approx(2 * p) and row["holds_adjusted"] is True


def test_the_report_and_the_check_carry_a_claim_between_metrics(tmp_path, capsys):
    claims = _versus(direction="higher") + _versus(direction="lower")
    rows, config, store = _store(tmp_path, claims)
    line = claim_line(rows[0])
    assert line.startswith("holds") and "only: a: lat_error_rmse higher than its lon_error_rmse (difference" in line
    summary = write_report(config, store, tmp_path)
    assert [c["outcome"] for c in json.loads(summary.read_text())["claims"]] == ["holds", "fails"]
    report = (tmp_path / "report.md").read_text()
    assert "1 of 2 hold" in report and "| fails | only | a: lat_error_rmse lower than its lon_error_rmse |" in report
    assert _report_claims(summary, check=True) == 1  # what compare --check returns: one does not hold
    out = capsys.readouterr().out
    assert "claims: 1 of 2 hold" in out and "fails           only: a: lat_error_rmse lower than its" in out


@pytest.mark.parametrize(
    "fields, field, message",
    [
        (
            {"versus_metric": "lon_rmse", "direction": "lower"},
            "claims[0].versus_metric",
            "unknown versus_metric 'lon_rmse'; allowed: lat_error_mean",
        ),
        (
            {"versus_metric": "convergence_epoch", "direction": "lower"},
            "claims[0].versus_metric",
            "'convergence_epoch' is in 'epochs' and metric 'lat_error_rmse' in 'm'",
        ),
        (
            {"candidate": "c", "versus_metric": "lon_error_rmse", "direction": "lower"},
            "claims[0].candidate",
            "unknown candidate 'c'; allowed: a, b",
        ),
        (
            {"versus_metric": "lat_error_rmse", "direction": "lower"},
            "claims[0]",
            "versus_metric is metric 'lat_error_rmse' itself",
        ),
        ({"versus_metric": "lon_error_rmse"}, "claims[0]", "an ordering between metrics needs direction"),
        (
            {"versus_metric": "lon_error_rmse", "reference": "b", "direction": "lower"},
            "claims[0]",
            "versus_metric pairs two metrics of the candidate on its own runs; reference is a separate claim",
        ),
        ({"versus_metric": "lon_error_rmse", "within": [0, 1]}, "claims[0]", "within is a separate claim"),
        ({"versus_metric": "lon_error_rmse", "consistent_states": 2}, "claims[0]", "versus_metric is a separate claim"),
        (
            {"versus_metric": "lon_error_rmse", "every_run_within": [0, 1], "reference_case": "only"},
            "claims[0]",
            "reference and reference_case are a separate claim",
        ),
    ],
)
def test_bad_claims_between_metrics_are_refused_at_load_naming_the_field(tmp_path, fields, field, message):
    path = tmp_path / "c.toml"
    path.write_text(
        two_candidate_config("claims", claims=claim_toml(**{"candidate": "a", "metric": "lat_error_rmse", **fields}))
    )
    with pytest.raises(ConfigError) as err:
        load_config(path)
    text = str(err.value)
    assert text.startswith(field) and message in text and "\n" not in text


@pytest.mark.slow
def test_compare_check_on_a_real_run_where_the_ordering_holds_in_every_run(tmp_path):
    # In every run the RMS of the latitude error is at least the mean of its absolute value
    # (the power-mean inequality; equal only for a constant |error|): rmse - mean >= 0 in every
    # run, so "in [0, 1e6] in every run" holds and "in [-1e6, 0) in every run" fails.
    claims = _versus_real(every_run_within=[0.0, 1e6]) + _versus_real(every_run_within=[-1e6, -1e-12])
    path = tmp_path / "c.toml"
    path.write_text(
        two_candidate_config("claims", top="claims_small_n = true", claims=claims).replace("runs = 4", "runs = 3")
    )
    proc = compare_check(path, tmp_path / "o")
    assert proc.returncode == 1, proc.stderr
    rows = json.loads((tmp_path / "o" / "summary.json").read_text())["claims"]
    assert [r["outcome"] for r in rows] == ["holds", "fails"] and all(r["n"] == 3 for r in rows)
    assert "claims: 1 of 2 hold" in proc.stdout
    assert "holds           only: a: lat_error_rmse minus its lat_error_mean in [0, 1e+06] in every run" in proc.stdout


def _versus_real(**fields) -> str:
    return claim_toml(candidate="a", metric="lat_error_rmse", versus_metric="lat_error_mean", **fields)


def test_a_claim_between_metrics_at_a_sweeps_points(tmp_path):
    # a's lat = LAT and lon = LAT - d at each point of a psi sweep, d per point: (0.5, 0.5, 1.0,
    # 0.5) t = 5, (0.5, 0.3, 1.0, 0.7) t = 4.19, (1.0, -0.5, 2.0, -0.4) t = 0.89, against
    # t(0.975, 3) = 3.182: holds, holds, not significant; no point fails, so "all" is not significant.
    sweep = '[[sweeps]]\nname = "psi"\npath = "scenario.psi"\nvalues = [0.2, 0.5, 0.8]'
    differences = [np.array([0.5, 0.5, 1.0, 0.5]), np.array([0.5, 0.3, 1.0, 0.7]), np.array([1.0, -0.5, 2.0, -0.4])]
    path = tmp_path / "c.toml"
    path.write_text(two_candidate_config("sweep", sweeps=sweep, claims=_versus(direction="higher", sweep="psi")))
    config = load_config(path)
    store = ResultStore(tmp_path / "results.sqlite")
    for (_, point), d in zip(config.sweep_points(0), differences):
        key = point.identity()
        store.register(key, config.batch_size)
        for name in ("a", "b"):
            own = {"lat_error_rmse": LAT, "lon_error_rmse": LAT - d} if name == "a" else {}
            for first in (0, 2):
                store.add_batch(
                    key, "only", name, first, {m: own.get(m, B)[first : first + 2] for m in config.metric_names}
                )
    rows = evaluate_claims(config, store)
    assert [(r["point"], r["outcome"]) for r in rows] == [
        (0.2, "holds"),
        (0.5, "holds"),
        (0.8, "not significant"),
        ("all", "not significant"),
    ]
    for row, d in zip(rows, differences):
        assert row["diff"] == pytest.approx(d.mean()) and row["se"] == pytest.approx(d.std(ddof=1) / 2)
