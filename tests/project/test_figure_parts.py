"""CI's lanes split the figure script's examples by cost (``--part K/N``), beside the
comparisons whose stores the rest reuse (``--ci-stores``, after them)."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "docs"))

import make_experiment_plots as plots  # noqa: E402


def _cost(part: tuple[str, ...]) -> int:
    return sum(plots.CI_COST_S.get(name, 0) for name in part)


def test_the_two_parts_and_the_ci_stores_are_the_whole_list_once_and_the_parts_of_equal_cost():
    first = plots.selected(["--part", "1/2"])
    second = plots.selected(["--part", "2/2"])
    stores = plots.selected(["--ci-stores"])
    assert sorted(first + second + stores) == sorted(plots.EXAMPLES)
    assert len(set(first + second + stores)) == len(plots.EXAMPLES)
    # LPT's bound: the parts differ by at most the costliest single example
    assert abs(_cost(first) - _cost(second)) <= max(plots.CI_COST_S.values())
    # better than taking every second example, the split it replaced
    alternate = abs(_cost(plots.EXAMPLES[0::2]) - _cost(plots.EXAMPLES[1::2]))
    assert abs(_cost(first) - _cost(second)) < alternate


def test_the_ci_stores_are_the_examples_ci_compares_itself():
    # the parts run beside .ci/run's comparisons: an example in both would be two processes on
    # one store; one CI compares but not listed would be computed twice
    script = (ROOT / ".ci" / "run").read_text()
    compared = set(re.findall(r"gnssframework compare examples/(\w+)\.toml --out results/\1 ", script))
    assert "vector_tracking" in compared and "deep_integration_ci" in compared  # the pattern reads it
    assert set(plots.CI_STORES) == compared & set(plots.EXAMPLES)
    assert "make_experiment_plots.py --ci-stores" in script


def test_a_part_keeps_the_lists_order_and_three_parts_balance_too():
    names = ("a", "b", "c", "d", "e", "f")
    costs = {"a": 1, "b": 9, "c": 5, "d": 4, "e": 3, "f": 0}
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(plots, "CI_COST_S", costs)
        parts = plots.balanced_parts(names, 3)
    # by hand, longest first to the lightest part: b|c|d, e to d's (4), a to c's (5), f to c's (6)
    assert parts == [("b",), ("a", "c", "f"), ("d", "e")]  # costs 9, 6, 7
    assert all(list(p) == sorted(p, key=names.index) for p in parts)


def test_every_costed_name_is_an_example_and_a_bad_part_is_refused():
    assert set(plots.CI_COST_S) <= set(plots.EXAMPLES + plots.SLOW_EXAMPLES)
    with pytest.raises(SystemExit, match="--part takes K/N"):
        plots.selected(["--part", "3/2"])
