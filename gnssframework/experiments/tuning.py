"""Tuning every candidate by the same procedure and budget, on seeds disjoint from the evaluation.

A comparison is only fair if every candidate had the same chance: an ordering that comes
from one candidate's hand-set process noise measures the hand, not the filter. A config
declares which parameters are free and one objective; the framework tunes each candidate
that has free parameters with the same sampler and the same number of trials, on runs
drawn from *tuning* streams (statistically independent of the evaluation's: every run's
seed sequence gets the spawn key of ``name_key("tuning")``), then evaluates every
candidate at its tuned values on the evaluation streams with common random numbers::

    [tuning]
    trials = 16                      # budget: trials per tuned candidate, the same for all
    runs = 4                         # runs per trial (tuning streams)
    sampler = "tpe"                  # "tpe" or "random" (Optuna, extra 'tune'), or "grid"
    metric = "velocity_error_rmse"   # the objective, minimised
    cases = ["45dBHz", "30dBHz"]     # default: every case
    combine = "geometric-mean"       # over cases: "geometric-mean" (scale-free), "mean", "max"

    [tuning.candidate_cases]         # optional: a candidate's own objective cases (a regime)
    pll-30dBHz = ["30dBHz"]

    [[tuning.free]]
    path = "candidates.*.nav_filter.params.accel_psd"   # every candidate with that parameter
    low = 1e-4
    high = 1.0
    scale = "log"

    [[tuning.free]]
    path = "candidates.ackf.channel_filter.params.window"
    low = 5
    high = 60
    type = "int"

``candidate_cases`` tunes a candidate for one regime (e.g. a loop tuned for the C/N0 it
will see): its objective is over those cases instead of ``cases``; the sampler, the
budget, the runs, the metric and ``combine`` stay the same for every candidate.

A candidate without free parameters is evaluated as given (keep the paper's literal
settings as such a row). Each trial is a small comparison of one candidate stored in the
results store under its own identity, and its outcome in the store's ``trials`` table,
so an interrupted tuning resumes with identical results: the samplers are seeded per
trial from the seed, the candidate and the trial's index, and see the completed trials
only. A trial whose filter fails numerically scores ``inf`` (the sampler learns to avoid
that region) instead of stopping the comparison.

The report lists each candidate's tuned values beside its given ones, the objective of
every trial against each free parameter (``plots/tuning-<candidate>.png``,
``tuning/<candidate>.csv``) and the budget used.
"""

from __future__ import annotations

import copy
from contextlib import closing
import itertools
import json
import math
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from ..errors import ConfigError, GnssFrameworkError, RunFailure
from ..random_streams import name_key
from .run_plan import TUNING_PURPOSE, resolve
from .tasks import plan

__all__ = ["Tuning", "FreeParameter", "TUNING_PURPOSE", "tuned_config", "tuning_points"]


class FreeParameter(BaseModel):
    """A parameter the tuner may set: a candidate path (``*`` for every candidate that
    has the parameter) and a range (``low``, ``high``, ``scale``, ``type``) or ``values``."""

    model_config = ConfigDict(extra="forbid")
    path: str = Field(
        ...,
        description="candidates.<candidate or *>.<kind>.params.<field> (nested plugins: "
        "...params.estimator.params.alpha)",
    )
    low: float | None = Field(None, description="lower end of the range")
    high: float | None = Field(None, description="upper end of the range")
    scale: Literal["linear", "log"] = Field("linear", description="sample the range linearly or in log")
    type: Literal["float", "int"] = Field("float", description="a float or an integer parameter")
    values: list[Any] | None = Field(None, min_length=2, description="a choice among these values, instead of a range")

    @model_validator(mode="after")
    def _one_form(self) -> FreeParameter:
        for end in ("low", "high"):
            value = getattr(self, end)
            if value is not None and not math.isfinite(value):
                raise ValueError(
                    f"{end} must be a finite number, got {value!r} (a sampler cannot draw from an unbounded range)"
                )
        if self.values is not None:
            bad = [v for v in self.values if isinstance(v, float) and not math.isfinite(v)]
            if bad:
                raise ValueError(f"values must be finite, got {bad[0]!r}")
            if self.low is not None or self.high is not None:
                raise ValueError("give values = [...] or low and high, not both")
            return self
        if self.low is None or self.high is None or not self.low < self.high:
            raise ValueError("give low < high (a range) or values = [...] (a choice)")
        if self.scale == "log" and self.low <= 0:
            raise ValueError(f"a log range needs low > 0 (got {self.low})")
        if self.type == "int" and (int(self.low) != self.low or int(self.high) != self.high):
            raise ValueError("an int range needs whole low and high")
        return self

    def grid(self, n: int) -> list[Any]:
        """``n`` values spread over the range (or every value of a choice)."""
        if self.values is not None:
            return list(self.values)
        if self.scale == "log":
            pts = np.geomspace(self.low, self.high, n)
        else:
            pts = np.linspace(self.low, self.high, n)
        if self.type == "int":
            return sorted({int(round(v)) for v in pts})
        return [float(np.round(v, 12)) for v in pts]


