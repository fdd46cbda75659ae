"""Claims: the orderings and bounds a comparison states, checked from its paired runs.

A page that says "A's frequency error is lower than B's" should say it because a run
checked it, on the machine that made the page and on every other. A config lists such
statements as ``[[claims]]``::

    [[claims]]                       # an ordering: paired difference to a reference
    candidate = "ackf"
    reference = "discriminator"
    metric = "carrier_freq_error_rmse"
    direction = "lower"              # the candidate's values are lower
    ratio_max = 0.55                 # optional: and the ratio of means is below 0.55
    case = "45dBHz"                  # optional: default every case (checked in each)

    [[claims]]                       # a bound on one candidate's mean
    candidate = "ackf"
    metric = "nees_velocity"
    within = [1.0, 10.0]

    [[claims]]                       # an ordering between cases: the same candidate
    candidate = "deep"
    metric = "freq_tracking_error_rmse"
    reference_case = "nominal"       # paired with its own runs in case "nominal"
    case = "g-sensitivity"           # optional: default every other case
    direction = "higher"

    [[claims]]                       # an ordering between two metrics of one candidate
    candidate = "ekf-pv"
    metric = "position_smoothed_error_rmse"
    versus_metric = "position_error_rmse"   # paired with its own value of this metric, run by run
    direction = "lower"

An ordering between two metrics pairs the candidate's value of ``metric`` in run ``r`` with
its value of ``versus_metric`` in the same run (the two are computed from the same run, so
the pairing is exact); the tested quantity is ``metric - versus_metric`` (and the ratio of
their means), judged exactly as a paired difference between candidates. The two metrics
must have the same unit.

An ordering between cases pairs run ``r`` of one case with run ``r`` of the other; the
pairing removes the shared noise only when the two cases draw the same random numbers
(``streams`` of ``[[cases]]``: the case that differs by an option names the reference
case's streams), so a case pair that differs only by a scenario option is compared on
common random numbers, as candidates are.

Each claim is evaluated per case into one of three outcomes, from the same 95 % t-
intervals the report's significance marks use (:data:`~.stats.SIGNIFICANCE_RULE`):

- ``holds``: the interval lies on the claimed side (the paired difference's interval
  excludes 0 on the claimed sign; the ratio's interval lies below ``ratio_max`` / above
  ``ratio_min``; the mean's interval lies inside ``within``);
- ``fails``: the interval lies entirely on the other side;
- ``not significant``: the interval straddles the bound: the runs cannot tell.

A claim with several conditions takes the worst outcome. ``summary.json`` and
``report.md`` list every claim's outcome with its evidence; ``gnssframework compare
--check`` exits 1 unless every claim holds, which is how CI checks what the docs state.

Claims at a sweep's points
--------------------------
A claim naming a ``[[sweeps]]`` entry is evaluated at that sweep's points instead of the
example's own cases (each point is the comparison with the swept value set, see
:mod:`.sweeps`)::

    [[claims]]                       # at every point from 30 to 50 (inclusive)
    candidate = "ackf"
    reference = "discriminator"
    metric = "velocity_error_rmse"
    direction = "lower"
    sweep = "cn0_dbhz"               # a sweep's name
    from = 30.0                      # optional: first point (default the sweep's first)
    to = 50.0                        # optional: last point (default its last)

    [[claims]]                       # at the points listed
    candidate = "discriminator-fixed-r"
    reference = "discriminator"
    metric = "velocity_error_rmse"
    direction = "higher"
    sweep = "cn0_dbhz"
    at = [25.0, 30.0]                # or one value: at = 30.0

``case`` then names a case the sweep varies (default each of them). Each point is one
test, judged exactly like a case claim (the same 95 % t-intervals), and gives one
outcome; a claim over several points adds one all-points outcome (``point`` ``"all"``):

- ``holds`` when it holds at every point: an intersection-union test, whose chance of
  wrongly saying "holds everywhere" is at most that of one point, so the
  per-point level needs no correction for it (R. L. Berger, "Multiparameter hypothesis
  testing and acceptance sampling", Technometrics 24(4), 1982);
- ``fails`` when at some point the claim fails at the Bonferroni-corrected level
  ``0.05 / N`` over the claim's ``N`` points (the t-interval at ``1 - 0.05 / N``): "fails
  somewhere" is a union of ``N`` tests, and the correction keeps its false-alarm rate at
  5 % (Holm's step-down, S. Holm, Scand. J. Statist. 6, 1979, gives the same answer to
  "does any point fail": its first step is Bonferroni's);
- ``not significant`` otherwise.

The per-point outcomes keep the uncorrected 95 % rule (each is a statement of its own, as a
claim checked in every case is), so ``compare --check``, which requires every outcome to
hold, is the conjunction of them all.
"""

from __future__ import annotations

import math
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from ..errors import ConfigError
from .claim_tests import (
    adjust,
    all_runs_bound,
    bootstrap_means,
    bootstrap_p,
    claim_rng,
    detectable_difference,
    equivalence_margin_for_power,
    nees_band,
    t_p_value,
    tost,
    wilcoxon_p,
)
from .number_format import at_rounding_level, format_estimate
from .stats import finite_or_none, mean_and_se, paired_difference, paired_values, t_quantile

__all__ = [
    "Claim",
    "replication_failed",
    "check_claims",
    "check_untuned_claims",
    "evaluate_claims",
    "claim_points",
    "OUTCOMES",
    "untuned_candidates",
    "adjust_claims",
    "small_n_declared",
    "unstated_small_n",
    "unstated_small_n_claims",
    "small_n_refusal",
    "MIN_CLAIM_RUNS",
    "STATED_POWER",
]

#: Outcomes from best to worst (``refused``: the claim cannot be tested as stated, e.g. its
#: metric has no spread over the runs).
OUTCOMES = ("holds", "not significant", "fails", "refused")

#: Tests a claim may ask for (``test``): the t-interval, the paired bootstrap, the
#: Wilcoxon signed-rank test (orderings by ``direction`` only).
TESTS = ("t", "bootstrap", "wilcoxon")

#: Significance level of every claim (two-sided 95 % intervals; TOST at 5 % per side).
ALPHA = 0.05

#: Paired runs below which a claim row states its power: the difference its t-test detects
#: with 80 % probability (`claim_tests.detectable_difference`), beside its evidence; and
#: below which ``compare --check`` refuses a claim that does not declare ``small_n = true``.
MIN_CLAIM_RUNS = 12

