"""A comparison's candidates resolved once: validated plugin specs, built where they run.

`resolve_candidate` is the one place a candidate of a config becomes a `CandidatePlan`
(its plugins' `gnssframework.plugin_ref.PluginSpec` by kind and its scenario options),
checked against the scenario: required and foreign kinds, every plugin created with its
parameters, the composition, the contexts the harness will run it in. The config resolves
its candidates with it when it is loaded (and so every sweep point and tuning trial,
each a validated config); the run plan carries the results to the workers, the sweeps
and the tuner read the plugins' parameter models from them, and `build_candidate`
creates fresh plugins from them for a batch or the report.
"""

from __future__ import annotations

import inspect
from dataclasses import dataclass
from typing import Any
from collections.abc import Sequence

from ..plugin_ref import PluginSpec
from .scenarios import Scenario

__all__ = ["CandidatePlan", "resolve_candidate", "build_candidate"]


@dataclass(frozen=True)
class CandidatePlan:
    """One resolved candidate: its name, its plugins' specs by kind and its scenario options."""

    name: str
    components: dict[str, PluginSpec]
    scenario_options: dict[str, Any]


def resolve_candidate(scenario: Scenario, candidate: Any, cases: Sequence[dict[str, Any]], where: str) -> CandidatePlan:
    """Check a config's candidate (``name``, ``components()``, ``scenario_options``) against
    ``scenario`` over the cases' parameters ``cases``, and resolve it.

    Raises
    ------
    ConfigError
        Naming the field under ``where`` (``candidates[i]``) that the scenario refuses.
    """
    specs = dict(candidate.components())
    plugins = scenario.check_candidate(specs, where, candidate.scenario_options)
    scenario.check_contexts(plugins, list(cases), where)
    return CandidatePlan(candidate.name, specs, dict(candidate.scenario_options))


def build_candidate(scenario: Scenario, candidate: CandidatePlan, case: dict[str, Any] | None = None) -> dict[str, Any]:
    """Fresh plugins of a resolved candidate, as ``scenario.run_batch`` takes them
    (`Scenario.build`, with what the scenario adds for its options; built for ``case``,
    a task's, when given: each plugin once, with the parameters the case sets)."""
    if case is None or not _takes_case(scenario.build):  # a scenario written before build took the case
        return scenario.build(candidate.components, candidate.scenario_options)
    return scenario.build(candidate.components, candidate.scenario_options, case=case)


def _takes_case(build: Any) -> bool:
    try:
        return "case" in inspect.signature(build).parameters
    except (TypeError, ValueError):
        return False
