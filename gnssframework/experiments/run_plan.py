"""A comparison resolved once: what the workers receive.

A :class:`RunPlan` holds the validated scenario instance, every case's parameters, every
candidate as the config resolved it (`gnssframework.experiments.candidates`: its
plugins' specs and scenario options), the seed and random stream and the metrics to
compute. The config is validated and resolved once, in the process that loads it; a
worker builds only its task's candidate and runs it. A plan is a plain picklable value
(process pool, Dask).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..random_streams import RunStreams, name_key, run_streams
from .candidates import CandidatePlan, build_candidate
from .scenarios import Scenario
from .tasks import Task

__all__ = ["CasePlan", "CandidatePlan", "RunPlan", "resolve", "task_streams", "TUNING_PURPOSE", "REPLICATE_PURPOSE"]

#: Spawn key of the tuning streams (``RunStreams(..., purpose=TUNING_PURPOSE)``).
TUNING_PURPOSE = name_key("tuning")

#: Spawn key of the replicate streams (``compare --replicate``: every claim re-checked on
#: runs disjoint from both the evaluation's and the tuning's).
REPLICATE_PURPOSE = name_key("replicate")


@dataclass(frozen=True)
class CasePlan:
    """One case: its name and validated parameters (as ``run_batch`` gets them, with the name)."""

    name: str
    values: dict[str, Any]
    streams: str | None = None  # the case whose random streams it draws (None: its own)

    def as_case(self) -> dict[str, Any]:
        """What ``Scenario.run_batch`` takes as ``case``."""
        return {"name": self.name, **self.values}


@dataclass(frozen=True)
class RunPlan:
    """A validated comparison resolved for the workers (see the module docstring)."""

    scenario: Scenario
    cases: tuple[CasePlan, ...]
    candidates: tuple[CandidatePlan, ...]
    seed: int
    random_stream: str
    metrics: tuple[str, ...]
    component_metrics: tuple[str, ...]

    def build(self, candidate_index: int, case_index: int | None = None) -> dict[str, Any]:
        """Fresh plugins of one candidate (``Scenario.build``), built for the case
        ``case_index`` when given (a task's: each plugin validated and created once)."""
        case = None if case_index is None else self.cases[case_index].as_case()
        return build_candidate(self.scenario, self.candidates[candidate_index], case)

    def where(self, task: Task) -> str:
        """A task in words, for failures: candidate, case, runs and sweep point."""
        point = f", sweep point {task.point}" if task.point else ""
        return (
            f"candidate {self.candidates[task.candidate_index].name!r}, case "
            f"{self.cases[task.case_index].name!r}, {task.run_range}{point}"
        )


def resolve(config: Any) -> RunPlan:
    """The :class:`RunPlan` of a validated ``ComparisonConfig`` (its scenario instance is
    the one the config was validated with)."""
    return RunPlan(
        scenario=config.resolved_scenario,
        cases=tuple(CasePlan(c.name, c.params(), c.streams) for c in config.cases),
        candidates=config.resolved_candidates,
        seed=config.seed,
        random_stream=config.random_stream,
        metrics=tuple(config.metric_names),
        component_metrics=tuple(config.component_metrics()),
    )


def task_streams(plan: Any, task: Task) -> RunStreams:
    """The random streams of a task's runs (a `RunPlan` or a ``ComparisonConfig``): they
    depend on the seed, the case's name (or the case its ``streams`` names) and the run
    indices, never on the batch or the candidate (see :mod:`gnssframework.experiments.runner`)."""
    case = plan.cases[task.case_index]
    case = getattr(case, "streams", None) or case.name
    runs = range(task.first_run, task.first_run + task.runs)
    if plan.random_stream == "tuning":  # disjoint from the evaluation's: a child of every run's seed
        return RunStreams((plan.seed, *name_key(case)), runs, TUNING_PURPOSE)
    if plan.random_stream == "replicate":  # disjoint from both: another child of every run's seed
        return RunStreams((plan.seed, *name_key(case)), runs, REPLICATE_PURPOSE)
    return run_streams(plan.seed, name_key(case), runs)
