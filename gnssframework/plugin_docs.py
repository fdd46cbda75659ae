"""A plugin's parameter table, generated from its ``Params`` model.

One source for the docs page, ``help()`` (appended to the class docstring),
``gnssframework plugins --describe NAME`` and the JSON schema.

Examples
--------
>>> from gnssframework import registry
>>> rows = parameter_rows(registry.get("estimator", "ukf").Params)
>>> [(r.name, r.default, r.bounds) for r in rows if r.name == "alpha"]
[('alpha', '0.001', '> 0')]
"""

from __future__ import annotations

import typing
from dataclasses import dataclass
from typing import Any
from collections.abc import Iterable

from pydantic import BaseModel
from pydantic_core import PydanticUndefined

from .plugin_ref_rules import plugin_ref_constraints, plugin_refs

__all__ = ["ParameterRow", "parameter_rows", "parameter_table", "describe_plugin", "nested_plugins_table"]

_BOUNDS = (
    ("gt", ">"),
    ("ge", ">="),
    ("lt", "<"),
    ("le", "<="),
    ("min_length", "length >="),
    ("max_length", "length <="),
)


@dataclass(frozen=True)
class ParameterRow:
    """One parameter: name, type, default, bounds and description, as text."""

    name: str
    type: str
    default: str
    bounds: str
    description: str


def _type_name(annotation: Any, refs: dict[str, tuple[str, str | None]], name: str) -> str:
    if name in refs:
        kind, unit = refs[name]
        optional = type(None) in typing.get_args(annotation)
        return f"{kind} plugin" + (f" ({unit})" if unit else "") + (" or null" if optional else "")
    text = getattr(annotation, "__name__", None) if isinstance(annotation, type) else None
    return text or str(annotation).replace("typing.", "")


def _default_text(value: Any, is_ref: bool = False) -> str:
    if value is PydanticUndefined:
        return "(required)"
    if is_ref and hasattr(value, "kind") and hasattr(value, "name"):  # a resolved PluginSpec: its name
        return str(value.name)
    return repr(value) if isinstance(value, str) else str(value)


def parameter_rows(params_model: type[BaseModel]) -> list[ParameterRow]:
    """The rows of a ``Params`` model's parameter table, in declaration order."""
    refs = plugin_refs(params_model)
    rows = []
    for name, info in params_model.model_fields.items():
        bounds = []
        for meta in info.metadata:
            for attr, symbol in _BOUNDS:
                value = getattr(meta, attr, None)
                if value is not None:
                    bounds.append(f"{symbol} {value}")
        literal = (
            [a for a in typing.get_args(info.annotation)]
            if typing.get_origin(info.annotation) is typing.Literal
            else []
        )
        if literal:
            bounds.append("one of " + ", ".join(map(repr, literal)))
        python = f" (Python keyword: {name})" if info.alias else ""  # a config name like `lambda`
        rows.append(
            ParameterRow(
                info.alias or name,
                _type_name(info.annotation, refs, name),
                _default_text(info.default, name in refs),
                ", ".join(bounds),
                (info.description or "") + python,
            )
        )
    return rows


def _cell(text: str) -> str:
    """A table cell: a bare ``|`` (``float | list[float]``) would split the row."""
    return text.replace("|", "\\|")


def parameter_table(params_model: type[BaseModel]) -> str:
    """The parameter table as Markdown (also readable as plain text in ``help()``)."""
    rows = parameter_rows(params_model)
    if not rows:  # say why, where the plugin's Params does (`PluginParams.no_parameters`)
        why = getattr(params_model, "no_parameters", "")
        return f"(no parameters: {why})" if why else "(no parameters)"
    out = ["| name | type | default | bounds | description |", "|---|---|---|---|---|"]
    cell = _cell
    out += [
        f"| `{r.name}` | {cell(r.type)} | `{cell(r.default)}` | {cell(r.bounds)} | {cell(r.description)} |"
        for r in rows
    ]
    return "\n".join(out)


def describe_plugin(kind: str, cls: type) -> str:
    """What ``gnssframework plugins --describe NAME`` prints for one plugin."""
    name = getattr(cls, "name", "") or getattr(cls, "kind", "")
    lines = [f"{kind} {name!r} ({cls.__module__}.{cls.__qualname__})"]
    text = getattr(cls, "description", "") or ""
    if text:
        lines.append(text.strip())
    for attr in ("unit", "needs_previous", "requires", "provides"):
        value = getattr(cls, attr, None)
        if value not in (None, "", ()):
            lines.append(f"{attr}: {', '.join(value) if isinstance(value, tuple) else value}")
    params = getattr(cls, "Params", None)
    if isinstance(params, type) and issubclass(params, BaseModel):
        lines += ["", "Parameters:", parameter_table(params)]
    return "\n".join(lines)


def nested_plugins_table(plugins: Iterable[Any], distribution: str | None = "gnssframework") -> str:
    """Markdown table of the plugins that take nested plugins: plugin, kind, each nested
    parameter with its default and what it demands (generated, so the docs cannot fall
    behind the code). ``plugins`` are ``registry.describe()``'s entries; ``distribution``
    limits it to one package (``None``: all)."""
    lines = ["| plugin | kind | nested parameter | default | takes |", "|---|---|---|---|---|"]
    for info in plugins:
        if distribution is not None and info.distribution != distribution:
            continue
        params = info.cls.Params
        for field, demand in plugin_ref_constraints(params).items():
            default = params.model_fields[field].default
            default = "null" if default is None else getattr(default, "name", default)  # a PluginSpec: its name
            lines.append(f"| `{info.name}` | {info.kind} | `{field}` | `{default}` | {demand} |")
    return "\n".join(lines)
