r"""Thresholds: where a probability along a sweep crosses a stated level, with a paired bootstrap.

A ``[[sweeps]]`` entry may carry a ``threshold`` table::

    [[sweeps]]
    name = "cn0"
    path = "cases.cn0_dbhz"
    values = [15.0, 20.0, 25.0, 30.0, 35.0, 40.0, 45.0]
    threshold = { metric = "loss_of_lock", level = 0.5, time_metric = "time_to_loss_s" }

``metric`` is a per-run 0/1 outcome (``loss_of_lock`` of the ``tracking-threshold``
scenario), so its mean at a point is a probability :math:`\hat p(x)`. The **threshold** of
a candidate is the swept value where :math:`\hat p` falls through ``level``, read from the
top of the grid down: the largest grid interval :math:`[x_i, x_{i+1}]` with
:math:`\hat p(x_i) \ge` level :math:`> \hat p(x_{i+1})`, linearly interpolated,

.. math:: x_t = x_i + \frac{\hat p_i - \ell}{\hat p_i - \hat p_{i+1}}\,(x_{i+1} - x_i).

(Read from the top, a curve that is not monotone gives the highest crossing: the value
above which the loop keeps lock with probability above :math:`1 - \ell`.) A curve entirely
below the level has its threshold *below the grid* (:math:`-\infty`), one at or above the
level at the top point *above the grid* (:math:`+\infty`).

Confidence intervals: a **paired bootstrap over runs**. Run ``r`` of every candidate and
every point shares its random numbers (`gnssframework.random_streams`: a run's streams
depend on the seed, the case and the run index only), so a resample draws run indices
once and applies them to every candidate and point; each resample's thresholds and
threshold differences come from the resampled curves, and the interval is the
percentile interval (2.5 % and 97.5 % quantiles, ``inverted_cdf``: an out-of-grid
resample counts as :math:`\pm\infty`). The resampling generator is seeded from the
comparison's seed and the sweep's name, so the interval is reproducible.

``fit = "logistic"`` (or ``"probit"``, ``"cloglog"``, ``"loglog"``: other shapes) reads the
threshold off a Firth-penalised curve fitted to every point instead
(`gnssframework.experiments.threshold_fit`; each resample refitted; ``"best"`` takes per
curve and per resample the link of smallest deviance, so the interval carries the shape's
choice), which
covers the between-grid uncertainty that interpolation does not (the interpolated curve's
threshold is not the loop's where the level is in a tail and the grid coarse), reports the
fit's deviance test, and widens the interval of a **separated** curve (every point at 0 or
1: no resample can move it) to the grid interval the crossing lies in; a threshold
difference involving one is widened to the difference of the two intervals' far ends
(conservative). With ``time_metric``
(the censored time to the event, the span when censored), each point also gets the
Kaplan-Meier restricted mean time to the event (`gnssframework.experiments.survival`).
"""

from __future__ import annotations

import math
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from .stats import finite_or_none
from .survival import exponential_mean_mle, kaplan_meier
from .threshold_fit import LINKS, best_link_fit, deviance_test, firth_binomial, fitted_crossing

__all__ = [
    "Threshold",
    "crossing",
    "bootstrap_thresholds",
    "threshold_rows",
    "plot_threshold",
    "threshold_markdown",
    "wilson",
    "difference_interval",
    "THRESHOLD_SEED_TAG",
]

#: Tag mixed into the bootstrap's seed (with the comparison's seed and the sweep's name).
THRESHOLD_SEED_TAG = 0x7E5


class Threshold(BaseModel):
    """The ``threshold`` table of a sweep (see the module docstring)."""

    model_config = ConfigDict(extra="forbid")
    metric: str = Field(..., description="per-run 0/1 outcome whose mean is the probability (loss_of_lock)")
    level: float = Field(0.5, gt=0, lt=1, description="the probability level the threshold crosses")
    bootstrap: int = Field(2000, ge=100, le=100000, description="bootstrap resamples over runs")
    fit: Literal["linear", "logistic", "probit", "cloglog", "loglog", "best"] = Field(
        "linear",
        description="how the threshold is read: linear interpolation between grid points, or a "
        "Firth-penalised curve of that link fitted to every point, or 'best': per curve and "
        "resample the link of smallest deviance (gnssframework.experiments.threshold_fit)",
    )
    time_metric: str | None = Field(
        None,
        description="optional per-run time to the event (censored at the span): "
        "adds the Kaplan-Meier restricted mean per point",
    )
    plot_metrics: list[str] = Field(
        default_factory=list,
        description="further metrics plotted against the swept value under the probability (e.g. the slip rates)",
    )


