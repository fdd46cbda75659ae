"""The comparison report: summary.json, report.md and PNG plots."""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from pathlib import Path

import numpy as np

from .candidates import build_candidate
from .claims import MIN_CLAIM_RUNS, STATED_POWER, claim_evidence, claim_where, evaluate_claims, in_family
from .config import ComparisonConfig
from ..io.files import atomic_open, atomic_write_text, write_json
from .number_format import format_estimate
from .stats import SIGNIFICANCE_RULE, paired_rows
from .store import ResultStore
from .sweeps import write_sweeps

__all__ = ["write_report", "summary_rows", "series_figure", "cdf_figure"]


def summary_rows(config: ComparisonConfig, store: ResultStore) -> list[dict]:
    """One row per case, candidate and metric: mean and std over the runs where the metric is
    defined (``runs`` counts them), unit, published value.

    A metric undefined in every run (NaN, e.g. a recovery time in runs without slips) has
    ``mean`` and ``std`` ``None`` and an ``undefined`` reason: the scenario's
    ``undefined_reasons[metric]`` when it gives one.
    """
    units = config.metric_units
    scenario = config.resolved_scenario
    key = config.identity()
    rows = []
    for case in config.cases:
        for cand in config.candidates:
            for metric in config.metric_names:
                v = store.values(key, case.name, cand.name, metric, config.runs)
                v = v[np.isfinite(v)]  # a metric may be undefined in a run (e.g. no isolated slip): NaN
                rows.append(
                    {
                        "case": case.name,
                        "candidate": cand.name,
                        "metric": metric,
                        "mean": float(np.mean(v)) if v.size else None,
                        "std": float(np.std(v, ddof=1)) if v.size > 1 else 0.0,
                        "runs": int(v.size),
                        "unit": units[metric],
                        "published": config.published.get(case.name, {}).get(cand.name, {}).get(metric),
                    }
                )
                if not v.size:
                    rows[-1].update(std=None, undefined=_undefined_reason(scenario, metric))
    return rows


def _undefined_reason(scenario, metric: str) -> str:
    reasons = getattr(scenario, "undefined_reasons", {}) or {}
    return reasons.get(metric, "undefined in every run")


def _fmt(x: float | None) -> str:
    if x is None:
        return "–"
    return f"{x:.4g}"


def mean_cell(row: dict) -> str:
    """``mean ± SE``, the standard error of the mean ``std / sqrt(runs)``, at the resolution
    it supports (the mean alone when the runs do not spread beyond rounding): the
    convention of the docs' generated tables (``docs/experiment_tables.py``) too."""
    std = row["std"] or 0.0
    return format_estimate(row["mean"], std / np.sqrt(row["runs"]))


def _paired_markdown(config: ComparisonConfig, paired: list[dict], case: str, units: dict[str, str]) -> list[str]:
    """The case's paired tables: the differences (candidate minus reference, per metric),
    then the ratios of means (candidate over reference), each one column per candidate."""
    others = [c.name for c in config.candidates if c.name != config.reference_name]
    if not others:
        return []
    mine = [r for r in paired if r["case"] == case and r["candidate"] in others and r["diff"] is not None]
    counts = [r["n"] for r in mine]
    n_all = max(set(counts), key=counts.count) if counts else None  # the usual n, stated once
    header = [
        "| metric | unit | " + " | ".join(others) + " |",
        "| --- | --- | " + " | ".join("---" for _ in others) + " |",
    ]
    lines = [
        f"Paired differences to `{config.reference_name}` (candidate minus reference, mean ± SE over "
        + (
            f"the n = {n_all} common-random-number runs, n given in a cell where it differs"
            if n_all is not None
            else "the n common-random-number runs"
        )
        + "; **\\***: significant, the 95 % paired t-interval excludes 0; a difference without ± "
        "has no spread over the runs and is not tested):",
        "",
        *header,
    ]
    ratios = []
    for metric in config.metric_names:
        cells, ratio_cells = [], []
        for cand in others:
            r = next(r for r in paired if r["case"] == case and r["candidate"] == cand and r["metric"] == metric)
            if r["diff"] is None:
                cells.append(f"– ({r['reason']})")
                ratio_cells.append("–")
                continue
            n_note = "" if r["n"] == n_all else f" n={r['n']}"
            cells.append(
                format_estimate(r["diff"], r["se"], sign=True) + (" **\\***" if r["significant"] else "") + n_note
            )
            ratio_cells.append("–" if r["ratio"] is None else f"×{format_estimate(r['ratio'], r['ratio_se'])}" + n_note)
        lines.append(f"| {metric} | {units.get(metric, '')} | " + " | ".join(cells) + " |")
        ratios.append(f"| {metric} | {units.get(metric, '')} | " + " | ".join(ratio_cells) + " |")
    if any(r["ratio"] is not None for r in mine):
        lines += [
            "",
            f"Ratios of means to `{config.reference_name}` (candidate mean over reference mean ± its SE, "
            "from the same paired runs; –: no ratio, a value is negative or the reference's mean is 0):",
            "",
            *header,
            *ratios,
        ]
    return lines + [""]