#: The power at which a claim over fewer than :data:`MIN_CLAIM_RUNS` runs states its
#: minimum detectable difference.
STATED_POWER = 0.8


class Claim(BaseModel):
    """One statement about a comparison's results (see the module docstring)."""

    model_config = ConfigDict(extra="forbid", validate_by_name=True, validate_by_alias=True)
    candidate: str = Field(..., description="the candidate the claim is about")
    metric: str = Field(..., description="a reported metric")
    case: str | None = Field(None, description="the case (default: the claim must hold in every case)")
    reference: str | None = Field(
        None,
        description="for an ordering: the candidate compared with (paired runs); "
        "with reference_case, default the candidate itself",
    )
    reference_case: str | None = Field(
        None,
        description="for an ordering between cases: the case the reference's "
        "runs come from (paired run by run with each claimed case)",
    )
    versus_metric: str | None = Field(
        None,
        description="for an ordering between two metrics of the candidate: "
        "the metric compared with, on the candidate's same runs (paired run by run; "
        "the difference is metric minus versus_metric, in one unit)",
    )
    direction: Literal["lower", "higher"] | None = Field(
        None, description="for an ordering: the candidate's values are lower / higher than the reference's"
    )
    ratio_max: float | None = Field(
        None, gt=0, description="for an ordering: ratio of means (candidate / reference) below this"
    )
    ratio_min: float | None = Field(None, gt=0, description="for an ordering: ratio of means above this")
    within: tuple[float, float] | None = Field(
        None, description="for a bound: the candidate's mean lies in [low, high]"
    )
    sweep: str | None = Field(
        None,
        description="evaluate at this sweep's points (a [[sweeps]] name) instead of "
        "the example's cases; each point one outcome, plus one for all of them",
    )
    at: float | str | list[float | str] | None = Field(
        None, description="with sweep: the point or list of points (swept values)"
    )
    points_from: float | None = Field(
        None, alias="from", description="with sweep: every point from this value (inclusive; default the first)"
    )
    points_to: float | None = Field(
        None, alias="to", description="with sweep: every point up to this value (inclusive; default the last)"
    )
    threshold: Literal["lower", "higher"] | None = Field(
        None,
        description="with sweep (one with a threshold table) and reference: the candidate's threshold is "
        "lower / higher than the reference's (paired bootstrap 95 % interval of the difference)",
    )
    threshold_difference: tuple[float, float] | None = Field(
        None,
        description="with sweep and reference: the candidate's threshold minus the reference's lies in "
        "[low, high] (its paired bootstrap 95 % interval does)",
    )
    equivalence_margin: float | None = Field(
        None,
        gt=0,
        description="for an ordering: the candidate and the reference are equivalent, |paired mean "
        "difference| < margin (two one-sided tests at 5 %: the 90 % interval inside (-margin, margin))",
    )
    consistent_states: int | None = Field(
        None,
        ge=1,
        le=1000,
        description="for a NEES metric: the candidate is consistent, its mean over the N runs "
        "inside the two-sided 95 % chi-square band [chi2(0.025, N n) / N, chi2(0.975, N n) / N] of n states",
    )
    every_run_within: tuple[float, float] | None = Field(
        None,
        description="every run's value lies in [low, high] (an observation over all runs, with the exact 95 % "
        "upper bound on the chance of a run outside; for a metric that is the same in every run, e.g. no loss of lock); "
        "with reference or reference_case, every run's paired difference (the candidate's minus the reference's)",
    )
    test: Literal["t", "bootstrap", "wilcoxon"] = Field(
        "t",
        description="t: the t-interval (default); bootstrap: the paired bootstrap percentile interval "
        "(heavy-tailed metrics: maxima, loss of lock), reproducible from the seed; wilcoxon: the signed-rank test "
        "of the paired differences (direction only)",
    )
    small_n: bool = Field(
        False,
        strict=True,
        description=f"the claim is checked on fewer than {MIN_CLAIM_RUNS} runs on "
        "purpose (e.g. a CI example kept short): compare --check accepts it and states its power, "
        "the difference its test detects with probability 0.8; without it such a claim is refused",
    )
    replicates: bool = Field(
        True,
        strict=True,
        description="false: the claim is stated to hold on the evaluation runs only (its page says so: "
        "re-checked on the replicate runs, it did not hold there); compare --check --replicate then checks it on "
        "the evaluation runs and reports its replicate outcome, marked, without failing on it",
    )
    note: str = Field("", description="where the claim is stated (a docs page, a paper's table)")

    @model_validator(mode="after")
    def _one_kind(self) -> Claim:
        self._new_kinds()
        if self.threshold is not None or self.threshold_difference is not None:
            if (self.reference is None and self.reference_case is None) or self.sweep is None:
                raise ValueError(
                    "a threshold claim compares the candidate's threshold with a reference candidate's "
                    'along a sweep: give reference = "<candidate>" (or reference_case = "<case>") and '
                    'sweep = "<name>"'
                )
            others = [
                k
                for k in (
                    "direction",
                    "ratio_max",
                    "ratio_min",
                    "within",
                    "versus_metric",
                    "at",
                    "points_from",
                    "points_to",
                )
                if getattr(self, k) is not None
            ]
            if others:
                raise ValueError(f"a threshold claim is about the whole sweep; {', '.join(others)} is a separate claim")
            if self.reference == self.candidate and self.reference_case is None:
                raise ValueError("the reference must be another candidate (or the same in a reference_case)")
            if self.case is not None and self.case == self.reference_case:
                raise ValueError(f"case and reference_case are both {self.case!r}: compare two cases")
            bounds = self.threshold_difference
            if bounds is not None and not bounds[0] < bounds[1]:
                raise ValueError(
                    f"threshold_difference = {list(self.threshold_difference)} must be [low, high] with low < high"
                )
            return self
        ordering = [
            k for k in ("direction", "ratio_max", "ratio_min", "equivalence_margin") if getattr(self, k) is not None
        ]
        if self.consistent_states is not None or self.every_run_within is not None:
            return self
        if self.versus_metric is not None:
            self._between_metrics(ordering)
        elif self.reference_case is not None:
            if not ordering:
                raise ValueError(
                    'an ordering between cases needs direction = "lower" or "higher", ratio_max or ratio_min'
                )
            if self.within is not None:
                raise ValueError("reference_case makes an ordering; a bound (within) is a separate claim")
            if self.case is not None and self.case == self.reference_case:
                raise ValueError(f"case and reference_case are both {self.case!r}: compare two cases")
        elif self.reference is None:
            if ordering:
                raise ValueError(f'{", ".join(ordering)} compare with a reference: give reference = "<candidate>"')
            if self.within is None:
                raise ValueError(
                    "a claim is an ordering (reference with direction, ratio_max, ratio_min or "
                    "equivalence_margin) or a bound (within = [low, high], consistent_states = n, "
                    "every_run_within = [low, high])"
                )
        else:
            if not ordering:
                raise ValueError('an ordering needs direction = "lower" or "higher", ratio_max or ratio_min')
            if self.reference == self.candidate:
                raise ValueError("the reference must be another candidate")
        for k in ("ratio_max", "ratio_min"):
            value = getattr(self, k)
            if value is not None and not math.isfinite(value):
                raise ValueError(f"{k} = {value!r} must be a finite number")
        if self.ratio_max is not None and self.ratio_min is not None and not self.ratio_min < self.ratio_max:
            raise ValueError(
                f"ratio_min = {self.ratio_min:g} is not below ratio_max = {self.ratio_max:g}: the claim "
                "could never hold"
            )
        if self.within is not None and not self.within[0] < self.within[1]:
            raise ValueError(f"within = {list(self.within)} must be [low, high] with low < high")
        return self

    def _between_metrics(self, ordering: list[str]) -> None:
        """An ordering between two metrics of the candidate (``versus_metric``) against the rest."""
        if self.versus_metric == self.metric:
            raise ValueError(f"versus_metric is metric {self.metric!r} itself: name another metric of the candidate")
        others = [k for k in ("reference", "reference_case", "within") if getattr(self, k) is not None]
        if others:
            raise ValueError(
                f"versus_metric pairs two metrics of the candidate on its own runs; {', '.join(others)} "
                "is a separate claim"
            )
        if not ordering:
            raise ValueError(
                'an ordering between metrics needs direction = "lower" or "higher", ratio_max, '
                "ratio_min or equivalence_margin (or every_run_within)"
            )

    def _new_kinds(self) -> None:
        """The equivalence, consistency and every-run kinds, and the test, against the rest."""
        own = [k for k in ("consistent_states", "every_run_within") if getattr(self, k) is not None]
        if own:
            paired = ("reference", "reference_case", "versus_metric") if own[0] == "every_run_within" else ()
            others = [
                k
                for k in (
                    "direction",
                    "ratio_max",
                    "ratio_min",
                    "equivalence_margin",
                    "within",
                    "reference",
                    "reference_case",
                    "versus_metric",
                    "threshold",
                    "threshold_difference",
                    "consistent_states",
                    "every_run_within",
                )
                if k not in (*own[:1], *paired) and getattr(self, k) is not None
            ]
            if others:
                raise ValueError(
                    f"{own[0]} is a claim about the candidate's own runs; {', '.join(others)} is a separate claim"
                )
            if self.versus_metric is not None and (self.reference is not None or self.reference_case is not None):
                raise ValueError(
                    "versus_metric pairs two metrics of the candidate on its own runs; reference and "
                    "reference_case are a separate claim"
                )
            if self.versus_metric == self.metric:
                raise ValueError(
                    f"versus_metric is metric {self.metric!r} itself: name another metric of the candidate"
                )
            if own[0] == "consistent_states" and "nees" not in self.metric.lower():
                raise ValueError(
                    f"consistent_states is the chi-square band of a NEES; metric {self.metric!r} is not a NEES"
                )
            if self.every_run_within is not None and not self.every_run_within[0] <= self.every_run_within[1]:
                raise ValueError(
                    f"every_run_within = {list(self.every_run_within)} must be [low, high] with low <= high"
                )
            if self.test != "t":
                raise ValueError(f"{own[0]} takes no test (it is not a t-interval); remove test = {self.test!r}")
        if self.equivalence_margin is not None:
            if self.direction is not None:
                raise ValueError(
                    "equivalence_margin (the two are equivalent) and direction (one is lower) contradict: give one"
                )
            if not math.isfinite(self.equivalence_margin):
                raise ValueError(f"equivalence_margin = {self.equivalence_margin!r} must be a finite number")
        if self.test == "wilcoxon":
            extra = [
                k for k in ("ratio_max", "ratio_min", "equivalence_margin", "within") if getattr(self, k) is not None
            ]
            if self.direction is None or extra:
                raise ValueError(
                    'test = "wilcoxon" tests the sign of the paired differences: it takes direction '
                    "only" + (f' ({", ".join(extra)} needs test = "t" or "bootstrap")' if extra else "")
                )
        if self.test != "t" and (self.threshold is not None or self.threshold_difference is not None):
            raise ValueError("a threshold claim is always judged by its paired bootstrap: remove test")

    def statement(self) -> str:
        """The claim in words."""
        parts = []
        theirs = f"{self.reference or self.candidate}'s" + (
            f" in {self.reference_case}" if self.reference_case is not None else ""
        )
        if self.threshold is not None:
            parts.append(f"threshold of {self.metric} along {self.sweep} {self.threshold} than {theirs}")
        if self.threshold_difference is not None:
            lo, hi = self.threshold_difference
            parts.append(f"threshold of {self.metric} along {self.sweep} minus {theirs} in [{lo:g}, {hi:g}]")
        ref = ratio_ref = f"{self.reference}'s"
        if self.reference_case is not None:
            own = self.reference in (None, self.candidate)
            ref = f"in {self.reference_case}" if own else f"{self.reference}'s in {self.reference_case}"
            ratio_ref = f"its value in {self.reference_case}" if own else ref
        if self.versus_metric is not None:
            ref = ratio_ref = f"its {self.versus_metric}"
        if self.direction is not None:
            parts.append(f"{self.metric} {self.direction} than {ref}")
        if self.ratio_max is not None:
            parts.append(f"{self.metric} / {ratio_ref} < {self.ratio_max:g}")
        if self.ratio_min is not None:
            parts.append(f"{self.metric} / {ratio_ref} > {self.ratio_min:g}")
        if self.equivalence_margin is not None:
            parts.append(f"{self.metric} equivalent to {ref} within ±{self.equivalence_margin:g}")
        if self.within is not None:
            parts.append(f"mean {self.metric} in [{self.within[0]:g}, {self.within[1]:g}]")
        if self.consistent_states is not None:
            parts.append(f"{self.metric} consistent ({self.consistent_states} states, chi-square 95 % band)")
        if self.every_run_within is not None:
            lo, hi = self.every_run_within
            paired = (
                ""
                if self.reference is None and self.reference_case is None and self.versus_metric is None
                else f" minus {ratio_ref}"
            )
            parts.append(f"{self.metric}{paired} in [{lo:g}, {hi:g}] in every run")
        test = {"t": "", "bootstrap": " [bootstrap]", "wilcoxon": " [Wilcoxon]"}[self.test]
        return f"{self.candidate}: " + " and ".join(parts) + test


