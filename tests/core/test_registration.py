"""Adding a built-in takes one code file: a plugin package's hooks register every plugin
class its modules define (`registry.plugin_hooks`), scenarios and metrics are looked up
in one place each, and every built-in is declared in exactly one module and named in no
other (docs/design-notes.md, "Adding a built-in")."""

from __future__ import annotations

import ast
import importlib
import sys
import textwrap
from pathlib import Path

import pytest

import gnssframework as gf
from conftest import builtin_plugins
from gnssframework import registry
from gnssframework.errors import PluginError

ROOT = Path(__file__).resolve().parents[2]
CODE_DIRS = (ROOT / "gnssframework", ROOT / "plugins")


def _write_package(tmp_path: Path, name: str, modules: dict[str, str]) -> None:
    package = tmp_path / name
    package.mkdir()
    (package / "__init__.py").write_text(
        "from gnssframework.registry import plugin_hooks, submodules\n\n"
        "globals().update(plugin_hooks(*submodules(__name__, __path__)))\n"
    )
    for module, source in modules.items():
        (package / f"{module}.py").write_text(textwrap.dedent(source))


@pytest.fixture()
def package_path(tmp_path):
    sys.path.insert(0, str(tmp_path))
    yield tmp_path
    sys.path.remove(str(tmp_path))
    for name in [m for m in sys.modules if m.startswith("h23e_pkg")]:
        del sys.modules[name]


FILTERS = """
from gnssframework import registry
from gnssframework.experiments.metrics import Metric, MetricValue
from gnssframework.interfaces import Discriminator

KalmanFilter = registry.get("estimator", "kf")   # imported: another module's plugin


class _Helper(KalmanFilter):                     # a shared base with no name of its own
    pass


class MyKf(_Helper):
    name = "h23e-kf"


class MyDisc(Discriminator):
    name = "h23e-disc"
    unit = "rad"

    def __call__(self, current, previous=None):
        return current.prompt.real

    def noise_variance(self, cn0_dbhz):
        return 1.0 / cn0_dbhz


class PeakCode(Metric):
    name = "h23e_peak"
    requires = ("code_error_chips",)

    def compute(self, series, time_s, scenario):
        return MetricValue(abs(series["code_error_chips"]).max(axis=0))
"""


def test_a_class_written_in_a_module_of_a_plugin_package_is_registered(package_path, scratch_registry):
    _write_package(package_path, "h23e_pkg", {"filters": FILTERS})
    package = importlib.import_module("h23e_pkg")
    registry.register_module(package, name="h23e-package", distribution="h23e-package")
    by_name = {i.name: i for i in registry.describe() if i.distribution == "h23e-package"}
    assert sorted(by_name) == ["h23e-disc", "h23e-kf", "h23e_peak"]
    assert [by_name[n].kind for n in ("h23e-kf", "h23e-disc", "h23e_peak")] == ["estimator", "discriminator", "metric"]
    assert registry.create("estimator", "h23e-kf").name == "h23e-kf"
    # Only the kinds the package defines get a hook; the base it imported stays the built-in's.
    assert sorted(k for k in vars(package) if k.startswith("register_")) == [
        "register_discriminator",
        "register_estimator",
        "register_metric",
    ]
    assert registry.get("estimator", "kf").__module__ == "gnssframework_plugins.estimators"


def test_a_new_module_of_a_plugin_package_needs_no_list_either(package_path, scratch_registry):
    _write_package(
        package_path,
        "h23e_pkg2",
        {
            "filters": FILTERS,
            "more": """
        from gnssframework import registry

        class OtherKf(registry.get("estimator", "kf")):
            name = "h23e-other-kf"
        """,
        },
    )
    registry.register_module(importlib.import_module("h23e_pkg2"), name="h23e-package2")
    assert {"h23e-kf", "h23e-other-kf", "h23e-disc"} <= set(
        registry.names("estimator") + registry.names("discriminator")
    )


def test_a_class_of_two_kinds_is_refused_by_name():
    module = type(sys)("h23e_pkg3.twice")
    from gnssframework.interfaces import ChannelFilter, NavFilter

    class Twice(ChannelFilter, NavFilter):
        name = "twice"

    Twice.__module__ = module.__name__
    module.Twice = Twice
    with pytest.raises(
        PluginError,
        match=r"h23e_pkg3\.twice\.Twice derives from the bases of channel_filter, "
        r"nav_filter",
    ):
        registry.defined_plugins(module)


