"""Orderings on the experiment pages are claims CI checks (issue 22's acceptance).

A page states an ordering (or a bound) next to a marker naming the claim it rests on, an
HTML comment the reader does not see::

    <!-- claim: deep_integration_ci: deep horizontal_velocity_error_rmse lower than vector at 35dBHz -->
    <!-- claim: deep_integration_ci: vector loss_of_lock_fraction every run within [-0.001, 0.001] -->

An equivalence (``equivalence_margin``, two one-sided tests) names its margin::

    <!-- claim: vector_tracking_realistic: ackf position_error_rmse equivalent to discriminator within 1.0 -->

(``at CASE`` only for a claim of one case; an ordering between cases names the reference
case: ``... higher than deep in nominal at gsens``; one between two metrics of the candidate,
a ``versus_metric`` claim, names the other metric: ``... lower than its position_error_rmse``).
A claim at a sweep's points ends with
``at SWEEP=POINTS``: ``cn0_dbhz=30..50`` for ``from``/``to`` (either end may be left
out), ``cn0_dbhz=30`` or ``cn0_dbhz=30,40`` for ``at``, ``cn0_dbhz=all`` for every point::

    <!-- claim: vector_tracking_sweep_ci: ackf nees_velocity within [1.0, 5.0] at cn0_dbhz=all -->

A consistency claim (``consistent_states``, the chi-square band) names its states::

    <!-- claim: vector_tracking: ackf nees_position consistent over 3 states -->

This test reads every marker of ``docs/experiments/*.md`` (and of any other docs page that
carries one, e.g. the smoothers page's) and requires that
``examples/<example>.toml`` holds that ``[[claims]]`` entry and that CI checks that
example's claims (``gnssframework compare ... --check`` in ``.ci/run``, or
``docs/make_experiment_plots.py``, which CI runs and which fails when a claim of its
examples does not hold), so a claim removed, changed or no longer checked in CI breaks
the build until the page says so too.

An ordering written *without* a marker is found too: a conservative detector of comparative
statements in the pages' prose ("beats", "lower than", "3x smaller", "wins", ...) requires a
claim marker in the same paragraph, or an exemption ``<!-- not-compared: reason -->`` with a
reason (a definition, a bound, a measurement no claim checks).
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

from gnssframework.experiments.config_base import read_config_data

ROOT = Path(__file__).resolve().parents[2]
PAGES = sorted((ROOT / "docs" / "experiments").glob("*.md"))
#: Pages outside docs/experiments whose claim markers are checked too (their prose is not scanned).
_HISTORY = ROOT / "docs" / "history.md"  # the changelog's page quotes markers as text
OTHER_MARKED_PAGES = sorted(
    p
    for p in (ROOT / "docs").rglob("*.md")
    if p.parent != ROOT / "docs" / "experiments" and p != _HISTORY and "<!-- claim:" in p.read_text()
)
MARKER = re.compile(r"<!--\s*claim:\s*(?P<body>.*?)\s*-->", re.S)
_WHERE = r"(?:\s+at\s+(?P<case>[^\s=]+))?(?:\s+at\s+(?P<sweep>[\w.+-]+)=(?P<points>\S+))?$"
ORDERING = re.compile(
    r"(?P<example>[\w-]+):\s+(?P<candidate>\S+)\s+(?P<metric>\w+)\s+"
    r"(?P<direction>lower|higher) than\s+(?:its\s+(?P<versus_metric>\w+)|(?P<reference>\S+))"
    r"(?:\s+in\s+(?P<reference_case>[^\s=]+))?" + _WHERE
)
EQUIVALENCE = re.compile(
    r"(?P<example>[\w-]+):\s+(?P<candidate>\S+)\s+(?P<metric>\w+)\s+equivalent to\s+(?P<reference>\S+)"
    r"\s+within\s+(?P<margin>[0-9.eE+-]+)" + _WHERE
)
BOUND = re.compile(
    r"(?P<example>[\w-]+):\s+(?P<candidate>\S+)\s+(?P<metric>\w+)\s+(?P<every>every run )?within\s+"
    r"\[(?P<low>[^,\]]+),\s*(?P<high>[^\]]+)\]" + _WHERE
)
#: A consistency claim (``consistent_states``: the averaged NEES inside its chi-square 95 % band):
#: ``ackf nees_position consistent over 3 states [at CASE] [at SWEEP=POINTS]``.
CONSISTENT = re.compile(
    r"(?P<example>[\w-]+):\s+(?P<candidate>\S+)\s+(?P<metric>\w+)\s+consistent over\s+(?P<states>\d+)\s+states" + _WHERE
)
#: A threshold claim (``threshold`` / ``threshold_difference`` along a sweep with a threshold table):
#: ``kf loss_of_lock threshold lower than pll along cn0 [within [-9, -5]]`` or
#: ``kf loss_of_lock threshold within [-1, 1] of pll along cn0`` (``at CASE`` after the sweep for a
#: claim of one case; ``pll in static along ...`` for a reference in another case).
THRESHOLD = re.compile(
    r"(?P<example>[\w-]+):\s+(?P<candidate>\S+)\s+(?P<metric>\w+)\s+threshold\s+"
    r"(?:(?P<threshold>lower|higher) than|within \[(?P<low>[^,\]]+),\s*(?P<high>[^\]]+)\] of)\s+"
    r"(?P<reference>\S+)(?:\s+in\s+(?P<reference_case>[^\s=]+))?\s+along\s+(?P<sweep>[\w.+-]+)(?:\s+at\s+(?P<case>[^\s=]+))?"
    r"(?:\s+within\s+\[(?P<dlow>[^,\]]+),\s*(?P<dhigh>[^\]]+)\])?$"
)


def _markers() -> list[tuple[str, int, str]]:
    found = []
    for page in PAGES + OTHER_MARKED_PAGES:
        text = page.read_text()
        for m in MARKER.finditer(text):
            found.append(
                (
                    str(page.relative_to(ROOT / "docs")),
                    text.count("\n", 0, m.start()) + 1,
                    " ".join(m.group("body").split()),
                )
            )
    return found


def _parse(body: str) -> dict:
    t = THRESHOLD.match(body)
    if t is not None:
        return {**t.groupdict(), "kind": "threshold"}
    m = ORDERING.match(body) or EQUIVALENCE.match(body) or BOUND.match(body) or CONSISTENT.match(body)
    if m is None:
        raise AssertionError(
            f"unreadable claim marker {body!r}: write '<example>: <candidate> <metric> "
            "lower|higher than <reference> [at <case>] [at <sweep>=<points>]', '... equivalent to "
            "<reference> within <margin> [at <case>]', '... within "
            "[low, high] [at <case>] [at <sweep>=<points>]' or '... consistent over <n> states [at <case>]'"
        )
    return m.groupdict()


def _point(text: str) -> float | str:
    try:
        return float(text)
    except ValueError:
        return text


def _same_points(claim: dict, want: dict) -> bool:
    """Whether the claim's sweep and points are the marker's ``at SWEEP=POINTS`` (none: no sweep)."""
    if claim.get("sweep") != want.get("sweep"):
        return False
    if want.get("sweep") is None:
        return True
    at, low, high, points = claim.get("at"), claim.get("from"), claim.get("to"), want["points"]
    if points == "all":
        return at is None and low is None and high is None
    if ".." in points:
        first, last = points.split("..", 1)
        return at is None and low == (_point(first) if first else None) and high == (_point(last) if last else None)
    return at is not None and [_point(str(v)) for v in (at if isinstance(at, list) else [at])] == [
        _point(v) for v in points.split(",")
    ]


def _matches(claim: dict, want: dict) -> bool:
    if want.get("kind") == "threshold":
        low, high = (want["low"], want["high"]) if want["low"] is not None else (want["dlow"], want["dhigh"])
        difference = None if low is None else (float(low), float(high))
        got = claim.get("threshold_difference")
        reference = claim.get("reference") or claim["candidate"]  # with reference_case: the candidate itself
        return (
            (claim["candidate"], claim["metric"], reference, claim.get("sweep"), claim.get("case"))
            == (want["candidate"], want["metric"], want["reference"], want["sweep"], want["case"])
            and claim.get("reference_case") == want["reference_case"]
            and claim.get("threshold") == want["threshold"]
            and (None if got is None else tuple(float(v) for v in got)) == difference
        )
    if (claim["candidate"], claim["metric"], claim.get("case")) != (want["candidate"], want["metric"], want["case"]):
        return False
    if not _same_points(claim, want):
        return False
    if want.get("versus_metric") or claim.get("versus_metric"):  # two metrics of one candidate
        return (
            claim.get("versus_metric") == want.get("versus_metric")
            and claim.get("direction") == want["direction"]
            and claim.get("reference") is None
        )
    if want.get("margin") is not None:  # an equivalence: its reference and margin
        margin = claim.get("equivalence_margin")
        return (
            margin is not None
            and float(margin) == float(want["margin"])
            and claim.get("reference") == want["reference"]
            and claim.get("direction") is None
        )
    if want.get("direction"):  # an ordering between cases names its reference case ("... than deep in nominal")
        reference = claim.get("reference") or (claim["candidate"] if claim.get("reference_case") else None)
        return (
            claim.get("direction") == want["direction"]
            and reference == want["reference"]
            and claim.get("reference_case") == want.get("reference_case")
        )
    if want.get("states") is not None:  # a consistency claim: the chi-square band of n states
        return claim.get("consistent_states") == int(want["states"]) and claim.get("within") is None
    within = claim.get("every_run_within" if want.get("every") else "within")  # "every run within": every_run_within
    return within is not None and tuple(within) == (float(want["low"]), float(want["high"]))


def _checked_in_ci() -> set[str]:
    """Examples CI checks the claims of: ``compare examples/X.toml ... --check`` in .ci/run,
    and the examples ``docs/make_experiment_plots.py`` runs (it exits 1 when a claim fails)
    when .ci/run runs it."""
    lines = [line for line in (ROOT / ".ci" / "run").read_text().splitlines() if not line.lstrip().startswith("#")]
    checked = {
        m.group(1)
        for line in lines
        if "--check" in line
        for m in re.finditer(r"compare\s+examples/([\w-]+)\.toml", line)
    }
    if any("docs/make_experiment_plots.py" in line and "--slow" not in line for line in lines):
        tree = ast.parse((ROOT / "docs" / "make_experiment_plots.py").read_text())
        checked |= next(
            set(ast.literal_eval(node.value))
            for node in tree.body
            if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "EXAMPLES" for t in node.targets)
        )
    return checked


MARKERS = _markers()


def test_the_pages_mark_their_orderings():
    # The pages whose orderings rest on claims carry markers; an empty scan would mean the regex broke.
    pages = {page for page, _, _ in MARKERS}
    assert {"experiments/deep-integration.md", "experiments/vector-tracking.md", "estimators/smoothers.md"} <= pages


@pytest.mark.parametrize("page, line, body", MARKERS, ids=[f"{p}:{n}" for p, n, _ in MARKERS])
def test_every_marked_ordering_is_a_claim_ci_checks(page, line, body):
    want = _parse(body)
    example = ROOT / "examples" / f"{want['example']}.toml"
    assert example.is_file(), f"{page}:{line}: no example {example.name}"
    claims = read_config_data(example).get("claims", [])
    assert any(_matches(c, want) for c in claims), f"{page}:{line}: {example.name} has no claim {body!r}"
    assert want["example"] in _checked_in_ci(), (
        f"{page}:{line}: CI does not check the claims of {example.name} (.ci/run's compare --check or "
        "docs/make_experiment_plots.py's EXAMPLES)"
    )


def test_ci_checks_the_reference_examples():
    assert {
        "vector_tracking",
        "deep_integration_ci",
        "carrier_smoothing",
        "vector_tracking_tcxo",
        "vector_tracking_regime_static_ci",
        "vector_tracking_regime_moving_ci",
        "vector_tracking_modes",
        "vector_tracking_sweep_ci",
        "vector_tracking_modes_moving",
    } <= _checked_in_ci()
    assert "deep_integration" not in _checked_in_ci()  # too slow for CI: its claims are not CI's


def test_a_marker_for_a_missing_claim_is_caught():
    claims = [
        {"candidate": "deep", "reference": "vector", "metric": "horizontal_velocity_error_rmse", "direction": "lower"}
    ]
    assert _matches(claims[0], _parse("x: deep horizontal_velocity_error_rmse lower than vector"))
    assert not _matches(claims[0], _parse("x: deep horizontal_velocity_error_rmse higher than vector"))
    assert not _matches(claims[0], _parse("x: deep horizontal_velocity_error_rmse lower than vector at 35dBHz"))
    assert not _matches(claims[0], _parse("x: deep horizontal_velocity_error_rmse within [0, 1]"))
    between_cases = {
        "candidate": "deep",
        "reference_case": "nominal",
        "metric": "freq_tracking_error_rmse",
        "direction": "higher",
        "case": "gsens",
    }
    assert _matches(between_cases, _parse("x: deep freq_tracking_error_rmse higher than deep in nominal at gsens"))
    assert not _matches(between_cases, _parse("x: deep freq_tracking_error_rmse higher than deep at gsens"))
    assert not _matches(claims[0], _parse("x: deep horizontal_velocity_error_rmse lower than vector in nominal"))
    with pytest.raises(AssertionError, match="unreadable claim marker"):
        _parse("x: deep beats vector")


def test_a_marker_names_a_claim_between_two_metrics():
    claim = {
        "candidate": "ekf-pv",
        "metric": "position_smoothed_error_rmse",
        "versus_metric": "position_error_rmse",
        "direction": "lower",
        "case": "45dBHz",
    }
    body = "x: ekf-pv position_smoothed_error_rmse lower than its position_error_rmse"
    assert _parse(body)["versus_metric"] == "position_error_rmse" and _parse(body)["reference"] is None
    assert _matches(claim, _parse(body + " at 45dBHz"))
    assert not _matches(claim, _parse(body))  # the claim is of one case
    assert not _matches(claim, _parse(body.replace("lower", "higher") + " at 45dBHz"))
    assert not _matches(
        claim, _parse(body.replace("its position_error_rmse", "its velocity_error_rmse") + " at 45dBHz")
    )
    # an ordering against a candidate is not one against a metric, either way round
    assert not _matches(claim, _parse("x: ekf-pv position_smoothed_error_rmse lower than ekf-pv at 45dBHz"))
    between_candidates = {k: v for k, v in claim.items() if k != "versus_metric"} | {"reference": "ekf-pv"}
    assert not _matches(between_candidates, _parse(body + " at 45dBHz"))


def test_a_marker_names_a_claims_sweep_points():
    claim = {
        "candidate": "ackf",
        "reference": "discriminator",
        "metric": "velocity_error_rmse",
        "direction": "lower",
        "sweep": "cn0_dbhz",
        "from": 30.0,
        "to": 50.0,
    }
    want = _parse("x: ackf velocity_error_rmse lower than discriminator at cn0_dbhz=30..50")
    assert (want["case"], want["sweep"], want["points"]) == (None, "cn0_dbhz", "30..50")
    assert _matches(claim, want)
    for other in ("at cn0_dbhz=30..45", "at cn0_dbhz=30", "at cn0_dbhz=all", "at snr=30..50", ""):
        body = f"x: ackf velocity_error_rmse lower than discriminator {other}".strip()
        assert not _matches(claim, _parse(body)), other
    assert not _matches({**claim, "direction": "higher"}, want)
    listed = {**claim, "from": None, "to": None, "at": [30, 40]}
    assert _matches(listed, _parse("x: ackf velocity_error_rmse lower than discriminator at cn0_dbhz=30,40"))
    assert not _matches(listed, _parse("x: ackf velocity_error_rmse lower than discriminator at cn0_dbhz=30"))
    single = {**claim, "from": None, "to": None, "at": 50}
    assert _matches(single, _parse("x: ackf velocity_error_rmse lower than discriminator at cn0_dbhz=50"))
    every = {"candidate": "ackf", "metric": "nees_velocity", "within": [1.0, 5.0], "sweep": "cn0_dbhz"}
    assert _matches(every, _parse("x: ackf nees_velocity within [1.0, 5.0] at cn0_dbhz=all"))
    assert _matches({**every, "case": "cn0"}, _parse("x: ackf nees_velocity within [1.0, 5.0] at cn0 at cn0_dbhz=all"))
    assert not _matches(every, _parse("x: ackf nees_velocity within [1.0, 5.0]"))
    each = {"candidate": "deep", "metric": "loss_of_lock_fraction", "every_run_within": [-0.001, 0.001]}
    assert _matches(each, _parse("x: deep loss_of_lock_fraction every run within [-0.001, 0.001]"))
    assert not _matches(each, _parse("x: deep loss_of_lock_fraction within [-0.001, 0.001]"))
    assert not _matches(
        {"candidate": "deep", "metric": "loss_of_lock_fraction", "within": [-0.001, 0.001]},
        _parse("x: deep loss_of_lock_fraction every run within [-0.001, 0.001]"),
    )
    upto = {**every, "to": 40}
    assert _matches(upto, _parse("x: ackf nees_velocity within [1.0, 5.0] at cn0_dbhz=..40"))


# --- Orderings written without a marker ------------------------------------------------
#
# A conservative detector of comparative statements in the pages' prose: a paragraph (lines
# between blank lines; headings, tables, code blocks and HTML comments are not prose) that
# says one thing beats, wins over, or is lower/better/N times smaller than another must
# carry a claim marker, or an exemption ``<!-- not-compared: reason -->`` saying why it is
# not an ordering CI checks (a definition, an arithmetic fact, a measurement of one run).

COMPARATIVE = re.compile(
    r"\b(?:beats?|beating|outperform(?:s|ed|ing)?|wins?|winning|loses? to"
    r"|(?:better|worse|lower|higher|smaller|larger) than"
    r"|\d+(?:\.\d+)?\s*(?:x|×|times)\s+(?:smaller|lower|larger|higher|better|worse))\b",
    re.I,
)
EXEMPTION = re.compile(r"<!--\s*not-compared:(?P<reason>.*?)-->", re.S)
_FENCE = re.compile(r"^\s*(```|~~~)")
_COMMENT = re.compile(r"<!--.*?-->", re.S)
_INLINE_CODE = re.compile(r"`[^`\n]*`")


_ITEM = re.compile(r"^(?:[-*+]|\d+\.)\s")


def paragraphs(text: str) -> list[tuple[int, str]]:
    """(first line, text) of each prose paragraph of a markdown page, code blocks left out;
    each top-level list item is a paragraph of its own (with its nested lines)."""
    found, block, start, fenced = [], [], 0, False
    for number, line in enumerate(text.splitlines() + [""], start=1):
        if _FENCE.match(line):
            fenced = not fenced
            continue
        if fenced:
            continue
        if block and (not line.strip() or _ITEM.match(line)):
            found.append((start, "\n".join(block)))
            block = []
        if line.strip():
            if not block:
                start = number
            block.append(line)
    return found


def unmarked_orderings(text: str) -> list[str]:
    """One line per paragraph of ``text`` that states a comparison without a claim marker
    or a non-empty ``not-compared`` exemption."""
    problems = []
    for start, para in paragraphs(text):
        empty = [m for m in EXEMPTION.finditer(para) if not m.group("reason").strip()]
        if empty:
            problems.append(f"line {start}: '<!-- not-compared: -->' needs a reason")
            continue
        prose = " ".join(
            line
            for line in _COMMENT.sub(" ", para).splitlines()
            if not line.lstrip().startswith(("|", "#", "--8<--", "!["))
        )
        hit = COMPARATIVE.search(_INLINE_CODE.sub(" ", prose))
        if hit and not MARKER.search(para) and not EXEMPTION.search(para):
            problems.append(
                f"line {start}: {hit.group(0)!r} states an ordering without a claim marker "
                "('<!-- claim: example: ... -->') or '<!-- not-compared: reason -->'"
            )
    return problems


@pytest.mark.parametrize("page", PAGES, ids=[p.name for p in PAGES])
def test_every_ordering_in_prose_is_marked(page):
    problems = unmarked_orderings(page.read_text())
    assert not problems, f"{page.name}: " + "; ".join(problems)


@pytest.mark.parametrize(
    "text",
    [
        "The CKF beats the baseline.",
        "Its error is 3.7x smaller at 45 dB-Hz.",
        "Its error is 3.7 times lower at 45 dB-Hz.",
        "- first item\n- `deep` is better than\n  `vector` in velocity",
        "Narrow loops win here.",
        "Raw code is lower than smoothing. <!-- not-compared:   -->",
        "The ordering is stated. <!-- claim is not a marker -->\nIt outperforms the PLL.",
        "- `a` beats `b`.\n- `c` ties `d`.\n  <!-- claim: x: c m lower than d -->",
    ],
)
def test_an_unmarked_ordering_is_found(text):
    assert unmarked_orderings(text), text


@pytest.mark.parametrize(
    "text",
    [
        "The CKF beats the baseline.\n<!-- claim: vector_tracking: ackf velocity_error_rmse lower than discriminator -->",
        "Its error is 3.7x smaller. <!-- not-compared: one run's measurement, no paired difference -->",
        "| a | b |\n| --- | --- |\n| beats | 3x lower |",
        "```python\nassert a.lower() != b  # lower than\n```",
        "The option `better-than` is a name.",
        "## Why the narrow loop wins",
        "Lower bounds, higher order, the winner's window: no comparison.",
    ],
)
def test_what_is_not_an_unmarked_ordering_passes(text):
    assert not unmarked_orderings(text), unmarked_orderings(text)


# --- CI-sized examples evaluated at another example's tuned values -------------------------

_TUNED_ROW = re.compile(
    r"^\|\s*(?:`(?P<candidate>[^`]+)`)?\s*\|\s*`(?P<label>[^`]+)`\s*\|[^|]*\|\s*(?P<tuned>[^|\s]+)\s*\|"
)


def _tuned_values(generated: Path) -> dict[tuple[str, str], float]:
    """(candidate, parameter label) -> tuned value, from a generated page table's tuning section."""
    values, candidate = {}, None
    for line in generated.read_text().split("**Tuning**", 1)[1].split("**Claims**", 1)[0].splitlines():
        m = _TUNED_ROW.match(line)
        if m:
            candidate = m.group("candidate") or candidate
            values[(candidate, m.group("label"))] = float(m.group("tuned"))
    return values