def check_claims(
    claims: list[Claim],
    cases: list[str],
    candidates: list[str],
    metrics: list[str],
    sweeps: list | tuple = (),
    units: dict[str, str] | None = None,
) -> None:
    """Refuse claims naming an unknown case, candidate, metric, sweep or sweep point, or
    two metrics of different units (``units``: metric -> unit) in one difference (at
    config load); ``sweeps`` are the config's :class:`~.sweeps.Sweep` entries."""
    labels = [s.label for s in sweeps]
    for i, c in enumerate(claims):
        for field, value, allowed in (
            ("candidate", c.candidate, candidates),
            ("reference", c.reference, candidates),
            ("case", c.case, cases),
            ("reference_case", c.reference_case, cases),
            ("metric", c.metric, metrics),
            ("versus_metric", c.versus_metric, metrics),
        ):
            if value is not None and value not in allowed:
                raise ConfigError(f"claims[{i}].{field}", f"unknown {field} {value!r}; allowed: {', '.join(allowed)}")
        if c.versus_metric is not None and units is not None:
            unit, versus = units.get(c.metric), units.get(c.versus_metric)
            if unit != versus:
                raise ConfigError(
                    f"claims[{i}].versus_metric",
                    f"{c.versus_metric!r} is in {versus!r} and metric "
                    f"{c.metric!r} in {unit!r}: a paired difference needs two metrics of one unit",
                )
        picks = [f for f, v in (("at", c.at), ("from", c.points_from), ("to", c.points_to)) if v is not None]
        if c.sweep is None:
            if picks:
                raise ConfigError(
                    f"claims[{i}].{picks[0]}",
                    f"{picks[0]} picks points of a sweep: add sweep = "
                    f'"<name>"; allowed: {", ".join(labels) or "none (this config has no [[sweeps]])"}',
                )
            continue
        if c.sweep not in labels:
            raise ConfigError(
                f"claims[{i}].sweep",
                f"unknown sweep {c.sweep!r}; allowed: {', '.join(labels) or 'none (this config has no [[sweeps]])'}",
            )
        sweep = sweeps[labels.index(c.sweep)]
        if c.threshold is not None or c.threshold_difference is not None:
            spec = getattr(sweep, "threshold", None)
            if spec is None:
                raise ConfigError(
                    f"claims[{i}].sweep",
                    f"sweep {c.sweep!r} has no threshold table: add threshold = "
                    '{ metric = "...", level = 0.5 } to it',
                )
            if c.metric != spec.metric:
                raise ConfigError(
                    f"claims[{i}].metric", f"sweep {c.sweep!r} finds the threshold of {spec.metric!r}; got {c.metric!r}"
                )
        claim_points(c, sweep, f"claims[{i}]")
        run = list(sweep.cases or cases)
        for field, value, allowed, what in (
            ("case", c.case, varied_cases(sweep, cases), "varies"),
            ("reference_case", c.reference_case, run, "runs"),
        ):
            if value is not None and value not in allowed:
                raise ConfigError(
                    f"claims[{i}].{field}",
                    f"case {value!r} is not one sweep {c.sweep!r} {what}, so "
                    f"it has no value at the sweep's points; allowed: {', '.join(allowed)}",
                )


