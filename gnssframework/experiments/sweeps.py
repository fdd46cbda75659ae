"""Parameter sweeps: ``[[sweeps]]`` tables that vary one scenario, case or candidate parameter.

::

    [[sweeps]]
    name = "cn0"                       # optional; default: the path's last part
    path = "cases.cn0_dbhz"            # every case; or "cases.45dBHz.cn0_dbhz" for one
    start = 25.0
    stop = 50.0                        # inclusive
    step = 5.0                         # or: num = 6 (evenly spaced, like numpy.linspace)

    [[sweeps]]
    path = "candidates.ackf.channel_filter.params.window"
    values = [10, 20, 40]

Paths: ``scenario.<field>``, ``cases.<field>`` (every case), ``cases.<case>.<field>``,
``candidates.<candidate>.<kind>.params.<field>`` (``kind`` may be left out when exactly
one of the candidate's plugins has that parameter), and further into a nested plugin's
parameters, ``...params.estimator.params.alpha`` (a nested plugin given by name is
rewritten as ``{name, params}``). The path must name a parameter of the
target's model, and every value is validated by that model when the config is loaded
(a bad value is refused naming the sweep, the path and the field's rule).

Each point is the comparison with that one value changed (sweeps are one at a time, not
a grid). Every point runs every case and candidate with the same seed, so the points
share their random numbers (common random numbers along the sweep as well as between
candidates), and is stored in the comparison's result store under the point's own
identity: an interrupted sweep resumes where it stopped, with identical numbers.

A threshold sweep may refine its grid around the thresholds it finds::

    [[sweeps]]
    name = "cn0-fine"
    path = "cases.cn0_dbhz"
    start = 15.0
    stop = 45.0
    step = 2.5
    threshold = { metric = "loss_of_lock", level = 0.1, fit = "logistic" }
    refine = { step = 0.5 }

Once the grid's runs are in, each case's and candidate's threshold is read off the grid
(the sweep's own ``threshold`` reading), and every grid cell its bootstrap interval
reaches gets a point every ``refine.step`` (`refined_values`); those points then run like
the grid's (every case and candidate, the same runs) and the sweep's tables, threshold
and threshold claims use grid and added points together (a claim at named points, or at
every point, names the grid's). The added points follow from the seed, so
a resumed comparison adds the same ones; more than ``refine.max_points`` is refused. A
sweep over the same grid without ``refine`` keeps the grid-only reading beside it (its
points are the same runs).
"""

from __future__ import annotations

import copy
import csv
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from ..errors import ConfigError
from ..io.files import atomic_open, write_json
from .file_names import check_file_name
from .number_format import format_estimate
from .stats import finite_or_none, mean_and_se, paired_difference, paired_values
from .threshold import Threshold, plot_threshold, threshold_markdown, threshold_rows

__all__ = ["Sweep", "Refine", "expand_sweep", "refined_values", "sweep_rows", "write_sweeps", "check_thresholds"]


#: Most points of one sweep, given as values or as a range: each point is a whole
#: comparison's work, and validating 100,000 listed values alone took minutes.
MAX_SWEEP_POINTS = 1000


class Refine(BaseModel):
    """The ``refine`` table of a threshold sweep: points added around each threshold."""

    model_config = ConfigDict(extra="forbid")
    step: float = Field(..., gt=0, description="spacing of the added points (smaller than the grid's)")
    max_points: int = Field(
        40,
        ge=1,
        le=MAX_SWEEP_POINTS,
        description="most points refinement may add; more is refused (a coarser step, or a raised bound)",
    )


