"""Scenario kinds of the comparison runner.

A scenario turns (case, candidate, a batch of runs, a random generator) into per-run
metrics and time series. Each kind declares its parameters, its case parameters, the
plugin kinds a candidate must (or may) compose, and its metrics with their units.
"""

from __future__ import annotations

import abc
from collections.abc import Sequence
from typing import Any, ClassVar

import numpy as np
from pydantic import BaseModel, ConfigDict, ValidationError, model_validator

from ... import registry
from ...errors import ConfigError
from ...interfaces import RunContext
from ...plugin import refuse_quiet_conversions, validation_message
from ...plugin_ref import PluginSpec, component_spec
from ...random_streams import RunStreams
from ...suggest import did_you_mean
from ..batch import BatchResult
from ..limits import check_batch_memory

__all__ = ["Scenario", "BatchResult", "get_scenario", "register_scenario", "scenario_kinds", "declared_scenarios"]


class ScenarioParams(BaseModel):
    """Base of scenario and case parameter models: unknown parameters are an error, and a
    string or boolean for a number is refused rather than converted."""

    model_config = ConfigDict(extra="forbid")

    @model_validator(mode="before")
    @classmethod
    def _no_quiet_conversions(cls, data: Any) -> Any:
        return refuse_quiet_conversions(cls, data)


class NoCandidateOptions(ScenarioParams):
    """A scenario without candidate options: ``scenario_options`` must stay empty."""


