"""Claims a referee accepts (issue 42): multiplicity adjustment, equivalence by TOST, the
chi-square NEES band, resampling tests, zero-spread refusal, replication and the fairness
rule on untuned candidates. Each expected value comes from the procedure's definition or
from scipy, never from the code under test."""

from __future__ import annotations

import itertools
import json

import numpy as np
import pytest
from scipy import stats

from gnssframework.errors import ConfigError
from gnssframework.experiments import load_config
from gnssframework.experiments.claim_tests import (
    all_runs_bound,
    benjamini_hochberg,
    bootstrap_means,
    claim_rng,
    holm,
    nees_band,
)
from gnssframework.experiments.claims import Claim, _judge, evaluate_claims
from gnssframework.experiments.report import write_report
from gnssframework.experiments.stats import paired_difference
from gnssframework.experiments.store import ResultStore
from two_candidates import claim_toml, compare_check, evaluate_stored, two_candidate_config

A = np.array([1.0, 2.0, 3.0, 4.0])
B = np.array([0.5, 1.5, 2.0, 3.5])  # d = A - B = (0.5, 0.5, 1.0, 0.5): mean 0.625, SE 0.125


_claim = claim_toml


def _evaluate(tmp_path, claims: str, a=A, b=B, top: str = ""):
    return evaluate_stored(tmp_path, claims, a, b, top)


# -- multiplicity ---------------------------------------------------------------------------------


def _holm_by_closed_testing(p: list[float], alpha: float) -> list[bool]:
    """Holm's rejections by its definition as a shortcut of closed testing with Bonferroni
    tests: H_i is rejected when every intersection containing it has min p < alpha / |I|."""
    m = len(p)
    rejected = []
    for i in range(m):
        others = [j for j in range(m) if j != i]
        ok = all(
            min(p[j] for j in (i, *sub)) < alpha / (len(sub) + 1)
            for k in range(m)
            for sub in itertools.combinations(others, k)
        )
        rejected.append(ok)
    return rejected


def test_holm_adjusted_p_values_reject_exactly_what_closed_testing_rejects():
    rng = np.random.default_rng(5)
    for _ in range(40):
        p = list(rng.uniform(0, 0.08, size=int(rng.integers(1, 7))))
        adjusted = holm(p)
        assert [bool(a < 0.05) for a in adjusted] == _holm_by_closed_testing(p, 0.05), p


def test_holm_and_benjamini_hochberg_on_hand_computed_values():
    # Sorted p = 0.01, 0.02, 0.03, 0.04, 0.2 (m = 5). Holm: 5*0.01 = 0.05, 4*0.02 = 0.08,
    # 3*0.03 = 0.09, 2*0.04 = 0.08 -> running max 0.09, 1*0.2 = 0.2.
    p = [0.03, 0.01, 0.2, 0.04, 0.02]
    assert holm(p) == pytest.approx([0.09, 0.05, 0.2, 0.09, 0.08])
    # BH: m p / rank = 0.05, 0.05, 0.05, 0.05, 0.2 -> running min from the top.
    assert benjamini_hochberg(p) == pytest.approx([0.05, 0.05, 0.2, 0.05, 0.05])


