"""Orderings on the experiment pages are claims CI checks (issue 22's acceptance).

A page states an ordering (or a bound) next to a marker naming the claim it rests on, an
HTML comment the reader does not see::

    <!-- claim: deep_integration_ci: deep horizontal_velocity_error_rmse lower than vector at 35dBHz -->
    <!-- claim: deep_integration_ci: vector loss_of_lock_fraction within [-0.001, 0.001] -->

(``at CASE`` only for a claim of one case). This test reads every marker of
``docs/experiments/*.md`` and requires that ``examples/<example>.toml`` holds that
``[[claims]]`` entry and that CI checks that example's claims (``gnssframework compare ...
--check`` in ``.ci/run``, or ``docs/make_experiment_plots.py``, which CI runs and which fails
when a claim of its examples does not hold), so a claim removed, changed or no longer checked in CI breaks the build
until the page says so too.
"""

from __future__ import annotations

import ast
import re
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = sorted((ROOT / "docs" / "experiments").glob("*.md"))
MARKER = re.compile(r"<!--\s*claim:\s*(?P<body>.*?)\s*-->", re.S)
ORDERING = re.compile(r"(?P<example>[\w-]+):\s+(?P<candidate>\S+)\s+(?P<metric>\w+)\s+"
                      r"(?P<direction>lower|higher) than\s+(?P<reference>\S+)(?:\s+at\s+(?P<case>\S+))?$")
BOUND = re.compile(r"(?P<example>[\w-]+):\s+(?P<candidate>\S+)\s+(?P<metric>\w+)\s+within\s+"
                   r"\[(?P<low>[^,\]]+),\s*(?P<high>[^\]]+)\](?:\s+at\s+(?P<case>\S+))?$")


def _markers() -> list[tuple[str, int, str]]:
    found = []
    for page in PAGES:
        text = page.read_text()
        for m in MARKER.finditer(text):
            found.append((page.name, text.count("\n", 0, m.start()) + 1, " ".join(m.group("body").split())))
    return found


def _parse(body: str) -> dict:
    m = ORDERING.match(body) or BOUND.match(body)
    if m is None:
        raise AssertionError(f"unreadable claim marker {body!r}: write '<example>: <candidate> <metric> "
                             "lower|higher than <reference> [at <case>]' or '... within [low, high] [at <case>]'")
    return m.groupdict()


def _matches(claim: dict, want: dict) -> bool:
    if (claim["candidate"], claim["metric"], claim.get("case")) != (want["candidate"], want["metric"], want["case"]):
        return False
    if want.get("direction"):
        return claim.get("direction") == want["direction"] and claim.get("reference") == want["reference"]
    within = claim.get("within")
    return within is not None and tuple(within) == (float(want["low"]), float(want["high"]))


def _checked_in_ci() -> set[str]:
    """Examples CI checks the claims of: ``compare examples/X.toml ... --check`` in .ci/run,
    and the examples ``docs/make_experiment_plots.py`` runs (it exits 1 when a claim fails)
    when .ci/run runs it."""
    lines = [line for line in (ROOT / ".ci" / "run").read_text().splitlines() if not line.lstrip().startswith("#")]
    checked = {m.group(1) for line in lines if "--check" in line
               for m in re.finditer(r"compare\s+examples/([\w-]+)\.toml", line)}
    if any("docs/make_experiment_plots.py" in line and "--slow" not in line for line in lines):
        tree = ast.parse((ROOT / "docs" / "make_experiment_plots.py").read_text())
        checked |= next(set(ast.literal_eval(node.value)) for node in tree.body if isinstance(node, ast.Assign)
                        and any(getattr(t, "id", None) == "EXAMPLES" for t in node.targets))
    return checked


MARKERS = _markers()


def test_the_pages_mark_their_orderings():
    # The pages whose orderings rest on claims carry markers; an empty scan would mean the regex broke.
    pages = {page for page, _, _ in MARKERS}
    assert {"deep-integration.md", "vector-tracking.md"} <= pages


@pytest.mark.parametrize("page, line, body", MARKERS, ids=[f"{p}:{n}" for p, n, _ in MARKERS])
def test_every_marked_ordering_is_a_claim_ci_checks(page, line, body):
    want = _parse(body)
    example = ROOT / "examples" / f"{want['example']}.toml"
    assert example.is_file(), f"{page}:{line}: no example {example.name}"
    claims = tomllib.loads(example.read_text()).get("claims", [])
    assert any(_matches(c, want) for c in claims), f"{page}:{line}: {example.name} has no claim {body!r}"
    assert want["example"] in _checked_in_ci(), \
        f"{page}:{line}: CI does not check the claims of {example.name} (.ci/run's compare --check or " \
        "docs/make_experiment_plots.py's EXAMPLES)"


def test_ci_checks_the_reference_examples():
    assert {"vector_tracking", "deep_integration_ci", "carrier_smoothing"} <= _checked_in_ci()
    assert "deep_integration" not in _checked_in_ci()  # too slow for CI: its claims are not CI's


def test_a_marker_for_a_missing_claim_is_caught():
    claims = [{"candidate": "deep", "reference": "vector", "metric": "horizontal_velocity_error_rmse",
               "direction": "lower"}]
    assert _matches(claims[0], _parse("x: deep horizontal_velocity_error_rmse lower than vector"))
    assert not _matches(claims[0], _parse("x: deep horizontal_velocity_error_rmse higher than vector"))
    assert not _matches(claims[0], _parse("x: deep horizontal_velocity_error_rmse lower than vector at 35dBHz"))
    assert not _matches(claims[0], _parse("x: deep horizontal_velocity_error_rmse within [0, 1]"))
    with pytest.raises(AssertionError, match="unreadable claim marker"):
        _parse("x: deep beats vector")
