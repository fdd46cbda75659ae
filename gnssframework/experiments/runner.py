"""Run a comparison: plan batches, execute them (local processes or Dask), store, report.

Reproducibility: run ``r`` of case ``c`` draws every random number from its own streams,
seeded from ``SeedSequence([seed, *name_key(c), r])`` (:mod:`gnssframework.random_streams`),
and every candidate gets the same streams (common random numbers: the candidates see the
same signals and noise). Runs are simulated in batches of ``batch_size`` at fixed
boundaries (:func:`~gnssframework.experiments.store.plan_batches`); the store records
which batches it holds, so the same seed gives the same numbers on any executor, in any
order of completion, after a resume, and when ``runs`` grows or shrinks.

A results folder holds one comparison: another configuration (other seed, scenario,
cases, candidates or batch size) is refused with one line, and two processes never
write into one folder at once.

Sweeps (``[[sweeps]]``): every point is the comparison with one value changed, run with
the same seed, so the points share their random numbers too (a case keeps its streams
when a sweep runs only some cases); each point is stored under its own identity in the
same store and resumes like the comparison.
"""

from __future__ import annotations

import os
from contextlib import closing, contextmanager
import pickle
import sys
import traceback
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from collections.abc import Callable, Generator, Iterator
from typing import Any, TypeAlias

import numpy as np

from ..errors import ConfigError, GnssFrameworkError, RunFailure, WorkerError
from ..progress import Progress
from .config import DASK_ADDRESS_ENV, ComparisonConfig, Executor
from ..io.files import atomic_open
from .folder import claim_folder
from .metric_components import evaluate
from .metrics import Metric, metric_component
from .run_plan import RunPlan, resolve, task_streams
from .store import plan_batches
from .sweeps import refined_values
from .tasks import Task, plan, series_file

__all__ = ["Task", "plan", "task_streams", "run_task", "run_comparison", "series_file"]

#: What `run_task` returns: the task, its metrics by name ``(runs,)``, its per-epoch series
#: by name (those the metric components add) and its time axis (``None`` without one).
TaskResult: TypeAlias = tuple[Task, dict[str, np.ndarray], dict[str, np.ndarray], np.ndarray | None]


def run_task(plan: RunPlan, task: Task) -> TaskResult:
    """Execute one task in any process: builds the task's candidate from the resolved plan.

    A library error raised while simulating is re-raised as a
    :class:`~gnssframework.errors.RunFailure` naming the candidate, case, runs and sweep point.
    """
    try:
        return _simulate(plan, task)
    except RunFailure:
        raise
    except GnssFrameworkError as exc:
        raise RunFailure(plan.where(task), str(exc), type(exc).__name__) from None
    except MemoryError as exc:
        raise RunFailure(
            plan.where(task),
            f"out of memory ({exc or 'MemoryError'}); use a smaller batch_size or a shorter case",
            "MemoryError",
        ) from None


def _simulate(plan: RunPlan, task: Task) -> TaskResult:
    scenario = plan.scenario
    plugins = plan.build(task.candidate_index, task.case_index)
    result = scenario.run_batch(plan.cases[task.case_index].as_case(), plugins, task.runs, task_streams(plan, task))
    metrics, series = dict(result.metrics), dict(result.series)
    # An optional metric this case does not compute (a bound on a moving receiver) is
    # undefined in its runs, as the scenario's undefined_reasons say, not a failure.
    components = getattr(scenario.metrics, "components", {})
    for m in plan.metrics:
        if m not in metrics and getattr(components.get(m), "optional", False):
            metrics[m] = np.full(task.runs, np.nan)
    missing = [m for m in plan.metrics if m in scenario.metrics and m not in metrics]
    wrong = [f"{m} {np.shape(v)}" for m, v in metrics.items() if np.shape(v) != (task.runs,)]
    if missing or wrong:  # a scenario's declared metrics and its run_batch must agree
        raise GnssFrameworkError(
            f"scenario {scenario.kind!r}: run_batch "
            + "; ".join(
                ([f"did not return the declared metrics {', '.join(missing)}"] if missing else [])
                + ([f"returned metrics not of shape ({task.runs},): {', '.join(wrong)}"] if wrong else [])
            )
        )
    # The metric plugins the config adds: computed once, here, as a scenario computes its own.
    try:
        added = evaluate(
            _added_components(plan.component_metrics, scenario), series, result.time_s, scenario, runs=task.runs
        )
    except ValueError as exc:  # a metric's own complaint (a wrong shape, no epoch selected): one line
        raise GnssFrameworkError(str(exc)) from None
    metrics.update(added.metrics)
    return task, metrics, added.series, result.time_s


