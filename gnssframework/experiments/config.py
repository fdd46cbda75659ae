"""The comparison config: a TOML file validated by pydantic.

A config names a scenario, the cases (e.g. C/N0 values), the candidates (each a
composition of plugins with parameters), the metrics, the number of Monte Carlo runs,
a seed, an executor and, optionally, published values to print beside the results.
"""

from __future__ import annotations

import hashlib
import json
import re
from pathlib import Path
from typing import Annotated, Any, Literal, TypeAlias

from pydantic import BaseModel, ConfigDict, Field, PrivateAttr, ValidationError, field_validator, model_validator

from ..errors import ConfigError
from ..hookspecs import COMPONENT_KINDS
from .config_base import read_config_data
from ..plugin import validation_message
from ..plugin_ref import PluginSpec, component_metadata
from .candidates import CandidatePlan, resolve_candidate
from .claims import Claim, check_claims, check_untuned_claims
from .file_names import check_file_name
from .sweeps import Sweep, check_thresholds, check_unique_labels, expand_sweep
from .tuning import Tuning, check_tuning

__all__ = ["Candidate", "Case", "Executor", "ComparisonConfig", "Sweep", "Claim", "load_config"]


#: Most Monte Carlo runs of a comparison (each case and candidate): a million runs of the
#: cheapest scenario take hours; a larger value is a typo that would only hang.
MAX_RUNS = 1_000_000

#: Most cases and candidates of one comparison (their product times the batches is the
#: work: 1000 x 1000 is already a million batches); the same bound as a sweep's points.
MAX_CASES = 1000
MAX_CANDIDATES = 1000


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


_REF = "the {kind} plugin: its name, or {{ name, params }}"
# A candidate's plugin of each kind: `plugin_ref.ComponentRef(kind)`, written out so that mypy reads it.
_EstimatorRef: TypeAlias = Annotated[PluginSpec, *component_metadata("estimator")]
_NoiseAdapterRef: TypeAlias = Annotated[PluginSpec, *component_metadata("noise_adapter")]
_AugmentationRef: TypeAlias = Annotated[PluginSpec, *component_metadata("augmentation")]
_DiscriminatorRef: TypeAlias = Annotated[PluginSpec, *component_metadata("discriminator")]
_ChannelFilterRef: TypeAlias = Annotated[PluginSpec, *component_metadata("channel_filter")]
_NavFilterRef: TypeAlias = Annotated[PluginSpec, *component_metadata("nav_filter")]


class Candidate(_Strict):
    """A named composition of plugins, one per kind the scenario uses."""

    name: str = Field(..., pattern=r"^[A-Za-z0-9_.+-]+$")
    estimator: _EstimatorRef | None = Field(None, description=_REF.format(kind="estimator"))
    noise_adapter: _NoiseAdapterRef | None = Field(None, description=_REF.format(kind="noise_adapter"))
    augmentation: _AugmentationRef | None = Field(None, description=_REF.format(kind="augmentation"))
    discriminator: _DiscriminatorRef | None = Field(None, description=_REF.format(kind="discriminator"))
    channel_filter: _ChannelFilterRef | None = Field(None, description=_REF.format(kind="channel_filter"))
    nav_filter: _NavFilterRef | None = Field(None, description=_REF.format(kind="nav_filter"))
    scenario_options: dict[str, Any] = Field(
        default_factory=dict,
        description="options the scenario applies to this candidate, not plugins (see the "
        "scenario's page; e.g. multipath's oracle)",
    )
    as_given: bool = Field(
        False,
        description="the candidate is deliberately evaluated as given (e.g. a paper's "
        "literal settings) while others are tuned: claims against it are then accepted, and the "
        "report says so",
    )

    _plain_name = field_validator("name")(lambda cls, v: check_file_name(v))

    def components(self) -> dict[str, PluginSpec]:
        """The candidate's plugins by kind (`gnssframework.plugin_ref.PluginSpec`)."""
        return {k: getattr(self, k) for k in COMPONENT_KINDS if getattr(self, k) is not None}


class Case(BaseModel):
    """A scenario variant: a name plus the scenario's case parameters (e.g. ``cn0_dbhz``)."""

    model_config = ConfigDict(extra="allow")
    name: str = Field(..., pattern=r"^[A-Za-z0-9_.+-]+$")
    streams: str | None = Field(
        None,
        pattern=r"^[A-Za-z0-9_.+-]+$",
        description="the random streams this case draws, named by a case "
        "(default: its own name): cases with the same streams draw the same random numbers run by run (common "
        "random numbers across cases, which claims with reference_case pair)",
    )

    _plain_name = field_validator("name")(lambda cls, v: check_file_name(v))

    def params(self) -> dict[str, Any]:
        return dict(self.model_extra or {})


