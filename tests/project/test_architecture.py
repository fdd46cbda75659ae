"""The import graph of ``gnssframework`` keeps the architecture of docs/design-notes.md.

Every ``import`` of every module counts, at module level or inside a function (a lazy
import is still a dependency), and so do the imports a module hides from the ``import``
statement: ``importlib.import_module("gnssframework....")`` (or ``__import__``) of a
literal name, and a literal ``"gnssframework.module:Class"`` string (what a loader imports
by name). The rules:

* no import circle;
* no arrow from a lower layer (`LAYERS`) to a higher one, and every module in a layer;
* the core never imports the built-in plugins (``gnssframework_plugins``);
* ``estimation`` imports nothing GNSS-specific: only itself and `ESTIMATION_MAY_IMPORT`;
* no module of ``receiver`` is over `RECEIVER_MAX_LINES` lines (issue 36).

A failure prints the offending import chain, each arrow with its file and line.
"""

from __future__ import annotations

import ast
import re
from dataclasses import dataclass, field
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = "gnssframework"

#: The layers, lowest first: a module may import its own layer and the layers below.
#: An entry is a package (with everything under it) or a module; the root package
#: itself (``gnssframework/__init__.py``, the public facade) is matched exactly.
#: docs/design-notes.md ("Where code lives") shows the same table.
LAYERS: tuple[tuple[str, tuple[str, ...]], ...] = (
    (
        "foundation",
        (
            "gnssframework.errors",
            "gnssframework.random_streams",
            "gnssframework.plugin",
            "gnssframework.hookspecs",
            "gnssframework.names",
            "gnssframework.backend",
            "gnssframework.suggest",
            "gnssframework.progress",
        ),
    ),
    # Generic Gaussian estimation (nothing GNSS) sits below the physical models, which
    # build their measurement models (and compiled twins) from its types.
    ("estimation", ("gnssframework.estimation",)),
    ("physical models", ("gnssframework.signal", "gnssframework.navigation", "gnssframework.inertial")),
    (
        "plugin contracts",
        (
            "gnssframework.interfaces",
            "gnssframework.registry",
            "gnssframework.plugin_ref",
            "gnssframework.plugin_ref_rules",
            "gnssframework.plugin_docs",
        ),
    ),
    ("data and truth", ("gnssframework.io", "gnssframework.simulation")),
    ("receiver", ("gnssframework.receiver",)),
    ("experiments", ("gnssframework.experiments",)),
    (
        "application",
        (
            "gnssframework",
            "gnssframework.__main__",
            "gnssframework.cli",
            "gnssframework.config_schema",
            "gnssframework.testing",
            "gnssframework.plugin_classes",
            "gnssframework.estimators",
            "gnssframework.discriminators",
            "gnssframework.channel_filters",
            "gnssframework.nav_filters",
            "gnssframework.noise_adapters",
            "gnssframework.augmentations",
        ),
    ),
)

#: What ``estimation`` may import besides itself: nothing that knows GNSS.
ESTIMATION_MAY_IMPORT = (
    "gnssframework.errors",
    "gnssframework.plugin",
    "gnssframework.random_streams",
    "gnssframework.backend",
)
#: Third-party packages that are GNSS- or geodesy-specific (refused in ``estimation`` too).
GNSS_LIBRARIES = ("georinex", "hatanaka", "pymap3d", "pynmea2")
PLUGIN_PACKAGES = ("gnssframework_plugins", "plugins")

#: Known violations, as import arrows (importer, imported) -> why, while a change that
#: removes them is under way; empty since issue 23 landed.
#: `test_every_allowed_violation_still_exists` says when one is gone.
KNOWN_VIOLATIONS: dict[tuple[str, str], str] = {}


@dataclass
class ImportGraph:
    """Modules of a package and their import arrows, each with where it is written."""

    modules: set[str]
    #: (importer, imported) -> "path:line" of the first such import
    arrows: dict[tuple[str, str], str] = field(default_factory=dict)
    #: imports of other top-level packages: (importer, top-level name) -> "path:line"
    external: dict[tuple[str, str], str] = field(default_factory=dict)

    def __repr__(self) -> str:
        return f"ImportGraph({len(self.modules)} modules, {len(self.arrows)} arrows)"

    def targets(self, module: str, skip: set[tuple[str, str]] = frozenset()) -> list[str]:
        return sorted(b for (a, b) in self.arrows if a == module and (a, b) not in skip)