def _added_components(names: tuple[str, ...], scenario: Any) -> list[Metric]:
    """The metric components of the metrics ``names`` a config adds to ``scenario``'s own."""
    components = []
    for name in names:
        component = metric_component(name, scenario)
        if component is None:  # the config checked each name (check_metric): not reached
            raise GnssFrameworkError(f"metric {name!r}: no metric component computes it in scenario {scenario.kind!r}")
        components.append(component)
    return components


def run_task_in_worker(plan: RunPlan, task: Task) -> TaskResult:
    """``run_task`` for a worker process: an exception that would not survive the trip
    back to the parent (unpicklable, or not rebuildable from its pickle) is replaced by a
    ``WorkerError`` carrying its type, message and traceback as text."""
    try:
        return run_task(plan, task)
    except Exception as exc:  # noqa: BLE001 - re-raised, as is or as text
        try:
            pickle.loads(pickle.dumps(exc))
        except Exception:  # noqa: BLE001 - any failure to round-trip means: send text
            raise WorkerError(plan.where(task), f"{type(exc).__name__}: {exc}", traceback.format_exc()) from None
        raise


def _save_series(
    out: Path, config: ComparisonConfig, task: Task, series: dict[str, np.ndarray], time_s: np.ndarray | None
) -> None:
    path = series_file(
        out, config.cases[task.case_index].name, config.candidates[task.candidate_index].name, task.first_run, task.runs
    )
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_open(path, "wb") as fh:  # a kill leaves no half npz
        # numpy's stub types **kwds as possibly naming its allow_pickle flag; the series'
        # names are the scenario's outputs and metric components' names, never allow_pickle.
        np.savez_compressed(fh, time_s=np.array([]) if time_s is None else time_s, first_run=task.first_run, **series)  # type: ignore[arg-type]


def _execute(jobs: list[tuple[RunPlan, Task]], executor: Executor) -> Generator[tuple[int, TaskResult], None, None]:
    """Run ``(plan, task)`` jobs; yields ``(job index, run_task's result)`` as they finish."""
    if not jobs:  # everything already in the store
        return
    ex = executor
    if ex.kind == "dask":
        try:
            from dask.distributed import Client, LocalCluster, as_completed as dask_completed
        except ImportError:
            raise ConfigError(
                "executor.kind", "'dask' needs the optional extra: pip install 'gnssframework[dask]'"
            ) from None
        cluster = None
        address = ex.address or os.environ.get(DASK_ADDRESS_ENV, "")  # never from a config file (see Executor)
        if address:
            client = Client(address)
        else:
            cluster = LocalCluster(
                n_workers=ex.workers or os.cpu_count() or 1,
                threads_per_worker=1,
                processes=False,
                dashboard_address=None,
            )
            client = Client(cluster)
        try:
            submitted = {client.submit(run_task, d, t, pure=False): i for i, (d, t) in enumerate(jobs)}
            for done in dask_completed(list(submitted)):
                yield submitted[done], done.result()
        finally:
            client.close()
            if cluster is not None:
                cluster.close()
        return
    workers = ex.workers or os.cpu_count() or 1
    if workers == 1 or len(jobs) == 1:
        for i, (d, t) in enumerate(jobs):
            yield i, run_task(d, t)
        return
    # Compile or load the numba kernels once here: the forked workers inherit them
    # instead of each loading them from the disk cache (or compiling them).
    from .. import backend

    if backend.compiled():
        from ..estimation import compiled

        compiled.warm_up()
    pool = ProcessPoolExecutor(max_workers=min(workers, len(jobs)))
    finished = False
    try:
        with _sigint_deferred():  # the pool forks its workers at the first submit
            futures = {pool.submit(run_task_in_worker, d, t): i for i, (d, t) in enumerate(jobs)}
        for fut in as_completed(futures):
            i = futures[fut]
            try:
                result: TaskResult = fut.result()
            except BrokenProcessPool as exc:
                # A worker died without raising (killed, out of memory, a crash in
                # compiled code): say which batch and how to see the real failure.
                raise RunFailure(
                    jobs[i][0].where(jobs[i][1]),
                    f"a worker process died ({exc}); run with executor.workers = 1 to see the failure in this process",
                    "BrokenProcessPool",
                ) from None
            yield i, result
        finished = True
    finally:
        if finished:
            pool.shutdown(wait=True)
        else:  # Ctrl-C, a failure, or the consumer stopped: do not wait for the batches in flight
            _stop(pool)