class Sweep(BaseModel):
    """One swept parameter: a dotted path and a list (``values``) or a range
    (``start``, ``stop`` and ``step`` or ``num``) of values."""

    model_config = ConfigDict(extra="forbid")
    path: str = Field(
        ...,
        description="dotted path of the parameter: scenario.<field>, cases.<field>, "
        "cases.<case>.<field> or candidates.<candidate>.<kind>.params.<field>",
    )
    name: str | None = Field(
        None,
        pattern=r"^[A-Za-z0-9_.+-]+$",
        description="name in reports and file names (default: the path's last part)",
    )
    values: list[Any] | None = Field(
        None,
        min_length=1,
        max_length=MAX_SWEEP_POINTS,
        description=f"the values, in order (at most {MAX_SWEEP_POINTS})",
    )
    start: float | None = Field(None, description="first value of a range")
    stop: float | None = Field(None, description="last value of a range (inclusive)")
    step: float | None = Field(None, description="spacing of a range (with start and stop)")
    num: int | None = Field(None, ge=2, le=MAX_SWEEP_POINTS, description="number of evenly spaced values of a range")
    cases: list[str] | None = Field(
        None, min_length=1, description="the cases the sweep's points run (default: every case)"
    )
    threshold: Threshold | None = Field(
        None,
        description="where a per-run 0/1 metric's mean crosses a level "
        "along the sweep, with a paired bootstrap interval "
        "(gnssframework.experiments.threshold)",
    )
    refine: Refine | None = Field(
        None,
        description="after the grid, add points every refine.step across the grid cells each "
        "candidate's threshold interval lies in (needs threshold; gnssframework.experiments.sweeps)",
    )

    @field_validator("name")
    @classmethod
    def _plain_name(cls, value: str | None) -> str | None:
        return None if value is None else check_file_name(value)

    @model_validator(mode="after")
    def _one_form(self) -> Sweep:
        ranged = [k for k in ("start", "stop", "step", "num") if getattr(self, k) is not None]
        if self.values is not None:
            if ranged:
                raise ValueError(
                    f"give either values or a range (start, stop, step or num), not both "
                    f"(got values and {', '.join(ranged)})"
                )
            return self
        if self.start is None or self.stop is None or (self.step is None) == (self.num is None):
            raise ValueError("give values = [...], or start and stop with exactly one of step and num")
        for k in ("start", "stop", "step"):
            if getattr(self, k) is not None and not math.isfinite(getattr(self, k)):
                raise ValueError(f"{k} = {getattr(self, k)!r} must be a finite number")
        if self.step is not None:
            if self.step == 0 or (self.stop - self.start) / self.step < 0:
                raise ValueError(f"step = {self.step} does not lead from start = {self.start} to stop = {self.stop}")
            if (self.stop - self.start) / self.step > MAX_SWEEP_POINTS:
                raise ValueError(f"more than {MAX_SWEEP_POINTS} points; use a larger step")
        return self

    @model_validator(mode="after")
    def _refinable(self) -> Sweep:
        if self.refine is None:
            return self
        if self.threshold is None:
            raise ValueError("refine adds points around a threshold: give the sweep a threshold table")
        pts = self.points()
        if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in pts) or len(pts) < 2:
            raise ValueError("refine needs at least two numeric swept values")
        gap = float(np.min(np.diff(np.sort(np.asarray(pts, float)))))
        if self.refine.step >= gap:
            raise ValueError(f"refine.step = {self.refine.step:g} must be smaller than the grid's spacing ({gap:g})")
        return self

    @property
    def label(self) -> str:
        return self.name or self.path.rsplit(".", 1)[-1]

    def points(self) -> list[Any]:
        """The swept values, in order."""
        if self.values is not None:
            return list(self.values)
        if self.num is not None:
            pts = np.linspace(self.start, self.stop, self.num)
        else:
            n = int(math.floor((self.stop - self.start) / self.step + 1e-9)) + 1
            pts = self.start + self.step * np.arange(n)
        whole = all(float(v).is_integer() for v in (self.start, self.stop, self.step or 1.0)) and self.num is None
        # Round away the float noise of start + k * step (0.1 + 2 * 0.1 -> 0.3).
        return [int(round(v)) if whole else float(np.round(v, 12)) for v in pts]


def _model_fields(model: type[BaseModel] | None) -> list[str]:
    return [] if model is None else [f for f in model.model_fields if f not in ("name", "kind")]