def _module_name(path: Path, src_root: Path) -> tuple[str, bool]:
    parts = list(path.relative_to(src_root).with_suffix("").parts)
    is_package = parts[-1] == "__init__"
    return ".".join(parts[:-1] if is_package else parts), is_package


def _imported(node: ast.Import | ast.ImportFrom, module: str, is_package: bool, modules: set[str]) -> list[str]:
    """Absolute names a statement imports: ``from p import m`` is module ``p.m`` when that is a module."""
    if isinstance(node, ast.Import):
        return [alias.name for alias in node.names]
    if node.level:
        base = module.split(".")[: len(module.split(".")) - (node.level - (1 if is_package else 0))]
        prefix = ".".join(base + ([node.module] if node.module else []))
    else:
        prefix = node.module or ""
    return [f"{prefix}.{a.name}" if f"{prefix}.{a.name}" in modules else prefix for a in node.names]


#: Calls that import the module their first argument names.
IMPORT_CALLS = ("importlib.import_module", "import_module", "__import__")
#: A "module:attribute" string (an entry point, a lazily loaded class) naming a submodule
#: of ``package`` or of the plugin packages. The module part has a dot: a bare
#: ``gnssframework:if_hz`` is a SigMF metadata key of the ``gnssframework`` namespace.
_MODULE_ATTRIBUTE = r"((?:{packages})(?:\.\w+)+):[A-Za-z_][\w.]*"


def _call_name(func: ast.expr) -> str:
    if isinstance(func, ast.Name):
        return func.id
    if isinstance(func, ast.Attribute) and isinstance(func.value, ast.Name):
        return f"{func.value.id}.{func.attr}"
    return ""


def _hidden_imports(node: ast.AST, module: str, is_package: bool, package: str) -> list[str]:
    """Modules a node imports without an ``import`` statement: ``importlib.import_module``
    (or ``__import__``) of a literal name (relative to ``__package__``/``__name__`` when it
    starts with a dot), and a literal ``"module:attribute"`` string naming one of ours."""
    if isinstance(node, ast.Call) and _call_name(node.func) in IMPORT_CALLS and node.args:
        first = node.args[0]
        if isinstance(first, ast.Constant) and isinstance(first.value, str):
            name = first.value
            if name.startswith("."):
                level = len(name) - len(name.lstrip("."))
                parts = module.split(".")[: len(module.split(".")) - (level - (1 if is_package else 0))]
                name = ".".join(parts + ([name.lstrip(".")] if name.lstrip(".") else []))
            return [name]
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        pattern = _MODULE_ATTRIBUTE.format(packages="|".join(map(re.escape, (package, *PLUGIN_PACKAGES))))
        hit = re.fullmatch(pattern, node.value.strip())
        if hit:
            return [hit.group(1)]
    return []


def import_graph(src_root: Path, package: str = PACKAGE) -> ImportGraph:
    """Parse every module under ``src_root/package`` (ast, nothing imported): its import
    statements and its hidden imports (`_hidden_imports`) are its arrows."""
    files = {(_module_name(p, src_root)): p for p in sorted((src_root / package).rglob("*.py"))}
    graph = ImportGraph({name for name, _ in files})
    for (module, is_package), path in files.items():
        where = path.relative_to(src_root).as_posix()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                names = _imported(node, module, is_package, graph.modules)
            else:
                names = _hidden_imports(node, module, is_package, package)
            for name in names:
                if name.split(".")[0] != package:
                    graph.external.setdefault((module, name.split(".")[0]), f"{where}:{node.lineno}")
                    continue
                while name not in graph.modules and "." in name:
                    name = name.rsplit(".", 1)[0]
                if name != module:
                    graph.arrows.setdefault((module, name), f"{where}:{node.lineno}")
    return graph


def layer_of(module: str, layers=LAYERS, package: str = PACKAGE) -> int | None:
    """Index of the layer holding ``module`` (the longest matching entry), or None."""
    best, best_len = None, -1
    for i, (_, entries) in enumerate(layers):
        for entry in entries:
            hit = module == entry or (entry != package and module.startswith(entry + "."))
            if hit and len(entry) > best_len:
                best, best_len = i, len(entry)
    return best