@contextmanager
def _sigint_deferred() -> Iterator[None]:
    """Hold a Ctrl-C (SIGINT) until the block ends, then hand it to the previous handler.

    A Ctrl-C delivered while ``ProcessPoolExecutor.submit`` forks the workers lands
    between ``Process.start()`` and the pool recording the process: `_stop` cannot
    terminate a worker the pool does not know, and that orphan, holding the terminal's
    pipes, keeps a caller that reads them waiting for ever (CI's real Ctrl-C test, under
    load). Here the Python-level handler only notes the signal (Python runs handlers in the
    main thread whichever thread the kernel picked, so a mask, which other threads do not
    share, would not do); the previous handler gets it when the block ends, inside the
    caller's ``try``, with every worker recorded. Forked in the block, the workers inherit
    the noting handler: a terminal's Ctrl-C, sent to the whole process group, stops the
    parent alone, which ends them. Outside the main thread, or with no Python handler
    installed, the block runs as it is."""
    import signal
    import threading

    previous = signal.getsignal(signal.SIGINT)
    if threading.current_thread() is not threading.main_thread() or not callable(previous):
        yield
        return
    pending: list[Any] = []
    signal.signal(signal.SIGINT, lambda signum, frame: pending.append(frame))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        if pending:
            previous(signal.SIGINT, pending[-1])


def _stop(pool: ProcessPoolExecutor) -> None:
    """End a pool's workers now (their batches are lost; finished ones are in the store)."""
    for process in list((getattr(pool, "_processes", None) or {}).values()):
        process.terminate()
    pool.shutdown(wait=False, cancel_futures=True)


def comparison_points(config: ComparisonConfig) -> list[tuple[str | None, ComparisonConfig]]:
    """The comparison itself (label ``None``) and every sweep point (label ``"<sweep>=<value>"``)."""
    points: list[tuple[str | None, ComparisonConfig]] = [(None, config)]
    for i, sweep in enumerate(config.sweeps):
        points += [(f"{sweep.label}={value}", point) for value, point in config.sweep_points(i)]
    return points


def work_estimate(config: ComparisonConfig) -> tuple[int, int]:
    """``(batches, runs)`` a comparison computes from scratch: every case x candidate x
    batch of the comparison and of each sweep point (a point equal to another counted
    once), plus every tuning trial's, each run being one candidate's filter over one case
    (2 cases x 3 candidates x 10 runs in batches of 5: 12 batches, 60 runs)."""
    batches = runs = 0
    seen = set()
    for _, point in comparison_points(config):
        key = point.identity()
        if key in seen:
            continue
        seen.add(key)
        per = len(point.cases) * len(point.candidates)
        batches += per * len(plan_batches(point.runs, point.batch_size))
        runs += per * point.runs
    tuning = config.tuning
    if tuning is not None:
        from .tuning import grid_points, objective_cases, resolve_free

        for cand, params in resolve_free(config).items():
            own = objective_cases(tuning, cand)
            cases = len(own) if own else len(config.cases)
            trials = len(grid_points(params, tuning.trials)) if tuning.sampler == "grid" else tuning.trials
            batches += trials * cases * len(plan_batches(tuning.runs, config.batch_size))
            runs += trials * cases * tuning.runs
    return batches, runs


def _say_recomputed(damaged: set[tuple[str, str, int, int]], label: str | None) -> None:
    """One line on standard error for the finished batches whose metric rows are missing
    (a store edited or damaged by hand): they are recomputed, never averaged as they are."""
    if not damaged:
        return
    where = "; ".join(f"case {c!r}, candidate {k!r}, runs {f}-{f + n - 1}" for c, k, f, n in sorted(damaged)[:3])
    more = f" and {len(damaged) - 3} more" if len(damaged) > 3 else ""
    at = f" (sweep point {label})" if label is not None else ""
    print(
        f"note: results.sqlite lacks metric rows of {len(damaged)} finished batch{'es' if len(damaged) > 1 else ''}"
        f"{at}: {where}{more}; recomputing {'them' if len(damaged) > 1 else 'it'}",
        file=sys.stderr,
    )


def replicate_config(config: ComparisonConfig) -> ComparisonConfig:
    """``config`` on the replicate streams: the same candidates (at their tuned values when
    ``config`` is the tuned one), cases, runs and seed, on runs disjoint from the
    evaluation's and the tuning's (`gnssframework.experiments.run_plan.REPLICATE_PURPOSE`)."""
    data = config.model_dump(mode="json", exclude={"tuning"}, exclude_none=True)
    data["random_stream"] = "replicate"
    return type(config).model_validate(data)