def _resolve(config, sweep: Sweep, where: str) -> list[tuple[Any, ...]]:
    """The locations in the config's data the path names, as key tuples; refuses a path
    that names no parameter (listing the allowed ones)."""
    parts = sweep.path.split(".")
    head, rest = parts[0], parts[1:]
    field = f"{where}.path"
    scenario = config.resolved_scenario
    if head == "scenario":
        allowed = _model_fields(type(scenario).Params)
        if len(rest) != 1 or rest[0] not in allowed:
            raise ConfigError(
                field,
                f"{sweep.path!r} names no parameter of scenario {scenario.kind!r}; "
                f"allowed: {', '.join('scenario.' + a for a in allowed)}",
            )
        return [("scenario", rest[0])]
    if head == "cases":
        allowed = _model_fields(type(scenario).CaseParams)
        names = [c.name for c in config.cases]
        if len(rest) == 1 and rest[0] in allowed:
            return [("cases", i, rest[0]) for i in range(len(config.cases))]
        if len(rest) == 2 and rest[0] in names and rest[1] in allowed:
            return [("cases", names.index(rest[0]), rest[1])]
        raise ConfigError(
            field,
            f"{sweep.path!r} names no case parameter; allowed: "
            f"{', '.join('cases.' + a for a in allowed)} or cases.<case>.<parameter> "
            f"with a case among {', '.join(names)}",
        )
    if head == "candidates":
        names = [c.name for c in config.candidates]
        if not rest or rest[0] not in names:
            raise ConfigError(
                field, f"{sweep.path!r}: the second part must be a candidate; allowed: {', '.join(names)}"
            )
        i = names.index(rest[0])
        comps = config.resolved_candidates[i].components
        tail = rest[1:]
        if tail[:1] == ["params"] and len(tail) >= 2:  # kind left out: the one plugin having the parameter
            kinds = [k for k, spec in comps.items() if tail[1] in _model_fields(spec.cls.Params)]
            if len(kinds) != 1:
                raise ConfigError(
                    field,
                    f"{sweep.path!r}: {'no' if not kinds else 'more than one'} plugin of "
                    f"candidate {rest[0]!r} has a parameter {tail[1]!r}; write "
                    f"candidates.{rest[0]}.<kind>.params.{tail[1]} with a kind among "
                    f"{', '.join(comps)}",
                )
            tail = [kinds[0]] + tail
        if len(tail) < 3 or tail[0] not in comps or tail[1] != "params":
            raise ConfigError(
                field,
                f"{sweep.path!r}: write candidates.{rest[0]}.<kind>.params.<parameter> with "
                f"a kind among {', '.join(comps)}",
            )
        allowed = _model_fields(comps[tail[0]].cls.Params)
        if tail[2] not in allowed:
            raise ConfigError(
                field,
                f"{sweep.path!r}: {comps[tail[0]].name!r} has no parameter {tail[2]!r}; allowed: {', '.join(allowed)}",
            )
        return [("candidates", i, tail[0], "params", *tail[2:])]
    raise ConfigError(field, f"{sweep.path!r} must start with scenario, cases or candidates")


def _set(data: dict, keys: tuple[Any, ...], value: Any, path: str, field: str) -> None:
    node = data
    for i, k in enumerate(keys[:-1]):
        if isinstance(node, dict) and k not in node and isinstance(k, str):
            node[k] = {}
        if isinstance(node, dict) and isinstance(node.get(k), str) and keys[i + 1] == "params":
            node[k] = {"name": node[k], "params": {}}  # a nested plugin given by name: its table form
        try:
            node = node[k]
        except (KeyError, IndexError, TypeError):
            raise ConfigError(field, f"{path!r} does not exist in the config (at {k!r})") from None
        if not isinstance(node, (dict, list)):
            raise ConfigError(
                field,
                f"{path!r} does not exist in the config: {k!r} is a value "
                f"({node!r}), not a table; write it as {{ name = ..., params = {{ ... }} }}",
            )
    node[keys[-1]] = value


