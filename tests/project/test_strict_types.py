"""The public API type-checks strictly (issue 37; CONTRIBUTING.md, "The lanes").

mypy's `strict` is a global-only option, so pyproject.toml gives the public API's modules
its flags in a `[[tool.mypy.overrides]]` section. These tests read that table and hold the
list to the modules it must cover, found from the code where they can be (every module of
`gnssframework.estimation`, every ``gnssframework.<kind>s`` class module, the module of
every plugin kind's base class, the modules of `compare`, `run_comparison` and
`ComparisonConfig`), so a new engine or kind is strict from the start and the list cannot
silently shrink.
"""

from __future__ import annotations

import fnmatch
import tomllib
from pathlib import Path

import gnssframework
from gnssframework import hookspecs, registry
from gnssframework.experiments import ComparisonConfig, run_comparison

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "gnssframework"

#: The per-module flags `mypy --strict` turns on (mypy's `--help`, "--strict"); the global
#: ones are below.
STRICT_FLAGS = (
    "disallow_any_generics",
    "disallow_subclassing_any",
    "disallow_untyped_calls",
    "disallow_untyped_defs",
    "disallow_incomplete_defs",
    "check_untyped_defs",
    "disallow_untyped_decorators",
    "warn_return_any",
    "no_implicit_reexport",
    "strict_equality",
    "extra_checks",
)
GLOBAL_STRICT_FLAGS = ("warn_unused_configs", "warn_redundant_casts", "warn_unused_ignores")

#: Private kernels of the estimation engines, checked but not strictly (their numba-typed
#: signatures are loose by design; pyproject.toml says so beside their section).
NOT_STRICT = ("gnssframework.estimation.compiled",)


def _mypy() -> dict:
    return tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["mypy"]


def _matches(pattern: str, module: str) -> bool:
    """mypy's section patterns: ``a.b.*`` covers ``a.b`` and its submodules."""
    if pattern.endswith(".*"):
        return module == pattern[:-2] or fnmatch.fnmatchcase(module, pattern)
    return module == pattern


def _module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _must_be_strict() -> set[str]:
    modules = {
        "gnssframework",
        "gnssframework.interfaces",
        "gnssframework.plugin",
        "gnssframework.plugin_classes",
        "gnssframework.hookspecs",
        "gnssframework.registry",
        # the per-run random streams every scenario draws from, and the plugin references of configs
        "gnssframework.random_streams",
        "gnssframework.plugin_ref",
    }
    modules |= {_module_name(p) for p in (PACKAGE / "estimation").glob("*.py")}  # the engines
    modules |= {_module_name(p) for p in PACKAGE.glob("*.py") if "kind_module(" in p.read_text()}
    registry.describe()  # loads every plugin, so every kind's base class is declared
    for kind in hookspecs.KINDS:
        base = registry.base_class(kind)
        assert base is not None, f"plugin kind {kind!r} has no base class declared"
        modules.add(base.__module__)
    modules |= {
        gnssframework.compare.__module__,
        run_comparison.__module__,
        ComparisonConfig.__module__,
        "gnssframework.experiments",
    }
    return modules


def test_the_required_modules_are_found():
    required = _must_be_strict()
    # What the search above must find, or it has gone blind (a moved base, a renamed module).
    assert {
        "gnssframework.estimation.estimator",
        "gnssframework.estimation.adaptation",
        "gnssframework.estimation.robust",
        "gnssframework.estimators",
        "gnssframework.nav_filters",
        "gnssframework.signal.registered",
        "gnssframework.signal.cn0_estimator",
        "gnssframework.experiments.metrics",
        "gnssframework.experiments.scenarios",
        "gnssframework.receiver.acquisition.search",
        "gnssframework.receiver.frontend.source",
        "gnssframework.experiments.results",
        "gnssframework.experiments.runner",
        "gnssframework.experiments.config",
    } <= required
    assert not [m for m in required for n in NOT_STRICT if m == n or m.startswith(n + ".")]


def test_the_public_api_has_every_strict_flag():
    config = _mypy()
    assert all(config.get(flag) is True for flag in GLOBAL_STRICT_FLAGS), GLOBAL_STRICT_FLAGS
    strict_sections = [o for o in config["overrides"] if all(o.get(flag) is True for flag in STRICT_FLAGS)]
    missing = sorted(
        m for m in _must_be_strict() if not any(_matches(p, m) for o in strict_sections for p in o["module"])
    )
    assert not missing, f"not in a strict [[tool.mypy.overrides]] section of pyproject.toml: {missing}"


def test_no_other_section_relaxes_the_public_api():
    """A later section that matches a strict module may not turn a strict flag off or its errors
    off (the compiled kernels' section relaxes only themselves)."""
    relaxing = [
        o for o in _mypy()["overrides"] if o.get("ignore_errors") or any(o.get(flag) is False for flag in STRICT_FLAGS)
    ]
    assert relaxing, "the test no longer sees the sections that relax (the ignore list, the kernels')"
    relaxed = sorted({(m, p) for m in _must_be_strict() for o in relaxing for p in o["module"] if _matches(p, m)})
    assert not relaxed, f"strict modules relaxed by another section (module, pattern): {relaxed}"