class Scenario(abc.ABC):
    """Base class of scenario kinds."""

    kind: ClassVar[str]
    Params: ClassVar[type[ScenarioParams]]
    CaseParams: ClassVar[type[ScenarioParams]]
    #: plugin kind -> True if required, False if optional.
    components: ClassVar[dict[str, bool]]
    #: metric name -> unit.
    metrics: ClassVar[dict[str, str]]
    #: further per-epoch series of ``BatchResult.series`` (name -> unit) that metric
    #: components (``gnssframework.experiments.metrics``) may read, beside the metrics' own.
    outputs: ClassVar[dict[str, str]] = {}
    #: What a candidate's ``scenario_options`` may set: options of the scenario that apply to
    #: one candidate and are not plugins (``multipath``'s oracle). Default: none.
    CandidateOptions: ClassVar[type[ScenarioParams]] = NoCandidateOptions
    #: Revision of the numbers the scenario gives a config: raised when its code or a
    #: default changes them, so that a result store written before holds "another
    #: configuration" (refused) instead of answering with the old numbers
    #: (`ComparisonConfig.identity`; 0, the first, leaves the identity as it was).
    revision: ClassVar[int] = 0

    def __init__(self, params: ScenarioParams) -> None:
        self.params = params

    def check_case(self, case: dict[str, Any], where: str) -> None:
        try:
            self.CaseParams.model_validate(case)
        except ValidationError as exc:
            raise validation_message(exc, prefix=where, model=self.CaseParams) from None

    def batch_memory(
        self, case: dict[str, Any], runs: int, where: str, candidates: Sequence[dict[str, Any]] = ()
    ) -> tuple[float, str, str] | None:
        """Estimated peak memory of one batch of ``runs`` runs of ``case`` (validated case
        parameters) for the most demanding of ``candidates`` (their plugin references by
        kind, and their ``scenario_options`` dict), for `check_memory`: ``(bytes, field path, the batch's size in words)``, or
        ``None`` when the scenario's memory does not grow with its parameters."""
        return None

    def check_memory(
        self, case: dict[str, Any], runs: int, where: str, candidates: Sequence[dict[str, Any]] = ()
    ) -> None:
        """Refuse a case whose batch of ``runs`` runs would exceed the memory budget
        (`gnssframework.experiments.limits`), before anything is allocated."""
        estimate = self.batch_memory(self.CaseParams.model_validate(case).model_dump(), runs, where, candidates)
        if estimate is not None:
            check_batch_memory(*estimate)

    def candidate_options(self, options: dict[str, Any] | None, where: str = "candidate") -> ScenarioParams:
        """A candidate's ``scenario_options`` validated by `CandidateOptions` (errors name
        ``<where>.scenario_options.<field>``)."""
        try:
            return self.CandidateOptions.model_validate(options or {})
        except ValidationError as exc:
            raise validation_message(exc, prefix=f"{where}.scenario_options", model=self.CandidateOptions) from None

    def check_candidate(
        self, components: dict[str, PluginSpec], where: str, options: dict[str, Any] | None = None
    ) -> dict[str, Any]:
        """Every required kind present, no foreign kind, every plugin creatable, composable,
        and valid ``scenario_options``; returns the plugins created to check them (for
        `check_contexts`)."""
        self.candidate_options(options, where)
        for kind, required in self.components.items():
            if required and kind not in components:
                raise ConfigError(
                    f"{where}.{kind}",
                    f"required by scenario {self.kind!r} (a candidate composes: {self._describe_components()})",
                )
        for kind in components:
            if kind not in self.components:
                raise ConfigError(
                    f"{where}.{kind}",
                    f"scenario {self.kind!r} does not use a {kind}; it composes: {self._describe_components()}",
                )
        built = {}
        for kind, ref in components.items():
            try:
                cls = registry.get(kind, ref.name)
            except ConfigError as exc:
                raise ConfigError(f"{where}.{kind}.name", exc.detail) from None
            try:
                built[kind] = cls(**ref.params)
            except ConfigError as exc:
                raise _config_path(exc, cls, f"{where}.{kind}") from None
        self.check_composition(built, where)
        return built

    def run_contexts(self, cases: list[dict[str, Any]]) -> list[RunContext]:
        """The run contexts (coherent time, correlator spacing) the candidates' filters get
        over ``cases``, for `check_contexts`; the default says nothing (no check)."""
        return []

    def check_contexts(self, plugins: dict[str, Any], cases: list[dict[str, Any]], where: str) -> None:
        """Let each of a candidate's filters (``plugins``, as `check_candidate` created them)
        refuse the harness contexts it would run in (``SequentialFilter.check_context``),
        naming the config field, before any batch."""
        contexts = self.run_contexts(cases)
        if not contexts:
            return
        for kind, plugin in plugins.items():
            for context in contexts if hasattr(plugin, "check_context") else ():
                try:
                    self.in_context(plugin, context).check_context(context)
                except ConfigError as exc:
                    raise _config_path(exc, type(plugin), f"{where}.{kind}") from None

    def in_context(self, plugin: Any, context: RunContext) -> Any:
        """``plugin`` as the harness runs it in ``context`` (itself unless the scenario
        re-creates it, e.g. at a case's own interval)."""
        return plugin

    def _describe_components(self) -> str:
        return ", ".join(f"{k} ({'required' if r else 'optional'})" for k, r in self.components.items())

    @staticmethod
    def capable(kind: str, outputs: tuple[str, ...]) -> list[str]:
        """Registered plugins of ``kind`` that provide every name in ``outputs``."""
        return [n for n in registry.names(kind) if all(o in registry.get(kind, n).provides for o in outputs)]

    def refuse(self, exc: ConfigError, where: str, outputs: tuple[str, ...]) -> ConfigError:
        """Re-address a harness's composition error to the candidate's field, naming the
        plugins of that kind that would work."""
        kind = exc.field
        able = ", ".join(self.capable(kind, outputs)) or "(none registered)"
        return ConfigError(f"{where}.{kind}.name", f"{exc.detail}; {kind.replace('_', ' ')}s that do: {able}")

    def check_composition(self, plugins: dict[str, Any], where: str) -> None:  # noqa: B027 - optional hook
        """Refuse compositions whose parts cannot work together (override per scenario; the
        default accepts every composition that passed the per-kind checks)."""

    def assumption_context(self, case: dict[str, Any]) -> dict[str, Any]:
        """What the plugins' ``assumptions`` need to know of a case (``coherent_time_s``,
        ``cn0_dbhz``...) for the report's assumptions table; the default gives nothing."""
        return {}

    def build(
        self, candidate: dict[str, Any], options: dict[str, Any] | None = None, case: dict[str, Any] | None = None
    ) -> dict[str, Any]:
        """Instantiate a candidate's plugins (fresh objects for every batch): what
        `run_batch` gets. ``candidate`` holds each kind's `PluginSpec` (a resolved
        candidate's, `gnssframework.experiments.candidates`), or a name or ``{name, params}``
        table. ``options`` are the candidate's ``scenario_options``; a scenario with
        `CandidateOptions` adds what `run_batch` needs of them to the returned dict.
        ``case`` (a task's, as `run_batch` gets it) builds each plugin with the parameters
        the case fixes (`case_parameters`), so `run_batch` need not re-create it: one
        validation and one construction per plugin and task."""
        plugins = {}
        for kind, ref in candidate.items():
            spec = component_spec(kind, ref)
            fixed = self.case_parameters(kind, spec, case) if case is not None else {}
            plugins[kind] = (PluginSpec(kind, spec.name, {**spec.params, **fixed}) if fixed else spec).create()
        return plugins

    def case_parameters(self, kind: str, spec: PluginSpec, case: dict[str, Any]) -> dict[str, Any]:
        """Parameters of the plugin ``spec`` (of ``kind``) that ``case`` sets, replacing the
        candidate's (a loop at the case's own interval); the default: none. `build` creates
        the plugin with them; `run_batch` must give the same plugin when it gets one built
        without the case (it re-creates it then, as `in_context` does)."""
        return {}

    @abc.abstractmethod
    def run_batch(
        self, case: dict[str, Any], plugins: dict[str, Any], runs: int, rng: RunStreams | np.random.Generator | int
    ) -> BatchResult:
        """Simulate ``runs`` Monte Carlo runs as one array program.

        ``rng`` is the runs' random streams: the runner gives `RunStreams` (one generator
        per run); a plain ``Generator`` or a seed is accepted too and made into streams with
        `gnssframework.random_streams.as_run_streams`."""