#: Environment variable with the Dask scheduler address of ``executor.kind = "dask"``.
DASK_ADDRESS_ENV = "GNSSFRAMEWORK_DASK_ADDRESS"


class Executor(_Strict):
    """Where the runs execute."""

    kind: Literal["local", "dask"] = "local"
    workers: int = Field(
        0, ge=0, le=1024, strict=True, description="local processes (0: one per core, 1: in this process), at most 1024"
    )
    address: str = Field(
        "",
        description="dask scheduler address, from the Python API only: a config file may not "
        "set it (Dask's protocol carries pickles, so the scheduler a config names runs code here); "
        f"give it with `compare --dask-address` or the {DASK_ADDRESS_ENV} environment variable. "
        "Empty: a LocalCluster on this machine",
    )


class ComparisonConfig(_Strict):
    """A Monte Carlo comparison."""

    name: str = Field(
        "comparison",
        description="the comparison's name: its results folder results/<name> "
        "without --out, so a plain file name (no '/', '.', '..' or control characters)",
    )
    description: str = ""
    runs: int = Field(
        10, ge=1, le=MAX_RUNS, strict=True, description=f"Monte Carlo runs per case and candidate, 1 to {MAX_RUNS}"
    )
    batch_size: int = Field(
        5,
        ge=1,
        le=MAX_RUNS,
        strict=True,
        description="runs simulated together as one array "
        f"program, 1 to {MAX_RUNS} (and within the memory budget, see experiments.limits)",
    )
    seed: int = Field(0, ge=0, lt=2**63, strict=True, description="seed of the runs' random numbers, 0 to 2^63 - 1")
    executor: Executor = Field(default_factory=Executor)
    scenario: dict[str, Any] = Field(..., description="scenario kind and its parameters (see the scenario's page)")
    cases: list[Case] = Field(
        ..., min_length=1, max_length=MAX_CASES, description=f"the conditions compared, 1 to {MAX_CASES}"
    )
    candidates: list[Candidate] = Field(
        ...,
        min_length=1,
        max_length=MAX_CANDIDATES,
        description=f"the filter compositions compared, 1 to {MAX_CANDIDATES}",
    )
    metrics: list[str] = Field(default_factory=list, description="metrics to report (default: all of the scenario)")
    reference: str | None = Field(
        None, description="candidate the others are compared with (paired differences); default: the first candidate"
    )
    sweeps: list[Sweep] = Field(
        default_factory=list,
        description="parameters varied one at a time over a list "
        "or range of values (each point runs every case and candidate)",
    )
    published: dict[str, dict[str, dict[str, float]]] = Field(
        default_factory=dict, description="published values: case -> candidate -> metric -> value"
    )
    tuning: Tuning | None = Field(
        None,
        description="tune every candidate with free parameters by the same "
        "procedure and budget on tuning streams, then evaluate them at their tuned values",
    )
    random_stream: Literal["evaluation", "tuning", "replicate"] = Field(
        "evaluation",
        description="the runs' random streams: evaluation (the default), the disjoint tuning "
        "streams (set by the tuner for its trials) or the disjoint replicate streams (set by compare --replicate)",
    )
    claims: list[Claim] = Field(
        default_factory=list,
        description="orderings and bounds the results must show, "
        "each checked from the paired runs (holds / fails / not significant); "
        "`compare --check` exits 1 unless every claim holds",
    )
    claims_adjustment: Literal["holm", "benjamini-hochberg"] = Field(
        "holm",
        description="multiplicity adjustment of the claims' p-values over the example: holm (family-wise "
        "error rate) or benjamini-hochberg (false discovery rate)",
    )
    claims_small_n: bool = Field(
        False,
        strict=True,
        description="every claim is checked on fewer than 12 runs on purpose (small_n = true on each): "
        "compare --check accepts them and states each one's power (the difference its test detects with "
        "probability 0.8); without it, or small_n on the claim, such a claim is refused",
    )

    _plain_name = field_validator("name")(lambda cls, v: check_file_name(v))

    @field_validator("candidates", "cases")
    @classmethod
    def _unique_names(cls, items: list[Case] | list[Candidate]) -> list[Case] | list[Candidate]:
        names = [i.name for i in items]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(f"names must be unique, repeated: {', '.join(dup)}")
        return items

    @model_validator(mode="after")
    def _check_against_scenario(self) -> ComparisonConfig:
        from .scenarios import get_scenario

        scenario = get_scenario(self.scenario)  # raises ConfigError naming scenario.kind / field
        self._scenario = scenario  # resolved once: every later use reads this instance
        from .metrics import check_metric

        for i, metric in enumerate(self.metrics):  # the scenario's own or a metric component's
            check_metric(metric, scenario, f"metrics[{i}]")
        for i, case in enumerate(self.cases):
            scenario.check_case(case.params(), f"cases[{i}]")
            scenario.check_memory(
                case.params(),
                min(self.batch_size, self.runs),
                f"cases[{i}]",
                [{**c.components(), "scenario_options": c.scenario_options} for c in self.candidates],
            )
        self._candidates = tuple(
            resolve_candidate(scenario, cand, [c.params() for c in self.cases], f"candidates[{i}]")
            for i, cand in enumerate(self.candidates)
        )
        case_names = {c.name for c in self.cases}
        cand_names = {c.name for c in self.candidates}
        if self.reference is not None and self.reference not in cand_names:
            raise ConfigError(
                "reference",
                f"got {self.reference!r}; allowed: the candidates' names {', '.join(c.name for c in self.candidates)}",
            )
        for case_name, per_cand in self.published.items():
            if case_name not in case_names:
                raise ConfigError(f"published.{case_name}", f"unknown case; allowed: {', '.join(sorted(case_names))}")
            for cand, values in per_cand.items():
                if cand not in cand_names:
                    raise ConfigError(
                        f"published.{case_name}.{cand}", f"unknown candidate; allowed: {', '.join(sorted(cand_names))}"
                    )
                for metric in values:
                    if metric not in self.metric_names:
                        raise ConfigError(
                            f"published.{case_name}.{cand}.{metric}",
                            f"unknown metric; allowed: {', '.join(self.metric_names)}",
                        )
        check_claims(
            self.claims,
            sorted(case_names),
            [c.name for c in self.candidates],
            self.metric_names,
            self.sweeps,
            self.metric_units if any(c.versus_metric for c in self.claims) else None,
        )
        if self.tuning is not None:
            check_tuning(self)
            check_untuned_claims(self)
        if self.sweeps:
            check_unique_labels(self.sweeps)
            check_thresholds(self.sweeps, self.metric_names)
            self._points = {i: expand_sweep(self, i) for i in range(len(self.sweeps))}  # validates every value
        return self

    _points: dict[int, list[tuple[Any, Any]]] = PrivateAttr(default_factory=dict)
    _refined: dict[int, list[float]] = PrivateAttr(default_factory=dict)
    _scenario: Any = PrivateAttr(None)
    _candidates: tuple[CandidatePlan, ...] | None = PrivateAttr(None)

    @property
    def resolved_scenario(self) -> Any:
        """The scenario instance (`gnssframework.experiments.scenarios.Scenario`) the config
        was validated with."""
        if self._scenario is None:  # a config made without validation (model_construct)
            from .scenarios import get_scenario

            self._scenario = get_scenario(self.scenario)
        return self._scenario

    @property
    def resolved_candidates(self) -> tuple[CandidatePlan, ...]:
        """The candidates as the config was validated with them
        (`gnssframework.experiments.candidates.resolve_candidate`), in order."""
        if self._candidates is None:  # a config made without validation (model_construct)
            cases = [c.params() for c in self.cases]
            self._candidates = tuple(
                resolve_candidate(self.resolved_scenario, cand, cases, f"candidates[{i}]")
                for i, cand in enumerate(self.candidates)
            )
        return self._candidates

    def sweep_points(self, index: int) -> list[tuple[Any, ComparisonConfig]]:
        """``(value, config)`` of every point of ``sweeps[index]`` (see ``sweeps.expand_sweep``),
        the points its refinement added (`with_refinement`) among them, in order."""
        if index not in self._points:
            self._points[index] = expand_sweep(self, index)
        return self._points[index]

    def refinement(self, index: int) -> list[float]:
        """The points added to ``sweeps[index]``'s grid by its ``refine`` table (none yet: [])."""
        return list(self._refined.get(index, []))

    def with_refinement(self, index: int, values: list[float]) -> ComparisonConfig:
        """This config with ``values`` (`sweeps.refined_values`) added to ``sweeps[index]``'s
        points (a copy: this one is left as it is)."""
        other = self.model_copy()
        other._refined = {**self._refined, index: [float(v) for v in values]}
        other._points = {k: v for k, v in self._points.items() if k != index}
        other._points[index] = expand_sweep(other, index)
        return other

    @property
    def reference_name(self) -> str:
        """The candidate paired differences are taken against (``reference``, default the first)."""
        return self.reference or self.candidates[0].name

    @property
    def metric_names(self) -> list[str]:
        return self.metrics or list(self.resolved_scenario.metrics)

    @property
    def metric_units(self) -> dict[str, str]:
        """Unit of every reported metric (the scenario's or the metric component's)."""
        from .metrics import check_metric

        return {m: check_metric(m, self.resolved_scenario, "metrics") for m in self.metric_names}

    def component_metrics(self) -> list[str]:
        """The reported metrics the config adds to the scenario's own: registered ``metric``
        plugins, which the worker computes after ``run_batch`` (the same `evaluate`)."""
        own = self.resolved_scenario.metrics
        return [m for m in self.metric_names if m not in own]

    def identity(self) -> str:
        """Hash of everything that changes the numbers (not runs, executor or description).

        A store keyed by it lets a longer or interrupted comparison reuse finished batches.
        """
        data = self.model_dump(
            exclude={
                "runs",
                "executor",
                "description",
                "published",
                "metrics",
                "name",
                "reference",
                "sweeps",
                "claims",
                "claims_adjustment",
                "claims_small_n",
            }
        )
        # The scenario's and the cases' values as their models read them, not as written:
        # `cn0_dbhz = 45` and `= 45.0` are one case (one key), as they are one simulation.
        scenario = self.resolved_scenario
        data["scenario"] = {"kind": self.scenario["kind"], **_as_read(scenario.params)}
        for case, written in zip(data["cases"], self.cases):
            for key in written.params():
                case.pop(key, None)
            case.update(_as_read(scenario.CaseParams.model_validate(written.params())))
        for case in data["cases"]:  # a case on its own streams keeps its old key
            if case.get("streams") is None:
                case.pop("streams", None)
        for cand in data["candidates"]:  # a candidate without options keeps its old key
            if not cand["scenario_options"]:
                del cand["scenario_options"]
            del cand["as_given"]  # what the report says of it, not what it computes
        extra = self.component_metrics()
        if extra:  # the stored rows must hold them; a config without components keeps its old key
            data["metric_components"] = sorted(extra)
        if scenario.revision:  # the scenario's numbers changed since revision 0: a store of before is another
            data["scenario_revision"] = scenario.revision
        return hashlib.sha256(json.dumps(data, sort_keys=True, default=str).encode()).hexdigest()[:16]