class Tuning(BaseModel):
    """The tuning procedure every candidate with free parameters goes through."""

    model_config = ConfigDict(extra="forbid")
    trials: int = Field(..., ge=1, le=2000, description="trials per tuned candidate (the same budget for all)")
    runs: int = Field(4, ge=1, le=10000, description="Monte Carlo runs per trial, on the tuning streams")
    sampler: Literal["tpe", "random", "grid"] = Field(
        "tpe",
        description="tpe (Optuna's TPE), random (Optuna's random sampler) or grid (the same number of "
        "points per free parameter, at most `trials` in all)",
    )
    metric: str | list[str] = Field(
        ...,
        description="the objective's metric (minimised), or a list of metrics: a stated composite, every "
        "metric's mean in every case combined by `combine` (with geometric-mean a relative change of any "
        "metric counts alike, whatever its unit), for a candidate whose claims are about several metrics",
    )
    cases: list[str] | None = Field(None, min_length=1, description="cases of the objective (default: every case)")
    combine: Literal["geometric-mean", "mean", "max"] = Field(
        "geometric-mean", description="how the cases' mean metrics make one objective"
    )
    candidate_cases: dict[str, list[str]] = Field(
        default_factory=dict,
        description="per tuned candidate, the cases of its own objective instead of `cases` "
        "(a loop tuned for one regime); sampler, budget, runs, metric and combine stay the same for all",
    )
    free: list[FreeParameter] = Field(..., min_length=1, description="the free parameters")

    @property
    def metrics(self) -> list[str]:
        """The objective's metrics: ``metric``, or each of a composite's."""
        return [self.metric] if isinstance(self.metric, str) else list(self.metric)


# -- resolving the free parameters ---------------------------------------------------------------


class _Path:
    def __init__(self, path: str) -> None:
        self.path = path


def resolve_free(config) -> dict[str, list[tuple[FreeParameter, tuple[Any, ...], str]]]:
    """Per tuned candidate: ``(parameter, keys into the config's data, label)``; refuses a
    path that names no candidate parameter, naming ``tuning.free[i].path``."""
    from .sweeps import _resolve

    names = [c.name for c in config.candidates]
    out: dict[str, list] = {}
    for i, free in enumerate(config.tuning.free):
        where = f"tuning.free[{i}]"
        parts = free.path.split(".")
        if len(parts) < 2 or parts[0] != "candidates":
            raise ConfigError(
                f"{where}.path",
                f"{free.path!r}: a free parameter is a candidate's: candidates.<candidate or *>.<kind>.params.<field>",
            )
        targets = names if parts[1] == "*" else [parts[1]]
        found = 0
        for cand in targets:
            path = ".".join(["candidates", cand, *parts[2:]])
            try:
                keys = _resolve(config, _Path(path), where)[0]
            except ConfigError:
                if parts[1] == "*":
                    continue  # '*': only the candidates that have it
                raise
            label = ".".join(str(k) for k in keys[2:])
            out.setdefault(cand, []).append((free, keys, label))
            found += 1
        if not found:
            raise ConfigError(f"{where}.path", f"{free.path!r}: no candidate has this parameter")
    return out


def _with_values(data: dict, index: int, params: list[tuple[FreeParameter, tuple, str]], values: list[Any]) -> dict:
    """``data`` (a config's dict) with candidate ``index``'s free parameters set; a path
    ending in an index (``...params.q.4``) sets one element of a list parameter, whose
    other elements keep their given (or default) values."""
    from .sweeps import _set

    data = copy.deepcopy(data)
    for (free, keys, label), value in zip(params, values):
        keys = ("candidates", index, *keys[2:])
        if str(keys[-1]).isdigit():
            current = _lookup(data["candidates"][index], keys[:-1])
            element = int(keys[-1])
            if not isinstance(current, list) or element >= len(current):
                raise ConfigError(
                    "tuning.free",
                    f"{free.path!r}: {label.rsplit('.', 1)[0]!r} has no element {element} (it is {current!r})",
                )
            value, keys = current[:element] + [value] + current[element + 1 :], keys[:-1]
        _set(data, keys, value, free.path, "tuning.free")
    return data


