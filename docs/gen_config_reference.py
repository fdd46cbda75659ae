"""Generate docs/experiments/config-reference.md from the config's JSON schema.

    python docs/gen_config_reference.py

The page is committed; tests/project/test_docs.py fails when it is out of date.
"""

from __future__ import annotations

import json
import pathlib

from gnssframework.experiments import ComparisonConfig, get_scenario
from gnssframework.experiments.scenarios import declared_scenarios

OUT = pathlib.Path(__file__).resolve().parent / "experiments" / "config-reference.md"


def _type(prop: dict) -> str:
    if "$ref" in prop:
        return prop["$ref"].split("/")[-1]
    if "anyOf" in prop:
        return " or ".join(_type(p) for p in prop["anyOf"])
    if prop.get("type") == "array":
        return f"list of {_type(prop.get('items', {}))}"
    if "enum" in prop:
        return " / ".join(json.dumps(v) for v in prop["enum"])
    if "const" in prop:
        return json.dumps(prop["const"])
    return prop.get("type", "any")


def _table(schema: dict) -> list[str]:
    rows = ["| field | type | default | description |", "| --- | --- | --- | --- |"]
    required = set(schema.get("required", []))
    for name, prop in schema.get("properties", {}).items():
        default = "required" if name in required else json.dumps(prop.get("default")) if "default" in prop else ""
        bounds = [f"{k} {prop[k]}" for k in ("minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum") if k in prop]
        desc = prop.get("description", "") + (f" ({', '.join(bounds)})" if bounds else "")
        rows.append(f"| `{name}` | {_type(prop)} | {default} | {desc} |")
    return rows


def render() -> str:
    schema = ComparisonConfig.model_json_schema()
    lines = [
        "# Config reference",
        "",
        "Generated from the JSON schema (`gnssframework schema`) by `docs/gen_config_reference.py`.",
        "",
        "## ComparisonConfig (the file)",
        "",
        "A file may also hold a `[base]` table (`file`, `drop`, `drop_candidates`, `drop_cases`, `extend`):",
        "it is then laid over that other config, as [Comparisons](index.md#a-config-built-on-another-base)",
        "says; the fields below are those of the config it resolves to.",
        "",
    ] + _table(schema)
    for name, sub in sorted(schema.get("$defs", {}).items()):
        lines += ["", f"## {name}", ""]
        if sub.get("description"):
            lines += [sub["description"].strip(), ""]
        lines += _table(sub)
    lines += [
        "",
        "## Scenario kinds",
        "",
        "`scenario.kind` selects one; the other keys of `[scenario]` are its parameters, and each",
        "`[[cases]]` entry has a `name` plus the case parameters.",
    ]
    for kind in sorted(cls.kind for cls in declared_scenarios()):
        scen = get_scenario({"kind": kind})
        lines += [
            "",
            f"### `{kind}`",
            "",
            (type(scen).__doc__ or "").strip().splitlines()[0],
            "",
            "Candidates compose: "
            + ", ".join(f"`{k}` ({'required' if r else 'optional'})" for k, r in scen.components.items())
            + ".",
            "",
            "Metrics: " + ", ".join(f"`{m}` ({u})" for m, u in scen.metrics.items()) + ".",
            "",
            "Scenario parameters:",
            "",
        ] + _table(scen.Params.model_json_schema())
        lines += ["", "Case parameters:", ""] + _table(scen.CaseParams.model_json_schema())
        if scen.CandidateOptions.model_fields:
            lines += ["", "Candidate options (`scenario_options`):", ""] + _table(
                scen.CandidateOptions.model_json_schema()
            )
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    OUT.write_text(render())
    print(f"wrote {OUT}")