def _markdown(config: ComparisonConfig, rows: list[dict], paired: list[dict] | None = None) -> str:
    lines = [f"# {config.name}", ""]
    if config.description:
        lines += [config.description.strip(), ""]
    lines += [
        f"{config.runs} Monte Carlo runs per case and candidate, seed {config.seed}, "
        f"batches of {config.batch_size}. Every ± is a standard error: each case's first table gives "
        "mean ± SE over the runs (SE = standard deviation / sqrt(runs), the uncertainty of the mean, "
        "not the spread of one run's metric), as the docs' tables do; orderings are read from the "
        "paired differences in the table below it. Numbers are given to the second "
        "significant figure of their standard error; a value without ± did not vary over the runs "
        "(beyond floating-point rounding).",
        "",
    ]
    for case in config.cases:
        lines += [
            f"## {case.name}",
            "",
            "| metric | unit | " + " | ".join(c.name for c in config.candidates) + " |",
            "| --- | --- | " + " | ".join("---" for _ in config.candidates) + " |",
        ]
        for metric in config.metric_names:
            cells = []
            unit = ""
            for cand in config.candidates:
                r = next(
                    r for r in rows if r["case"] == case.name and r["candidate"] == cand.name and r["metric"] == metric
                )
                unit = r["unit"]
                cell = r["undefined"] if r.get("undefined") else mean_cell(r)
                if r["published"] is not None:
                    cell += f" (paper {_fmt(r['published'])})"
                cells.append(cell)
            lines.append(f"| {metric} | {unit} | " + " | ".join(cells) + " |")
        lines += [""] + _paired_markdown(config, paired or [], case.name, {r["metric"]: r["unit"] for r in rows})
        lines += [
            f"![time series](plots/{case.name}-series.png)",
            "",
            f"![CDFs over runs](plots/{case.name}-cdf.png)",
            "",
        ]
    return "\n".join(lines) + "\n"


#: Epochs at which the report's time-series plots take the median over runs: a figure
#: shows no more, and it bounds the report step's memory to this many values per run.
PLOT_EPOCHS = 2000


def _median_series(
    out: Path, config: ComparisonConfig, case: str, cand: str
) -> tuple[np.ndarray | None, dict[str, np.ndarray]]:
    """Per metric, the median over runs at up to ``PLOT_EPOCHS`` evenly spaced epochs, read
    from the batches of this comparison's plan only, one series at a time (memory bounded
    whatever the number of runs)."""
    from .store import plan_batches
    from .tasks import series_file

    files = [series_file(out, case, cand, first, n) for first, n in plan_batches(config.runs, config.batch_size)]
    files = [f for f in files if f.exists()]
    if not files:
        return None, {}
    with np.load(files[0]) as first:
        time_s = first["time_s"]
        keys = [k for k in first.files if k not in ("time_s", "first_run")]
    if not time_s.size:
        return time_s, {}
    pick = np.unique(np.linspace(0, time_s.size - 1, min(PLOT_EPOCHS, time_s.size)).round().astype(int))
    medians = {}
    for key in keys:
        parts = []
        for f in files:
            with np.load(f) as data:
                if key in data.files and data[key].shape[0] == time_s.size:
                    parts.append(data[key][pick])
        if parts:
            medians[key] = np.median(np.concatenate(parts, axis=-1), axis=-1)
    return time_s[pick], medians