def _lookup(cand_data: dict, keys: tuple) -> Any:
    """The value at ``keys`` (from ``("candidates", i, kind, "params", field, ...)``) in a
    candidate's dict, the plugin's default where the config leaves a first-level field out."""
    from .. import registry

    node: Any = cand_data
    for k in keys[2:]:
        if isinstance(node, str):  # a nested plugin given by name: its parameters are the defaults
            node = {"name": node, "params": {}}
        if isinstance(node, list) and str(k).isdigit() and int(k) < len(node):
            node = node[int(k)]
            continue
        if isinstance(node, dict) and k in node:
            node = node[k]
            continue
        if len(keys) < 5 or k != keys[4] and k != keys[3]:
            return None
        ref = cand_data[keys[2]]
        info = registry.get(keys[2], ref if isinstance(ref, str) else ref["name"]).Params.model_fields.get(keys[4])
        if info is None or info.is_required():
            return None
        default = info.get_default(call_default_factory=True)
        return (
            default[int(keys[5])]
            if len(keys) > 5 and isinstance(default, list) and str(keys[5]).isdigit()
            else list(default)
            if isinstance(default, (list, tuple)) and len(keys) == 5
            else default
        )
    return list(node) if isinstance(node, tuple) else node


def trial_config(config, candidate: str, values: list[Any]):
    """The comparison one trial runs: the candidate alone at ``values``, the tuning's runs,
    cases and streams, no sweeps or claims."""
    tuning = config.tuning
    params = resolve_free(config)[candidate]
    base = config.model_dump(mode="json", exclude={"sweeps", "claims", "tuning", "published"}, exclude_none=True)
    index = [c["name"] for c in base["candidates"]].index(candidate)
    data = _with_values(base, index, params, values)
    data.update(
        candidates=[data["candidates"][index]],
        runs=tuning.runs,
        reference=None,
        random_stream="tuning",
        metrics=tuning.metrics,
        name=f"{config.name}-tune-{candidate}",
    )
    cases = objective_cases(tuning, candidate)
    if cases:
        data["cases"] = [c for c in data["cases"] if c["name"] in cases]
    return type(config).model_validate(data)  # this module sits below experiments.config


def objective_cases(tuning: Tuning, candidate: str) -> list[str] | None:
    """The cases of ``candidate``'s objective: its own (``candidate_cases``), else the
    tuning's ``cases`` (``None``: every case)."""
    return tuning.candidate_cases.get(candidate) or tuning.cases


def check_tuning(config) -> None:
    """Load-time checks of ``[tuning]``: metric, cases, every free path, both ends of every
    range accepted by the parameter's model, a grid within the budget."""
    from pydantic import ValidationError

    from ..plugin import validation_message

    tuning = config.tuning
    if not tuning.metrics:
        raise ConfigError("tuning.metric", "a composite objective needs at least one metric, got []")
    composite = not isinstance(tuning.metric, str)
    for j, metric in enumerate(tuning.metrics):
        if metric not in config.metric_names:
            raise ConfigError(
                f"tuning.metric[{j}]" if composite else "tuning.metric",
                f"unknown metric {metric!r}; allowed: {', '.join(config.metric_names)}",
            )
    cases = [c.name for c in config.cases]
    for j, case in enumerate(tuning.cases or []):
        if case not in cases:
            raise ConfigError(f"tuning.cases[{j}]", f"unknown case {case!r}; allowed: {', '.join(cases)}")
    resolved = resolve_free(config)
    for cand, own in tuning.candidate_cases.items():
        if cand not in resolved:
            raise ConfigError(
                f"tuning.candidate_cases.{cand}",
                f"{cand!r} is not a tuned candidate (no free parameter of it); tuned: {', '.join(resolved) or 'none'}",
            )
        if not own:
            raise ConfigError(f"tuning.candidate_cases.{cand}", "give at least one case")
        for j, case in enumerate(own):
            if case not in cases:
                raise ConfigError(
                    f"tuning.candidate_cases.{cand}[{j}]", f"unknown case {case!r}; allowed: {', '.join(cases)}"
                )
    for cand, params in resolved.items():
        for end in (0, -1):
            values = [p.grid(2)[end] for p, _, _ in params]
            try:
                trial_config(config, cand, values)
            except (ConfigError, ValidationError) as exc:
                text = str(exc) if isinstance(exc, ConfigError) else str(validation_message(exc))
                raise ConfigError(
                    "tuning.free", f"candidate {cand!r} at {dict(zip([lb for _, _, lb in params], values))}: {text}"
                ) from None
        if tuning.sampler == "grid":
            points = len(grid_points(params, tuning.trials))
            if points > tuning.trials:
                raise ConfigError(
                    "tuning.trials",
                    f"the grid of candidate {cand!r} has {points} points (its choices "
                    f"alone), more than the budget of {tuning.trials} trials",
                )