def _param(candidate: dict, label: str) -> float:
    component, _, *path = label.split(".")
    value = candidate[component]["params"]
    for key in path:
        value = value[int(key)] if key.isdigit() else value[key]
    return float(value)


@pytest.mark.parametrize(
    "example, tuned_by",
    [
        ("vector_tracking_regime_static_ci", "vector_tracking_static"),
        ("vector_tracking_regime_moving_ci", "vector_tracking_moving"),
        ("vector_tracking_tcxo", "vector_tracking"),
        ("vector_tracking_modes", "vector_tracking"),
        ("vector_tracking_fade_ci", "vector_tracking"),
        ("vector_tracking_modes_moving", "vector_tracking"),
        ("vector_tracking_sweep", "vector_tracking"),
        ("vector_tracking_sweep_ci", "vector_tracking"),
    ],
)
def test_ci_examples_evaluate_at_the_tuned_values(example, tuned_by):
    # The CI examples carry the values the slow tuning selected (its generated table, 3
    # significant digits); a retuning that moves them must move the CI example too.
    tuned = _tuned_values(ROOT / "docs" / "experiments" / "generated" / f"{tuned_by}.md")
    candidates = {c["name"]: c for c in read_config_data(ROOT / "examples" / f"{example}.toml")["candidates"]}
    checked = [(name, label) for name, label in tuned if name in candidates]
    assert {name for name, _ in checked} >= {"ackf", "discriminator"}
    for name, label in checked:
        assert _param(candidates[name], label) == pytest.approx(tuned[(name, label)], rel=5e-3), (
            f"{example}.toml: {name} {label} is not {tuned_by}'s tuned {tuned[(name, label)]}"
        )