def crossing(x: np.ndarray, p: np.ndarray, level: float) -> np.ndarray:
    """Thresholds of curves ``p`` ``(points, ...)`` over increasing ``x`` ``(points,)``
    (see the module docstring): ``(...)``, :math:`\\pm\\infty` outside the grid."""
    x = np.asarray(x, float)
    p = np.asarray(p, float)
    above = p >= level
    n = x.size
    # the last point at or above the level (from the top), -1 if none
    idx = np.where(above.any(axis=0), n - 1 - np.argmax(above[::-1], axis=0), -1)
    out = np.full(p.shape[1:], np.nan)
    out = np.where(idx < 0, -np.inf, out)
    out = np.where(idx == n - 1, np.inf, out)
    inner = (idx >= 0) & (idx < n - 1)
    i = np.clip(idx, 0, n - 2)
    p0 = np.take_along_axis(p, i[None, ...], axis=0)[0] if p.ndim > 1 else p[i]
    p1 = np.take_along_axis(p, (i + 1)[None, ...], axis=0)[0] if p.ndim > 1 else p[i + 1]
    with np.errstate(invalid="ignore", divide="ignore"):
        xt = x[i] + (p0 - level) / (p0 - p1) * (x[i + 1] - x[i])
    return np.where(inner, xt, out)


def _interval(samples: np.ndarray) -> tuple[float, float]:
    lo, hi = np.quantile(samples, [0.025, 0.975], method="inverted_cdf")
    return float(lo), float(hi)


def bootstrap_thresholds(
    x: np.ndarray,
    outcomes: dict[str, np.ndarray],
    level: float,
    resamples: int,
    rng: np.random.Generator,
    fit: str = "linear",
) -> dict[str, Any]:
    """Thresholds of each candidate and their paired differences.

    Parameters
    ----------
    x
        ``(points,)`` swept values, increasing.
    outcomes
        candidate -> ``(points, runs)`` 0/1 outcomes, run ``r`` the same run everywhere.
    fit
        ``"linear"`` (interpolation), a link of `threshold_fit.LINKS` (a fitted curve,
        refitted per resample) or ``"best"`` (per curve, the link of smallest deviance).

    Returns
    -------
    dict
        ``{"threshold": {cand: (estimate, lo, hi)}, "samples": {cand: (resamples,)}}``; with
        a fitted curve also ``"fit": {cand: {...}}`` (link, deviance, degrees of freedom,
        p-value, ``separated`` and the grid interval ``gap`` of a separated curve; with
        ``"best"`` every link's deviance and the share of resamples that chose each).
    """
    names = list(outcomes)
    runs = next(iter(outcomes.values())).shape[1]
    idx = rng.integers(0, runs, size=(resamples, runs))
    out: dict[str, Any] = {"threshold": {}, "samples": {}}
    if fit != "linear":
        out["fit"] = {}
    for name in names:
        v = np.asarray(outcomes[name], float)
        if fit != "linear":
            est, lo, hi, samples, out["fit"][name] = _fitted(x, v, idx, level, name, fit)
        else:
            est = float(crossing(x, v.mean(axis=1), level))
            samples = crossing(x, v[:, idx].mean(axis=2), level)
            lo, hi = _interval(samples)
        out["threshold"][name] = (est, lo, hi)
        out["samples"][name] = samples
    return out


def _fit(x: np.ndarray, k: np.ndarray, runs: int, link: str):
    return best_link_fit(x, k, runs) if link == "best" else firth_binomial(x, k, runs, link)