def test_every_claim_row_carries_its_p_value_and_the_examples_adjustment(tmp_path):
    claims = _claim(candidate="a", reference="b", metric="lat_error_rmse", direction="higher") + _claim(
        candidate="a", metric="lat_error_rmse", within=[0.4, 4.6]
    )
    rows, config, store = _evaluate(tmp_path, claims)
    # Ordering: t = 0.625 / 0.125 = 5 with 3 dof, two-sided p = 2 * t.sf(5, 3).
    p1 = 2 * stats.t.sf(5.0, 3)
    assert rows[0]["p_value"] == pytest.approx(p1)
    # Bound: mean 2.5, SE sd/2; the larger one-sided p of the two bounds, doubled.
    se = np.std(A, ddof=1) / 2
    p2 = 2 * max(stats.t.sf((2.5 - 0.4) / se, 3), stats.t.sf((4.6 - 2.5) / se, 3))
    assert rows[1]["p_value"] == pytest.approx(p2)
    # Holm with m = 2: the smaller p doubled, the larger max(that, itself) (capped at 1).
    lo, hi = sorted([p1, p2])
    expected = {lo: min(1.0, 2 * lo), hi: min(1.0, max(2 * lo, hi))}
    assert [r["p_adjusted"] for r in rows] == pytest.approx([expected[p1], expected[p2]])
    assert all(r["adjustment"] == "holm" and r["family_size"] == 2 for r in rows)
    summary = json.loads(write_report(config, store, tmp_path).read_text())
    assert summary["claims_adjustment"] == "holm"
    assert "Holm's step-down (family-wise error rate) over the 2 tests" in (tmp_path / "report.md").read_text()
    (tmp_path / "bh").mkdir()
    rows, _, _ = _evaluate(tmp_path / "bh", claims, top='claims_adjustment = "benjamini-hochberg"')
    assert rows[0]["adjustment"] == "benjamini-hochberg"
    assert [r["p_adjusted"] for r in rows] == pytest.approx(list(benjamini_hochberg([p1, p2])))


# -- equivalence ----------------------------------------------------------------------------------


def _tost_by_scipy(d: np.ndarray, margin: float) -> float:
    """TOST's p-value from scipy's one-sample t-tests of d against -margin and +margin."""
    lower = stats.ttest_1samp(d, -margin, alternative="greater").pvalue
    upper = stats.ttest_1samp(d, margin, alternative="less").pvalue
    return float(max(lower, upper))


@pytest.mark.parametrize("margin", [1.0, 0.9, 1.5, 0.3, 0.05])
def test_equivalence_by_two_one_sided_tests(tmp_path, margin):
    d = A - B
    rows, _, _ = _evaluate(
        tmp_path, _claim(candidate="a", reference="b", metric="lat_error_rmse", equivalence_margin=margin)
    )
    (row,) = rows
    p = _tost_by_scipy(d, margin)
    assert row["p_value"] == pytest.approx(p)
    half95 = stats.t.ppf(0.975, 3) * 0.125
    expected = "holds" if p < 0.05 else "fails" if 0.625 - half95 > margin else "not significant"
    assert row["outcome"] == expected
    # By hand: margin 1.0 is t = (1.0 - 0.625) / 0.125 = 3 from the mean, one-sided p = 0.029 (holds);
    # 0.9 is t = 2.2, p = 0.058 (cannot tell); 0.3 lies inside the 95 % interval (0.227, 1.023);
    # 0.05 lies below all of it (fails).
    assert {1.0: "holds", 0.9: "not significant", 1.5: "holds", 0.3: "not significant", 0.05: "fails"}[
        margin
    ] == expected


def test_not_significant_is_not_equivalence(tmp_path):
    # d = (1.0, -0.5, 2.0, -0.4): mean 0.525, SE 0.59 -> no ordering, and no equivalence at 0.5 either.
    noisy = np.array([0.0, 2.5, 1.0, 4.4])
    rows, _, _ = _evaluate(
        tmp_path,
        _claim(candidate="a", reference="b", metric="lat_error_rmse", direction="higher")
        + _claim(candidate="a", reference="b", metric="lat_error_rmse", equivalence_margin=0.5),
        b=noisy,
    )
    assert [r["outcome"] for r in rows] == ["not significant", "not significant"]


# -- zero spread ----------------------------------------------------------------------------------


def test_a_claim_with_no_spread_is_refused_not_held(tmp_path):
    constant = np.full(4, 0.25)
    rows, config, store = _evaluate(
        tmp_path,
        _claim(candidate="a", metric="lat_error_rmse", within=[0.0, 1.0])
        + _claim(candidate="a", reference="b", metric="lat_error_rmse", direction="lower"),
        a=constant,
        b=constant + 0.5,
    )
    assert [r["outcome"] for r in rows] == ["refused", "refused"]
    assert "no spread" in rows[0]["reason"] and "in all 4 runs" in rows[0]["reason"]
    assert all(r.get("p_value") is None for r in rows)