def test_a_threshold_marker_names_the_claims_kind_and_interval():
    claim = {
        "candidate": "kf",
        "reference": "pll",
        "metric": "loss_of_lock",
        "sweep": "cn0",
        "threshold": "lower",
        "threshold_difference": [-9.0, -5.5],
    }
    assert _matches(claim, _parse("x: kf loss_of_lock threshold lower than pll along cn0 within [-9.0, -5.5]"))
    assert not _matches(claim, _parse("x: kf loss_of_lock threshold lower than pll along cn0"))
    assert not _matches(claim, _parse("x: kf loss_of_lock threshold higher than pll along cn0 within [-9.0, -5.5]"))
    only = {**claim, "threshold": None, "threshold_difference": [-1.0, 1.0]}
    assert _matches(only, _parse("x: kf loss_of_lock threshold within [-1.0, 1.0] of pll along cn0"))
    assert not _matches(only, _parse("x: kf loss_of_lock threshold within [-1.0, 2.0] of pll along cn0"))
    one = {**claim, "case": "accel"}
    assert _matches(one, _parse("x: kf loss_of_lock threshold lower than pll along cn0 at accel within [-9.0, -5.5]"))
    assert not _matches(one, _parse("x: kf loss_of_lock threshold lower than pll along cn0 within [-9.0, -5.5]"))


def test_a_marker_names_an_equivalence_and_its_margin():
    claim = {
        "candidate": "ackf",
        "reference": "discriminator",
        "metric": "position_error_rmse",
        "equivalence_margin": 1,
    }
    body = "x: ackf position_error_rmse equivalent to discriminator within 1.0"
    assert _parse(body)["margin"] == "1.0"
    assert _matches(claim, _parse(body))
    assert not _matches(claim, _parse(body.replace("1.0", "0.5")))  # another margin
    assert not _matches(claim, _parse(body.replace("to discriminator", "to ckf")))
    assert not _matches(claim, _parse(body + " at 45dBHz"))  # the claim is of every case
    # an ordering is not an equivalence, either way round
    assert not _matches(claim, _parse("x: ackf position_error_rmse lower than discriminator"))
    ordering = {k: v for k, v in claim.items() if k != "equivalence_margin"} | {"direction": "lower"}
    assert not _matches(ordering, _parse(body))
