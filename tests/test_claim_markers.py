"""Orderings on the experiment pages are claims CI checks (issue 22's acceptance).

A page states an ordering (or a bound) next to a marker naming the claim it rests on, an
HTML comment the reader does not see::

    <!-- claim: deep_integration_ci: deep horizontal_velocity_error_rmse lower than vector at 35dBHz -->
    <!-- claim: deep_integration_ci: vector loss_of_lock_fraction within [-0.001, 0.001] -->

(``at CASE`` only for a claim of one case). This test reads every marker of
``docs/experiments/*.md`` and requires that ``examples/<example>.toml`` holds that
``[[claims]]`` entry and that ``.ci/run`` runs ``gnssframework compare`` on that example
with ``--check``, so a claim removed, changed or no longer checked in CI breaks the build
until the page says so too.
"""

from __future__ import annotations

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
    ci = (ROOT / ".ci" / "run").read_text()
    return {m.group(1) for line in ci.splitlines() if "--check" in line and not line.lstrip().startswith("#")
            for m in re.finditer(r"compare\s+examples/([\w-]+)\.toml", line)}


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
        f"{page}:{line}: .ci/run does not run 'gnssframework compare examples/{example.name} --check'"


def test_a_marker_for_a_missing_claim_is_caught():
    claims = [{"candidate": "deep", "reference": "vector", "metric": "horizontal_velocity_error_rmse",
               "direction": "lower"}]
    assert _matches(claims[0], _parse("x: deep horizontal_velocity_error_rmse lower than vector"))
    assert not _matches(claims[0], _parse("x: deep horizontal_velocity_error_rmse higher than vector"))
    assert not _matches(claims[0], _parse("x: deep horizontal_velocity_error_rmse lower than vector at 35dBHz"))
    assert not _matches(claims[0], _parse("x: deep horizontal_velocity_error_rmse within [0, 1]"))
    with pytest.raises(AssertionError, match="unreadable claim marker"):
        _parse("x: deep beats vector")