def _fitted(
    x: np.ndarray, v: np.ndarray, idx: np.ndarray, level: float, name: str, link: str
) -> tuple[float, float, float, np.ndarray, dict[str, Any]]:
    """One candidate's threshold off the fitted curve of its outcomes ``v`` ``(points, runs)``
    and of each resample ``idx`` ``(resamples, runs)``: the estimate, the interval (a
    separated curve's widened to its grid interval), the resamples' thresholds and the
    fit's report."""
    runs = v.shape[1]
    p, k = v.mean(axis=1), v.sum(axis=1)
    curve = _fit(x, k, runs, link)
    boot_fit = _fit(x, v[:, idx].sum(axis=2), runs, link)
    if not (curve.converged and boot_fit.converged):
        raise ValueError(f"threshold fit of candidate {name!r} ({link}): the iteration did not converge")
    est = float(fitted_crossing(curve, x, level))
    samples = fitted_crossing(boot_fit, x, level)
    lo, hi = _interval(samples)
    dev, df, p_fit = deviance_test(curve, x, k, runs)
    separated = bool(np.all((p == 0) | (p == 1)) and math.isfinite(est))
    gap = None
    if separated:  # no resample can move it: the crossing is known to its grid interval only
        i = int(np.searchsorted(x, float(crossing(x, p, level)), side="right")) - 1
        gap = (float(x[i]), float(x[min(i + 1, x.size - 1)]))
        lo, hi = min(lo, gap[0]), max(hi, gap[1])
    report = {
        "link": str(curve.link),
        "deviance": dev,
        "df": df,
        "p_value": p_fit,
        "separated": separated,
        "gap": gap,
        "beta": [float(b) for b in curve.beta],
        "centre": curve.centre,
        "spread": curve.spread,
    }
    if link == "best":
        report["deviances"] = {n: float(d) for n, d in curve.link_deviances.items()}
        report["resample_links"] = {n: float(np.mean(boot_fit.link == n)) for n in LINKS}
    return est, lo, hi, samples, report


def _bound(v: float) -> float | str:
    """An interval's end for strict JSON: the number, or "-inf" / "+inf" beyond the grid."""
    return float(v) if math.isfinite(v) else ("-inf" if v < 0 else "+inf")


def _num(v: float | str | None) -> float:
    return math.nan if v is None else float(v)


def _where(v: float) -> str:
    return "below the grid" if v == -np.inf else "above the grid" if v == np.inf else "in the grid"


def sweep_seed(config, sweep_label: str) -> np.random.Generator:
    """The bootstrap's generator: the comparison's seed, the sweep's name and a tag."""
    from ..random_streams import name_key

    return np.random.default_rng([int(config.seed), *name_key(sweep_label), THRESHOLD_SEED_TAG])


def threshold_rows(config, store, index: int) -> dict[str, Any] | None:
    """The threshold report of ``config.sweeps[index]`` (``None`` without a threshold
    table): per case, each candidate's threshold with its bootstrap interval, the paired
    differences to the reference, the curve (mean and a Wilson 95 % interval per point)
    and, with ``time_metric``, the Kaplan-Meier restricted mean time to the event."""
    sweep = config.sweeps[index]
    spec = sweep.threshold
    if spec is None:
        return None
    pairs = config.sweep_points(index)
    x = np.array([float(v) for v, _ in pairs])
    order = np.argsort(x)
    ref = config.reference_name
    cases = [c.name for c in config.cases if not sweep.cases or c.name in sweep.cases]
    result = {
        "sweep": sweep.label,
        "metric": spec.metric,
        "level": spec.level,
        "bootstrap": spec.bootstrap,
        "fit": spec.fit,
        "interval": "paired bootstrap over runs, 95 % percentile",
        "values": [float(v) for v in x[order]],
        "cases": [],
    }
    for case in cases:
        raw, raw_times = {}, {}
        for cand in config.candidates:
            raw[cand.name] = [
                store.run_values(pairs[j][1].identity(), case, cand.name, spec.metric, pairs[j][1].runs) for j in order
            ]
            if spec.time_metric is not None:
                raw_times[cand.name] = [
                    store.run_values(pairs[j][1].identity(), case, cand.name, spec.time_metric, pairs[j][1].runs)
                    for j in order
                ]
        # the runs every candidate has at every point: run r is paired everywhere
        common = sorted(set.intersection(*(set(v) for vals in raw.values() for v in vals)))
        outcomes = {k: np.array([[v[r] for r in common] for v in vals], float) for k, vals in raw.items()}
        times = {k: np.array([[v[r] for r in common] for v in vals], float) for k, vals in raw_times.items()}
        runs = len(common)
        # a fresh generator of the same seed per case: every case with the same runs draws
        # the same resample indices, so thresholds of two cases pair resample by resample
        boot = bootstrap_thresholds(
            x[order], outcomes, spec.level, spec.bootstrap, sweep_seed(config, sweep.label), fit=spec.fit
        )
        intervals = {name: (lo, hi) for name, (_, lo, hi) in boot["threshold"].items()}
        fits = boot.get("fit", {})
        rows = []
        for name, (est, lo, hi) in boot["threshold"].items():
            p = outcomes[name].mean(axis=1)
            curve = [
                {"value": float(xv), "p": float(pv), "ci95": list(wilson(pv, runs))} for xv, pv in zip(x[order], p)
            ]
            if name in times:
                for c, t, o in zip(curve, times[name], outcomes[name]):
                    km = kaplan_meier(t, o > 0.5)
                    horizon = float(np.max(t))
                    c.update(
                        km_restricted_mean=km.restricted_mean(horizon),
                        horizon=horizon,
                        exponential_mean_mle=finite_or_none(exponential_mean_mle(t, o > 0.5)),
                    )
            row = {
                "candidate": name,
                "threshold": finite_or_none(est),
                "where": _where(est),
                "ci95": [_bound(lo), _bound(hi)],
                "n": runs,
                "curve": curve,
            }
            if name in fits:
                f = fits[name]
                row["fit"] = {
                    "link": f["link"],
                    "deviance": f["deviance"],
                    "df": f["df"],
                    "p_value": finite_or_none(f["p_value"]),
                    "separated": f["separated"],
                    "gap": list(f["gap"]) if f["gap"] else None,
                    "beta": f["beta"],
                    "centre": f["centre"],
                    "spread": f["spread"],
                    **{key: f[key] for key in ("deviances", "resample_links") if key in f},
                }
            if name != ref:
                d = _differences(boot["samples"][name], boot["samples"][ref])
                dest = est - boot["threshold"][ref][0]
                ci = _difference_bounds(d, intervals[name], intervals[ref], _separated(fits, name, ref))
                row["difference"] = {
                    "reference": ref,
                    "estimate": finite_or_none(dest),
                    "ci95": [_bound(v) for v in ci] if ci else [None, None],
                    "resamples": int(d.size),
                }
            rows.append(row)
        result["cases"].append(
            {
                "case": case,
                "runs": runs,
                "rows": rows,
                "_samples": boot["samples"],
                "_runs": common,
                "_intervals": intervals,
                "_fits": fits,
            }
        )
    return result