def circles(graph: ImportGraph, skip: set[tuple[str, str]] = frozenset()) -> list[list[str]]:
    """One import circle per strongly connected component (Tarjan), as a closed path."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph.targets(v, skip):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                components.append(sorted(component))

    for v in sorted(graph.modules):
        if v not in index:
            visit(v)
    return [_closed_path(graph, c, skip) for c in components]


def _closed_path(graph: ImportGraph, component: list[str], skip) -> list[str]:
    """A shortest path from the component's first module back to itself (breadth first)."""
    start, inside = component[0], set(component)
    previous: dict[str, str] = {}
    frontier = [start]
    while frontier:
        nxt = []
        for v in frontier:
            for w in graph.targets(v, skip):
                if w == start:
                    back = [v]
                    while back[-1] != start:
                        back.append(previous[back[-1]])
                    return back[::-1] + [start]
                if w in inside and w not in previous:
                    previous[w] = v
                    nxt.append(w)
        frontier = nxt
    return component


def chain(graph: ImportGraph, path: list[str]) -> str:
    """``a -> b (file:line)`` for each arrow of ``path``."""
    return "\n".join(f"  {a} -> {b}   ({graph.arrows[(a, b)]})" for a, b in zip(path, path[1:]))


def upward_arrows(graph: ImportGraph, skip: set[tuple[str, str]] = frozenset(), layers=LAYERS) -> list[str]:
    out = []
    for (a, b), where in sorted(graph.arrows.items()):
        la, lb = layer_of(a, layers), layer_of(b, layers)
        if (a, b) not in skip and la is not None and lb is not None and lb > la:
            out.append(f"  {a} ({layers[la][0]}) -> {b} ({layers[lb][0]})   ({where})")
    return out


@pytest.fixture(scope="module")
def graph() -> ImportGraph:
    return import_graph(ROOT)


def test_no_import_circle(graph):
    found = circles(graph, set(KNOWN_VIOLATIONS))
    assert not found, (
        "import circles (break each by moving what both sides share to a module below both):\n"
        + "\n\n".join(chain(graph, c) for c in found)
    )


def test_no_arrow_from_a_lower_layer_to_a_higher_one(graph):
    up = upward_arrows(graph, set(KNOWN_VIOLATIONS))
    assert not up, (
        "imports from a lower layer to a higher one (layers: tests/project/test_architecture.py LAYERS):\n"
        + "\n".join(up)
    )


def test_every_module_is_in_a_layer(graph):
    homeless = sorted(m for m in graph.modules if layer_of(m) is None)
    assert not homeless, f"modules in no layer (add their package to LAYERS and docs/design-notes.md): {homeless}"


def test_the_core_never_imports_the_plugins(graph):
    bad = [f"  {a} -> {b}   ({w})" for (a, b), w in sorted(graph.external.items()) if b in PLUGIN_PACKAGES]
    assert not bad, "the core imports the built-in plugins:\n" + "\n".join(bad)


def test_estimation_imports_nothing_gnss_specific(graph):
    def allowed(b: str) -> bool:
        return b.startswith("gnssframework.estimation") or b in ESTIMATION_MAY_IMPORT

    bad = [
        f"  {a} -> {b}   ({w})"
        for (a, b), w in sorted(graph.arrows.items())
        if a.startswith("gnssframework.estimation") and not allowed(b)
    ]
    bad += [
        f"  {a} -> {b}   ({w})"
        for (a, b), w in sorted(graph.external.items())
        if a.startswith("gnssframework.estimation") and b in GNSS_LIBRARIES
    ]
    assert not bad, "estimation imports GNSS-specific code:\n" + "\n".join(bad)


def test_every_allowed_violation_still_exists(graph):
    gone = [f"  {a} -> {b} ({why})" for (a, b), why in KNOWN_VIOLATIONS.items() if (a, b) not in graph.arrows]
    assert not gone, "fixed; remove from KNOWN_VIOLATIONS in tests/project/test_architecture.py:\n" + "\n".join(gone)


#: Issue 36's acceptance: no module of the receiver over this many lines (a larger one holds
#: more than one idea; split it by what it holds).
RECEIVER_MAX_LINES = 600