def untuned_candidates(config) -> list[str]:
    """The candidates a config with ``[tuning]`` leaves at their given values (no free
    parameter) while others are tuned; empty without ``[tuning]``."""
    if getattr(config, "tuning", None) is None:
        return []
    from .tuning import resolve_free

    tuned = set(resolve_free(config))
    return [c.name for c in config.candidates if c.name not in tuned]


def check_untuned_claims(config) -> None:
    """Refuse an ordering between candidates one of which was not tuned while others were,
    unless that candidate is marked ``as_given = true`` (deliberately as given); a
    ``ConfigError`` naming the claim (``claims[i].reference`` or ``.candidate``)."""
    untuned = untuned_candidates(config)
    if not untuned:
        return
    given = {c.name for c in config.candidates if c.as_given}
    for i, c in enumerate(config.claims):
        if c.reference is None or c.reference == c.candidate:
            continue
        for field, name in (("reference", c.reference), ("candidate", c.candidate)):
            if name in untuned and name not in given:
                raise ConfigError(
                    f"claims[{i}].{field}",
                    f"candidate {name!r} is not tuned while others are "
                    f"([tuning] has no free parameter of it), so the claim {c.statement()!r} compares "
                    f"hands, not filters: tune it, or mark it as_given = true if it is deliberately "
                    "evaluated as given",
                )


def varied_cases(sweep, cases: list[str]) -> list[str]:
    """The cases whose runs change along ``sweep``: the one its path names
    (``cases.<case>.<field>``), else every case it runs."""
    parts = sweep.path.split(".")
    if parts[0] == "cases" and len(parts) == 3 and parts[1] in cases:
        return [parts[1]]
    return [c for c in cases if not sweep.cases or c in sweep.cases]


def _same_point(a: Any, b: Any) -> bool:
    numeric = all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in (a, b))
    return math.isclose(float(a), float(b), rel_tol=1e-9, abs_tol=1e-12) if numeric else a == b