def expand_sweep(config, index: int) -> list[tuple[Any, Any]]:
    """The points of ``config.sweeps[index]``: ``(value, ComparisonConfig)`` pairs, each the
    config with that value set and no sweeps, validated (a bad value raises a
    ``ConfigError`` naming ``sweeps[index].values[j]``, the path and the field's rule)."""
    model = type(config)  # the config's own class: this module sits below experiments.config
    sweep = config.sweeps[index]
    where = f"sweeps[{index}]"
    names = [c.name for c in config.cases]
    for j, case in enumerate(sweep.cases or []):
        if case not in names:
            raise ConfigError(f"{where}.cases[{j}]", f"unknown case {case!r}; allowed: {', '.join(names)}")
    locations = _resolve(config, sweep, where)
    base = config.model_dump(mode="json", exclude={"sweeps", "claims", "tuning"}, exclude_none=True)
    out = []
    grid = sweep.points()
    added = config.refinement(index)
    values = sorted(grid + added, key=float) if added else grid
    for value in values:
        j = grid.index(value) if value in grid else None
        data = copy.deepcopy(base)
        for keys in locations:
            _set(data, keys, value, sweep.path, f"{where}.path")
        data["name"] = f"{config.name}-{sweep.label}={value}"
        if sweep.cases:
            data["cases"] = [c for c in data["cases"] if c["name"] in sweep.cases]
            data["published"] = {k: v for k, v in data.get("published", {}).items() if k in sweep.cases}
        at = f"{where}.values[{j}]" if j is not None else f"{where}.refine"
        try:
            point = model.model_validate(data)
        except ConfigError as exc:
            raise ConfigError(at, f"{sweep.path} = {value!r}: {exc}") from None
        except Exception as exc:  # pydantic's ValidationError, made one line by the config loader
            from pydantic import ValidationError

            from ..plugin import validation_message

            if isinstance(exc, ValidationError):
                raise ConfigError(at, f"{sweep.path} = {value!r}: {validation_message(exc, model=model)}") from None
            raise
        out.append((value, point))
    return out


def refined_values(config, store, index: int) -> list[float]:
    """The points ``sweeps[index].refine`` adds, read off the grid's runs in ``store``.

    For every case and candidate whose threshold lies in the grid, the grid cells its
    bootstrap interval reaches (from the last grid value at or below the interval's lower
    end to the first at or above its upper end; an infinite end: the grid's end) get a
    point every ``refine.step`` from the cell's lower value, the grid values themselves
    excluded. The union over cases and candidates, in order. The interval is the sweep's
    own threshold reading (its level and ``fit``) on the grid, so the points are fixed by
    the seed: a resumed run adds the same ones.

    Raises
    ------
    ConfigError
        ``sweeps[index].refine`` when more than ``refine.max_points`` would be added.
    """
    sweep = config.sweeps[index]
    if sweep.refine is None:
        return []
    if config.refinement(index):
        raise ValueError(f"sweeps[{index}] is refined already")
    report = threshold_rows(config, store, index)
    grid = np.array(sorted(float(v) for v in sweep.points()))
    step = sweep.refine.step
    added: set[float] = set()
    for entry in report["cases"] if report else []:
        for row in entry["rows"]:
            if row["threshold"] is None:
                continue  # beyond the grid: nothing between grid points to refine
            lo, hi = (float(v) for v in row["ci95"])
            a = grid[max(0, int(np.searchsorted(grid, lo, side="right")) - 1)] if math.isfinite(lo) else grid[0]
            b = grid[min(grid.size - 1, int(np.searchsorted(grid, hi, side="left")))] if math.isfinite(hi) else grid[-1]
            k = np.arange(1, int(math.floor((b - a) / step + 1e-9)) + 1)
            for v in np.round(a + step * k, 12):
                if not np.any(np.isclose(v, grid, rtol=0, atol=1e-9 * max(1.0, abs(v)))):
                    added.add(float(v))
    if len(added) > sweep.refine.max_points:
        raise ConfigError(
            f"sweeps[{index}].refine",
            f"{len(added)} points around the thresholds of sweep {sweep.label!r} exceed max_points = "
            f"{sweep.refine.max_points}; give a larger step or raise max_points",
        )
    return sorted(added)