def _savefig(fig, path: Path) -> None:
    with atomic_open(path, "wb") as fh:  # a killed run leaves no half PNG
        fig.savefig(fh, format="png", dpi=90)


def _folded_bounds(config: ComparisonConfig) -> dict[str, str]:
    """Error metric -> its lower bound, for the bounds drawn inside their metric's panel
    (one curve: the bound is the same for every candidate) rather than in a panel of their own."""
    bounds = getattr(config.resolved_scenario, "bounds", {}) or {}
    return {m: b for m, b in bounds.items() if m in config.metric_names and b in config.metric_names}


def _candidate_styles(config: ComparisonConfig) -> dict[str, dict]:
    """Each candidate's colour, the same in every panel and figure."""
    import matplotlib

    colours = matplotlib.colormaps["tab10"].colors
    return {c.name: {"color": colours[i % len(colours)], "linewidth": 0.9} for i, c in enumerate(config.candidates)}


def series_figure(config: ComparisonConfig, out: Path, case: str):
    """The case's time series: per metric, the median over runs of the per-epoch series
    the metric reduces (not the metric itself: the median of ``|e_k|`` is no RMSE), each
    bound as one dashed curve in its metric's panel.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from .figures import BOUND_STYLE, Curve, Panel, panel_grid
    from .metric_components import series_label

    scenario = config.resolved_scenario
    units = config.metric_units
    bounds = _folded_bounds(config)
    styles = _candidate_styles(config)
    medians = {c.name: _median_series(out, config, case, c.name) for c in config.candidates}
    panels = []
    for metric in config.metric_names:
        if metric in bounds.values():
            continue
        curves = [
            Curve(cand, t, series[metric], styles[cand])
            for cand, (t, series) in medians.items()
            if t is not None and t.size and metric in series
        ]
        bound = bounds.get(metric)
        drawn = next(
            (
                (t, series[bound])
                for t, series in medians.values()
                if bound and t is not None and t.size and bound in series
            ),
            None,
        )
        if drawn is not None:
            curves.append(Curve(f"{bound} (bound)", *drawn, BOUND_STYLE))
        panels.append(
            Panel(
                metric,
                "time (s)",
                f"{series_label(scenario, metric)} ({units[metric]})",
                curves,
                note="no time series stored",
            )
        )
    return panel_grid(
        panels, f"{config.name} – {case}: median over {config.runs} runs of each metric's per-epoch series"
    )


def cdf_figure(config: ComparisonConfig, store: ResultStore, case: str):
    """The case's distributions over runs: per metric, the empirical CDF of each
    candidate's per-run values, a bound as one dashed curve in its metric's panel.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from .figures import BOUND_STYLE, Curve, Panel, panel_grid

    units = config.metric_units
    bounds = _folded_bounds(config)
    styles = _candidate_styles(config)
    key = config.identity()

    def cdf(name: str, metric: str, style: dict) -> Curve | None:
        v = np.sort(store.values(key, case, name, metric, config.runs))
        v = v[np.isfinite(v)]
        # The staircase starts at 0 at the smallest value: each run adds 1/n where it lies.
        return Curve(name, np.r_[v[:1], v], np.arange(v.size + 1) / v.size, style, step=True) if v.size else None

    panels = []
    for metric in config.metric_names:
        if metric in bounds.values():
            continue
        curves = [cdf(c.name, metric, styles[c.name]) for c in config.candidates]
        if metric in bounds:
            bound = cdf(config.candidates[0].name, bounds[metric], BOUND_STYLE)
            if bound is not None:
                bound.label = f"{bounds[metric]} (bound)"
                curves.append(bound)
        panels.append(
            Panel(
                metric,
                f"{metric} ({units[metric]})",
                "fraction of runs at or below (-)",
                [c for c in curves if c is not None],
                values_on="x",
                note="undefined in every run",
            )
        )
    return panel_grid(panels, f"{config.name} – {case}: distribution over {config.runs} runs")