def grid_points(params: list[tuple[FreeParameter, tuple, str]], trials: int) -> list[list[Any]]:
    """The grid sampler's points: the same number of values per range parameter (as many
    as the budget allows), every value of a choice."""
    choices = math.prod(len(p.values) for p, _, _ in params if p.values is not None)
    ranges = [p for p, _, _ in params if p.values is None]
    n = max(2, int(math.floor((trials / choices) ** (1 / len(ranges)) + 1e-9))) if ranges else 0
    axes = [p.grid(n) for p, _, _ in params]
    return [list(v) for v in itertools.product(*axes)]


# -- the tuning loop ---------------------------------------------------------------------------------


def _objective(config, store, trial) -> float:
    """The combined objective of a finished trial (``inf`` where undefined): the mean of the
    metric (of each metric of a composite) in each case, combined by ``combine``."""
    key = trial.identity()
    per_case = []
    for metric in config.tuning.metrics:
        for case in trial.cases:
            v = store.values(key, case.name, trial.candidates[0].name, metric, trial.runs)
            m = float(np.mean(v)) if v.size and np.all(np.isfinite(v)) else math.inf
            per_case.append(m)
    combine = config.tuning.combine
    if any(not math.isfinite(m) for m in per_case):
        return math.inf
    if combine == "max":
        return max(per_case)
    if combine == "mean":
        return float(np.mean(per_case))
    if any(m <= 0 for m in per_case):
        return float(np.mean(per_case))  # a zero metric: the geometric mean would hide the other cases
    return float(np.exp(np.mean(np.log(per_case))))


def _run_trial(config, store, trial, execute) -> float:
    """Run (or reuse) a trial's batches; ``inf`` if its filter fails."""
    key = trial.identity()
    store.register(key, trial.batch_size)
    done = store.finished_batches(key)
    resolved = resolve(trial)
    jobs = [
        (resolved, t)
        for t in plan(trial, f"tuning trial of {trial.candidates[0].name}")
        if (trial.cases[t.case_index].name, trial.candidates[t.candidate_index].name, t.first_run, t.runs) not in done
    ]
    try:
        with closing(execute(jobs)) as results:  # closed at once on Ctrl-C: workers stop
            for _i, (task, metrics, _series, _time) in results:
                store.add_batch(
                    key, trial.cases[task.case_index].name, trial.candidates[0].name, task.first_run, metrics
                )
    except RunFailure:
        return math.inf
    return _objective(config, store, trial)