def wilson(p: float, n: int, z: float = 1.959964) -> tuple[float, float]:
    """Wilson score 95 % interval of a binomial proportion ``p`` over ``n`` runs."""
    if n == 0:
        return (float("nan"), float("nan"))
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return (max(0.0, centre - half), min(1.0, centre + half))


def _differences(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Paired resample differences ``a - b``; a resample where both lie beyond the same
    end of the grid has no difference and is dropped (inf - inf: NaN, by design, so
    NumPy's warning is silenced)."""
    with np.errstate(invalid="ignore"):
        d = a - b
    return d[~np.isnan(d)]


def _separated(fits: dict, *names: str) -> bool:
    return any(fits.get(n, {}).get("separated", False) for n in names)


def _difference_bounds(
    d: np.ndarray, a: tuple[float, float], b: tuple[float, float], separated: bool
) -> tuple[float, float] | None:
    """The 95 % interval of a threshold difference from its paired resamples ``d``; where
    either curve is separated (its resamples cannot move it), widened to cover
    ``[a_lo - b_hi, a_hi - b_lo]`` from the two thresholds' own intervals."""
    if d.size == 0:
        return None
    lo, hi = _interval(d)
    if separated:
        with np.errstate(invalid="ignore"):
            lo, hi = float(np.nanmin([lo, a[0] - b[1]])), float(np.nanmax([hi, a[1] - b[0]]))
    return lo, hi


def difference_interval(
    report: dict, case: str, candidate: str, reference: str, reference_case: str | None = None
) -> tuple[float, float, float]:
    """Estimate and bootstrap 95 % interval of ``candidate``'s threshold in ``case`` minus
    ``reference``'s (in ``reference_case``, default the same case) of a `threshold_rows`
    report (``nan`` estimate when either is outside the grid; widened where a fitted curve
    is separated). Across cases the resamples pair because every case's bootstrap draws
    the same run indices (`threshold_rows`); cases whose runs differ are refused."""
    entry = next(c for c in report["cases"] if c["case"] == case)
    other = entry if reference_case is None else next(c for c in report["cases"] if c["case"] == reference_case)
    if other["_runs"] != entry["_runs"]:
        raise ValueError(
            f"threshold difference between cases {case!r} and {reference_case!r}: their runs differ "
            f"({len(entry['_runs'])} against {len(other['_runs'])} common to every candidate and point)"
        )
    a = next(r["threshold"] for r in entry["rows"] if r["candidate"] == candidate)
    b = next(r["threshold"] for r in other["rows"] if r["candidate"] == reference)
    d = _differences(entry["_samples"][candidate], other["_samples"][reference])
    ci = _difference_bounds(
        d,
        entry["_intervals"][candidate],
        other["_intervals"][reference],
        _separated(entry["_fits"], candidate) or _separated(other["_fits"], reference),
    )
    if ci is None:
        return math.nan, -math.inf, math.inf
    e = (a - b) if a is not None and b is not None else math.nan
    return e, ci[0], ci[1]


def plot_threshold(path, config, report: dict, entry: dict, sweep: dict) -> None:
    """The probability against the swept value with its Wilson 95 % band, one line per
    candidate, each threshold marked with its bootstrap interval; below it the
    ``plot_metrics`` (mean ± 1.96 SE over runs)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..io.files import atomic_open

    spec = next(s for s in config.sweeps if s.label == report["sweep"]).threshold
    extra = list(spec.plot_metrics)
    fig, axes = plt.subplots(1 + len(extra), 1, figsize=(6.5, 2.6 + 2.0 * len(extra)), sharex=True, squeeze=False)
    ax = axes[0, 0]
    for row in entry["rows"]:
        xs = np.array([c["value"] for c in row["curve"]])
        p = np.array([c["p"] for c in row["curve"]])
        lo = np.array([c["ci95"][0] for c in row["curve"]])
        hi = np.array([c["ci95"][1] for c in row["curve"]])
        t = row["threshold"]
        label = row["candidate"] + (
            f" ({t:.1f} [{_fmt(row['ci95'][0])}, {_fmt(row['ci95'][1])}])" if t is not None else f" ({row['where']})"
        )
        fitted = row.get("fit")
        (line,) = ax.plot(xs, p, marker="o", ms=3, lw=0 if fitted else 1.0, label=label)
        ax.fill_between(xs, lo, hi, color=line.get_color(), alpha=0.15, lw=0)
        if fitted:
            fine = np.linspace(xs[0], xs[-1], 200)
            b0, b1 = fitted["beta"]
            ax.plot(
                fine,
                LINKS[fitted["link"]].cdf(b0 + b1 * (fine - fitted["centre"]) / fitted["spread"]),
                lw=1.0,
                color=line.get_color(),
            )
        if t is not None:
            ax.axvline(t, color=line.get_color(), lw=0.8, ls="--")
            lo_t = _num(row["ci95"][0]) if math.isfinite(_num(row["ci95"][0])) else xs[0]
            hi_t = _num(row["ci95"][1]) if math.isfinite(_num(row["ci95"][1])) else xs[-1]
            ax.axvspan(lo_t, hi_t, color=line.get_color(), alpha=0.08, lw=0)
    ax.axhline(report["level"], color="k", lw=0.6)
    ax.set_ylabel(f"P({report['metric']})", fontsize=8)
    ax.set_ylim(-0.02, 1.02)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=6)
    ax.set_title(
        f"{config.name} - {entry['case']}: {entry['runs']} paired runs, Wilson 95 % bands;\n"
        f"threshold at p = {report['level']:g} (dashed), paired-bootstrap 95 % interval (shaded)"
        + (_CURVES[report["fit"]] if report.get("fit", "linear") != "linear" else ""),
        fontsize=7,
    )
    for ax, metric in zip(axes[1:, 0], extra):
        for cand in config.candidates:
            rows = {
                r["value"]: r
                for r in sweep["rows"]
                if r["case"] == entry["case"] and r["candidate"] == cand.name and r["metric"] == metric
            }
            values = sorted(rows, key=float)
            xs = np.array(values, float)
            m = np.array([np.nan if rows[v]["mean"] is None else rows[v]["mean"] for v in values], float)
            se = np.array([0.0 if rows[v]["se"] is None else rows[v]["se"] for v in values], float)
            (line,) = ax.plot(xs, m, marker="o", ms=3, lw=1.0, label=cand.name)
            ax.fill_between(xs, m - 1.96 * se, m + 1.96 * se, color=line.get_color(), alpha=0.15, lw=0)
        ax.set_ylabel(f"{metric}\n({config.metric_units[metric]})", fontsize=7)
        ax.set_yscale("symlog", linthresh=0.1)  # slip rates span 0 to hundreds per second
        ax.grid(alpha=0.3)
    axes[-1, 0].set_xlabel(sweep["path"])
    fig.tight_layout()
    with atomic_open(path, "wb") as fh:
        fig.savefig(fh, format="png", dpi=90)
    plt.close(fig)


def _fmt(v: float | str | None) -> str:
    return "–" if v is None else v if isinstance(v, str) else f"{v:.2f}"


_READ = {
    "linear": "linear interpolation between grid points",
    **{
        link: f"a Firth-penalised {link} curve fitted to every point, refitted per resample; a separated "
        "curve's interval widened to its grid interval"
        for link in LINKS
    },
    "best": "per candidate the Firth-penalised curve of the link (logistic, probit, cloglog, loglog) with the "
    "smallest deviance, chosen again per resample; a separated curve's interval widened to its grid interval",
}
_CURVES = {**{link: f"; lines: the fitted {link} curves" for link in LINKS}, "best": "; lines: the best-fitting curves"}


def _fit_cell(fit: dict | None) -> str:
    if not fit:
        return ""
    p = fit["p_value"]
    cell = f"{fit['deviance']:.1f} on {fit['df']}" + (f" (p = {p:.2g})" if p is not None else "")
    if "resample_links" in fit:
        share = ", ".join(f"{n} {v:.0%}" for n, v in fit["resample_links"].items() if v > 0)
        cell = f"{fit['link']}: {cell}; resamples: {share}"
    return cell + (f"; separated in [{fit['gap'][0]:g}, {fit['gap'][1]:g}]" if fit["separated"] else "")


def threshold_markdown(config, report: dict) -> list[str]:
    """The report's threshold section: per case, each candidate's threshold, its interval
    and its paired difference to the reference; the curve's points with the survival."""
    lines = [
        f"## Thresholds along sweep `{report['sweep']}`",
        "",
        f"Where P({report['metric']}) falls through {report['level']:g} ({_READ[report.get('fit', 'linear')]}, "
        f"read from the top of the grid); intervals: {report['interval']} ({report['bootstrap']} resamples, seeded "
        f"from the comparison's seed). Table: `sweeps/{report['sweep']}-threshold.json`.",
        "",
    ]
    for entry in report["cases"]:
        lines += [
            f"### {entry['case']}",
            "",
            f"![threshold](plots/threshold-{report['sweep']}-{entry['case']}.png)",
            "",
        ]
        fitted = report.get("fit", "linear") != "linear"
        lines += [
            "| candidate | threshold | 95 % interval | difference to reference | 95 % interval |"
            + (" fit: deviance on df (p) |" if fitted else ""),
            "| --- | --- | --- | --- | --- |" + (" --- |" if fitted else ""),
        ]
        for row in entry["rows"]:
            d = row.get("difference")
            diff = (
                (f"{_fmt(d['estimate'])} (vs {d['reference']})", f"[{_fmt(d['ci95'][0])}, {_fmt(d['ci95'][1])}]")
                if d
                else ("", "")
            )
            thr = _fmt(row["threshold"]) if row["threshold"] is not None else row["where"]
            lines.append(
                f"| {row['candidate']} | {thr} | [{_fmt(row['ci95'][0])}, {_fmt(row['ci95'][1])}] | "
                f"{diff[0]} | {diff[1]} |" + (f" {_fit_cell(row.get('fit'))} |" if fitted else "")
            )
        lines.append("")
        survival = any("km_restricted_mean" in c for r in entry["rows"] for c in r["curve"])
        head = "| candidate | " + " | ".join(f"{v:g}" for v in report["values"]) + " |"
        lines += [
            f"P({report['metric']}) [Wilson 95 %]"
            + (" / Kaplan-Meier restricted mean time to it (s)" if survival else "")
            + ":",
            "",
            head,
            "| --- |" + " --- |" * len(report["values"]),
        ]
        for row in entry["rows"]:
            cells = []
            for c in row["curve"]:
                cell = f"{c['p']:.2f} [{c['ci95'][0]:.2f}, {c['ci95'][1]:.2f}]"
                if "km_restricted_mean" in c:
                    cell += f" / {c['km_restricted_mean']:.2f}"
                cells.append(cell)
            lines.append(f"| {row['candidate']} | " + " | ".join(cells) + " |")
        lines.append("")
    return lines
