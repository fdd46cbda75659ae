"""The units of work of a comparison: tasks (one batch of one case and candidate), the
plan that lists them, and where a task's time series are stored.

Below the config, the tuner, the report and the runner, which all use it.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .store import plan_batches

__all__ = ["Task", "plan", "series_file"]


@dataclass(frozen=True)
class Task:
    """One batch of runs (``first_run`` .. ``first_run + runs - 1``) of one case and
    candidate, of the comparison or of a sweep point (``point``, its label)."""

    case_index: int
    candidate_index: int
    first_run: int
    runs: int
    point: str | None = None

    @property
    def run_range(self) -> str:
        last = self.first_run + self.runs - 1
        return f"run {self.first_run}" if self.runs == 1 else f"runs {self.first_run}-{last}"


def plan(config: Any, point: str | None = None) -> list[Task]:
    """Every (case, candidate, batch) of a ``ComparisonConfig``, batch-major for early partial results."""
    return [
        Task(i, j, first, n, point)
        for first, n in plan_batches(config.runs, config.batch_size)
        for i in range(len(config.cases))
        for j in range(len(config.candidates))
    ]


def series_file(out: Path, case: str, candidate: str, first_run: int, runs: int) -> Path:
    """The ``.npz`` of a batch's time series: ``raw/<case>/<candidate>/run<first>-<last>.npz``."""
    return out / "raw" / case / candidate / f"run{first_run:06d}-{first_run + runs - 1:06d}.npz"