def _sampler(kind: str, seed: int, trials: int):
    try:
        import optuna
    except ImportError:
        raise ConfigError(
            "tuning.sampler", f"{kind!r} needs Optuna: pip install 'gnssframework[tune]' (or use sampler = \"grid\")"
        ) from None
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    if kind == "tpe":
        # TPE's random start-up: a third of the budget, 2 to 10 trials.
        return optuna.samplers.TPESampler(seed=seed, n_startup_trials=max(2, min(10, trials // 3)))
    return optuna.samplers.RandomSampler(seed=seed)


def _distributions(params):
    import optuna

    out = {}
    for free, _, label in params:
        if free.values is not None:
            out[label] = optuna.distributions.CategoricalDistribution(free.values)
        elif free.type == "int":
            out[label] = optuna.distributions.IntDistribution(int(free.low), int(free.high), log=free.scale == "log")
        else:
            out[label] = optuna.distributions.FloatDistribution(free.low, free.high, log=free.scale == "log")
    return out


def _suggest(config, cand: str, params, history: list[tuple[list[Any], float]], index: int) -> list[Any]:
    """The ``index``-th trial's values: from the grid, or from an Optuna sampler seeded by
    (seed, candidate, index) that sees the completed trials only (resumes identically)."""
    tuning = config.tuning
    if tuning.sampler == "grid":
        return grid_points(params, tuning.trials)[index]
    import optuna

    seed = int(np.random.SeedSequence([config.seed, *name_key(cand), index]).generate_state(1)[0])
    dists = _distributions(params)
    study = optuna.create_study(direction="minimize", sampler=_sampler(tuning.sampler, seed, tuning.trials))
    for values, objective in history:
        study.add_trial(
            optuna.trial.create_trial(
                params=dict(zip(dists, values)),
                distributions=dists,
                value=objective if math.isfinite(objective) else 1e300,
            )
        )
    trial = study.ask(dists)
    return [trial.params[label] for label in dists]


def tune(config, store, out: Path, execute, progress: bool = False) -> dict[str, dict]:
    """Tune every candidate with free parameters; returns per candidate its trials and best."""
    tuning = config.tuning
    key = config.identity()
    results = {}
    for cand, params in resolve_free(config).items():
        labels = [label for _, _, label in params]
        budget = len(grid_points(params, tuning.trials)) if tuning.sampler == "grid" else tuning.trials
        history = store.trials(key, cand)
        while len(history) < budget:
            index = len(history)
            values = _suggest(config, cand, params, history, index)
            objective = _run_trial(config, store, trial_config(config, cand, values), execute)
            store.add_trial(key, cand, index, json.dumps(values), objective)
            history.append((values, objective))
            if progress:
                print(f"tuning {cand}: trial {index + 1}/{budget} {dict(zip(labels, values))} -> {objective:.4g}")
        finite = [(v, o) for v, o in history if math.isfinite(o)]
        if not finite:
            raise GnssFrameworkError(
                f"tuning: every trial of candidate {cand!r} failed (objective undefined); "
                "narrow the ranges in tuning.free"
            )
        failed = len(history) - len(finite)
        if 2 * failed > len(history):  # the "best" of a few survivors is not a tuning
            raise GnssFrameworkError(
                f"tuning: {failed} of {len(history)} trials of candidate {cand!r} failed "
                "(objective undefined): the tuned value would be the best of the few that ran; "
                "narrow the ranges in tuning.free"
            )
        best_values, best = min(finite, key=lambda t: t[1])
        given = [_get(config, cand, keys) for _, keys, _ in params]
        results[cand] = {
            "labels": labels,
            "trials": [{"values": v, "objective": o} for v, o in history],
            "best": dict(zip(labels, best_values)),
            "best_objective": best,
            "given": dict(zip(labels, given)),
            "budget": budget,
            "metric": tuning.metric,
            "combine": tuning.combine,
            "own_cases": tuning.candidate_cases.get(cand),
        }
    return results


def _get(config, cand: str, keys: tuple) -> Any:
    """A candidate's given value at ``keys`` (its plugin's default when the config leaves it
    out; ``None`` for a nested plugin's default)."""
    data = config.model_dump(mode="json")
    return _lookup(data["candidates"][[c["name"] for c in data["candidates"]].index(cand)], keys)


def tuned_config(config, results: dict[str, dict]):
    """The comparison to evaluate: every tuned candidate at its best values (evaluation
    streams, the config's runs), the others as given; no ``[tuning]``."""
    data = config.model_dump(mode="json", exclude={"tuning"}, exclude_none=True)
    resolved = resolve_free(config)
    names = [c["name"] for c in data["candidates"]]
    for cand, res in results.items():
        data = _with_values(data, names.index(cand), resolved[cand], [res["best"][lb] for lb in res["labels"]])
    return type(config).model_validate(data)


def tuning_points(results: dict[str, dict]) -> list[dict]:
    """Strict-JSON summary entries (candidate, given and tuned values, objective, budget)."""
    return [
        {
            "candidate": c,
            "given": r["given"],
            "tuned": r["best"],
            "objective": r["best_objective"],
            "trials": len(r["trials"]),
            "budget": r["budget"],
            "failed_trials": sum(not math.isfinite(t["objective"]) for t in r["trials"]),
        }
        for c, r in results.items()
    ]
