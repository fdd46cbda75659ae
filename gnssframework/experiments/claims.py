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
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator
from scipy import special as _sc  # not scipy.stats: its import costs every run of the CLI a second

from ..errors import ConfigError
from .number_format import format_estimate
from .stats import finite_or_none, mean_and_se, paired_difference, paired_values

__all__ = ["Claim", "check_claims", "evaluate_claims", "OUTCOMES"]

#: Outcomes from best to worst.
OUTCOMES = ("holds", "not significant", "fails")


class Claim(BaseModel):
    """One statement about a comparison's results (see the module docstring)."""

    model_config = ConfigDict(extra="forbid")
    candidate: str = Field(..., description="the candidate the claim is about")
    metric: str = Field(..., description="a reported metric")
    case: str | None = Field(None, description="the case (default: the claim must hold in every case)")
    reference: str | None = Field(None, description="for an ordering: the candidate compared with (paired runs); "
                                  "with reference_case, default the candidate itself")
    reference_case: str | None = Field(None, description="for an ordering between cases: the case the reference's "
                                       "runs come from (paired run by run with each claimed case)")
    direction: Literal["lower", "higher"] | None = Field(
        None, description="for an ordering: the candidate's values are lower / higher than the reference's")
    ratio_max: float | None = Field(None, gt=0, description="for an ordering: ratio of means (candidate / "
                                    "reference) below this")
    ratio_min: float | None = Field(None, gt=0, description="for an ordering: ratio of means above this")
    within: tuple[float, float] | None = Field(None, description="for a bound: the candidate's mean lies in "
                                               "[low, high]")
    note: str = Field("", description="where the claim is stated (a docs page, a paper's table)")

    @model_validator(mode="after")
    def _one_kind(self) -> "Claim":
        ordering = [k for k in ("direction", "ratio_max", "ratio_min") if getattr(self, k) is not None]
        if self.reference_case is not None:
            if not ordering:
                raise ValueError("an ordering between cases needs direction = \"lower\" or \"higher\", "
                                 "ratio_max or ratio_min")
            if self.within is not None:
                raise ValueError("reference_case makes an ordering; a bound (within) is a separate claim")
            if self.case is not None and self.case == self.reference_case:
                raise ValueError(f"case and reference_case are both {self.case!r}: compare two cases")
        elif self.reference is None:
            if ordering:
                raise ValueError(f"{', '.join(ordering)} compare with a reference: give reference = \"<candidate>\"")
            if self.within is None:
                raise ValueError("a claim is an ordering (reference with direction, ratio_max or ratio_min) or a "
                                 "bound (within = [low, high])")
        else:
            if not ordering:
                raise ValueError("an ordering needs direction = \"lower\" or \"higher\", ratio_max or ratio_min")
            if self.reference == self.candidate:
                raise ValueError("the reference must be another candidate")
        if self.within is not None and not self.within[0] < self.within[1]:
            raise ValueError(f"within = {list(self.within)} must be [low, high] with low < high")
        return self

    def statement(self) -> str:
        """The claim in words."""
        parts = []
        ref = ratio_ref = f"{self.reference}'s"
        if self.reference_case is not None:
            own = self.reference in (None, self.candidate)
            ref = f"in {self.reference_case}" if own else f"{self.reference}'s in {self.reference_case}"
            ratio_ref = f"its value in {self.reference_case}" if own else ref
        if self.direction is not None:
            parts.append(f"{self.metric} {self.direction} than {ref}")
        if self.ratio_max is not None:
            parts.append(f"{self.metric} / {ratio_ref} < {self.ratio_max:g}")
        if self.ratio_min is not None:
            parts.append(f"{self.metric} / {ratio_ref} > {self.ratio_min:g}")
        if self.within is not None:
            parts.append(f"mean {self.metric} in [{self.within[0]:g}, {self.within[1]:g}]")
        return f"{self.candidate}: " + " and ".join(parts)


