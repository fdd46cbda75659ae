"""The import circles this package had between the registry, plugin references and their
docs, and inside the experiments layer, stay broken: no module of either group imports,
even inside a function, one that imports it back."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import gnssframework as gf

ROOT = Path(gf.__file__).parent.parent
GROUPS = {
    "registry": ["registry", "plugin_ref", "plugin_ref_rules", "plugin_docs", "plugin"],
    "experiments": ["experiments.config", "experiments.sweeps", "experiments.tuning", "experiments.tasks",
                    "experiments.run_plan", "experiments.report", "experiments.runner", "experiments.store",
                    "experiments.claims", "experiments.files", "experiments.folder"],
}


def _imports(module: str) -> set[str]:
    """gnssframework modules that ``module`` imports anywhere in its source."""
    path = ROOT / "gnssframework" / (module.replace(".", "/") + ".py")
    package = ["gnssframework", *module.split(".")[:-1]]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom):
            base = package[:len(package) - node.level + 1] if node.level else []
            target = ".".join(base + ([node.module] if node.module else []))
            found.update(f"{target}.{a.name}" for a in node.names)
            found.add(target)
        elif isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
    return {m[len("gnssframework."):] for m in found if m.startswith("gnssframework.")}


@pytest.mark.parametrize("group", sorted(GROUPS))
def test_no_circle_within_the_group(group):
    members = GROUPS[group]
    edges = {m: _imports(m) & set(members) - {m} for m in members}

    def reaches(start: str, goal: str, seen: set[str]) -> bool:
        return any(n == goal or (n not in seen and reaches(n, goal, seen | {n})) for n in edges[start])

    circles = sorted(m for m in members if reaches(m, m, {m}))
    assert circles == [], f"modules on an import circle: {circles} (edges: {edges})"