# -- report ---------------------------------------------------------------------------------


def sweep_rows(config, store) -> list[dict]:
    """Per sweep: ``{"name", "path", "values", "rows", "paired"}``; ``rows`` hold each
    point's mean, SE and n per case, candidate and metric; ``paired`` each point's paired
    difference to the reference candidate (see :mod:`gnssframework.experiments.stats`)."""
    out = []
    ref = config.reference_name
    units = config.metric_units
    for i, sweep in enumerate(config.sweeps):
        rows, paired = [], []
        for value, point in config.sweep_points(i):
            key = point.identity()
            for case in point.cases:
                for metric in point.metric_names:
                    y = store.run_values(key, case.name, ref, metric, point.runs)
                    for cand in point.candidates:
                        x = store.run_values(key, case.name, cand.name, metric, point.runs)
                        mean, se, n = mean_and_se(np.array([x[r] for r in sorted(x)]))
                        rows.append(
                            {
                                "value": value,
                                "case": case.name,
                                "candidate": cand.name,
                                "metric": metric,
                                "mean": finite_or_none(mean),
                                "se": finite_or_none(se),
                                "n": n,
                                "unit": units[metric],
                            }
                        )
                        if cand.name != ref:
                            pd = paired_difference(*paired_values(x, y))
                            paired.append(
                                {
                                    "value": value,
                                    "case": case.name,
                                    "candidate": cand.name,
                                    "metric": metric,
                                    "reference": ref,
                                    **pd.to_json(),
                                }
                            )
        out.append(
            {
                "name": sweep.label,
                "path": sweep.path,
                "values": [v for v, _ in config.sweep_points(i)],
                "refined": config.refinement(i),
                "cases": [c.name for c in config.cases if not sweep.cases or c.name in sweep.cases],
                "rows": rows,
                "paired": paired,
            }
        )
    return out


def _write_csv(path: Path, sweep: dict) -> None:
    paired = {(p["value"], p["case"], p["candidate"], p["metric"]): p for p in sweep["paired"]}
    with atomic_open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(
            [
                sweep["name"],
                "case",
                "candidate",
                "metric",
                "unit",
                "mean",
                "se",
                "n",
                "diff_to_reference",
                "diff_se",
                "significant",
            ]
        )
        for r in sweep["rows"]:
            p = paired.get((r["value"], r["case"], r["candidate"], r["metric"]), {})
            w.writerow(
                [
                    r["value"],
                    r["case"],
                    r["candidate"],
                    r["metric"],
                    r["unit"],
                    "" if r["mean"] is None else r["mean"],
                    "" if r["se"] is None else r["se"],
                    r["n"],
                    "" if p.get("diff") is None else p["diff"],
                    "" if p.get("se") is None else p["se"],
                    p.get("significant", ""),
                ]
            )


def _plot(path: Path, config, sweep: dict, case: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    values = sweep["values"]
    numeric = all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values)
    xs = np.array(values, dtype=float) if numeric else np.arange(len(values), dtype=float)
    metrics = config.metric_names
    fig, axes = plt.subplots(len(metrics), 1, figsize=(6.5, 2.2 * len(metrics)), sharex=True, squeeze=False)
    for ax, metric in zip(axes[:, 0], metrics):
        for cand in config.candidates:
            rows = {
                r["value"]: r
                for r in sweep["rows"]
                if r["case"] == case and r["candidate"] == cand.name and r["metric"] == metric
            }
            mean = np.array([np.nan if rows[v]["mean"] is None else rows[v]["mean"] for v in values], dtype=float)
            se = np.array([np.nan if rows[v]["se"] is None else rows[v]["se"] for v in values], dtype=float)
            (line,) = ax.plot(xs, mean, marker="o", ms=3, lw=1.0, label=cand.name)
            ax.fill_between(xs, mean - 1.96 * se, mean + 1.96 * se, color=line.get_color(), alpha=0.2, lw=0)
        ax.set_ylabel(f"{metric}\n({config.metric_units[metric]})", fontsize=7)
        ax.grid(alpha=0.3)
    if not numeric:
        axes[-1, 0].set_xticks(xs, [str(v) for v in values])
    axes[-1, 0].set_xlabel(sweep["path"])
    axes[0, 0].legend(fontsize=7)
    axes[0, 0].set_title(f"{config.name} - {case}: mean ± 1.96 SE over runs", fontsize=9)
    fig.tight_layout()
    with atomic_open(path, "wb") as fh:
        fig.savefig(fh, format="png", dpi=90)
    plt.close(fig)