registry.register_kind("scenario", Scenario)  # this layer owns the kind's base


def _config_path(exc: ConfigError, cls: type[Any], where: str) -> ConfigError:
    """A plugin's error re-addressed to the config: the plugin names its field from its own
    root (``channel_filter 'iq-filter'.estimator...``); continue the config's path ``where``
    instead, so the field is written one way."""
    own = f"{cls.kind or 'plugin'} {cls.name!r}"
    if exc.field == own or exc.field.startswith((own + ".", own + "[")):
        return ConfigError(f"{where}.params{exc.field[len(own) :]}", exc.detail)
    return ConfigError(f"{where}.params", str(exc))


#: Scenario kinds declared with `register_scenario` in this package's modules, in the order
#: they are declared: what the package's ``register_scenario`` hook (`hooks`) hands the
#: plugin registry. Nothing looks a scenario up here; `get_scenario` asks the registry.
_DECLARED: list[type[Scenario]] = []


def register_scenario(cls: type[Scenario]) -> type[Scenario]:
    """Class decorator declaring a scenario kind in a module of this package; the package's
    ``register_scenario`` hook registers it with the plugin registry, as another package's
    ``register_scenario`` hook (``gnssframework`` entry-point group) registers its own.
    (At run time, e.g. in a notebook, use `gnssframework.registry.register_module`.)"""
    if cls not in _DECLARED:
        _DECLARED.append(cls)
    return cls


def declared_scenarios() -> tuple[type[Scenario], ...]:
    """The scenario kinds this package's modules declare (for its registration hook)."""
    return tuple(_DECLARED)


def scenario_kinds() -> dict[str, type[Scenario]]:
    """Every registered scenario kind (the core's and other packages'), by name."""
    return {n: registry.get("scenario", n) for n in registry.names("scenario")}


#: Cross-field rules that hold in every scenario having both fields: (smaller, larger, strict).
ORDERED_FIELDS = (
    ("settle_s", "duration_s", True),
    ("coherent_time_s", "duration_s", True),
    ("lock_window_s", "duration_s", True),
    ("settle_epochs", "epochs", True),
    ("convergence_window", "epochs", True),
    ("slip_min_cycles", "slip_max_cycles", False),
)


def _check_ordered_fields(params: BaseModel, prefix: str) -> None:
    for small, large, strict in ORDERED_FIELDS:
        a, b = getattr(params, small, None), getattr(params, large, None)
        if a is None or b is None:
            continue
        if (a >= b) if strict else (a > b):
            relation = "less than" if strict else "at most"
            raise ConfigError(f"{prefix}.{small}", f"must be {relation} {large} = {b!r} (got {a!r})")


def get_scenario(config: dict[str, Any]) -> Scenario:
    """Instantiate the scenario named by ``config["kind"]`` with the other keys as parameters."""
    kind = config.get("kind")
    kinds = registry.names("scenario")
    if kind not in kinds:
        raise ConfigError(
            "scenario.kind", f"got {kind!r}; allowed: {', '.join(kinds)}{did_you_mean(str(kind), kinds, cutoff=0.4)}"
        )
    cls: type[Scenario] = registry.get("scenario", kind)
    try:
        params = cls.Params.model_validate({k: v for k, v in config.items() if k != "kind"})
    except ValidationError as exc:
        raise validation_message(exc, prefix="scenario", model=cls.Params) from None
    _check_ordered_fields(params, "scenario")
    return cls(params)
