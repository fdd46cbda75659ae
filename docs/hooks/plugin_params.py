"""mkdocs hook: put each plugin's parameter table on its own page.

A page that documents a plugin class with a mkdocstrings directive
(``::: plugins.estimators.KalmanFilter``) gets, after the directive and its options,
the class's parameter table generated from its ``Params`` by
``gnssframework.plugin_docs.parameter_table`` (the same table as ``help()``,
``gnssframework plugins --describe NAME`` and docs/api/plugin-parameters.md), with the
plugin's kind, registry name and contract. mkdocstrings reads the source statically, so
the table appended to ``__doc__`` at registration would not reach the page otherwise.
"""

from __future__ import annotations

import re

from gnssframework import registry
from gnssframework.plugin_docs import nested_plugins_table, parameter_table

#: A line that a page holds where the generated table of nested-plugin parameters goes.
NESTED_MARKER = "<!-- nested-plugins-table -->"

_DIRECTIVE = re.compile(r"^::: plugins\.(?P<module>[\w.]+)\.(?P<cls>\w+)\s*$")


def _plugins_by_path() -> dict[tuple[str, str], object]:
    out = {}
    for info in registry.describe():
        module = info.cls.__module__
        if module.startswith("gnssframework_plugins."):
            out[(module.removeprefix("gnssframework_plugins."), info.cls.__qualname__)] = info
    return out


def plugin_section(info) -> str:
    """The Markdown added under a plugin's directive."""
    cls = info.cls
    lines = [
        "",
        f"## Parameters of `{info.name}`",
        "",
        f"Plugin kind `{info.kind}`, registry name `{info.name}`; generated from `{cls.__qualname__}.Params`.",
    ]
    for attr in ("unit", "requires", "provides"):
        value = getattr(cls, attr, None)
        if value not in (None, "", ()):
            text = ", ".join(f"`{v}`" for v in value) if isinstance(value, tuple) else f"`{value}`"
            lines.append(f"`{attr}`: {text}.")
    lines += ["", parameter_table(cls.Params), ""]
    return "\n".join(lines)


def on_page_markdown(markdown: str, page, config, files) -> str:
    if NESTED_MARKER in markdown:
        markdown = markdown.replace(NESTED_MARKER, nested_plugins_table(registry.describe()))
    plugins = _plugins_by_path()
    lines = markdown.split("\n")
    out: list[str] = []
    i = 0
    while i < len(lines):
        line = lines[i]
        out.append(line)
        i += 1
        match = _DIRECTIVE.match(line)
        if not match:
            continue
        while i < len(lines) and (lines[i].startswith(" ") or lines[i].startswith("\t")):
            out.append(lines[i])  # the directive's options block
            i += 1
        info = plugins.get((match["module"], match["cls"]))
        if info is not None:
            out.append(plugin_section(info))
    return "\n".join(out)
