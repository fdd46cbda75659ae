"""What one batch of Monte Carlo runs returns: per-run metrics and per-epoch series.

Below both the scenario kinds (`gnssframework.experiments.scenarios`), which return it
from ``run_batch``, and the metric components (`gnssframework.experiments.metric_components`),
whose ``evaluate`` builds it, so that neither imports the other.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["BatchResult"]


@dataclass
class BatchResult:
    """Metrics ``(runs,)`` and time series ``(K, runs)`` of one batch of runs."""

    metrics: dict[str, np.ndarray]
    series: dict[str, np.ndarray] = field(default_factory=dict)
    time_s: np.ndarray | None = None
