"""What a nested-plugin parameter demands: the rule a ``PluginRef`` annotation carries
(kind, unit, capabilities, extra check), and reading those rules off a ``Params`` model.

Pure introspection, below both the registry (whose parameter tables show the rules) and
:mod:`gnssframework.plugin_ref` (which resolves references through the registry).
"""

from __future__ import annotations

import typing
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any
from collections.abc import Callable

if TYPE_CHECKING:
    from pydantic import BaseModel

__all__ = ["RefRule", "field_rules", "misfit", "plugin_refs", "plugin_ref_constraints"]


@dataclass(frozen=True)
class RefRule:
    """What a nested-plugin parameter takes: a plugin of ``kind``, of ``unit`` (if set),
    listing every name of ``provides``, and passing ``check`` (returns why not, or ``""``)."""

    kind: str
    unit: str | None
    provides: tuple[str, ...]
    check: Callable[[type], str] | None


def misfit(rule: RefRule, cls: type) -> str:
    """Why ``cls`` does not fit ``rule`` ("" if it does)."""
    if rule.unit is not None and getattr(cls, "unit", None) != rule.unit:
        return f"its unit is {getattr(cls, 'unit', None)!r}, this parameter needs {rule.unit!r}"
    missing = [p for p in rule.provides if p not in getattr(cls, "provides", ())]
    if missing:
        return f"it does not provide {', '.join(missing)}"
    return rule.check(cls) if rule.check is not None else ""


def field_rules(params_model: type[BaseModel]) -> dict[str, RefRule]:
    """The nested-plugin parameters of a ``Params`` model: field -> its rule."""

    def rules(obj: Any) -> list[RefRule]:
        found = [m for m in getattr(obj, "__metadata__", ()) if isinstance(m, RefRule)]
        for arg in typing.get_args(obj):
            found += rules(arg)
        return found

    out = {}
    for fname, info in params_model.model_fields.items():
        found = [m for m in info.metadata if isinstance(m, RefRule)] + rules(info.annotation)
        if found:
            out[fname] = found[0]
    return out


def plugin_refs(params_model: type[BaseModel]) -> dict[str, tuple[str, str | None]]:
    """The nested-plugin parameters of a ``Params`` model: field -> (kind, unit)."""
    return {f: (r.kind, r.unit) for f, r in field_rules(params_model).items()}


def plugin_ref_constraints(params_model: type) -> dict[str, str]:
    """What each nested-plugin parameter of ``params_model`` demands, in words
    (``"discriminator, unit 'chips'"``, ``"estimator, handles nonlinear models"``)."""
    out = {}
    for fname, rule in field_rules(params_model).items():
        parts = [rule.kind]
        if rule.unit:
            parts.append(f"unit {rule.unit!r}")
        if rule.provides:
            parts.append(f"provides {', '.join(rule.provides)}")
        if rule.check is not None:
            parts.append(getattr(rule.check, "label", rule.check.__name__.replace("_", " ")))
        out[fname] = ", ".join(parts)
    return out
