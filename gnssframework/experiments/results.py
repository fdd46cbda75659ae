"""A comparison's results as data: pandas frames and xarray datasets, from Python.

::

    import gnssframework as gf

    res = gf.compare("examples/multipath.toml", runs=10)      # out=None: kept in memory
    res.rows          # pandas DataFrame: case, candidate, metric, mean, std, runs, unit, published
    res.paired        # pandas DataFrame: paired differences to the reference
    res.claims        # pandas DataFrame: each claim's outcome and evidence
    res.runs          # xarray Dataset: one variable per metric, dims (case, candidate, run), units in attrs
    res.series        # xarray Dataset: the time series, dims (case, candidate, epoch, run), time_s coordinate
    print(res.report())                                       # report.md's markdown

The column and dimension names are those of ``summary.json`` and the results store
(``case``, ``candidate``, ``metric``, ``run``), so a frame, the JSON and an SQL query on
``results.sqlite`` read the same.
"""

from __future__ import annotations

import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:  # imported where used: loading the results needs them, importing this module not
    import pandas as pd
    import xarray as xr

__all__ = ["ComparisonResult", "compare", "load_results"]


@dataclass
class ComparisonResult:
    """What a comparison produced: its summary, per-run metrics and time series.

    Attributes
    ----------
    summary
        ``summary.json`` as a dict.
    runs
        ``xarray.Dataset``: a variable per metric, dims ``(case, candidate, run)``,
        attribute ``units``.
    series
        ``xarray.Dataset``: a variable per per-epoch series, dims ``(case, candidate,
        epoch, run)``, coordinate ``time_s`` (s) over ``epoch``.
    out
        The results folder, or ``None`` when the comparison ran in memory.
    """

    summary: dict[str, Any]
    runs: Any
    series: Any
    markdown: str
    out: Path | None = None

    @property
    def rows(self) -> pd.DataFrame:
        """Mean, std and runs per case, candidate and metric (``pandas.DataFrame``)."""
        import pandas as pd

        return pd.DataFrame(self.summary["rows"])

    @property
    def paired(self) -> pd.DataFrame:
        """Paired differences to the reference candidate (``pandas.DataFrame``)."""
        import pandas as pd

        return pd.DataFrame(self.summary["paired"])

    @property
    def claims(self) -> pd.DataFrame:
        """Each claim's outcome and evidence (``pandas.DataFrame``)."""
        import pandas as pd

        return pd.DataFrame(self.summary.get("claims") or [])

    def report(self) -> str:
        """The markdown of ``report.md``."""
        return self.markdown

    def __repr__(self) -> str:
        s = self.summary
        cases = list(dict.fromkeys(r["case"] for r in s["rows"]))
        cands = list(dict.fromkeys(r["candidate"] for r in s["rows"]))
        claims = s.get("claims") or []
        held = sum(c["outcome"] == "holds" for c in claims)
        where = f", in {self.out}" if self.out else ", in memory"
        return (
            f"<ComparisonResult {s['name']!r}: {len(cases)} cases x {len(cands)} candidates x {s.get('runs')} runs"
            f"{f', claims {held}/{len(claims)} hold' if claims else ''}{where}>"
        )

    def _repr_html_(self) -> str:
        """A notebook's view: the one-line summary, then per case a table of each metric's
        mean ± SE (standard error over the runs, as in ``report.md``) per candidate, and
        the claims' outcomes."""
        from html import escape

        from .report import mean_cell

        s = self.summary
        cases = list(dict.fromkeys(r["case"] for r in s["rows"]))
        cands = list(dict.fromkeys(r["candidate"] for r in s["rows"]))
        metrics = list(dict.fromkeys(r["metric"] for r in s["rows"]))
        rows = {(r["case"], r["candidate"], r["metric"]): r for r in s["rows"]}
        units: dict[str, str] = {}
        for r in s["rows"]:  # a metric's unit as its first row gives it
            units.setdefault(r["metric"], r["unit"])
        left = " style='text-align:left'"

        def cell(r: dict[str, Any] | None) -> str:
            if r is None or r.get("mean") is None:
                return "–" if r is None else escape(str(r.get("undefined") or "–"))
            return escape(mean_cell(r))  # report.md's cell: a zero or missing SE prints the mean alone

        parts = [f"<p><b>{escape(repr(self))}</b>; cells: mean ± SE over the runs</p>"]
        head = "".join(f"<th>{escape(c)}</th>" for c in cands)
        for case in cases:
            body = "".join(
                f"<tr><th{left}>{escape(m)}</th><td>{escape(str(units[m]))}</td>"
                + "".join(f"<td>{cell(rows.get((case, c, m)))}</td>" for c in cands)
                + "</tr>"
                for m in metrics
            )
            parts.append(
                f"<table><caption{left}>{escape(case)}</caption><tr><th>metric</th><th>unit</th>{head}</tr>"
                f"{body}</table>"
            )
        claims = s.get("claims") or []
        if claims:
            body = "".join(
                f"<tr><td>{escape(str(c['outcome']))}</td><td{left}>{escape(str(c.get('statement', '')))}</td></tr>"
                for c in claims
            )
            parts.append(f"<table><caption{left}>claims</caption><tr><th>outcome</th><th>claim</th></tr>{body}</table>")
        return "".join(parts)