def claim_points(claim: Claim, sweep, where: str) -> list[Any]:
    """The points of ``sweep`` a claim names (``at``, or the range ``from``..``to``, default
    every point), in the sweep's order; a value that is not a point raises a
    ``ConfigError`` naming ``<where>.at`` / ``.from`` / ``.to`` and the sweep's points."""
    points = sweep.points()
    shown = ", ".join(str(v) for v in points)
    if claim.at is not None:
        if claim.points_from is not None or claim.points_to is not None:
            raise ConfigError(f"{where}.at", "give at (the points listed) or from / to (a range), not both")
        wanted = claim.at if isinstance(claim.at, list) else [claim.at]
        if not wanted:
            raise ConfigError(f"{where}.at", f"an empty list names no point; allowed: {shown}")
        for v in wanted:
            if not any(_same_point(p, v) for p in points):
                raise ConfigError(f"{where}.at", f"{v!r} is not a point of sweep {sweep.label!r}; allowed: {shown}")
        return [p for p in points if any(_same_point(p, v) for v in wanted)]
    first, last = 0, len(points) - 1
    for field, value in (("from", claim.points_from), ("to", claim.points_to)):
        if value is None:
            continue
        hit = [j for j, p in enumerate(points) if _same_point(p, value)]
        if not hit:
            raise ConfigError(
                f"{where}.{field}",
                f"{value:g} is not a point of sweep {sweep.label!r} (a range "
                f"starts and ends at points); allowed: {shown}",
            )
        first, last = (hit[0], last) if field == "from" else (first, hit[0])
    if first > last:
        raise ConfigError(
            f"{where}.from",
            f"from = {claim.points_from:g} comes after to = {claim.points_to:g} in sweep {sweep.label!r} ({shown})",
        )
    return points[first : last + 1]


def _against(low: float, high: float, bound: float, below: bool) -> str:
    """Outcome of "the quantity is below (above) ``bound``" from its interval [low, high]."""
    if below:
        return "holds" if high < bound else "fails" if low > bound else "not significant"
    return "holds" if low > bound else "fails" if high < bound else "not significant"


def _worst(outcomes: list[str]) -> str:
    return max(outcomes, key=OUTCOMES.index)


def _evidence(claim: Claim, store, key: str, case: str, runs: int) -> tuple[dict, object, np.ndarray, tuple | None]:
    """The claim's evidence in one case of one comparison (a config or a sweep point):
    the row's fields, the paired difference (``None`` for a bound), the candidate's values
    and the finite pairs ``(x, y)`` (``None`` for a bound)."""
    x = store.run_values(key, case, claim.candidate, claim.metric, runs)
    row, pd, pair = {}, None, None
    own = claim.reference_case is not None or claim.versus_metric is not None  # paired with the candidate itself
    reference = claim.reference or (claim.candidate if own else None)
    if reference is not None:
        y = store.run_values(key, claim.reference_case or case, reference, claim.versus_metric or claim.metric, runs)
        xs, ys = paired_values(x, y)
        pd = paired_difference(xs, ys)
        ok = np.isfinite(xs) & np.isfinite(ys)
        pair = (xs[ok], ys[ok])
        row.update(reference=reference, **{k: v for k, v in pd.to_json().items() if k != "reason"})
        if claim.reference_case is not None:
            row["reference_case"] = claim.reference_case
        if claim.versus_metric is not None:
            row["versus_metric"] = claim.versus_metric
    values = np.array([x[r] for r in sorted(x)], dtype=float)
    if claim.within is not None or claim.consistent_states is not None or claim.every_run_within is not None:
        mean, se, n = mean_and_se(values)
        row.update(mean=finite_or_none(mean), mean_se=finite_or_none(se), n=n)
    return row, pd, values, pair


def _no_spread(values: np.ndarray) -> bool:
    """Whether ``values`` are the same in every run (up to floating-point rounding)."""
    v = values[np.isfinite(values)]
    return v.size > 1 and at_rounding_level(float(np.std(v, ddof=1)), float(np.max(np.abs(v))))


def _two_sided(p_one: float) -> float:
    """A one-sided p-value on the claimed side as the two-sided-equivalent p compared with
    :data:`ALPHA` (holds at p < 0.05 exactly when the 95 % interval excludes the bound)."""
    return min(1.0, 2.0 * p_one)


