"""[[claims]]: orderings and bounds checked from the paired runs (hand-computed values)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy import stats

from gnssframework.errors import ConfigError
from gnssframework.experiments import load_config
from gnssframework.experiments.report import write_report
from two_candidates import claim_toml, compare_check, evaluate_stored, two_candidate_config


# Per-run values of candidate a and b: d = a - b = (0.5, 0.5, 1.0, 0.5): mean 0.625,
# SE 0.125, t(0.975, 3) = 3.182 -> interval (0.227, 1.023): a is higher, significantly.
A = np.array([1.0, 2.0, 3.0, 4.0])
B = np.array([0.5, 1.5, 2.0, 3.5])


def _evaluate(tmp_path, claims: str, a=A, b=B):
    return evaluate_stored(tmp_path, claims, a, b)


_claim = claim_toml


@pytest.mark.parametrize("direction, outcome", [("higher", "holds"), ("lower", "fails")])
def test_an_ordering_holds_or_fails_by_its_paired_interval(tmp_path, direction, outcome):
    rows, _, _ = _evaluate(tmp_path, _claim(candidate="a", reference="b", metric="lat_error_rmse", direction=direction))
    (row,) = rows
    assert row["outcome"] == outcome
    assert row["diff"] == pytest.approx(0.625) and row["se"] == pytest.approx(0.125) and row["n"] == 4


def test_an_ordering_the_runs_cannot_tell_is_not_significant(tmp_path):
    noisy = np.array([0.0, 2.5, 1.0, 4.4])  # d = (1.0, -0.5, 2.0, -0.4): mean 0.525, SE 0.59
    rows, _, _ = _evaluate(
        tmp_path, _claim(candidate="a", reference="b", metric="lat_error_rmse", direction="higher"), b=noisy
    )
    assert rows[0]["outcome"] == "not significant"


def test_a_ratio_bound_uses_the_ratio_interval(tmp_path):
    # ratio of means 2.5 / 1.875 = 1.333; its delta-method SE from the paired covariance.
    c = np.cov(A, B, ddof=1)
    r = A.mean() / B.mean()
    se = np.sqrt(c[0, 0] - 2 * r * c[0, 1] + r**2 * c[1, 1]) / (B.mean() * 2)
    half = stats.t.ppf(0.975, 3) * se
    for bound, outcome in ((r + 1.01 * half, "holds"), (r - 1.01 * half, "fails"), (r, "not significant")):
        rows, _, _ = _evaluate(
            tmp_path, _claim(candidate="a", reference="b", metric="lat_error_rmse", ratio_max=float(bound))
        )
        assert rows[0]["outcome"] == outcome, bound
        assert rows[0]["ratio"] == pytest.approx(r)
    # Two conditions: the worst outcome (the direction holds, the ratio bound fails).
    rows, _, _ = _evaluate(
        tmp_path,
        _claim(
            candidate="a", reference="b", metric="lat_error_rmse", direction="higher", ratio_min=float(r + 1.01 * half)
        ),
    )
    assert rows[0]["outcome"] == "fails"


def test_a_bound_on_a_mean(tmp_path):
    # A: mean 2.5, SE 0.645, t-interval (0.446, 4.554).
    for within, outcome in (([0.4, 4.6], "holds"), ([5.0, 9.0], "fails"), ([1.0, 9.0], "not significant")):
        rows, _, _ = _evaluate(tmp_path, _claim(candidate="a", metric="lat_error_rmse", within=within))
        assert rows[0]["outcome"] == outcome, within
        assert rows[0]["mean"] == pytest.approx(2.5)


def test_summary_report_and_check_carry_the_outcomes(tmp_path):
    claims = _claim(candidate="a", reference="b", metric="lat_error_rmse", direction="higher") + _claim(
        candidate="a", reference="b", metric="lat_error_rmse", direction="lower"
    )
    _, config, store = _evaluate(tmp_path, claims)
    summary = json.loads(write_report(config, store, tmp_path).read_text())
    assert [c["outcome"] for c in summary["claims"]] == ["holds", "fails"]
    report = (tmp_path / "report.md").read_text()
    assert "## Claims" in report and "1 of 2 hold" in report
    assert "| fails | only | a: lat_error_rmse lower than b's |" in report


@pytest.mark.parametrize(
    "fields, field, message",
    [
        (
            {"candidate": "c", "reference": "b", "metric": "lat_error_rmse", "direction": "lower"},
            "claims[0].candidate",
            "unknown candidate 'c'; allowed: a, b",
        ),
        (
            {"candidate": "a", "reference": "b", "metric": "rmse", "direction": "lower"},
            "claims[0].metric",
            "unknown metric 'rmse'",
        ),
        (
            {"candidate": "a", "reference": "b", "metric": "lat_error_rmse", "direction": "lower", "case": "x"},
            "claims[0].case",
            "unknown case 'x'; allowed: only",
        ),
        ({"candidate": "a", "reference": "b", "metric": "lat_error_rmse"}, "claims[0]", "an ordering needs direction"),
        ({"candidate": "a", "metric": "lat_error_rmse", "direction": "lower"}, "claims[0]", "give reference"),
        ({"candidate": "a", "metric": "lat_error_rmse", "within": [2, 1]}, "claims[0]", "low < high"),
    ],
)
def test_bad_claims_are_refused_at_load_naming_the_field(tmp_path, fields, field, message):
    path = tmp_path / "c.toml"
    path.write_text(two_candidate_config("claims", claims=_claim(**fields)))
    with pytest.raises(ConfigError) as err:
        load_config(path)
    assert str(err.value).startswith(field) and message in str(err.value)


@pytest.mark.slow
def test_compare_check_exits_1_when_a_claim_does_not_hold(tmp_path):
    claims = _claim(candidate="a", reference="b", metric="lat_error_rmse", direction="lower")
    path = tmp_path / "c.toml"
    path.write_text(
        two_candidate_config("claims", top="claims_small_n = true", claims=claims).replace("runs = 4", "runs = 3")
    )
    proc = compare_check(path, tmp_path / "o")
    outcome = json.loads((tmp_path / "o" / "summary.json").read_text())["claims"][0]["outcome"]
    assert proc.returncode == (0 if outcome == "holds" else 1), proc.stderr
    assert (
        f"claims: {int(outcome == 'holds')} of 1 hold" in proc.stdout
        and "a: lat_error_rmse lower than b's" in proc.stdout
    )