def check_claims(claims: list[Claim], cases: list[str], candidates: list[str], metrics: list[str]) -> None:
    """Refuse claims naming an unknown case, candidate or metric (at config load)."""
    for i, c in enumerate(claims):
        for field, value, allowed in (("candidate", c.candidate, candidates), ("reference", c.reference, candidates),
                                      ("case", c.case, cases), ("reference_case", c.reference_case, cases),
                                      ("metric", c.metric, metrics)):
            if value is not None and value not in allowed:
                raise ConfigError(f"claims[{i}].{field}", f"unknown {field} {value!r}; allowed: {', '.join(allowed)}")


def _t(n: int) -> float:
    return float(_sc.stdtrit(n - 1, 0.975))  # = scipy.stats.t.ppf(0.975, n - 1)


def _against(low: float, high: float, bound: float, below: bool) -> str:
    """Outcome of "the quantity is below (above) ``bound``" from its interval [low, high]."""
    if below:
        return "holds" if high < bound else "fails" if low > bound else "not significant"
    return "holds" if low > bound else "fails" if high < bound else "not significant"


def _worst(outcomes: list[str]) -> str:
    return max(outcomes, key=OUTCOMES.index)


def evaluate_claims(config, store, key: str | None = None) -> list[dict]:
    """Every claim of ``config`` in every case it names: outcome and evidence (strict JSON)."""
    key = key or config.identity()
    out = []
    for i, claim in enumerate(config.claims):
        cases = [claim.case] if claim.case else [c.name for c in config.cases if c.name != claim.reference_case]
        for case in cases:
            x = store.run_values(key, case, claim.candidate, claim.metric, config.runs)
            row = {"claim": i, "statement": claim.statement(), "case": case, "candidate": claim.candidate,
                   "metric": claim.metric, "note": claim.note}
            outcomes = []
            reference = claim.reference or (claim.candidate if claim.reference_case else None)
            if reference is not None:
                y = store.run_values(key, claim.reference_case or case, reference, claim.metric, config.runs)
                pd = paired_difference(*paired_values(x, y))
                row.update(reference=reference, **{k: v for k, v in pd.to_json().items() if k != "reason"})
                if claim.reference_case is not None:
                    row["reference_case"] = claim.reference_case
                if pd.se is None or pd.n < 2:
                    outcomes.append("not significant")
                else:
                    if claim.direction is not None:
                        outcomes.append(("holds" if (pd.diff < 0) == (claim.direction == "lower") else "fails")
                                        if pd.significant else "not significant")
                    for bound, below in ((claim.ratio_max, True), (claim.ratio_min, False)):
                        if bound is None:
                            continue
                        if pd.ratio is None or pd.ratio_se is None:
                            outcomes.append("not significant")
                            continue
                        half = _t(pd.n) * pd.ratio_se
                        outcomes.append(_against(pd.ratio - half, pd.ratio + half, bound, below))
            if claim.within is not None:
                mean, se, n = mean_and_se(np.array([x[r] for r in sorted(x)]))
                row.update(mean=finite_or_none(mean), mean_se=finite_or_none(se), n=n)
                if mean is None or se is None:
                    outcomes.append("not significant")
                else:
                    lo, hi = mean - _t(n) * se, mean + _t(n) * se
                    outcomes += [_against(lo, hi, claim.within[0], below=False),
                                 _against(lo, hi, claim.within[1], below=True)]
            row["outcome"] = _worst(outcomes)
            out.append(row)
    return out


def claim_line(row: dict) -> str:
    """One line of a claim's outcome and evidence, for the terminal and the report."""
    ev = []
    if row.get("diff") is not None:
        ev.append(f"difference {format_estimate(row['diff'], row.get('se'), sign=True)}")
    if row.get("ratio") is not None:
        ev.append(f"ratio {format_estimate(row['ratio'], row.get('ratio_se'))}")
    if row.get("mean") is not None:
        ev.append(f"mean {format_estimate(row['mean'], row.get('mean_se'))}")
    n = row.get("n")
    return f"{row['outcome']:<15} {row['case']}: {row['statement']} ({', '.join(ev)}{f', n={n}' if n else ''})"