def _judge(
    claim: Claim,
    pd,
    values: np.ndarray,
    pair: tuple | None,
    level: float = 0.95,
    rng: np.random.Generator | None = None,
) -> tuple[str, float | None, str]:
    """The claim's outcome from its evidence, its p-value (the largest of its conditions',
    an intersection-union test; ``None`` for a claim that is not a significance test) and
    why it was refused (``""`` otherwise). Each condition is judged on the ``level``
    interval of the claim's test (t, bootstrap percentile, or Wilcoxon's p-value)."""
    outcomes: list[str] = []
    ps: list[float] = []
    if claim.every_run_within is not None:
        v = values[np.isfinite(values)] if pair is None else pair[0] - pair[1]
        lo, hi = claim.every_run_within
        if v.size == 0:
            return "not significant", None, ""
        return ("holds" if bool(np.all((v >= lo) & (v <= hi))) else "fails"), None, ""
    if claim.consistent_states is not None:
        v = values[np.isfinite(values)]
        if v.size == 0:
            return "not significant", None, ""
        lo, hi = nees_band(v.size, claim.consistent_states)
        return ("holds" if lo <= float(np.mean(v)) <= hi else "fails"), None, ""
    tail = (1.0 - level) / 2
    if pd is not None:
        x, y = pair
        d = x - y
        if pd.n < 2:
            return "not significant", None, ""
        if _no_spread(d) or pd.se is None or pd.se == 0.0:
            other, on = (
                ("the reference's", " on each candidate") if claim.versus_metric is None else (claim.versus_metric, "")
            )
            return (
                "refused",
                None,
                f"{claim.metric} minus {other} is the same in all {pd.n} runs (no "
                f"spread): nothing to test; state it with every_run_within{on}",
            )
        if claim.test == "t":
            if claim.direction is not None:
                below = claim.direction == "lower"
                half = t_quantile(pd.n, level) * pd.se
                # pd.significant is the 95 % rule; a stricter level can only shrink what it calls significant.
                outcomes.append(
                    _against(pd.diff - half, pd.diff + half, 0.0, below) if pd.significant else "not significant"
                )
                ps.append(_two_sided(t_p_value(pd.diff, pd.se, pd.n, 0.0, below)))
            for bound, below in ((claim.ratio_max, True), (claim.ratio_min, False)):
                if bound is None:
                    continue
                if pd.ratio is None or pd.ratio_se is None or pd.ratio_se == 0.0:
                    outcomes.append("not significant")
                    ps.append(1.0)
                    continue
                half = t_quantile(pd.n, level) * pd.ratio_se
                outcomes.append(_against(pd.ratio - half, pd.ratio + half, bound, below))
                ps.append(_two_sided(t_p_value(pd.ratio, pd.ratio_se, pd.n, bound, below)))
            if claim.equivalence_margin is not None:
                m = claim.equivalence_margin
                p = tost(pd.diff, pd.se, pd.n, m)
                wide = t_quantile(pd.n, level) * pd.se
                outside = pd.diff - wide > m or pd.diff + wide < -m
                outcomes.append(
                    "holds" if p < ALPHA * (1 - level) / 0.05 else "fails" if outside else "not significant"
                )
                ps.append(p)
        elif claim.test == "wilcoxon":
            below = claim.direction == "lower"
            p_one = wilcoxon_p(d, below)
            p_other = wilcoxon_p(d, not below)
            outcomes.append("holds" if p_one < tail else "fails" if p_other < tail else "not significant")
            ps.append(_two_sided(p_one))
        else:  # the paired bootstrap, resampling runs
            mx, my = bootstrap_means(x, y, rng if rng is not None else np.random.default_rng(0))
            diff = mx - my
            if claim.direction is not None:
                below = claim.direction == "lower"
                lo, hi = np.quantile(diff, [tail, 1 - tail])
                outcomes.append(_against(float(lo), float(hi), 0.0, below))
                ps.append(_two_sided(bootstrap_p(diff, 0.0, below)))
            for bound, below in ((claim.ratio_max, True), (claim.ratio_min, False)):
                if bound is None:
                    continue
                if pd.ratio is None:
                    outcomes.append("not significant")
                    ps.append(1.0)
                    continue
                ratio = mx / my
                lo, hi = np.quantile(ratio, [tail, 1 - tail])
                outcomes.append(_against(float(lo), float(hi), bound, below))
                ps.append(_two_sided(bootstrap_p(ratio, bound, below)))
            if claim.equivalence_margin is not None:
                m = claim.equivalence_margin
                p = max(bootstrap_p(diff, m, True), bootstrap_p(diff, -m, False))
                lo, hi = np.quantile(diff, [tail, 1 - tail])
                outcomes.append(
                    "holds" if p < ALPHA * (1 - level) / 0.05 else "fails" if lo > m or hi < -m else "not significant"
                )
                ps.append(p)
    if claim.within is not None:
        v = values[np.isfinite(values)]
        mean, se, n = mean_and_se(v)
        if mean is None or se is None:
            outcomes.append("not significant")
            ps.append(1.0)
        elif _no_spread(v) or se == 0.0:
            return (
                "refused",
                None,
                f"{claim.metric} is {mean:g} in all {n} runs (no spread): a mean's interval has "
                "nothing to test; state it with every_run_within",
            )
        else:
            if claim.test == "bootstrap":
                draws = bootstrap_means(v, None, rng if rng is not None else np.random.default_rng(0))[0]
                lo, hi = (float(q) for q in np.quantile(draws, [tail, 1 - tail]))
                p_lo, p_hi = bootstrap_p(draws, claim.within[0], False), bootstrap_p(draws, claim.within[1], True)
            else:
                lo, hi = mean - t_quantile(n, level) * se, mean + t_quantile(n, level) * se
                p_lo = t_p_value(mean, se, n, claim.within[0], below=False)
                p_hi = t_p_value(mean, se, n, claim.within[1], below=True)
            outcomes += [_against(lo, hi, claim.within[0], below=False), _against(lo, hi, claim.within[1], below=True)]
            ps.append(_two_sided(max(p_lo, p_hi)))
    return _worst(outcomes), (max(ps) if ps else None), ""


def _outcome(
    claim: Claim,
    pd,
    values: np.ndarray,
    level: float = 0.95,
    pair: tuple | None = None,
    rng: np.random.Generator | None = None,
) -> str:
    """The claim's outcome alone (see :func:`_judge`)."""
    return _judge(claim, pd, values, pair, level, rng)[0]


def _row_judgement(claim: Claim, evidence: tuple, rng: np.random.Generator, declared: bool = False) -> dict:
    """The outcome fields of a claim row: ``outcome``, ``p_value`` and ``reason`` (refused);
    over fewer than :data:`MIN_CLAIM_RUNS` runs also ``few_runs``, ``small_n`` (whether the
    config declares it, ``declared``) and, for a claim judged by an interval of a mean or a
    paired mean difference, ``detectable80``: its minimum detectable difference at 80 % power."""
    row, pd, values, pair = evidence
    outcome, p, reason = _judge(claim, pd, values, pair, rng=rng)
    out: dict[str, Any] = {"outcome": outcome, "test": claim.test, "p_value": finite_or_none(p)}
    if reason:
        out["reason"] = reason
    n = int(np.isfinite(values).sum())  # the runs a band or bound is over
    runs, se = (pd.n, pd.se) if pd is not None else (n, row.get("mean_se"))
    if runs is not None and runs < MIN_CLAIM_RUNS:
        out["few_runs"] = True
        out["small_n"] = bool(declared)
        # An ordering (direction, ratio) or a bound on the mean (within) is the 95 % interval on the
        # claimed side, the two-sided 5 % t-test; an equivalence states the margin its TOST shows
        # at a true difference of 0; a band or an every-run observation states its own band or bound.
        tested = (
            claim.direction is not None
            or claim.ratio_max is not None
            or claim.ratio_min is not None
            or claim.within is not None
        )
        if tested and runs >= 2 and se:
            out["detectable80"] = detectable_difference(se, runs, STATED_POWER, ALPHA)
        if claim.equivalence_margin is not None and runs >= 2 and se:
            out["equivalence_margin80"] = equivalence_margin_for_power(se, runs, STATED_POWER, ALPHA)
    if n and claim.consistent_states is not None:
        out["nees_band95"] = list(nees_band(n, claim.consistent_states))
    if n and claim.every_run_within is not None:
        out["outside_bound95"] = all_runs_bound(n)
    return out