def _as_read(params: BaseModel) -> dict[str, Any]:
    """The parameters a config set, as the model holds them (an integer written for a float
    field is that float), for `ComparisonConfig.identity`."""
    return params.model_dump(mode="json", exclude_unset=True)


_INDEXED = re.compile(r"\b(candidates|cases)\[(\d+)\]")


def with_names(exc: ConfigError, data: Any) -> ConfigError:
    """``exc`` whose field names a case or candidate by index (``candidates[2].nav_filter...``)
    with the name the config gives it appended: ``... (candidates[2] is 'AUKF1')``, so the
    user finds it as written. The field itself is unchanged."""
    found = _INDEXED.search(exc.field or "")
    if not found or not isinstance(data, dict):
        return exc
    items = data.get(found[1])
    index = int(found[2])
    item = items[index] if isinstance(items, list) and index < len(items) else None
    name = item.get("name") if isinstance(item, dict) else None
    if not isinstance(name, str) or repr(name) in exc.detail:
        return exc
    return type(exc)(exc.field, f"{exc.detail} ({found[0]} is {name!r})")


def load_config(path: str | Path, **overrides: Any) -> ComparisonConfig:
    """Read and validate a comparison TOML file (with its ``[base]`` resolved:
    `gnssframework.experiments.config_base`).

    Raises
    ------
    DataFileError
        If the file is missing or not valid TOML (with the line).
    ConfigError
        For any invalid field, naming it and what it allows.
    """
    path = Path(path)
    data = read_config_data(path)  # its [base] resolved (`config_base`)
    executor = data.get("executor")
    if isinstance(executor, dict) and executor.get("address"):
        # Dask's protocol carries pickles: a shared config that names a scheduler would make
        # whoever runs it execute that scheduler's code and send it theirs.
        raise ConfigError(
            "executor.address",
            "a Dask scheduler address is not taken from a config file (Dask's "
            "protocol carries pickles: the scheduler it names would run code here); give it with "
            f"`gnssframework compare --dask-address ADDR` or the {DASK_ADDRESS_ENV} environment "
            "variable",
        )
    data.update({k: v for k, v in overrides.items() if v is not None})
    try:
        config = ComparisonConfig.model_validate(data)
    except ValidationError as exc:
        raise validation_message(exc, model=ComparisonConfig) from None
    # Checked here, not in the model: a sweep or a tuning that runs some of the cases keeps
    # a case's streams named after a case it leaves out.
    names = [c.name for c in config.cases]
    for i, case in enumerate(config.cases):
        if case.streams is not None and case.streams not in names:
            raise ConfigError(f"cases[{i}].streams", f"unknown case {case.streams!r}; allowed: {', '.join(names)}")
    return config
