"""EM (`learn_noise`) against the online adapters on the same data: the table of
docs/estimators/em.md ("Against the online adapters") is docs/em_vs_adapters.py's output,
and the orderings the page states hold with their paired standard errors.

The truth is the simulation's: every estimator learns Q and R from the same simulated
records (common random numbers), and is scored against the Q and R that generated them,
and by the RMSE of a filter with what it learned on a fresh record against the filter with
the true Q and R. An ordering "EM is closer" is asserted where the paired difference (EM
minus the adapter, per run) is below zero by more than K standard errors; "EM is not worse"
(every stationary pair) where it is not above zero by more than K. Each regime is its own
test (its rows of the table, then its orderings); the stationary ones are slow (5 to 15
CPU-seconds each), the step regime's about 1.
The orderings were checked once on seeds 0 to 3 as well as the page's (not in the suite).
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("em_vs_adapters", ROOT / "docs" / "em_vs_adapters.py")
assert _spec is not None and _spec.loader is not None
EX = importlib.util.module_from_spec(_spec)
sys.modules[_spec.name] = EX  # its dataclasses look their module up
_spec.loader.exec_module(EX)

K = 3.0  # standard errors
ADAPTERS = ("innovation", "sage-husa", "sage-husa classic")


def _block(blocks, unknowns):
    return next(b for b in blocks if b.unknowns == unknowns)


def _errors(block, name):
    """Per-run |log q error|, |log r error| and RMSE / true of an estimator."""
    lq, lr = block.log_errors(name)
    return {"q": lq, "r": lr, "rmse": block.estimators[name].rmse_ratio}


def em_minus(block, name, metric):
    """Paired EM minus ``name`` in ``metric`` ("q", "r" or "rmse"): mean and SE over runs."""
    return EX.paired(_errors(block, "EM")[metric], _errors(block, name)[metric])


def assert_em_closer(block, name, metric):
    mean, se = em_minus(block, name, metric)
    assert mean + K * se < 0, (
        f"{block.regime.name}, {block.regime.steps} steps, {block.unknowns}: EM − {name} "
        f"in {metric} = {mean:+.3f} ± {se:.3f}, not below 0 by {K} SE"
    )


def assert_em_not_worse(block):
    for name in block.estimators:
        if name == "EM":
            continue
        for metric in ("q", "r", "rmse") if block.unknowns == "Q and R" else ("r", "rmse"):
            mean, se = em_minus(block, name, metric)
            assert mean < K * se, (
                f"{block.regime.name}, {block.regime.steps} steps, {block.unknowns}: EM − {name} "
                f"in {metric} = {mean:+.3f} ± {se:.3f}: EM worse by {K} SE"
            )


def assert_centred(values, truth, what):
    """The mean of log(values / truth) within K standard errors of 0 (and the SE small enough
    for that to say something: under 0.1, a 10 % bias)."""
    err = np.log(values / truth)
    se = err.std(ddof=1) / np.sqrt(err.size)
    assert se < 0.1 and abs(err.mean()) < K * se, f"{what}: mean log error {err.mean():+.3f} ± {se:.3f}"


@pytest.fixture(scope="module")
def page():
    return (ROOT / "docs" / "estimators" / "em.md").read_text(encoding="utf-8")


def _regime_blocks(page, index):
    """The regime's blocks, after checking the page shows its rows and the table's header."""
    blocks = EX.compare(EX.REGIMES[index])
    assert EX.HEADER in page, "run: python docs/em_vs_adapters.py and paste its table"
    for line in EX.rows(blocks):
        assert line in page, f"run: python docs/em_vs_adapters.py and paste its table; missing:\n{line}"
    return blocks


def check_stationary(blocks):
    """What holds in every stationary regime: EM's R closer than the window and the
    improved Sage-Husa's (anchored at R0 by design: r_hat above r), its Q closer than the
    classic Sage-Husa's, its filter better than the improved Sage-Husa's with Q and R free;
    and EM worse than no adapter in anything."""
    r_only, both = _block(blocks, "R only"), _block(blocks, "Q and R")
    for name in ("innovation", "sage-husa"):
        assert_em_closer(r_only, name, "r")
    assert_em_closer(both, "sage-husa", "r")
    assert_em_closer(both, "sage-husa", "rmse")
    assert_em_closer(both, "sage-husa classic", "q")
    for block in (r_only, both):
        assert_em_not_worse(block)
        sh = block.estimators["sage-husa"].r / EX.R_TRUE_M2
        assert np.log(sh).mean() - K * np.log(sh).std(ddof=1) / np.sqrt(sh.size) > 0
    return r_only, both


@pytest.mark.slow
def test_well_observed_q_short_records(page):
    r_only, both = check_stationary(_regime_blocks(page, 0))
    assert_em_closer(r_only, "sage-husa classic", "r")
    assert_em_closer(both, "sage-husa classic", "r")
    assert_em_closer(both, "sage-husa", "q")


@pytest.mark.slow
def test_weakly_observed_q_short_records(page):
    """Here the classic Sage-Husa's R and filter tie with EM's (not asserted: a tie)."""
    check_stationary(_regime_blocks(page, 2))


@pytest.mark.slow
def test_well_observed_q_long_records_em_converges_to_the_truth(page):
    r_only, both = check_stationary(_regime_blocks(page, 1))
    for name in ("sage-husa", "sage-husa classic"):
        for metric in ("r", "q", "rmse"):
            assert_em_closer(both, name, metric)
    assert_em_closer(r_only, "sage-husa classic", "r")
    assert both.em_converged == r_only.em_converged == EX.RUNS
    assert_centred(both.estimators["EM"].r, both.r_true, "EM's r, Q and R free")
    assert_centred(r_only.estimators["EM"].r, r_only.r_true, "EM's r, Q known")
    # q: the maximum-likelihood estimate's small downward bias (a mean log error of -0.01 to
    # -0.06 on seeds 0 to 3 and the page's, SE about 0.02) is detectable with 80 runs; held
    # to within 10 %, against the 100-step record's RMS log error of about 0.5
    err = np.log(both.estimators["EM"].q / both.q_true)
    assert err.std(ddof=1) / np.sqrt(err.size) < 0.03 and abs(err.mean()) < 0.1, err.mean()


@pytest.mark.slow
def test_weakly_observed_q_long_records(page):
    """EM's R converges to the truth; its Q has not converged in 100 iterations (EM is slow
    where the data say little about Q), and still its filter beats both Sage-Husas'."""
    r_only, both = check_stationary(_regime_blocks(page, 3))
    assert_em_closer(both, "sage-husa classic", "rmse")
    assert_em_closer(both, "sage-husa classic", "r")
    assert_em_closer(r_only, "sage-husa classic", "r")
    assert_em_closer(both, "sage-husa", "q")
    assert both.em_iterations == EX.ITERATIONS and both.em_converged < EX.RUNS // 2
    assert_centred(both.estimators["EM"].r, both.r_true, "EM's r, Q and R free")
    assert_centred(r_only.estimators["EM"].r, r_only.r_true, "EM's r, Q known")


def test_a_window_tracks_an_r_that_steps_where_em_fits_the_record(page):
    """R steps from r to 4 r at mid-record: EM fits one constant R to the whole record (the
    mean, 2.5 r), the classic Sage-Husa's forgetting follows the step, so its final R is
    closer to the 4 r in force at the end. (The innovation window's is too, by less: 1.9 to
    2.6 SE on two of seeds 0 to 3; not asserted.)"""
    (r_only,) = _regime_blocks(page, 4)
    mean, se = em_minus(r_only, "sage-husa classic", "r")
    assert mean - K * se > 0, f"EM − sage-husa classic in r = {mean:+.3f} ± {se:.3f}"
    assert_centred(r_only.estimators["EM"].r, 2.5 * EX.R_TRUE_M2, "EM's r against the record's mean R")