def _sweep_rows(config, store, i: int, claim: Claim) -> list[dict]:
    """A sweep claim's rows: one per case and point, then one all-points row per case
    (when it names several points; see the module docstring for the levels)."""
    index = [s.label for s in config.sweeps].index(claim.sweep)
    sweep = config.sweeps[index]
    pairs = config.sweep_points(index)
    points = claim_points(claim, sweep, f"claims[{i}]")
    names = [c.name for c in config.cases]
    cases = [claim.case] if claim.case else [c for c in varied_cases(sweep, names) if c != claim.reference_case]
    corrected = 1.0 - 0.05 / len(points)  # Bonferroni over the claim's points, for "fails somewhere"
    out = []
    for case in cases:
        rows, failed = [], []
        for value in points:
            point = next(p for v, p in pairs if _same_point(v, value))
            evidence = _evidence(claim, store, point.identity(), case, point.runs)
            where = f"{case} {claim.sweep}={value}"  # each judgement resamples from a fresh generator of it
            row = {
                "claim": i,
                "statement": claim.statement(),
                "case": case,
                "sweep": claim.sweep,
                "point": value,
                "candidate": claim.candidate,
                "metric": claim.metric,
                "note": claim.note,
                **evidence[0],
                **_row_judgement(claim, evidence, claim_rng(config.seed, i, where), small_n_declared(config, claim)),
            }
            _, pd, values, pair = evidence
            if (
                len(points) > 1
                and _outcome(claim, pd, values, corrected, pair, claim_rng(config.seed, i, where)) == "fails"
            ):
                failed.append(value)
            rows.append(row)
        out += rows
        if len(points) > 1:
            held = sum(r["outcome"] == "holds" for r in rows)
            out.append(
                {
                    "claim": i,
                    "statement": claim.statement(),
                    "case": case,
                    "sweep": claim.sweep,
                    "point": "all",
                    "points": points,
                    "candidate": claim.candidate,
                    "metric": claim.metric,
                    "note": claim.note,
                    "held": held,
                    "corrected_level": corrected,
                    "failed_corrected": failed,
                    "outcome": "refused"
                    if any(r["outcome"] == "refused" for r in rows)
                    else "holds"
                    if held == len(points)
                    else "fails"
                    if failed
                    else "not significant",
                }
            )
    return out


def _threshold_claim_rows(config, i: int, claim: Claim, report: dict) -> list[dict]:
    """A threshold claim's rows, one per case: the paired bootstrap 95 % interval of the
    candidate's threshold minus the reference's (`gnssframework.experiments.threshold`)."""
    from .threshold import _bound, difference_interval

    names = [c["case"] for c in report["cases"] if c["case"] != claim.reference_case]
    reference = claim.reference or claim.candidate
    out = []
    for case in [claim.case] if claim.case else names:
        est, lo, hi = difference_interval(report, case, claim.candidate, reference, claim.reference_case)
        outcomes = []
        if claim.threshold is not None:
            outcomes.append(_against(lo, hi, 0.0, claim.threshold == "lower"))
        if claim.threshold_difference is not None:
            a, b = claim.threshold_difference
            outcomes.append(_worst([_against(lo, hi, a, below=False), _against(lo, hi, b, below=True)]))
        out.append(
            {
                "claim": i,
                "statement": claim.statement(),
                "case": case,
                "sweep": claim.sweep,
                "point": "threshold",
                "candidate": claim.candidate,
                "reference": reference,
                **({"reference_case": claim.reference_case} if claim.reference_case is not None else {}),
                "metric": claim.metric,
                "note": claim.note,
                "threshold_difference": finite_or_none(est),
                "threshold_ci95": [_bound(lo), _bound(hi)],
                "outcome": _worst(outcomes),
            }
        )
    return out


def evaluate_claims(config, store, key: str | None = None) -> list[dict]:
    """Every claim of ``config`` in every case (and sweep point) it names: outcome and
    evidence (strict JSON)."""
    key = key or config.identity()
    out = []
    reports: dict[int, dict] = {}
    for i, claim in enumerate(config.claims):
        if claim.threshold is not None or claim.threshold_difference is not None:
            from .threshold import threshold_rows

            index = [s.label for s in config.sweeps].index(claim.sweep)
            if index not in reports:
                reports[index] = threshold_rows(config, store, index)
            out += _threshold_claim_rows(config, i, claim, reports[index])
            continue
        if claim.sweep is not None:
            out += _sweep_rows(config, store, i, claim)
            continue
        cases = [claim.case] if claim.case else [c.name for c in config.cases if c.name != claim.reference_case]
        for case in cases:
            evidence = _evidence(claim, store, key, case, config.runs)
            out.append(
                {
                    "claim": i,
                    "statement": claim.statement(),
                    "case": case,
                    "candidate": claim.candidate,
                    "metric": claim.metric,
                    "note": claim.note,
                    **evidence[0],
                    **_row_judgement(claim, evidence, claim_rng(config.seed, i, case), small_n_declared(config, claim)),
                }
            )
    return adjust_claims(out, config.claims_adjustment)


def in_family(row: dict) -> bool:
    """Whether a claim row is one of the example's significance tests (the family the
    adjustment runs over): a row with a p-value; not a sweep claim's all-points row (it
    summarises its points' rows), a threshold row (a bootstrap interval with no p-value),
    a consistency band or an every-run observation (no test of significance: a NEES band
    that "holds" is a test not rejected)."""
    return row.get("p_value") is not None and row.get("point") not in ("all", "threshold")


def adjust_claims(rows: list[dict], method: str) -> list[dict]:
    """``rows`` with ``p_adjusted`` (``method``'s adjusted p over the family of
    :func:`in_family` rows), ``adjustment`` and ``holds_adjusted`` (a row that holds and
    whose adjusted p is below :data:`ALPHA`) on every row of the family. The adjusted p
    is reported beside the outcome; it does not change it (each claim's own 95 % test)."""
    family = [r for r in rows if in_family(r)]
    if not family:
        return rows
    adjusted = adjust([r["p_value"] for r in family], method)
    for r, p in zip(family, adjusted):
        r["p_adjusted"] = float(p)
        r["adjustment"] = method
        r["family_size"] = len(family)
        r["holds_adjusted"] = bool(r["outcome"] == "holds" and p < ALPHA)
        if r.get("detectable80") is not None and len(family) > 1:
            # The strictest level either adjustment compares a p-value with is ALPHA / m (Holm's
            # first step is Bonferroni's; BH's smallest p is held to the same): the MDD there
            # bounds the adjusted test's from above.
            se = r["se"] if r.get("diff") is not None else r["mean_se"]
            r["detectable80_adjusted"] = detectable_difference(se, r["n"], STATED_POWER, ALPHA / len(family))
    return rows