def test_every_run_within_states_a_constant_with_its_exact_bound(tmp_path):
    constant = np.zeros(4)
    rows, _, _ = _evaluate(
        tmp_path,
        _claim(candidate="a", metric="lat_error_rmse", every_run_within=[-0.001, 0.001])
        + _claim(candidate="b", metric="lat_error_rmse", every_run_within=[-0.001, 0.001]),
        a=constant,
    )
    assert [r["outcome"] for r in rows] == ["holds", "fails"]
    # Clopper-Pearson with 0 of n: (1 - bound)^n = 0.05.
    assert (1 - rows[0]["outside_bound95"]) ** 4 == pytest.approx(0.05)
    assert all_runs_bound(12) == pytest.approx(1 - 0.05 ** (1 / 12))


def test_every_run_within_with_a_reference_bounds_each_runs_paired_difference(tmp_path):
    """A candidate identical to its reference run by run (no spread: an ordering is refused)
    is stated as every run's difference within a tolerance; a difference outside fails."""
    same = A.copy()
    same[2] += 0.0005  # within 1 mm of A in every run
    claims = _claim(candidate="a", reference="b", metric="lat_error_rmse", every_run_within=[-0.001, 0.001]) + _claim(
        candidate="a", reference="b", metric="lat_error_rmse", every_run_within=[-0.0001, 0.0001]
    )
    rows, config, _ = _evaluate(tmp_path, claims, a=A, b=same)
    assert [r["outcome"] for r in rows] == ["holds", "fails"]
    assert "minus b's in [-0.001, 0.001] in every run" in config.claims[0].statement()
    # the candidate's own values (A, spread 1-4) would fail the same bound: the difference is what is judged
    (tmp_path / "own").mkdir()
    rows, _, _ = _evaluate(
        tmp_path / "own", _claim(candidate="a", metric="lat_error_rmse", every_run_within=[-0.001, 0.001]), a=A, b=same
    )
    assert rows[0]["outcome"] == "fails"


@pytest.mark.slow
def test_compare_check_names_a_refused_claim_in_one_line(tmp_path):

    path = tmp_path / "c.toml"
    claims = _claim(candidate="a", reference="b", metric="lat_error_rmse", direction="lower")
    text = two_candidate_config("claims", top="claims_small_n = true", claims=claims)
    ckf = 'estimator = { name = "ckf" }'
    assert ckf in text
    path.write_text(text.replace(ckf, 'estimator = { name = "kf" }'))  # b is a: the same values in every run
    proc = compare_check(path, tmp_path / "o", timeout=600)
    (row,) = json.loads((tmp_path / "o" / "summary.json").read_text())["claims"]
    assert row["outcome"] == "refused" and row["p_value"] is None
    assert proc.returncode == 1
    last = proc.stderr.strip().splitlines()[-1]
    assert last.startswith("error: claims[0] in only refused: lat_error_rmse minus the reference's is the same")


# -- NEES consistency -----------------------------------------------------------------------------


@pytest.mark.parametrize("runs, states", [(12, 3), (4, 3), (24, 8), (1, 1)])
def test_nees_band_is_the_chi_square_band_of_runs_times_states(runs, states):
    lo, hi = nees_band(runs, states)
    assert lo == pytest.approx(stats.chi2.ppf(0.025, runs * states) / runs, rel=1e-10)
    assert hi == pytest.approx(stats.chi2.ppf(0.975, runs * states) / runs, rel=1e-10)


