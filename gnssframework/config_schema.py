"""The comparison config's JSON schema, with each plugin's parameters checked against its name.

``ComparisonConfig.model_json_schema()`` knows a candidate's components only as
``{name, params}``; this schema replaces each component by one branch per registered
plugin of that kind, ``{name: const, params: <the plugin's Params schema>}``, so an
editor or a JSON-schema validator refuses an unknown name or a bad parameter.
"""

from __future__ import annotations

import copy
from typing import TYPE_CHECKING, Any

from . import registry
from .hookspecs import COMPONENT_KINDS

if TYPE_CHECKING:
    from .plugin import Plugin

__all__ = ["comparison_schema", "plugin_ref_schema"]


def _params_schema(cls: type[Plugin]) -> dict[str, Any]:
    schema = copy.deepcopy(cls.Params.model_json_schema())
    schema.pop("title", None)
    return schema


def plugin_ref_schema(kind: str) -> dict[str, Any]:
    """``{name, params}`` of any registered plugin of ``kind``, params checked by name, or
    its bare name."""
    branches: list[dict[str, Any]] = [{"enum": registry.names(kind)}] if registry.names(kind) else []
    for name in registry.names(kind):
        params = _params_schema(registry.get(kind, name))
        branches.append(
            {
                "type": "object",
                "additionalProperties": False,
                "required": ["name"],
                "properties": {"name": {"const": name}, "params": params},
            }
        )
    return {"oneOf": branches, "description": f"a {kind} plugin: its name, or {{name, params}}"}


def comparison_schema() -> dict[str, Any]:
    """The JSON schema printed by ``gnssframework schema``."""
    from .experiments import ComparisonConfig

    schema = ComparisonConfig.model_json_schema()
    candidate = schema["$defs"]["Candidate"]
    for kind in COMPONENT_KINDS:
        if kind in candidate["properties"]:
            prop = candidate["properties"][kind]
            prop.pop("anyOf", None)
            prop.pop("$ref", None)
            prop["anyOf"] = [plugin_ref_schema(kind), {"type": "null"}]
    sweep = schema["$defs"].get("Sweep")
    if sweep is not None:  # a list of values, or a range with exactly one of step and num
        sweep["oneOf"] = [
            {"required": ["values"], "not": {"anyOf": [{"required": [k]} for k in ("start", "stop", "step", "num")]}},
            {"required": ["start", "stop", "step"], "not": {"required": ["num"]}},
            {"required": ["start", "stop", "num"], "not": {"required": ["step"]}},
        ]
    names = {"type": "array", "items": {"type": "string"}}
    schema["properties"]["base"] = {  # read by `experiments.config_base`, before the model
        "type": "object",
        "additionalProperties": False,
        "required": ["file"],
        "properties": {
            "file": {"type": "string"},
            "drop": names,
            "drop_candidates": names,
            "drop_cases": names,
            "extend": names,
        },
        "description": "another config this one is laid over (its path relative to this file); the other "
        "fields then hold what differs",
    }
    return schema