def small_n_declared(config, claim: Claim) -> bool:
    """Whether a claim may be checked on fewer than :data:`MIN_CLAIM_RUNS` runs: ``small_n``
    on the claim or ``claims_small_n`` on the config."""
    return bool(claim.small_n or getattr(config, "claims_small_n", False))


def unstated_small_n(rows: list[dict]) -> list[dict]:
    """The claim rows over fewer than :data:`MIN_CLAIM_RUNS` runs whose claim does not
    declare ``small_n``: what ``compare --check`` refuses (one row per claim)."""
    seen: set[int] = set()
    out = []
    for r in rows:
        if r.get("few_runs") and not r.get("small_n") and r["claim"] not in seen:
            seen.add(r["claim"])
            out.append(r)
    return out


def unstated_small_n_claims(config) -> list[int]:
    """The indices of the claims ``compare --check`` will refuse before it runs: the config
    runs fewer than :data:`MIN_CLAIM_RUNS` runs and the claim does not declare ``small_n``
    (a threshold claim, a bootstrap interval of a sweep's thresholds, is exempt)."""
    if config.runs >= MIN_CLAIM_RUNS:
        return []
    return [
        i
        for i, c in enumerate(config.claims)
        if not small_n_declared(config, c) and c.threshold is None and c.threshold_difference is None
    ]


def small_n_refusal(name: str, claim: int, statement: str, runs: int) -> str:
    """The one-line refusal of a claim over too few runs, naming the example and the claim."""
    return (
        f"{name}: claims[{claim}] ({statement}) is checked on {runs} paired runs, fewer than "
        f"{MIN_CLAIM_RUNS}: run {MIN_CLAIM_RUNS} or more, or declare small_n = true on the claim (or "
        "claims_small_n = true in the config) to state its power instead"
    )


def claim_where(row: dict) -> str:
    """Where a claim's row was evaluated: its case, and its sweep point (or all its points)."""
    if row.get("sweep") is None:
        return row["case"]
    point = row["point"]
    if point == "threshold":
        return f"{row['case']} {row['sweep']} threshold"
    if point == "all":
        point = ",".join(str(v) for v in row["points"]) + " (all)"
    return f"{row['case']} {row['sweep']}={point}"


def claim_evidence(row: dict) -> str:
    """A claim row's evidence in words, and its outcome on the replicate runs where it was
    re-checked there (``compare --replicate``)."""
    text = _evidence_words(row)
    rep = row.get("replicate_outcome")
    if rep is not None:
        text += f"; replicate seed set: {rep}"
        if row.get("replicates") is False:
            text += " (stated: holds on the evaluation runs only)"
    return text


def _evidence_words(row: dict) -> str:
    """A claim row's evidence on the evaluation runs, in words."""
    if row.get("point") == "threshold":
        lo, hi = row["threshold_ci95"]
        est = row["threshold_difference"]
        return (
            f"threshold difference {'undefined' if est is None else format(est, '+.2f')}, paired bootstrap "
            f"95 % interval [{lo if isinstance(lo, str) else format(lo, '+.2f')}, "
            f"{hi if isinstance(hi, str) else format(hi, '+.2f')}]"
        )
    if row.get("point") == "all":
        failed = row.get("failed_corrected") or []
        return (
            f"holds at {row['held']} of {len(row['points'])} points; fails at the Bonferroni level "
            f"{1 - row['corrected_level']:.2g} at {', '.join(map(str, failed)) if failed else 'none'}"
        )
    if row.get("outcome") == "refused" and row.get("reason"):
        return f"refused: {row['reason']}"
    ev = []
    if row.get("diff") is not None:
        ev.append(f"difference {format_estimate(row['diff'], row.get('se'), sign=True)}")
    if row.get("ratio") is not None:
        ev.append(f"ratio {format_estimate(row['ratio'], row.get('ratio_se'))}")
    if row.get("mean") is not None:
        ev.append(f"mean {format_estimate(row['mean'], row.get('mean_se'))}")
    if row.get("nees_band95") is not None:
        lo, hi = row["nees_band95"]
        ev.append(f"chi-square 95 % band [{lo:.3g}, {hi:.3g}]")
    if row.get("outside_bound95") is not None:
        ev.append(f"95 % upper bound on the chance of a run outside {row['outside_bound95']:.2g}")
    n = row.get("n")
    text = ", ".join(ev) + (f", n={n}" if n else "")
    if row.get("few_runs"):
        text += f" (n < {MIN_CLAIM_RUNS}" + ("" if row.get("small_n") else ", small_n not declared")
        if row.get("detectable80") is not None:
            text += f": detects differences >= {row['detectable80']:.2g} at power {STATED_POWER:g}"
            if row.get("detectable80_adjusted") is not None:
                text += (
                    f", >= {row['detectable80_adjusted']:.2g} after adjustment (level {ALPHA:g}/{row['family_size']})"
                )
        if row.get("equivalence_margin80") is not None:
            text += (
                f": shows equivalence within +-{row['equivalence_margin80']:.2g} at power {STATED_POWER:g} "
                "when the true difference is 0"
            )
        text += ")"
    if row.get("test") not in (None, "t"):
        text += f", {row['test']}"
    if row.get("p_value") is not None:
        text += f", p={row['p_value']:.2g}"
    if row.get("p_adjusted") is not None:
        name = {"holm": "Holm", "benjamini-hochberg": "BH"}.get(row.get("adjustment"), row.get("adjustment"))
        text += f", {name}-adjusted p={row['p_adjusted']:.2g} of {row['family_size']}"
        if row["outcome"] == "holds" and not row.get("holds_adjusted"):
            text += " (not significant after adjustment)"
    return text


def replication_failed(row: dict) -> bool:
    """Whether a claim row checked on the replicate runs (``compare --replicate``) fails its
    replication: a claim stated to replicate (the default) that does not hold there. A claim
    stated to hold on the evaluation runs only (``replicates = false``) has its replicate
    outcome reported, not checked: it sits near the edge of significance there (that is
    why it does not replicate), where another machine's rounding may tip it either way.
    False for a row not checked on replicate runs."""
    rep = row.get("replicate_outcome")
    return rep is not None and rep != "holds" and row.get("replicates", True)


def claim_line(row: dict) -> str:
    """One line of a claim's outcome and evidence, for the terminal and the report."""
    return f"{row['outcome']:<15} {claim_where(row)}: {row['statement']} ({claim_evidence(row)})"
