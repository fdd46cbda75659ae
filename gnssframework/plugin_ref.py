"""Typed references to nested plugins: a parameter whose value is another plugin.

A plugin that uses other plugins (``iq-filter.estimator``, ``discriminator.code_discriminator``
...) declares the parameter as ``PluginRef(kind, ...)``. In a config it takes a name or a
``{name, params}`` table::

    estimator = "ckf"
    estimator = { name = "ukf", params = { alpha = 0.5 } }

and is resolved and validated when the config is loaded: an unknown name is refused with
the field path, the known names and the closest one; the nested parameters are validated
by the nested plugin's own model; a unit or capability that does not fit (a frequency
discriminator given as ``phase_discriminator``) is refused naming the plugins that fit.

Examples
--------
>>> from gnssframework.plugin import PluginParams
>>> class P(PluginParams):
...     estimator: PluginRef("estimator") = "kf"
>>> P().estimator
PluginSpec(kind='estimator', name='kf', params={})
>>> P(estimator={"name": "ukf", "params": {"alpha": 0.5}}).estimator.create().params.alpha
0.5
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Annotated, Any
from collections.abc import Callable

import numpy as np
from pydantic import BeforeValidator, PlainSerializer, ValidationError, WithJsonSchema

from . import registry
from .errors import ConfigError
from .plugin import NestedFieldError, validation_message
from .plugin_ref_rules import RefRule, misfit, plugin_ref_constraints, plugin_refs
from .suggest import did_you_mean

__all__ = [
    "PluginSpec",
    "PluginRef",
    "ComponentRef",
    "component_spec",
    "plugin_refs",
    "plugin_ref_constraints",
    "handles_nonlinear",
]


def handles_nonlinear(cls: type) -> str:
    """``check`` for an estimator that will see a nonlinear model: refuses one that
    declares ``linear_only = True`` (the linear Kalman filter)."""
    return (
        "it is linear-only (linear_only = True) and this model is nonlinear"
        if getattr(cls, "linear_only", False)
        else ""
    )


handles_nonlinear.label = "handles nonlinear models (not linear-only)"  # type: ignore[attr-defined]


@dataclass(frozen=True)
class PluginSpec:
    """A resolved plugin reference: kind, registered name and validated parameters."""

    kind: str
    name: str
    params: dict[str, Any] = field(default_factory=dict)

    def __hash__(self) -> int:
        return hash((self.kind, self.name, tuple(sorted(map(str, self.params.items())))))

    def table(self) -> dict[str, Any]:
        """The reference as a config writes it: ``{"name": ..., "params": {...}}``."""
        return {"name": self.name, "params": dict(self.params)}

    @property
    def cls(self) -> type[Any]:
        """The registered plugin class."""
        return registry.get(self.kind, self.name)

    def create(self, defaults: dict[str, Any] | None = None, **owned: Any) -> Any:
        """Instantiate the plugin with its parameters.

        Parameters
        ----------
        defaults
            Values the owner suggests (an adapter's window...); the reference's own
            parameters override them. Those the plugin does not take are dropped.
        **owned
            Values the owner fixes because its harness owns them (``coherent_time_s``,
            ``early_late_spacing_chips`` ...); those the plugin does not take are dropped.
            A parameter of the reference that repeats one must equal it.

        Raises
        ------
        ConfigError
            If the reference sets an owned value to something else, naming the parameter.
        """
        cls = self.cls
        fields = cls.Params.model_fields
        for key, value in owned.items():
            if key in fields and key in self.params and not _same(self.params[key], value):
                raise ConfigError(
                    f"{self.kind} {self.name!r}.{key}",
                    f"is {self.params[key]!r} but its owner runs "
                    f"with {value!r} (the harness's value); leave the parameter out",
                )
        chosen = {k: v for k, v in (defaults or {}).items() if k in fields}
        return cls(**{**chosen, **self.params, **{k: v for k, v in owned.items() if k in fields}})


def _same(a: Any, b: Any) -> bool:
    try:
        return bool(np.allclose(a, b, rtol=1e-12, atol=0))
    except (TypeError, ValueError):
        return bool(a == b)


def _names_that_fit(rule: RefRule) -> list[str]:
    return [n for n in registry.names(rule.kind) if not misfit(rule, registry.get(rule.kind, n))]


def _article(word: str) -> str:
    return "an" if word[:1] in "aeiou" else "a"


def _resolve(rule: RefRule, value: Any) -> PluginSpec:
    # Raise ValueError (not ConfigError) so pydantic attaches the field path.
    if isinstance(value, PluginSpec):
        return value
    if isinstance(value, str):
        name, params = value, {}
    elif isinstance(value, dict):
        extra = sorted(set(value) - {"name", "params"})
        if extra or "name" not in value:
            hint = (
                f"; plugin parameters go under `params`: {{ name = ..., params = {{ {extra[0]} = ... }} }}"
                if extra and "name" in value
                else ""
            )
            raise ValueError(
                f"{_article(rule.kind)} {rule.kind} reference is a name or {{ name, params }}, "
                f"got keys {sorted(value)}{hint}"
            )
        name, params = value["name"], dict(value.get("params") or {})
    else:
        raise ValueError(f"{_article(rule.kind)} {rule.kind} reference is a name or {{ name, params }}, got {value!r}")
    known = registry.names(rule.kind)
    if name not in known:
        hint = did_you_mean(name, known, cutoff=0.4)
        raise ValueError(f"unknown {rule.kind} {name!r}; known: {', '.join(known) or '(none)'}{hint}")
    cls = registry.get(rule.kind, name)
    why = misfit(rule, cls)
    if why:
        raise ValueError(
            f"{rule.kind} {name!r} does not fit: {why}; {rule.kind}s that do: "
            f"{', '.join(_names_that_fit(rule)) or '(none registered)'}"
        )
    try:
        cls.Params(**params)
    except ValidationError as exc:
        inner = validation_message(exc, prefix="params", model=cls.Params)
        raise NestedFieldError(inner.field, inner.detail) from None
    return PluginSpec(rule.kind, name, params)


def PluginRef(
    kind: str, *, unit: str | None = None, provides: tuple[str, ...] = (), check: Callable[[type], str] | None = None
) -> Any:  # noqa: N802 - reads as a type
    """The type of a parameter that names a nested plugin of ``kind``.

    Parameters
    ----------
    kind
        Registry kind of the nested plugin (``"estimator"``, ``"discriminator"`` ...).
    unit
        Required ``unit`` of the nested plugin (discriminators: ``"chips"``, ``"rad"``, ``"Hz"``).
    provides
        Names the nested plugin must list in its ``provides``.
    check
        Extra capability test: returns why a class does not fit, or ``""``.
    """
    rule = RefRule(kind, unit, tuple(provides), check)
    what = f"a {kind} plugin" + (f" with unit {unit!r}" if unit else "")
    schema = {
        "description": f"{what}: its name, or {{name, params}}",
        "anyOf": [
            {"type": "string"},
            {
                "type": "object",
                "required": ["name"],
                "additionalProperties": False,
                "properties": {"name": {"type": "string"}, "params": {"type": "object"}},
            },
        ],
    }
    # PluginParams validates defaults, so a default written as a name is resolved too.
    return Annotated[PluginSpec, BeforeValidator(lambda v: _resolve(rule, v)), WithJsonSchema(schema), rule]


def _component(kind: str, value: Any) -> PluginSpec:
    """A candidate's plugin of ``kind``: a name or ``{name, params}``, the name known to the
    registry (its parameters are validated with the candidate, naming their path)."""
    if isinstance(value, PluginSpec):
        return value
    if isinstance(value, str):
        value = {"name": value}
    if not isinstance(value, dict):
        raise ValueError(f"{_article(kind)} {kind} is a name or {{ name, params }}, got {value!r}")
    extra = sorted(set(value) - {"name", "params"})
    if extra:
        raise NestedFieldError(
            extra[0],
            "unknown parameter; valid: name, params; plugin parameters go under "
            f"`params`: {{ name = ..., params = {{ {extra[0]} = ... }} }}",
        )
    if not isinstance(value.get("name"), str):
        raise NestedFieldError("name", f"required: the registered name of {_article(kind)} {kind}")
    params = value.get("params") or {}
    if not isinstance(params, dict):
        raise NestedFieldError("params", f"must be a table of the plugin's parameters, got {params!r}")
    try:
        registry.get(kind, value["name"])
    except ConfigError as exc:
        raise NestedFieldError("name", exc.detail) from None
    return PluginSpec(kind, value["name"], dict(params))


def component_spec(kind: str, value: Any) -> PluginSpec:
    """A candidate's plugin of ``kind`` as a `PluginSpec`, from a spec, a name or a
    ``{name, params}`` table (as `ComponentRef` reads a config).

    Raises
    ------
    ConfigError
        Naming ``<kind>.name`` for an unknown plugin, or the malformed part of the table.
    """
    try:
        return _component(kind, value)
    except NestedFieldError as exc:
        raise ConfigError(f"{kind}.{exc.field}", exc.detail) from None
    except ValueError as exc:
        raise ConfigError(kind, str(exc)) from None


def ComponentRef(kind: str) -> Any:  # noqa: N802 - reads as a type
    """The type of a comparison candidate's plugin of ``kind``: a `PluginSpec` written as a
    name or ``{name, params}`` (and dumped back that way). Unlike `PluginRef`, the
    parameters are left to the candidate's check, which names their config path.

    A type checker cannot read a call as a type; a module checked by one writes the same
    type as ``Annotated[PluginSpec, *component_metadata(kind)]``."""
    return Annotated[PluginSpec, *component_metadata(kind)]


def component_metadata(kind: str) -> tuple[Any, ...]:
    """The pydantic metadata of `ComponentRef` (its validator, serializer and JSON schema)."""
    schema = {
        "description": f"a {kind} plugin: its name, or {{name, params}}",
        "anyOf": [
            {"type": "string"},
            {
                "type": "object",
                "required": ["name"],
                "additionalProperties": False,
                "properties": {"name": {"type": "string"}, "params": {"type": "object"}},
            },
        ],
    }
    return (BeforeValidator(lambda v: _component(kind, v)), PlainSerializer(PluginSpec.table), WithJsonSchema(schema))


def _as_config(value: Any) -> Any:
    """A plugin's dumped parameters as config input again (nested references without 'kind')."""
    if isinstance(value, dict):
        if {"kind", "name", "params"} <= set(value):
            return {"name": value["name"], "params": _as_config(value["params"])}
        return {k: _as_config(v) for k, v in value.items()}
    return value


def recreated(plugin: Any, **changes: Any) -> Any:
    """``plugin`` created again from its registry entry with ``changes`` to its parameters
    (its other parameters as they are): a loop at another interval ``coherent_time_s``,
    say. A new object, validated like any other; ``plugin`` itself is left alone."""
    params = _as_config(plugin.params.model_dump(mode="json"))
    return registry.create(plugin.kind, plugin.name, **{**params, **changes})