def _run_points(
    config: ComparisonConfig,
    replica: ComparisonConfig | None,
    store: Any,
    out: Path,
    progress: bool,
    on_batch: Callable[[Task], None] | None,
) -> None:
    """Run every unfinished batch of ``config``, its sweep points and, with ``replica``, the
    replicate runs of both; a point equal to another (same identity) runs once."""
    jobs, where = [], []
    seen: set[tuple[str, str, str, int, int]] = set()
    points = comparison_points(config)
    if replica is not None:  # labelled, so its runs keep their metrics only (the series are the evaluation's)
        points += [
            ("replicate" if label is None else f"replicate {label}", point)
            for label, point in comparison_points(replica)
        ]
    for label, point in points:
        key = point.identity()
        store.register(key, point.batch_size)
        done = store.finished_batches(key)
        _say_recomputed(store.damaged_batches(key, done), label)
        resolved = resolve(point)  # once per point: the workers get it, nothing to re-validate
        for t in plan(point, label):
            ident = (
                key,
                point.cases[t.case_index].name,
                point.candidates[t.candidate_index].name,
                t.first_run,
                t.runs,
            )
            if ident[1:] in done or ident in seen:
                continue
            seen.add(ident)
            jobs.append((resolved, t))
            where.append((label, point, key))
    bar = Progress(len(jobs), config.name, "batch") if progress and jobs else None
    with closing(_execute(jobs, config.executor)) as results:  # closed at once on Ctrl-C: workers stop
        for i, (task, metrics, series, time_s) in results:
            label, point, key = where[i]
            case = point.cases[task.case_index].name
            cand = point.candidates[task.candidate_index].name
            if label is None:  # sweep points keep their metrics only (the store), not the time series
                _save_series(out, point, task, series, time_s)
            store.add_batch(key, case, cand, task.first_run, metrics)
            if on_batch is not None:
                on_batch(task)
            if bar is not None:
                bar.update()
    if bar is not None:
        bar.close()


def run_comparison(
    config: ComparisonConfig,
    out: str | Path,
    progress: bool = True,
    on_batch: Callable[[Task], None] | None = None,
    replicate: bool = False,
    trials_from: str | Path | None = None,
    figures: Callable[[str], bool] | None = None,
) -> Path:
    """Run (or resume) ``config`` and write the report into ``out`` (the plots ``figures``
    accepts by file name, every one when it is None: `report.write_report`); with ``replicate``,
    also run it on the replicate streams (a second, disjoint set of runs) and re-check
    every claim there (each claim row's ``replicate_outcome``). A tuned comparison also
    writes its trials (``tuning_trials.json``); ``trials_from``, such a file of an earlier
    run of the same config, seeds the tuning with its trials, which are not rerun
    (`gnssframework.experiments.trial_record`).

    Returns
    -------
    Path
        The ``summary.json`` written.

    Raises
    ------
    ConfigError
        If ``out`` holds another comparison's results or another process is writing it, or
        ``trials_from`` is given to an untuned config or records another config's trials.
    RunFailure
        If a batch fails, naming its candidate, case, runs and sweep point.
    """
    from .report import write_report

    out = Path(out)
    if trials_from is not None and config.tuning is None:
        raise ConfigError("trials_from", f"{trials_from}: {config.name!r} has no [tuning] to seed")
    with claim_folder(out, config) as store:
        tuning = None
        if config.tuning is not None:  # tune every candidate with free parameters, then evaluate them
            from .trial_record import TRIALS_FILE, seed_trials, write_trial_record
            from .tuning import tune, tuned_config

            if trials_from is not None:
                seed_trials(trials_from, config, store)
            tuning = tune(config, store, out, lambda jobs: _execute(jobs, config.executor), progress=progress)
            write_trial_record(out / TRIALS_FILE, config, tuning)
            config = tuned_config(config, tuning)
        replica = replicate_config(config) if replicate else None
        _run_points(config, replica, store, out, progress, on_batch)
        # Sweeps with a refine table: points around each threshold read off the grid's runs,
        # then those points' batches (the replicate runs get the same points).
        refined = False
        for i, sweep in enumerate(config.sweeps):
            if sweep.refine is not None and not config.refinement(i):
                values = refined_values(config, store, i)
                config = config.with_refinement(i, values)
                if replica is not None:
                    replica = replica.with_refinement(i, values)
                refined = refined or bool(values)
        if refined:
            _run_points(config, replica, store, out, progress, on_batch)
        return write_report(config, store, out, tuning=tuning, replicate=replica, figures=figures)
