"""`gnssframework.estimation` knows nothing of GNSS and its modules import in one direction.

Read from the source (every ``import`` statement, the ones inside functions included),
so the rule stays true as the package grows: the estimation layer may use the framework's
errors, plugin base and backend switch, and itself; nothing of signal, receiver,
navigation, simulation, experiments or the plugins. Within the package the imports
form no circle.
"""

from __future__ import annotations

import ast
from pathlib import Path

import gnssframework.estimation as estimation

PACKAGE = Path(estimation.__file__).parent
#: The framework modules outside the package that it may import.
ALLOWED_OUTSIDE = {"gnssframework.errors", "gnssframework.plugin", "gnssframework.backend"}
#: Packages whose ``from P import name`` names a module (or a name of the package itself).
PACKAGES = {"gnssframework"} | {_p for _p in (
    ".".join(["gnssframework", *init.relative_to(PACKAGE.parent).parent.parts]) for init in PACKAGE.rglob("__init__.py"))}


def _module_name(path: Path) -> str:
    rel = path.relative_to(PACKAGE.parent).with_suffix("")
    parts = ["gnssframework", *rel.parts]
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(path: Path) -> set[str]:
    """Framework modules ``path`` imports (``from . import x`` as ``package.x``)."""
    name = _module_name(path)
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names if a.name.split(".")[0] in ("gnssframework", "gnssframework_plugins"))
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.rsplit(".", node.level - 1)[0] if node.level > 1 else package
                target = f"{base}.{node.module}" if node.module else base
            else:
                target = node.module or ""
            if target.split(".")[0] not in ("gnssframework", "gnssframework_plugins"):
                continue
            if target in PACKAGES:  # from .. import backend: the modules named
                found.update(f"{target}.{a.name}" for a in node.names)
            else:
                found.add(target)
    return found


def _graph() -> dict[str, set[str]]:
    return {_module_name(p): _imports(p) for p in sorted(PACKAGE.rglob("*.py"))}


def test_estimation_imports_nothing_gnss_specific():
    outside = {(mod, dep) for mod, deps in _graph().items() for dep in deps
               if not dep.startswith("gnssframework.estimation") and dep not in ALLOWED_OUTSIDE}
    assert outside == set()


def test_estimation_modules_import_in_one_direction():
    graph = _graph()
    # A package's __init__ only re-exports its modules: the modules carry the direction.
    inside = {mod: {d for d in deps if d in graph and d not in PACKAGES}
              for mod, deps in graph.items() if mod not in PACKAGES}
    # Depth-first search for a back edge: any circle shows as the path that closes it.
    state: dict[str, int] = {}
    circles = []

    def visit(mod: str, path: list[str]) -> None:
        state[mod] = 1
        for dep in sorted(inside.get(mod, ())):
            if state.get(dep) == 1:
                circles.append(path[path.index(dep):] + [dep] if dep in path else [mod, dep])
            elif dep not in state:
                visit(dep, path + [dep])
        state[mod] = 2

    for mod in sorted(inside):
        if mod not in state:
            visit(mod, [mod])
    assert circles == []