def test_a_3x_overconfident_filter_fails_the_band_the_old_one_passed():
    claim = Claim(candidate="a", metric="nees_position", consistent_states=3)
    old = Claim(candidate="a", metric="nees_position", within=[1.0, 10.0])
    rng = np.random.default_rng(1)
    consistent = rng.chisquare(3 * 50, size=12) / 50  # per-run mean of 50 chi2(3) epochs
    overconfident = 3 * consistent  # P three times too small: NEES about 9
    assert _judge(claim, None, consistent, None)[0] == "holds"
    assert _judge(claim, None, overconfident, None)[0] == "fails"
    assert _judge(old, None, overconfident, None)[0] == "holds"
    with pytest.raises(ValueError, match="not a NEES"):
        Claim(candidate="a", metric="lat_error_rmse", consistent_states=3)


# -- resampling tests -----------------------------------------------------------------------------


def test_bootstrap_claim_is_its_percentile_interval_and_reproducible(tmp_path):
    claims = _claim(candidate="a", reference="b", metric="lat_error_rmse", direction="higher", test="bootstrap")
    rows, config, _ = _evaluate(tmp_path, claims)
    (tmp_path / "x").mkdir()
    again, _, _ = _evaluate(tmp_path / "x", claims)
    assert rows[0]["p_value"] == again[0]["p_value"]  # the same seed: the same resamples
    # Independently: resample the 4 runs with the claim's generator, count differences <= 0.
    rng = claim_rng(config.seed, 0, "only")
    idx = rng.integers(0, 4, size=(10_000, 4))
    diff = (A - B)[idx].mean(axis=1)
    assert rows[0]["p_value"] == pytest.approx(min(1.0, 2 * (np.count_nonzero(diff <= 0) + 1) / 10_001))
    # All four differences are positive: every resample is; the interval excludes 0.
    assert rows[0]["outcome"] == "holds"


def test_bootstrap_and_t_disagree_on_a_heavy_tailed_difference():
    # One huge run: the t-interval is wide (not significant), the bootstrap keeps every
    # resample of the other runs' sign (holds) - the case a maximum error makes.
    x = np.array([1.1, 1.2, 1.15, 1.3, 1.25, 1.1, 1.2, 1.3, 1.15, 1.2, 1.25, 30.0])
    y = np.ones(12)
    pd = paired_difference(x, y)
    t_claim = Claim(candidate="a", reference="b", metric="m", direction="higher")
    b_claim = Claim(candidate="a", reference="b", metric="m", direction="higher", test="bootstrap")
    w_claim = Claim(candidate="a", reference="b", metric="m", direction="higher", test="wilcoxon")
    assert _judge(t_claim, pd, x, (x, y))[0] == "not significant"
    assert _judge(b_claim, pd, x, (x, y), rng=np.random.default_rng(0))[0] == "holds"
    outcome, p, _ = _judge(w_claim, pd, x, (x, y))
    assert outcome == "holds"
    assert p == pytest.approx(2 * stats.wilcoxon(x - y, alternative="greater").pvalue)
    assert p == pytest.approx(2 / 2**12)  # every difference positive: the exact one-sided p is 1 / 2^12


def test_bootstrap_means_pair_the_runs():
    x, y = np.arange(5.0), np.arange(5.0) + 1.0
    mx, my = bootstrap_means(x, y, np.random.default_rng(3), resamples=200)
    assert np.allclose(my - mx, 1.0)  # the same run indices in both


# -- fairness: untuned candidates -----------------------------------------------------------------

_TUNING = """
[tuning]
trials = 2
runs = 1
sampler = "grid"
metric = "lat_error_rmse"
[[tuning.free]]
path = "candidates.a.nav_filter.params.r0"
low = 0.5
high = 2.0
"""


def _tuned_text(claims: str, as_given: bool = False) -> str:
    text = two_candidate_config("fair", claims=claims) + _TUNING
    if as_given:
        text = text.replace('name = "b"\n', 'name = "b"\nas_given = true\n')
    return text