def _runs_dataset(config: Any, store: Any) -> xr.Dataset:
    import xarray as xr

    key = config.identity()
    cases = [c.name for c in config.cases]
    cands = [c.name for c in config.candidates]
    units = config.metric_units
    data = {}
    for metric in config.metric_names:
        values = np.full((len(cases), len(cands), config.runs), np.nan)
        for i, case in enumerate(cases):
            for j, cand in enumerate(cands):
                for r, v in store.run_values(key, case, cand, metric, config.runs).items():
                    values[i, j, r] = v
        data[metric] = xr.DataArray(values, dims=("case", "candidate", "run"), attrs={"units": units[metric]})
    return xr.Dataset(
        data,
        coords={"case": cases, "candidate": cands, "run": np.arange(config.runs)},
        attrs={"name": config.name, "seed": config.seed},
    )


def _series_dataset(config: Any, out: Path) -> xr.Dataset:
    """Every batch file's ``(epoch, run)`` series on the union of the candidates' time axes
    (a filter that drops its first epoch, as a decorrelating augmentation does, has NaN
    there)."""
    import xarray as xr

    from .runner import series_file
    from .store import plan_batches

    cases = [c.name for c in config.cases]
    cands = [c.name for c in config.candidates]
    files = [
        (i, j, first, n, series_file(out, case, cand, first, n))
        for i, case in enumerate(cases)
        for j, cand in enumerate(cands)
        for first, n in plan_batches(config.runs, config.batch_size)
    ]
    files = [f for f in files if f[-1].exists()]
    times = []
    for *_, path in files:
        with np.load(path) as npz:
            times.append(np.asarray(npz["time_s"]))
    if not files or not any(t.size for t in times):
        return xr.Dataset()
    time_s = np.unique(np.concatenate(times))
    blocks: dict[str, np.ndarray] = {}
    for (i, j, first, n, path), t in zip(files, times):
        at = np.searchsorted(time_s, t)
        with np.load(path) as npz:
            for name in npz.files:
                arr = npz[name]
                if name in ("time_s", "first_run") or arr.ndim != 2 or arr.shape[0] != t.size:
                    continue  # only (epoch, run) series on the file's own time axis
                if name not in blocks:
                    blocks[name] = np.full((len(cases), len(cands), time_s.size, config.runs), np.nan)
                blocks[name][i, j, at, first : first + n] = arr
    data = {k: (("case", "candidate", "epoch", "run"), v) for k, v in blocks.items()}
    return xr.Dataset(
        data,
        coords={
            "case": cases,
            "candidate": cands,
            "epoch": np.arange(time_s.size),
            "run": np.arange(config.runs),
            "time_s": ("epoch", time_s),
        },
        attrs={"time_s": "s, the union of the candidates' epochs (NaN where a filter has none)"},
    )


def load_results(out: str | Path, config: Any = None) -> ComparisonResult:
    """The results of the comparison written in ``out`` (its ``config.json`` unless given)."""
    from .config import ComparisonConfig
    from ..io.files import loads_strict
    from .store import ResultStore

    out = Path(out)
    summary = loads_strict((out / "summary.json").read_text())
    if config is None:
        config = ComparisonConfig.model_validate_json((out / "config.json").read_text())
    if config.tuning is not None:  # the evaluated comparison: the candidates at their tuned values
        from .tuning import tuned_config

        config = tuned_config(config, _tuning_results(config, summary))
    store = ResultStore(out / "results.sqlite")
    return ComparisonResult(
        summary, _runs_dataset(config, store), _series_dataset(config, out), (out / "report.md").read_text(), out
    )


def _tuning_results(config: Any, summary: dict[str, Any]) -> dict[str, dict[str, Any]]:
    from .tuning import resolve_free

    resolved = resolve_free(config)
    return {
        t["candidate"]: {"labels": [lb for _, _, lb in resolved[t["candidate"]]], "best": t["tuned"]}
        for t in summary["tuning"]
    }


def compare(
    config: Any,
    out: str | Path | None = None,
    *,
    runs: int | None = None,
    seed: int | None = None,
    progress: bool = False,
) -> ComparisonResult:
    """Run (or resume) a comparison from Python and return its results as data.

    Parameters
    ----------
    config
        A path to a TOML config, a ``ComparisonConfig`` or a dict of the same fields.
    out
        The results folder (resumed like ``gnssframework compare --out``); ``None`` runs
        in a temporary folder and keeps everything in memory.
    runs, seed
        Overrides, like the command's ``--runs`` and ``--seed``.
    """
    from .config import ComparisonConfig, load_config
    from .runner import run_comparison

    overrides = {k: v for k, v in (("runs", runs), ("seed", seed)) if v is not None}
    if isinstance(config, (str, Path)):
        config = load_config(config, **overrides)
    elif isinstance(config, dict):
        config = ComparisonConfig.model_validate({**config, **overrides})
    elif isinstance(config, ComparisonConfig):
        if overrides:  # validated again: a claim or a sweep may depend on them
            config = ComparisonConfig.model_validate({**config.model_dump(mode="json", exclude_none=True), **overrides})
    else:
        raise TypeError(f"compare() takes a TOML path, a ComparisonConfig or a dict, not {type(config).__name__}")
    if out is not None:
        run_comparison(config, out, progress=progress)
        return load_results(out, config)
    tmp = Path(tempfile.mkdtemp(prefix="gnssframework-"))
    try:
        run_comparison(config, tmp, progress=progress)
        result = load_results(tmp, config)
        result.series = result.series.load() if hasattr(result.series, "load") else result.series
        result.out = None
        return result
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