def _plots(config: ComparisonConfig, store: ResultStore, out: Path, wanted: Callable[[str], bool]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plot_dir = out / "plots"
    plot_dir.mkdir(exist_ok=True)
    for case in config.cases:
        for name, draw in (
            (f"{case.name}-series.png", partial(series_figure, config, out, case.name)),
            (f"{case.name}-cdf.png", partial(cdf_figure, config, store, case.name)),
        ):
            if wanted(name):
                fig = draw()
                _savefig(fig, plot_dir / name)
                plt.close(fig)


def assumption_rows(config: ComparisonConfig) -> list[dict]:
    """Per case and candidate, what each plugin assumes (``SequentialFilter.assumptions``):
    ``{"case", "candidate", "component", "label", "value", "unit"}``."""
    scenario = config.resolved_scenario
    rows = []
    for case in config.cases:
        context = scenario.assumption_context({"name": case.name, **case.params()})
        for cand in config.resolved_candidates:
            plugins = build_candidate(scenario, cand)
            for kind, plugin in plugins.items():
                declared = getattr(plugin, "assumptions", None)
                for label, (value, unit) in (declared(context) if declared else {}).items():
                    rows.append(
                        {
                            "case": case.name,
                            "candidate": cand.name,
                            "component": kind,
                            "label": label,
                            "value": value,
                            "unit": unit,
                        }
                    )
    return rows


def _assumptions_markdown(config: ComparisonConfig, rows: list[dict]) -> list[str]:
    if not rows:
        return []
    names = [c.name for c in config.candidates]
    lines = [
        "## Assumptions",
        "",
        "What each candidate's filters assume about the dynamics and the noise, in "
        "common units (from each plugin's `assumptions`): a mismatch here explains a ranking before the "
        "ranking is read.",
        "",
    ]
    for case in config.cases:
        mine = [r for r in rows if r["case"] == case.name]
        keys = list(dict.fromkeys((r["component"], r["label"], r["unit"]) for r in mine))
        lines += [
            f"### {case.name}",
            "",
            "| component | assumption | unit | " + " | ".join(names) + " |",
            "| --- | --- | --- | " + " | ".join("---" for _ in names) + " |",
        ]
        for comp, label, unit in keys:
            cells = []
            for name in names:
                r = next((r for r in mine if (r["candidate"], r["component"], r["label"]) == (name, comp, label)), None)
                v = None if r is None else r["value"]
                cells.append("–" if v is None else f"{v:.3g}" if isinstance(v, float) else str(v))
            lines.append(f"| {comp} | {label} | {unit} | " + " | ".join(cells) + " |")
        lines.append("")
    return lines


def _claims_markdown(
    claims: list[dict],
    adjustment: str = "holm",
    untuned: list[str] = (),
    given: set[str] = frozenset(),
    replicated: bool = False,
) -> list[str]:
    lines = []
    if untuned:  # the fairness rule: every candidate left as given while others were tuned, marked
        lines += [
            "## Untuned candidates",
            "",
            "Tuned by `[tuning]`: every candidate but "
            + ", ".join(
                f"`{n}` ({'deliberately as given: as_given = true' if n in given else 'not tuned'})" for n in untuned
            )
            + ". A claim against a candidate that is not tuned is refused unless it is marked as given.",
            "",
        ]
    if not claims:
        return lines
    held = sum(c["outcome"] == "holds" for c in claims)
    family = [c for c in claims if in_family(c)]
    adjusted = sum(bool(c.get("holds_adjusted")) for c in family)
    name = {
        "holm": "Holm's step-down (family-wise error rate)",
        "benjamini-hochberg": "Benjamini-Hochberg (false discovery rate)",
    }[adjustment]
    lines += [
        "## Claims",
        "",
        f"{held} of {len(claims)} hold. Each is checked from the 95 % intervals of its test "
        "(t by default; a claim may ask for the paired bootstrap or Wilcoxon's signed-rank test) on its "
        "paired differences, ratio of means or mean (`holds`: on the claimed side; `fails`: on the other; "
        "`not significant`: the runs cannot tell; `refused`: no spread over the runs, nothing to test); an "
        "equivalence by two one-sided tests against its margin; a NEES consistency by the chi-square band of "
        "its runs and states; a claim at a sweep's points is one row per point and one for all of them (fails "
        "only at the Bonferroni level over its points).",
        "",
        f"Multiple comparisons: {name} over the {len(family)} tests of this example; "
        f"{adjusted} of them hold after it at 5 %. "
        "Reported only: the outcome above is each claim's own 95 % test.",
        "",
    ]
    few = [c for c in claims if c.get("few_runs")]
    if few:
        lines += [
            f"Power: {len(few)} of the claim rows are over fewer than {MIN_CLAIM_RUNS} paired runs; each states "
            f"the difference its test detects with probability {STATED_POWER:g} at its 5 % level (and, after "
            "the adjustment, at the strictest adjusted level), a property of the design, not of the difference "
            "observed."
            + (
                ""
                if all(c.get("small_n") for c in few)
                else " Those marked `small_n not declared` are refused by `compare --check`."
            ),
            "",
        ]
    if replicated:
        both = sum(c["outcome"] == "holds" and c.get("replicate_outcome") == "holds" for c in claims)
        one = sum((c["outcome"] == "holds") != (c.get("replicate_outcome") == "holds") for c in claims)
        stated = sum(c.get("replicates") is False for c in claims)
        lines += [
            f"Replication: every claim re-checked on a second, disjoint set of runs (the replicate streams): "
            f"{both} hold on both, {one} on one seed set only"
            + (f" ({stated} stated so: `replicates = false`)" if stated else "")
            + ".",
            "",
        ]
    lines += ["| outcome | case | claim | evidence |", "| --- | --- | --- | --- |"]
    for c in claims:
        outcome = c["outcome"]
        if replicated and c.get("replicate_outcome") != outcome:
            outcome += f" (replicate: {c.get('replicate_outcome')}"
            outcome += "; stated: evaluation runs only)" if c.get("replicates") is False else ")"
        lines.append(f"| {outcome} | {claim_where(c)} | {c['statement']} | {claim_evidence(c)} |")
    return lines + [""]


#: Units read off a parameter's name suffix (the project names quantities with their
#: units: ``pll_bandwidth_hz``), for the tuning plots' x axes.
_UNIT_SUFFIXES = (
    ("_dbhz", "dB-Hz"),
    ("_hz_s", "Hz/s"),
    ("_hz", "Hz"),
    ("_m2", "m²"),
    ("_m_s", "m/s"),
    ("_chips", "chips"),
    ("_rad", "rad"),
    ("_deg", "deg"),
    ("_db", "dB"),
    ("_ms", "ms"),
    ("_s", "s"),
    ("_m", "m"),
)


def parameter_axis_label(label: str) -> str:
    """A tuned parameter's axis label with its unit: from its name's suffix
    (``pll_bandwidth_hz`` -> Hz), else the unit of the config (``q[1]``, ``window``), said so.

    >>> parameter_axis_label("channel_filter.pll_bandwidth_hz")
    'channel_filter.pll_bandwidth_hz (Hz)'
    >>> parameter_axis_label("channel_filter.q[1]")
    "channel_filter.q[1] (the config's unit)"
    """
    name = label.split(".")[-1].split("[")[0].lower()
    unit = next((u for suffix, u in _UNIT_SUFFIXES if name.endswith(suffix)), None)
    return f"{label} ({unit})" if unit else f"{label} (the config's unit)"


def tuning_figure(cand: str, res: dict, unit: str):
    """The objective against each free parameter of one candidate's tuning (a panel per
    parameter, trials as dots, the tuned point as a star), units on both axes."""
    import matplotlib.pyplot as plt

    labels = res["labels"]
    fig, axes = plt.subplots(1, len(labels), figsize=(3.6 * len(labels), 3.2), squeeze=False)
    obj = np.array([t["objective"] for t in res["trials"]], dtype=float)
    for ax, label, k in zip(axes[0], labels, range(len(labels))):
        x = [t["values"][k] for t in res["trials"]]
        numeric = all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in x)
        ok = np.isfinite(obj)
        xs = np.array(x, dtype=float) if numeric else np.array([str(v) for v in x])
        ax.plot(xs[ok], obj[ok], "o", ms=4, label="trial")
        ax.plot(
            [res["best"][label]] if numeric else [str(res["best"][label])],
            [res["best_objective"]],
            "r*",
            ms=10,
            label="tuned",
        )
        if numeric and min(x) > 0 and max(x) / min(x) > 50:
            ax.set_xscale("log")
        ax.set_xlabel(parameter_axis_label(label), fontsize=7)
        ax.tick_params(labelsize=6)
        ax.grid(alpha=0.3)
    metric = res["metric"] if isinstance(res["metric"], str) else " x ".join(res["metric"])  # a composite's
    for ax in axes[0]:  # units on every axis, on two lines so the label fits the panel's height
        ax.set_ylabel(f"{metric} ({unit})\n{res['combine']} over cases", fontsize=7)
    handles, names = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, names, loc="lower center", fontsize=6, ncol=2, frameon=False)
    fig.suptitle(f"tuning {cand}", fontsize=9)
    fig.tight_layout(rect=(0, 0.07, 1, 1))  # room for the legend below
    return fig