def _plot_paired(path: Path, config, sweep: dict, case: str) -> None:
    """Each metric's paired difference to the reference against the parameter, with its
    95 % paired t-interval (the interval the significance mark uses)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    values = sweep["values"]
    numeric = all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values)
    xs = np.array(values, dtype=float) if numeric else np.arange(len(values), dtype=float)
    metrics = config.metric_names
    fig, axes = plt.subplots(len(metrics), 1, figsize=(6.5, 2.2 * len(metrics)), sharex=True, squeeze=False)
    for ax, metric in zip(axes[:, 0], metrics):
        for cand in config.candidates:
            if cand.name == config.reference_name:
                continue
            rows = {
                p["value"]: p
                for p in sweep["paired"]
                if p["case"] == case and p["candidate"] == cand.name and p["metric"] == metric
            }
            diff = np.array([np.nan if rows[v]["diff"] is None else rows[v]["diff"] for v in values], dtype=float)
            lo = np.array(
                [
                    np.nan if rows[v]["ci95"] is None or rows[v]["ci95"][0] is None else rows[v]["ci95"][0]
                    for v in values
                ],
                dtype=float,
            )
            hi = np.array(
                [
                    np.nan if rows[v]["ci95"] is None or rows[v]["ci95"][1] is None else rows[v]["ci95"][1]
                    for v in values
                ],
                dtype=float,
            )
            (line,) = ax.plot(xs, diff, marker="o", ms=3, lw=1.0, label=f"{cand.name} - {config.reference_name}")
            ax.fill_between(xs, lo, hi, color=line.get_color(), alpha=0.2, lw=0)
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_ylabel(f"Δ {metric}\n({config.metric_units[metric]})", fontsize=7)
        ax.grid(alpha=0.3)
    if not numeric:
        axes[-1, 0].set_xticks(xs, [str(v) for v in values])
    axes[-1, 0].set_xlabel(sweep["path"])
    if axes[0, 0].get_legend_handles_labels()[0]:
        axes[0, 0].legend(fontsize=7)
    axes[0, 0].set_title(
        f"{config.name} - {case}: paired difference to {config.reference_name}, 95 % paired t-interval", fontsize=9
    )
    fig.tight_layout()
    with atomic_open(path, "wb") as fh:
        fig.savefig(fh, format="png", dpi=90)
    plt.close(fig)


def _markdown(config, sweep: dict) -> list[str]:
    ref = config.reference_name
    paired = {(p["value"], p["case"], p["candidate"], p["metric"]): p for p in sweep["paired"]}
    means = {(r["value"], r["case"], r["candidate"], r["metric"]): r for r in sweep["rows"]}
    names = [c.name for c in config.candidates]
    lines = [
        f"## Sweep `{sweep['name']}`: {sweep['path']}",
        "",
        f"Mean ± SE over runs; for candidates other than `{ref}`, the paired difference to it "
        "(**\\***: significant). Table: `sweeps/" + sweep["name"] + ".csv`.",
        "",
    ]
    if sweep.get("refined"):
        lines += [
            f"Refined: {len(sweep['refined'])} points added around the thresholds read off the grid "
            f"({', '.join(f'{v:g}' for v in sweep['refined'])}).",
            "",
        ]
    for case in sweep["cases"]:
        lines += [f"### {case}", "", f"![sweep {sweep['name']}](plots/sweep-{sweep['name']}-{case}.png)", ""]
        if len(names) > 1:
            lines += [f"![paired differences](plots/sweep-{sweep['name']}-{case}-paired.png)", ""]
        lines += [
            f"| {sweep['name']} | metric | " + " | ".join(names) + " |",
            "| --- | --- | " + " | ".join("---" for _ in names) + " |",
        ]
        for metric in config.metric_names:
            for v in sweep["values"]:
                cells = []
                for cand in names:
                    r = means[(v, case, cand, metric)]
                    cell = format_estimate(r["mean"], r["se"])
                    p = paired.get((v, case, cand, metric))
                    if p is not None and p["diff"] is not None:
                        cell += (
                            f" (Δ {format_estimate(p['diff'], p['se'], sign=True)}"
                            + (" **\\***" if p["significant"] else "")
                            + ")"
                        )
                    cells.append(cell)
                lines.append(f"| {v} | {metric} | " + " | ".join(cells) + " |")
        lines.append("")
    return lines


def write_sweeps(
    config, store, out: Path, figures: Callable[[str], bool] | None = None
) -> tuple[list[dict], list[str]]:
    """Write each sweep's table (``sweeps/<name>.csv`` and ``.json``) and plots
    (``plots/sweep-<name>-<case>.png``, those ``figures`` accepts by file name: every one
    when it is None); return the summary entries and report lines."""
    wanted = figures or (lambda name: True)
    if not config.sweeps:
        return [], []
    sweeps = sweep_rows(config, store)
    (out / "sweeps").mkdir(exist_ok=True)
    (out / "plots").mkdir(exist_ok=True)
    lines: list[str] = []
    for sweep in sweeps:
        _write_csv(out / "sweeps" / f"{sweep['name']}.csv", sweep)
        write_json(out / "sweeps" / f"{sweep['name']}.json", sweep)  # strict JSON, atomic
        for case in sweep["cases"]:
            if wanted(name := f"sweep-{sweep['name']}-{case}.png"):
                _plot(out / "plots" / name, config, sweep, case)
            if len(config.candidates) > 1 and wanted(name := f"sweep-{sweep['name']}-{case}-paired.png"):
                _plot_paired(out / "plots" / name, config, sweep, case)
        lines += _markdown(config, sweep)
    for i, sweep in enumerate(config.sweeps):
        report = threshold_rows(config, store, i)
        if report is None:
            continue
        for entry in report["cases"]:
            if wanted(name := f"threshold-{sweep.label}-{entry['case']}.png"):
                plot_threshold(out / "plots" / name, config, report, entry, sweeps[i])
        lines += threshold_markdown(config, report)
        sweeps[i]["threshold"] = {k: v for k, v in report.items() if k != "cases"} | {
            "cases": [{k: v for k, v in c.items() if not k.startswith("_")} for c in report["cases"]]
        }
        write_json(out / "sweeps" / f"{sweep.label}-threshold.json", sweeps[i]["threshold"])
    return sweeps, lines


def check_thresholds(sweeps: list[Sweep], metrics: list[str]) -> None:
    """Refuse a sweep's threshold table naming a metric the comparison does not report."""
    for i, sweep in enumerate(sweeps):
        t = sweep.threshold
        if t is None:
            continue
        for field in ("metric", "time_metric"):
            value = getattr(t, field)
            if value is not None and value not in metrics:
                raise ConfigError(
                    f"sweeps[{i}].threshold.{field}", f"unknown metric {value!r}; allowed: {', '.join(metrics)}"
                )
        for j, value in enumerate(t.plot_metrics):
            if value not in metrics:
                raise ConfigError(
                    f"sweeps[{i}].threshold.plot_metrics[{j}]",
                    f"unknown metric {value!r}; allowed: {', '.join(metrics)}",
                )


def check_unique_labels(sweeps: list[Sweep]) -> None:
    labels = [s.label for s in sweeps]
    dup = sorted({n for n in labels if labels.count(n) > 1})
    if dup:
        raise ConfigError("sweeps", f"sweep names must be unique, repeated: {', '.join(dup)} (set name = ...)")
