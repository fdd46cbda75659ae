"""Markdown table of the lock sweep in docs/experiments/deep-integration.md.

Run: ``gnssframework compare examples/deep_integration_lock.toml --out results/deep_lock`` (about 3 min
on the shared 2-core machine), then ``python docs/deep_integration_lock_table.py results/deep_lock``.
Reads the sweep's CSV (mean and standard error over runs per point, and the paired difference of
``deep`` minus ``loose`` with its standard error, common random numbers).
"""

from __future__ import annotations

import csv
import sys
from pathlib import Path

METRICS = ("phase_lock_loss_fraction", "cycle_slip_rate", "loss_of_lock_fraction", "phase_tracking_error_rmse",
           "vertical_velocity_error_max")


def _f(x: str) -> str:
    v = float(x)
    return "0" if v == 0 else f"{v:.3g}"


def table(run: Path) -> str:
    rows = list(csv.DictReader((run / "sweeps" / "jerk.csv").open()))
    at = {(r["jerk"], r["case"], r["candidate"], r["metric"]): r for r in rows}
    lines = ["| C/N0 | peak jerk (g/s) | metric | `loose` | `deep` | `deep` − `loose` |", "| --- | --- | --- | --- | --- | --- |"]
    cases = list(dict.fromkeys(r["case"] for r in rows))
    jerks = list(dict.fromkeys(r["jerk"] for r in rows))
    for case in cases:
        for j in jerks:
            for m in METRICS:
                lo, de = at[(j, case, "loose", m)], at[(j, case, "deep", m)]
                lines.append(f"| {case} | {float(j):g} | {m} | {_f(lo['mean'])} ± {_f(lo['se'])} | "
                             f"{_f(de['mean'])} ± {_f(de['se'])} | {_f(de['diff_to_reference'])} ± {_f(de['diff_se'])} |")
    return "\n".join(lines)


if __name__ == "__main__":
    print(table(Path(sys.argv[1])))
