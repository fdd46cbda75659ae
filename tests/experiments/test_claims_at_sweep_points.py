"""[[claims]] at a sweep's points: one outcome per point and one for all of them.

The per-run values are set by hand in a results store, so every outcome follows from a
paired t-interval computed here with scipy.stats (independently of the code under test).
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
from scipy import stats

from gnssframework.errors import ConfigError
from gnssframework.experiments import load_config
from gnssframework.experiments.claims import evaluate_claims
from gnssframework.experiments.report import write_report
from gnssframework.experiments.store import ResultStore
from two_candidates import two_candidate_config

SWEEP = """[[sweeps]]
name = "psi"
path = "{path}"
values = [0.2, 0.5, 0.8]"""

A = np.array([1.0, 2.0, 3.0, 4.0])
# b = a - d per point: d = (0.5, 0.5, 1.0, 0.5): mean 0.625, SE 0.125 (t = 5.0);
# d = (0.5, 0.3, 1.0, 0.7): mean 0.625, SE 0.149 (t = 4.19); d = (1.0, -0.5, 2.0, -0.4):
# mean 0.525, SE 0.59 (t = 0.89, not significant at any level).
STRONG = np.array([0.5, 0.5, 1.0, 0.5])
MIDDLING = np.array([0.5, 0.3, 1.0, 0.7])
TIE = np.array([1.0, -0.5, 2.0, -0.4])


def _text(claims: str, path: str = "scenario.psi", cases: str = "") -> str:
    return two_candidate_config("sweep-claims", case_fields=cases, sweeps=SWEEP.format(path=path), claims=claims)


def _config(tmp_path, claims: str, path: str = "scenario.psi", cases: str = ""):
    file = tmp_path / "c.toml"
    file.write_text(_text(claims, path, cases))
    return load_config(file)


def _claim(**fields) -> str:
    return "[[claims]]\n" + "\n".join(f"{k} = {json.dumps(v)}" for k, v in fields.items()) + "\n"


def _store(tmp_path, config, differences) -> ResultStore:
    """Candidate a's values A and b's A - d at each point, d from ``differences`` in point order."""
    store = ResultStore(tmp_path / "results.sqlite")
    for (_, point), d in zip(config.sweep_points(0), differences):
        key = point.identity()
        store.register(key, config.batch_size)
        for case in point.cases:
            for name, values in (("a", A), ("b", A - d)):
                for first in (0, 2):
                    store.add_batch(
                        key, case.name, name, first, {m: values[first : first + 2] for m in config.metric_names}
                    )
    return store


def _t_ratio(d: np.ndarray) -> float:
    return float(d.mean() / (d.std(ddof=1) / np.sqrt(d.size)))


def _expected(d: np.ndarray, direction: str, level: float) -> str:
    """The outcome of "a is <direction> than b" from the paired t-interval at ``level``."""
    t = _t_ratio(d)
    if abs(t) <= stats.t.ppf(0.5 + level / 2, d.size - 1):
        return "not significant"
    return "holds" if (t < 0) == (direction == "lower") else "fails"


def _rows(tmp_path, differences, **fields):
    config = _config(tmp_path, _claim(candidate="a", reference="b", metric="lat_error_rmse", sweep="psi", **fields))
    return evaluate_claims(config, _store(tmp_path, config, differences))


@pytest.mark.parametrize("direction", ["higher", "lower"])
def test_each_point_is_judged_like_a_case_claim_and_all_points_together(tmp_path, direction):
    differences = [STRONG, STRONG, TIE]
    rows = _rows(tmp_path, differences, direction=direction)
    assert [r["point"] for r in rows] == [0.2, 0.5, 0.8, "all"]
    for row, d in zip(rows, differences):
        assert row["outcome"] == _expected(d, direction, 0.95)
        assert row["diff"] == pytest.approx(d.mean()) and row["se"] == pytest.approx(d.std(ddof=1) / 2)
        assert row["sweep"] == "psi" and row["case"] == "only" and row["n"] == 4
    assert [r["outcome"] for r in rows[:3]] == (
        ["holds", "holds", "not significant"] if direction == "higher" else ["fails", "fails", "not significant"]
    )
    everywhere = rows[3]
    assert everywhere["points"] == [0.2, 0.5, 0.8] and everywhere["held"] == (2 if direction == "higher" else 0)
    # Not "holds" (the tie at 0.8); "fails" only where the Bonferroni interval (level
    # 1 - 0.05 / 3) lies on the other side: t = 5.0 > t(1 - 0.05/6, 3) = 4.86.
    assert _expected(STRONG, direction, 1 - 0.05 / 3) == ("fails" if direction == "lower" else "holds")
    assert everywhere["outcome"] == ("not significant" if direction == "higher" else "fails")
    assert everywhere["failed_corrected"] == ([] if direction == "higher" else [0.2, 0.5])


def test_a_claim_that_holds_at_every_point_holds(tmp_path):
    rows = _rows(tmp_path, [STRONG, MIDDLING, STRONG], direction="higher")
    assert [r["outcome"] for r in rows] == ["holds"] * 4


def test_a_failure_significant_only_per_point_is_not_a_failure_of_the_whole(tmp_path):
    # t = 4.19 at 0.5: outside the 95 % interval (3.18), inside the Bonferroni one (4.86).
    assert _expected(MIDDLING, "lower", 0.95) == "fails"
    assert _expected(MIDDLING, "lower", 1 - 0.05 / 3) == "not significant"
    rows = _rows(tmp_path, [-STRONG, MIDDLING, -STRONG], direction="lower")
    assert [r["outcome"] for r in rows] == ["holds", "fails", "holds", "not significant"]
    # With two points the correction is milder (t(1 - 0.05/4, 3) = 4.18 < 4.19): it fails.
    assert _expected(MIDDLING, "lower", 1 - 0.05 / 2) == "fails"
    rows = _rows(tmp_path, [-STRONG, MIDDLING, -STRONG], direction="lower", **{"from": 0.2, "to": 0.5})
    assert [r["point"] for r in rows] == [0.2, 0.5, "all"]
    assert [r["outcome"] for r in rows] == ["holds", "fails", "fails"]


def test_a_ratio_bound_and_a_bound_on_a_mean_at_points(tmp_path):
    # ratio of means at 0.5: mean(A) / mean(A - STRONG) = 2.5 / 1.875 = 1.333.
    rows = _rows(tmp_path, [TIE, STRONG, TIE], ratio_min=1.05, at=0.5)
    (row,) = rows  # one point: no all-points row
    assert row["point"] == 0.5 and row["ratio"] == pytest.approx(2.5 / 1.875)
    x, y = A, A - STRONG
    c = np.cov(x, y, ddof=1)
    r = x.mean() / y.mean()
    se = np.sqrt(c[0, 0] - 2 * r * c[0, 1] + r**2 * c[1, 1]) / (y.mean() * 2)
    assert row["outcome"] == ("holds" if r - stats.t.ppf(0.975, 3) * se > 1.05 else "not significant")
    config = _config(
        tmp_path, _claim(candidate="b", metric="lat_error_rmse", sweep="psi", at=[0.8, 0.2], within=[-5.0, 10.0])
    )
    rows = evaluate_claims(config, _store(tmp_path, config, [TIE, STRONG, TIE]))
    assert [r["point"] for r in rows] == [0.2, 0.8, "all"]  # the sweep's order
    assert rows[0]["mean"] == pytest.approx((A - TIE).mean())
    assert [r["outcome"] for r in rows] == ["holds"] * 3


@pytest.mark.parametrize(
    "fields, field, message",
    [
        ({"sweep": "cn0"}, "claims[0].sweep", "unknown sweep 'cn0'; allowed: psi"),
        ({"sweep": "psi", "at": 0.3}, "claims[0].at", "0.3 is not a point of sweep 'psi'; allowed: 0.2, 0.5, 0.8"),
        ({"sweep": "psi", "at": []}, "claims[0].at", "allowed: 0.2, 0.5, 0.8"),
        ({"sweep": "psi", "from": 0.25}, "claims[0].from", "not a point of sweep 'psi'"),
        ({"sweep": "psi", "to": 0.9}, "claims[0].to", "allowed: 0.2, 0.5, 0.8"),
        ({"sweep": "psi", "from": 0.8, "to": 0.2}, "claims[0].from", "comes after"),
        ({"sweep": "psi", "at": 0.5, "to": 0.8}, "claims[0].at", "not both"),
        ({"at": 0.5}, "claims[0].at", 'add sweep = "<name>"; allowed: psi'),
        ({"to": 0.5}, "claims[0].to", "allowed: psi"),
    ],
)
def test_bad_sweep_claims_are_refused_at_load_naming_the_field(tmp_path, fields, field, message):
    with pytest.raises(ConfigError) as err:
        _config(tmp_path, _claim(candidate="a", reference="b", metric="lat_error_rmse", direction="lower", **fields))
    assert str(err.value).startswith(field) and message in str(err.value), str(err.value)


def test_a_case_the_sweep_does_not_vary_is_refused(tmp_path):
    # The sweep sets psi of case "only"; case "other" is the same comparison at every point.
    other = '[[cases]]\nname = "other"\npsi = 0.1'
    with pytest.raises(ConfigError) as err:
        _config(
            tmp_path,
            _claim(candidate="a", reference="b", metric="lat_error_rmse", direction="lower", sweep="psi", case="other"),
            path="cases.only.psi",
            cases=other,
        )
    assert str(err.value).startswith("claims[0].case") and "allowed: only" in str(err.value)
    # Without a case the claim is evaluated in the case the sweep varies only.
    config = _config(
        tmp_path,
        _claim(candidate="a", reference="b", metric="lat_error_rmse", direction="higher", sweep="psi", at=0.2),
        path="cases.only.psi",
        cases=other,
    )
    rows = evaluate_claims(config, _store(tmp_path, config, [STRONG, STRONG, STRONG]))
    assert [(r["case"], r["point"], r["outcome"]) for r in rows] == [("only", 0.2, "holds")]


@pytest.mark.slow
def test_summary_and_report_name_the_points(tmp_path):
    config = _config(
        tmp_path, _claim(candidate="a", reference="b", metric="lat_error_rmse", direction="higher", sweep="psi")
    )
    store = _store(tmp_path, config, [STRONG, STRONG, TIE])
    summary = json.loads(write_report(config, store, tmp_path).read_text())
    assert [(c["point"], c["outcome"]) for c in summary["claims"]] == [
        (0.2, "holds"),
        (0.5, "holds"),
        (0.8, "not significant"),
        ("all", "not significant"),
    ]
    report = (tmp_path / "report.md").read_text()
    assert "2 of 4 hold" in report
    assert "| holds | only psi=0.2 | a: lat_error_rmse higher than b's |" in report
    assert (
        "| not significant | only psi=0.2,0.5,0.8 (all) | a: lat_error_rmse higher than b's | holds at 2 of 3 "
        "points; fails at the Bonferroni level 0.017 at none |" in report
    )


@pytest.mark.slow
def test_compare_check_exits_1_when_a_sweep_point_claim_does_not_hold(tmp_path):
    # A bound no mean can meet fails at every point; the run itself decides nothing else.
    claims = _claim(candidate="a", metric="lat_error_rmse", sweep="psi", within=[0.0, 1e9]) + _claim(
        candidate="a", metric="lat_error_rmse", sweep="psi", at=0.5, within=[1e9, 1e10]
    )
    path = tmp_path / "c.toml"
    # 3 runs on purpose (small_n declared, else --check refuses every claim before the run).
    path.write_text(_text(claims).replace("runs = 4", "runs = 3\nclaims_small_n = true"))
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "gnssframework",
            "compare",
            str(path),
            "--out",
            str(tmp_path / "o"),
            "--quiet",
            "--check",
        ],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 1, proc.stderr
    outcomes = [(c["point"], c["outcome"]) for c in json.loads((tmp_path / "o" / "summary.json").read_text())["claims"]]
    assert outcomes == [(0.2, "holds"), (0.5, "holds"), (0.8, "holds"), ("all", "holds"), (0.5, "fails")]
    assert (
        "claims: 4 of 5 hold" in proc.stdout
        and "fails           only psi=0.5: a: mean lat_error_rmse in" in proc.stdout
    )