def test_the_builtin_plugins_are_registered_by_their_modules_alone():
    import gnssframework_plugins

    source = (ROOT / "plugins" / "__init__.py").read_text()
    hooks = {k: v for k, v in vars(gnssframework_plugins).items() if k.startswith("register_")}
    kinds_defined = {i.kind for i in registry.describe() if i.cls.__module__.startswith("gnssframework_plugins")}
    assert set(hooks) == {f"register_{k}" for k in kinds_defined}
    for info in registry.describe():  # the package's __init__ names no plugin class
        if info.cls.__module__.startswith("gnssframework_plugins"):
            assert info.cls.__name__ not in source


# -- every built-in declared once, named nowhere else ---------------------------------------


def _builtins() -> list[registry.PluginInfo]:
    return builtin_plugins()


def _module_file(module: str) -> Path:
    parts = module.split(".")
    if parts[0] == "gnssframework_plugins":
        parts[0] = "plugins"
    return ROOT.joinpath(*parts).with_suffix(".py")


def _references(tree: ast.AST) -> tuple[set[str], set[str]]:
    """Names a module uses (``Name``, ``Attribute`` and imported names) and those it uses
    only as the base of a class it defines."""
    bases: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ClassDef):
            bases.update(id(b) for b in node.bases)
    used, as_base = set(), set()
    for node in ast.walk(tree):
        name = node.id if isinstance(node, ast.Name) else node.attr if isinstance(node, ast.Attribute) else None
        if name is not None:
            (as_base if id(node) in bases else used).add(name)
    imported = {a.asname or a.name for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) for a in n.names}
    return used, as_base | (imported - used)


@pytest.mark.slow
def test_every_builtin_is_defined_in_one_module_and_named_in_no_other():
    infos = _builtins()
    assert {i.kind for i in infos} >= {"estimator", "discriminator", "scenario", "channel_filter", "nav_filter"}
    files = sorted(p for d in CODE_DIRS for p in d.rglob("*.py"))
    trees = {p: ast.parse(p.read_text(encoding="utf-8")) for p in files}
    refs = {p: _references(t) for p, t in trees.items()}
    homes: dict[str, list] = {}  # each class name's defining files, from one walk of every tree
    for p, t in trees.items():
        for n in ast.walk(t):
            if isinstance(n, ast.ClassDef):
                homes.setdefault(n.name, []).append(p)
    offenders = []
    for info in infos:
        home = _module_file(info.cls.__module__)
        defined = homes.get(info.cls.__name__, [])
        assert defined == [home], f"{info.kind} {info.name!r}: class {info.cls.__name__} defined in {defined}"
        for path, (used, _) in refs.items():
            if path != home and info.cls.__name__ in used:  # a subclass's base in another module is fine
                offenders.append(f"{info.kind} {info.name!r} ({info.cls.__name__}) in {path.relative_to(ROOT)}")
    assert not offenders, "a built-in named outside its own module (a list to edit):\n" + "\n".join(offenders)


def test_every_builtin_scenario_metric_is_declared_by_one_component_of_its_module():
    for info in _builtins():
        if info.kind != "scenario":
            continue
        table = info.cls.metrics
        components = getattr(table, "components", {})
        assert set(components) == set(table), (
            f"{info.name}: metrics without a component: {sorted(set(table) - set(components))}"
        )
        declared = sys.modules[info.cls.__module__].METRICS
        for name, component in components.items():
            assert sum(c is component for c in declared) == 1, f"{info.name}: {name} not in its module's METRICS"
            assert component.unit == table[name]


def test_the_reference_check_sees_a_plugin_named_in_another_module():
    tree = ast.parse(
        "from plugins.estimators import KalmanFilter\nFILTERS = (KalmanFilter,)\n"
        "class Mine(KalmanFilter):\n    name = 'x'\n"
    )
    used, _ = _references(tree)
    assert "KalmanFilter" in used
    used, as_base = _references(
        ast.parse("from plugins.estimators import KalmanFilter\nclass Mine(KalmanFilter):\n    name = 'x'\n")
    )
    assert "KalmanFilter" not in used and "KalmanFilter" in as_base


def test_scenarios_are_found_in_the_registry_only():
    from gnssframework.experiments import get_scenario
    from gnssframework.experiments.scenarios import declared_scenarios, scenario_kinds

    core = {cls.kind for cls in declared_scenarios()}
    assert core == {i.name for i in _builtins() if i.kind == "scenario"}
    assert scenario_kinds() == {n: registry.get("scenario", n) for n in registry.names("scenario")}
    with pytest.raises(gf.ConfigError) as err:
        get_scenario({"kind": "Multipath"})
    assert err.value.field == "scenario.kind" and "did you mean 'multipath'" in str(err.value)