def test_a_claim_against_an_untuned_candidate_is_refused_unless_as_given(tmp_path):
    claims = _claim(candidate="a", reference="b", metric="lat_error_rmse", direction="lower")
    path = tmp_path / "c.toml"
    path.write_text(_tuned_text(claims))
    with pytest.raises(ConfigError) as err:
        load_config(path)
    text = str(err.value)
    assert text.startswith("claims[0].reference") and "'b' is not tuned" in text and "\n" not in text
    path.write_text(_tuned_text(claims, as_given=True))
    config = load_config(path)
    assert [c.as_given for c in config.candidates] == [False, True]
    # A bound on the untuned candidate alone compares it with nothing: accepted.
    path.write_text(_tuned_text(_claim(candidate="b", metric="lat_error_rmse", within=[0.0, 10.0])))
    load_config(path)


def test_as_given_does_not_change_the_store_key(tmp_path):
    path = tmp_path / "c.toml"
    path.write_text(two_candidate_config("k"))
    plain = load_config(path).identity()
    path.write_text(two_candidate_config("k").replace('name = "b"\n', 'name = "b"\nas_given = true\n'))
    assert load_config(path).identity() == plain


def test_the_report_marks_the_untuned_candidates(tmp_path):
    from gnssframework.experiments.report import _claims_markdown

    lines = "\n".join(_claims_markdown([], "holm", ["b", "c"], {"b"}))
    assert "## Untuned candidates" in lines
    assert "`b` (deliberately as given: as_given = true)" in lines and "`c` (not tuned)" in lines


# -- replication ----------------------------------------------------------------------------------


def test_replicate_streams_are_disjoint_from_evaluation_and_tuning(tmp_path):
    from gnssframework.experiments.run_plan import task_streams
    from gnssframework.experiments.runner import replicate_config
    from gnssframework.experiments.tasks import plan

    path = tmp_path / "c.toml"
    path.write_text(two_candidate_config("r"))
    config = load_config(path)
    rep = replicate_config(config)
    assert rep.random_stream == "replicate" and rep.identity() != config.identity()
    tuning = config.model_copy(update={"random_stream": "tuning"})
    task = plan(config, None)[0]
    draws = [task_streams(c, task).generators[0].standard_normal(4) for c in (config, rep, tuning)]
    assert not np.allclose(draws[0], draws[1]) and not np.allclose(draws[1], draws[2])
    again = task_streams(replicate_config(config), task).generators[0].standard_normal(4)
    assert np.array_equal(draws[1], again)


@pytest.mark.slow
def test_compare_replicate_rechecks_every_claim(tmp_path):
    from gnssframework.experiments.runner import run_comparison

    path = tmp_path / "c.toml"
    claims = _claim(candidate="a", reference="b", metric="lat_error_rmse", direction="lower") + _claim(
        candidate="a", reference="b", metric="lat_error_rmse", direction="higher"
    )
    text = two_candidate_config("rep", claims=claims)
    b = 'name = "b"\nnav_filter = { name = "position-ca" }'
    assert b in text
    path.write_text(text.replace(b, 'name = "b"\nnav_filter = { name = "position-ca", params = { r0 = 9.0 } }'))
    summary = json.loads(run_comparison(load_config(path), tmp_path / "o", progress=False, replicate=True).read_text())
    assert summary["replicated"] is True
    for row in summary["claims"]:
        assert row["replicate_outcome"] in ("holds", "not significant", "fails", "refused")
        first, second = row["outcome"] == "holds", row["replicate_outcome"] == "holds"
        assert (
            row["replicated"]
            == {
                (True, True): "both",
                (True, False): "first only",
                (False, True): "replicate only",
                (False, False): "neither",
            }[(first, second)]
        )
    # The replicate's numbers are its own runs: re-evaluated from the store on its key.
    from gnssframework.experiments.runner import replicate_config

    store = ResultStore(tmp_path / "o" / "results.sqlite")
    rep_rows = evaluate_claims(replicate_config(load_config(path)), store)
    assert [r["outcome"] for r in rep_rows] == [r["replicate_outcome"] for r in summary["claims"]]
    assert all(r["outcome"] != "refused" for r in rep_rows)
    assert rep_rows[0]["diff"] != summary["claims"][0]["diff"]