def test_no_receiver_module_is_over_600_lines():
    long = {
        str(p.relative_to(ROOT)): n
        for p in sorted((ROOT / PACKAGE / "receiver").rglob("*.py"))
        if (n := len(p.read_text(encoding="utf-8").splitlines())) > RECEIVER_MAX_LINES
    }
    assert not long, f"receiver modules over {RECEIVER_MAX_LINES} lines (split them by what they hold): {long}"


def test_the_design_notes_show_the_same_layers():
    text = (ROOT / "docs" / "design-notes.md").read_text(encoding="utf-8")
    rows = re.findall(r"^\| (\d) \| ([a-z ]+) \| (.+?) \|", text, flags=re.M)
    documented = [(name, tuple(sorted(re.findall(r"`(gnssframework[\w.]*)`", entries)))) for _, name, entries in rows]
    assert documented == [(name, tuple(sorted(entries))) for name, entries in LAYERS]


# -- the checks themselves catch what they are for ---------------------------------------------


def _tree(tmp_path: Path, files: dict[str, str]) -> Path:
    for rel, text in files.items():
        p = tmp_path / "pkg" / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(text)
    return tmp_path


def test_the_checks_see_a_circle_through_a_lazy_import_and_an_arrow_up(tmp_path):
    root = _tree(
        tmp_path,
        {
            "__init__.py": "",
            "low/__init__.py": "",
            "low/a.py": "def f():\n    from ..high import b\n",  # lazy, and up a layer
            "high/__init__.py": "",
            "high/b.py": "from pkg.low import a\nimport plugins.x\n",
        },
    )
    g = import_graph(root, "pkg")
    layers = (("low", ("pkg.low",)), ("high", ("pkg.high",)))
    assert circles(g) == [["pkg.high.b", "pkg.low.a", "pkg.high.b"]]
    assert chain(g, ["pkg.low.a", "pkg.high.b"]) == "  pkg.low.a -> pkg.high.b   (pkg/low/a.py:2)"
    assert upward_arrows(g, layers=layers) == ["  pkg.low.a (low) -> pkg.high.b (high)   (pkg/low/a.py:2)"]
    assert circles(g, {("pkg.low.a", "pkg.high.b")}) == []
    assert ("pkg.high.b", "plugins") in g.external


def test_a_from_import_of_a_module_points_at_the_module(tmp_path):
    root = _tree(tmp_path, {"__init__.py": "", "m.py": "from . import n\nfrom .n import thing\n", "n.py": ""})
    g = import_graph(root, "pkg")
    assert set(g.arrows) == {("pkg.m", "pkg.n")}


def test_hidden_string_imports_are_arrows_too(tmp_path):
    # A lower layer that loads a higher one's class by name, or imports it through
    # importlib, reaches up just as an import statement would: both are caught.
    root = _tree(
        tmp_path,
        {
            "__init__.py": "",
            "low/__init__.py": "",
            "low/by_string.py": 'BASES = {"thing": "pkg.high.b:Thing"}\n',
            "low/by_importlib.py": "import importlib\n\ndef f():\n    return importlib.import_module('pkg.high.b')\n",
            "low/relative.py": "from importlib import import_module\n\nm = import_module('..high.b', __package__)\n",
            "low/sigmf_key.py": 'KEY = "pkg:if_hz"\nTEXT = "see pkg.high.b:Thing for details"\n',
            "low/plugins_by_name.py": 'import importlib\nimportlib.import_module("gnssframework_plugins.x")\n',
            "high/__init__.py": "",
            "high/b.py": "class Thing:\n    pass\n",
        },
    )
    g = import_graph(root, "pkg")
    layers = (("low", ("pkg.low",)), ("high", ("pkg.high",)))
    assert upward_arrows(g, layers=layers) == [
        "  pkg.low.by_importlib (low) -> pkg.high.b (high)   (pkg/low/by_importlib.py:4)",
        "  pkg.low.by_string (low) -> pkg.high.b (high)   (pkg/low/by_string.py:1)",
        "  pkg.low.relative (low) -> pkg.high.b (high)   (pkg/low/relative.py:3)",
    ]
    # A namespaced key and prose that mentions a module are not imports; a plugin
    # package named by importlib is an external import (the core-never-imports check).
    assert not [a for a in g.arrows if a[0] == "pkg.low.sigmf_key"]
    assert ("pkg.low.plugins_by_name", "gnssframework_plugins") in g.external
