"""The tests mirror the package (CONTRIBUTING.md, "Layout"): a folder per layer, so one
layer's tests are one command (`pytest tests/estimation`).

The folders are no packages: pytest imports a test file under its own name with its folder
put first on the path, and `pythonpath = ["tests"]` (pyproject.toml) adds the top of tests/,
where conftest.py and the shared helper modules are. That holds while a test file's name is
unique across the folders and a test module another imports (``from test_kernels import
_close``) is in its importer's folder: in another folder it would be found only when pytest
happened to have collected that folder first.
"""

from __future__ import annotations

import ast
from collections import defaultdict
from pathlib import Path

TESTS = Path(__file__).resolve().parents[1]
#: The package's layers (tests/project/test_architecture.py), the core outside them and the project.
FOLDERS = (
    "estimation",
    "signal",
    "simulation",
    "navigation",
    "inertial",
    "io",
    "receiver",
    "experiments",
    "core",
    "project",
)


def _test_files() -> list[Path]:
    return sorted(p for p in TESTS.rglob("test_*.py") if "__pycache__" not in p.parts)


def test_every_test_file_is_in_a_layer_folder():
    misplaced = [
        p.relative_to(TESTS).as_posix()
        for p in _test_files()
        if p.parent.parent != TESTS or p.parent.name not in FOLDERS
    ]
    assert not misplaced, f"test files outside the folders {FOLDERS} (CONTRIBUTING.md, 'Layout'): {misplaced}"
    assert all((TESTS / folder).is_dir() for folder in FOLDERS)


def test_test_file_names_are_unique_across_the_folders():
    folders = defaultdict(list)
    for p in _test_files():
        folders[p.name].append(p.parent.name)
    assert not {name: where for name, where in folders.items() if len(where) > 1}


def _imported_test_modules(path: Path) -> list[tuple[str, int]]:
    names = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names += [(alias.name, node.lineno) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and not node.level and node.module:
            names.append((node.module, node.lineno))
    return [(name, line) for name, line in names if name.startswith("test_")]


def test_a_test_module_another_imports_is_in_the_importers_folder():
    where = {p.stem: p.parent for p in _test_files()}
    elsewhere = []
    for path in _test_files():
        for name, line in _imported_test_modules(path):
            if where.get(name) != path.parent:
                found = where[name].relative_to(TESTS).as_posix() if name in where else "no test folder"
                elsewhere.append(f"{path.relative_to(TESTS).as_posix()}:{line} imports {name} ({found})")
    assert not elsewhere, "move the helper to the top of tests/ or the files together:\n" + "\n".join(elsewhere)
