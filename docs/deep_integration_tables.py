"""Markdown tables of docs/experiments/deep-integration.md from runs of the deep-integration example.

Run: ``python docs/deep_integration_tables.py CONFIG.toml RESULT_DIR`` (the config given to
``gnssframework compare`` and its output directory, which holds ``results.sqlite``). Prints, per case, the
mean over runs of every metric per candidate beside reference 002's bounds, and the paired
differences (mean and standard error over runs, common random numbers) of every candidate
against ``deep``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from gnssframework.experiments.config import load_config
from gnssframework.experiments.stats import paired_difference, paired_values
from gnssframework.experiments.store import ResultStore

CANDIDATES = ("deep", "deep-no-accel", "vector", "loose")
PAPER = {"horizontal_position_error_max": "< 2", "height_error_max": "< 8", "horizontal_velocity_error_max": "≈ 0.5",
         "vertical_velocity_error_max": "< 1", "attitude_error_max": "< 0.5"}


def _fmt(x: float | None) -> str:
    if x is None or not np.isfinite(x):
        return "—"
    return f"{x:.3g}" if abs(x) < 1000 else f"{x:.3e}"


def tables(config_path: Path, run: Path) -> str:
    config = load_config(config_path)
    store = ResultStore(run / "results.sqlite")
    key = config.identity()
    metrics = config.metric_names
    lines = []
    for case in config.cases:
        vals = {(c, m): store.run_values(key, case.name, c, m, config.runs) for c in CANDIDATES for m in metrics}
        lines += [f"**{case.name}** ({config.runs} runs, mean over runs; reference 002 gives bounds for `deep` at "
                  "45 dB-Hz only)", "",
                  "| metric | " + " | ".join(f"`{c}`" for c in CANDIDATES) + " | paper (deep) |",
                  "| --- |" + " --- |" * (len(CANDIDATES) + 1)]
        for m in metrics:
            means = []
            for c in CANDIDATES:
                v = np.array(list(vals[(c, m)].values()), float)
                means.append(float(np.mean(v[np.isfinite(v)])) if np.isfinite(v).any() else np.nan)
            lines.append(f"| {m} | " + " | ".join(_fmt(x) for x in means) + f" | {PAPER.get(m, '')} |")
        lines += ["", f"Paired differences against `deep` ({case.name}; mean ± standard error over runs):", "",
                  "| metric | " + " | ".join(f"`{c}` − `deep`" for c in CANDIDATES[1:]) + " |",
                  "| --- |" + " --- |" * (len(CANDIDATES) - 1)]
        for m in metrics:
            cells = []
            for c in CANDIDATES[1:]:
                x, y = paired_values(vals[(c, m)], vals[("deep", m)])
                if len(x) < 2:
                    cells.append("—")
                    continue
                pd = paired_difference(x, y)
                cells.append(f"{_fmt(pd.diff)} ± {_fmt(pd.se)}")
            lines.append(f"| {m} | " + " | ".join(cells) + " |")
        lines.append("")
    return "\n".join(lines)


if __name__ == "__main__":
    print(tables(Path(sys.argv[1]), Path(sys.argv[2])))
