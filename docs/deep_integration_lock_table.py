"""Markdown table of the lock sweep in docs/experiments/deep-integration.md.

Run: ``gnssframework compare examples/deep_integration_lock.toml --out results/deep_lock`` (about 4 min
on the shared 2-core machine), then ``python docs/deep_integration_lock_table.py results/deep_lock``.
Per C/N0 and peak jerk: the mean ± standard error over runs of each candidate's loss-of-lock fraction
(code/frequency), phase-lock loss fraction and cycle-slip rate, and the paired differences (mean ±
standard error over the common-random-number runs) of ``deep`` against both scalar candidates.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from gnssframework.experiments.config import load_config
from gnssframework.experiments.store import ResultStore
from gnssframework.experiments.sweeps import expand_sweep

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "deep_integration_lock.toml"
CANDIDATES = ("loose", "loose-no-fll", "deep")
METRICS = {"loss_of_lock_fraction": "code/frequency loss of lock", "phase_lock_loss_fraction": "phase beyond 45°",
           "cycle_slip_rate": "half-cycle slips per channel-second"}


def _ms(v: np.ndarray) -> str:
    m, se = float(np.mean(v)), float(np.std(v, ddof=1) / np.sqrt(len(v)))
    return "0" if m == 0 and se == 0 else f"{m:.3g} ± {se:.2g}"


def table(run: Path) -> str:
    config = load_config(EXAMPLE)
    store = ResultStore(run / "results.sqlite")
    lines = []
    for metric, what in METRICS.items():
        lines += [f"**{metric}** ({what}; mean ± SE over {config.runs} runs; differences paired)", "",
                  "| C/N0 | peak jerk (g/s) | `loose` | `loose-no-fll` | `deep` | `deep` − `loose` | "
                  "`deep` − `loose-no-fll` |", "| --- | --- | --- | --- | --- | --- | --- |"]
        for case in config.cases:
            for value, point in expand_sweep(config, 0):
                key = point.identity()
                v = {c: np.array([x for _, x in sorted(store.run_values(key, case.name, c, metric,
                                                                         config.runs).items())])
                     for c in CANDIDATES}
                lines.append(f"| {case.name} | {value:g} | " + " | ".join(_ms(v[c]) for c in CANDIDATES)
                             + f" | {_ms(v['deep'] - v['loose'])} | {_ms(v['deep'] - v['loose-no-fll'])} |")
        lines.append("")
    return "\n".join(lines)


if __name__ == "__main__":
    print(table(Path(sys.argv[1])))
