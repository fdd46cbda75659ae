"""Generate docs/api/plugin-parameters.md: every built-in plugin's parameter table,
from its ``Params`` (gnssframework.plugin_docs), nested plugin references included.

    python docs/gen_plugin_parameters.py

The page is committed; tests/project/test_docs.py fails when it is out of date.
"""

from __future__ import annotations

import pathlib

from gnssframework import registry
from gnssframework.plugin_docs import parameter_table

OUT = pathlib.Path(__file__).resolve().parent / "api" / "plugin-parameters.md"


def render() -> str:
    lines = [
        "# Plugin parameters",
        "",
        "Generated from each plugin's `Params` by `docs/gen_plugin_parameters.py`; the same",
        "table is in the class's `help()` and in `gnssframework plugins --describe NAME`.",
        "A parameter of type *kind plugin* takes a name or `{ name, params }` and is",
        "validated when the config is loaded (see",
        "[From a registered plugin to a comparison](../tutorial/from-plugin-to-comparison.md)).",
        "",
    ]
    for info in registry.describe():
        if info.distribution != "gnssframework" or info.kind == "scenario":
            continue
        lines += [f"## {info.kind} `{info.name}`", "", info.description, "", parameter_table(info.cls.Params), ""]
    return "\n".join(lines)


if __name__ == "__main__":
    OUT.write_text(render())
    print(f"wrote {OUT}")
