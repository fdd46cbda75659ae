"""The core does not know the built-in plugins by name: no built-in plugin's registry name
is a string literal in the logic of ``gnssframework/`` (a comparison, a ``registry.create``
call, a branch). It may be a declared default (a parameter's default, an UPPER_CASE
module constant that composes a documented recipe) or prose (docstrings, messages).

The core picks a plugin by what it can do (the capability interfaces of
:mod:`gnssframework.interfaces`), so a third-party plugin with the same capability is
used the same way.
"""

from __future__ import annotations

import ast
from pathlib import Path

import gnssframework as gf

CORE = Path(gf.__file__).parent


#: Built-in names that are also ordinary words of the core's data: a plugin kind
#: ("discriminator") and the filters' innovation sequence (the "innovation" adapter).
WORDS = {"innovation", *gf.registry.kinds()}


def _builtin_names() -> set[str]:
    """Registry names of the built-in plugins (not the core's own scenarios), but `WORDS`."""
    names = {i.name for i in gf.registry.describe() if i.cls.__module__.startswith("gnssframework_plugins")}
    return names - WORDS


def _allowed_nodes(tree: ast.AST) -> set[int]:
    """ids of the nodes under which a name is a declaration, not logic."""
    allowed: set[int] = set()

    def cover(node: ast.AST | None) -> None:
        if node is not None:
            allowed.update(id(n) for n in ast.walk(node))

    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            for default in node.args.defaults + [d for d in node.args.kw_defaults if d is not None]:
                cover(default)
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
                cover(body[0])  # the docstring
        if isinstance(node, ast.Call):
            for kw in node.keywords:
                if kw.arg in ("default", "description", "help"):
                    cover(kw.value)
            if getattr(node.func, "id", None) == "Field" and node.args:
                cover(node.args[0])  # a pydantic field's default
        if isinstance(node, ast.JoinedStr):
            cover(node)  # an f-string: a message
    for stmt in getattr(tree, "body", []):  # module constants declared in capitals: recipes, documented
        targets = (
            stmt.targets if isinstance(stmt, ast.Assign) else [stmt.target] if isinstance(stmt, ast.AnnAssign) else []
        )
        if targets and all(isinstance(t, ast.Name) and t.id.isupper() for t in targets):
            cover(stmt)
    return allowed


def plugin_names_in_logic(root: Path = CORE) -> list[str]:
    """``path:line: 'name'`` of every built-in plugin name used in the core's logic."""
    names = _builtin_names()
    found = []
    for path in sorted(root.rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        allowed = _allowed_nodes(tree)
        for node in ast.walk(tree):
            if (
                isinstance(node, ast.Constant)
                and isinstance(node.value, str)
                and node.value in names
                and id(node) not in allowed
            ):
                found.append(f"{path.relative_to(root.parent)}:{node.lineno}: {node.value!r}")
    return found


def test_the_core_names_no_builtin_plugin_in_its_logic():
    assert plugin_names_in_logic() == []


def test_the_check_finds_a_name_in_a_comparison_and_a_create_call(tmp_path):
    (tmp_path / "pkg").mkdir()
    (tmp_path / "pkg" / "mod.py").write_text(
        '"""Uses ins-ekf."""\n'
        'RECIPE = {"nav_filter": "position-ca"}\n'
        'def f(nav, name="ukf"):\n'
        '    if nav.name == "ins-ekf":\n'
        '        return registry.create("estimator", "kf")\n'
        "    raise ValueError(f\"not {nav.name!r}: use 'ekf-pv'\")\n"
    )
    assert plugin_names_in_logic(tmp_path / "pkg") == ["pkg/mod.py:4: 'ins-ekf'", "pkg/mod.py:5: 'kf'"]