def replicate_claims(claims: list[dict], replica: list[dict], stated: list[bool]) -> None:
    """Add each claim row's outcome on the replicate runs (``replicate_outcome``, and its
    ``replicate_p_value``) and ``replicated``: ``both``, ``first only``, ``replicate only``
    or ``neither``; ``replica`` is the same claims evaluated on the replicate streams.
    ``stated``: per config claim (``row["claim"]``), whether it is stated to replicate
    (`Claim.replicates`), kept in the row as ``replicates`` (`claims.replication_failed`)."""
    for row, rep in zip(claims, replica, strict=True):
        row["replicates"] = stated[row["claim"]]
        row["replicate_outcome"] = rep["outcome"]
        row["replicate_p_value"] = rep.get("p_value")
        first, second = row["outcome"] == "holds", rep["outcome"] == "holds"
        row["replicated"] = (
            "both" if first and second else "first only" if first else "replicate only" if second else "neither"
        )


def _tuning_outputs(
    config: ComparisonConfig, tuning: dict, out: Path, wanted: Callable[[str], bool] = lambda name: True
) -> list[str]:
    """``tuning/<candidate>.csv`` (every trial), ``plots/tuning-<candidate>.png`` (objective
    against each free parameter) and the report's tuning section."""
    import csv

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    (out / "tuning").mkdir(exist_ok=True)
    (out / "plots").mkdir(exist_ok=True)
    spec = next(iter(tuning.values()), None)
    lines = [
        "## Tuning",
        "",
        "Every candidate with free parameters was tuned by the same procedure and budget on runs drawn from "
        "the tuning streams (disjoint from the evaluation's), then evaluated above at its tuned values.",
        "",
    ]
    if spec is not None:
        lines += [
            "| candidate | parameter | given | tuned | objective | trials (failed) |",
            "| --- | --- | --- | --- | --- | --- |",
        ]
    for cand, res in tuning.items():
        failed = sum(not np.isfinite(t["objective"]) for t in res["trials"])
        for i, label in enumerate(res["labels"]):
            given, best = res["given"][label], res["best"][label]
            first = i == 0
            cells = [
                cand if first else "",
                f"`{label}`",
                "(default)" if given is None else str(given),
                _fmt(best) if isinstance(best, float) else str(best),
                _fmt(res["best_objective"]) if first else "",
                f"{len(res['trials'])} ({failed})" if first else "",
            ]
            lines.append("| " + " | ".join(cells) + " |")
        with atomic_open(out / "tuning" / f"{cand}.csv", "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["trial", *res["labels"], "objective"])
            for j, t in enumerate(res["trials"]):
                w.writerow([j, *t["values"], t["objective"] if np.isfinite(t["objective"]) else ""])
        if wanted(f"tuning-{cand}.png"):
            metric = res["metric"]  # a composite's objective has no one unit
            fig = tuning_figure(cand, res, config.metric_units.get(metric, "-") if isinstance(metric, str) else "-")
            _savefig(fig, out / "plots" / f"tuning-{cand}.png")
            plt.close(fig)
    lines.append("")
    own = {cand: res["own_cases"] for cand, res in tuning.items() if res.get("own_cases")}
    lines += [
        f"Objective of `{cand}` over its own cases (`tuning.candidate_cases`): "
        + ", ".join(f"`{c}`" for c in cases)
        + "."
        for cand, cases in own.items()
    ]
    lines += [""] if own else []
    lines += [f"![tuning {cand}](plots/tuning-{cand}.png)" for cand in tuning] + [""]
    return lines


def join_sections(sections: list[str]) -> str:
    """Markdown sections joined with one blank line between them (a heading right after a
    table row would be read as part of the table), empty ones left out.

    >>> join_sections(["| a |\\n| - |\\n| 1 |\\n", "", "## Next\\n\\ntext\\n"])
    '| a |\\n| - |\\n| 1 |\\n\\n## Next\\n\\ntext\\n'
    """
    return "\n\n".join(s.strip("\n") for s in sections if s.strip()) + "\n"


def write_report(
    config: ComparisonConfig,
    store: ResultStore,
    out: Path,
    tuning: dict | None = None,
    replicate: ComparisonConfig | None = None,
    figures: Callable[[str], bool] | None = None,
) -> Path:
    """Write ``summary.json``, ``report.md`` and ``plots/`` into ``out`` (and the tuning's
    tables and plots when the comparison was tuned). ``figures``, given a plot's file name
    (``45dBHz-cdf.png``, ``tuning-ckf.png``, ``sweep-cn0-static.png``), says whether to draw
    it (None: every plot); ``report.md`` names every plot either way."""
    wanted = figures or (lambda name: True)
    from .tuning import tuning_points

    rows = summary_rows(config, store)
    paired = paired_rows(config, store)
    claims = evaluate_claims(config, store)
    if replicate is not None:
        replicate_claims(claims, evaluate_claims(replicate, store), [c.replicates for c in config.claims])
    untuned = [c.name for c in config.candidates if c.name not in tuning] if tuning else []
    given = {c.name for c in config.candidates if c.as_given}
    assumptions = assumption_rows(config)
    sweeps, sweep_lines = write_sweeps(config, store, out, wanted)
    summary = out / "summary.json"
    write_json(
        summary,
        {
            "name": config.name,
            "seed": config.seed,
            "runs": config.runs,
            "rows": rows,  # strict, atomic
            "reference": config.reference_name,
            "significance_rule": SIGNIFICANCE_RULE,
            "paired": paired,
            "claims": claims,
            "sweeps": sweeps,
            "tuning": tuning_points(tuning) if tuning else None,
            "assumptions": assumptions,
            "untuned": [{"candidate": n, "as_given": n in given} for n in untuned],
            "claims_adjustment": config.claims_adjustment if claims else None,
            "replicated": replicate is not None,
        },
    )
    tuning_lines = _tuning_outputs(config, tuning, out, wanted) if tuning else []
    sections = [
        _markdown(config, rows, paired),
        "\n".join(_assumptions_markdown(config, assumptions)),
        "\n".join(_claims_markdown(claims, config.claims_adjustment, untuned, given, replicate is not None)),
        "\n".join(tuning_lines),
        "\n".join(sweep_lines),
    ]
    atomic_write_text(out / "report.md", join_sections(sections))
    _plots(config, store, out, wanted)
    return summary
