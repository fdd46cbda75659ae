"""The plugin registry, plugin loading and the CLI listing."""

from __future__ import annotations

import ast
import importlib.metadata as md
import pathlib
import subprocess
import sys
import types

import pytest

import gnssframework as gf
from conftest import builtin_names
from gnssframework import registry

ROOT = pathlib.Path(__file__).resolve().parents[2]


def test_kinds_and_builtin_names():
    assert registry.kinds() == [
        "acquisition",
        "augmentation",
        "channel_filter",
        "cn0_estimator",
        "discriminator",
        "estimator",
        "metric",
        "nav_filter",
        "noise_adapter",
        "robust_update",
        "sample_source",
        "scenario",
        "signal",
    ]
    assert builtin_names("robust_update") == ["cauchy", "gate", "huber", "student-t"]
    assert builtin_names("cn0_estimator") == ["beaulieu", "m2m4", "narrow-wide", "noise-channel", "snv"]
    assert builtin_names("signal") == [
        "beidou-b1c",
        "beidou-b1i",
        "beidou-b1i-geo",
        "galileo-e1b",
        "galileo-e1b-boc11",
        "galileo-e1c",
        "galileo-e1c-boc11",
        "galileo-e5ai",
        "galileo-e5aq",
        "gps-l1ca",
        "gps-l2c",
        "gps-l5i",
        "gps-l5q",
        "qzss-l1ca",
        "qzss-l2c",
        "qzss-l5q",
        "sbas-l1",
    ]
    assert builtin_names("estimator") == ["ckf", "ekf", "kf", "svd-ckf", "ukf"]
    assert builtin_names("scenario") == [
        "boc-tracking",
        "carrier-smoothing",
        "deep-integration",
        "multipath",
        "sample-receiver",
        "sample-recording",
        "scintillation",
        "tracking-threshold",
        "vector-threshold",
        "vector-tracking",
    ]


def test_builtin_name_sets_ignore_a_plugin_installed_beside_the_project(scratch_registry):
    class ThirdPartyKf(registry.get("estimator", "kf")):
        name = "third-party-kf"

    module = types.SimpleNamespace(register_estimator=gf.hookimpl(lambda register: register(ThirdPartyKf)))
    registry.register_module(module, name="test-third-party-kf", distribution="someone-elses-package")
    assert "third-party-kf" in registry.names("estimator")
    assert builtin_names("estimator") == ["ckf", "ekf", "kf", "svd-ckf", "ukf"]


def test_a_third_party_scenario_registers_through_the_hook_and_runs_from_a_config(tmp_path, scratch_registry):
    from gnssframework.experiments.scenarios import Scenario, get_scenario

    base = get_scenario({"kind": "multipath"})

    class Renamed(type(base)):
        kind = "third-party-multipath"

    module = types.SimpleNamespace(register_scenario=gf.hookimpl(lambda register: register(Renamed)))
    registry.register_module(module, name="test-third-party-scenario", distribution="someone-elses-package")
    assert registry.get("scenario", "third-party-multipath") is Renamed
    assert issubclass(Renamed, Scenario)
    assert isinstance(get_scenario({"kind": "third-party-multipath", "epochs": 30}), Renamed)
    with pytest.raises(gf.ConfigError, match="did you mean 'third-party-multipath'"):
        get_scenario({"kind": "third-party-multipth"})


def test_registration_refuses_a_scenario_that_is_not_a_scenario(scratch_registry):
    class NotAScenario:
        kind = "not-a-scenario"

    module = types.SimpleNamespace(register_scenario=gf.hookimpl(lambda register: register(NotAScenario)))
    registry.register_module(module, name="test-not-a-scenario")
    assert "not-a-scenario" not in registry.names("scenario")
    [failure] = [f for f in registry.failures() if f.entry_point == "test-not-a-scenario"]
    assert "is not a subclass of Scenario" in failure.error
    assert {"innovation", "sage-husa", "ml-q"} <= set(registry.names("noise_adapter"))
    assert "colored-ar1" in registry.names("augmentation")


def test_create_validates_parameters():
    ukf = registry.create("estimator", "ukf", alpha=0.01, beta=2.0, kappa=0.0)
    assert ukf.params.alpha == 0.01
    with pytest.raises(gf.ConfigError) as err:
        registry.create("estimator", "ukf", alpha=-1)
    assert "alpha" in str(err.value) and "greater than 0" in str(err.value)
    with pytest.raises(gf.ConfigError, match="alhpa: unknown parameter"):
        registry.create("estimator", "ukf", alhpa=0.1)
    with pytest.raises(gf.ConfigError, match=r"variant.*'classic' or 'improved'"):
        registry.create("noise_adapter", "sage-husa", variant="fancy")


def test_unknown_name_lists_known_ones_and_the_closest():
    with pytest.raises(gf.ConfigError) as err:
        registry.create("estimator", "svdckf")
    msg = str(err.value)
    assert f"known: {', '.join(registry.names('estimator'))};" in msg and "did you mean 'svd-ckf'" in msg
    with pytest.raises(gf.ConfigError, match="unknown plugin kind 'estimators'; allowed: acquisition, augmentation"):
        registry.names("estimators")


def test_describe_names_the_source_distribution():
    infos = {(i.kind, i.name): i for i in registry.describe()}
    info = infos[("estimator", "svd-ckf")]
    assert info.distribution == "gnssframework" and info.version == gf.__version__
    assert "SVD" in info.description


def test_a_plugin_that_fails_to_import_is_reported_and_the_rest_load(monkeypatch):
    real = md.entry_points

    class BrokenEP:
        name = "broken"
        group = "gnssframework"
        dist = types.SimpleNamespace(name="broken-dist", version="9.9")

        def load(self):
            raise ImportError("No module named 'missing_dependency'")

    def fake_entry_points(group=None, **kw):
        eps = list(real(group=group, **kw))
        return eps + [BrokenEP()] if group == "gnssframework" else eps

    monkeypatch.setattr(md, "entry_points", fake_entry_points)
    registry.reload()
    try:
        failures = registry.failures()
        assert [(f.distribution, f.entry_point) for f in failures] == [("broken-dist", "broken")]
        assert "missing_dependency" in failures[0].error
        assert "ukf" in registry.names("estimator")
    finally:
        monkeypatch.undo()
        registry.reload()


def test_the_core_scenarios_register_through_the_entry_point_group_only(monkeypatch):
    # One registration path: the core's scenario hooks are an entry point of the
    # ``gnssframework`` group (pyproject.toml), loaded like the built-in plugins; without
    # that entry point no scenario kind is registered (there is no second, direct path).
    hooks = "gnssframework.experiments.scenarios.hooks"
    ours = [ep for ep in md.entry_points(group=registry.ENTRY_POINT_GROUP) if ep.value == hooks]
    assert [(ep.name, ep.dist.name) for ep in ours] == [("scenarios", "gnssframework")]
    infos = [i for i in registry.describe() if i.kind == "scenario" and i.distribution == "gnssframework"]
    # the core's hooks register every built-in scenario (the list test_kinds_and_builtin_names holds)
    assert sorted(i.name for i in infos) == [
        "boc-tracking",
        "carrier-smoothing",
        "deep-integration",
        "multipath",
        "sample-receiver",
        "sample-recording",
        "scintillation",
        "tracking-threshold",
        "vector-threshold",
        "vector-tracking",
    ]
    real = md.entry_points

    def without_core_hooks(group=None, **kw):
        return [ep for ep in real(group=group, **kw) if ep.value != hooks]

    monkeypatch.setattr(md, "entry_points", without_core_hooks)
    registry.reload()
    try:
        assert builtin_names("scenario") == [] and "ukf" in registry.names("estimator")
    finally:
        monkeypatch.undo()
        registry.reload()
    assert "vector-tracking" in registry.names("scenario")


def test_a_plugin_whose_hook_raises_or_registers_garbage_is_reported():
    bad = types.ModuleType("bad_plugin")

    @gf.hookimpl
    def register_estimator(register):
        register(dict)  # not an Estimator

    bad.register_estimator = register_estimator
    registry.register_module(bad, "bad", distribution="bad-dist")
    try:
        failure = registry.failures()[-1]
        assert failure.distribution == "bad-dist" and "not a subclass of Estimator" in failure.error
        assert "ukf" in registry.names("estimator")
    finally:
        registry.reload()


def test_core_never_imports_the_plugins_package():
    offenders = []
    for path in (ROOT / "gnssframework").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            mods = []
            if isinstance(node, ast.Import):
                mods = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module:
                mods = [node.module]
            offenders += [f"{path.name}: {m}" for m in mods if m.split(".")[0] == "gnssframework_plugins"]
    assert offenders == []


@pytest.mark.slow
def test_cli_lists_kind_name_description_and_source():
    out = subprocess.run(
        [sys.executable, "-m", "gnssframework", "plugins"], capture_output=True, text=True, check=True
    ).stdout
    line = next(l for l in out.splitlines() if " svd-ckf " in l)
    assert line.split()[0] == "estimator" and f"gnssframework {gf.__version__}" in line


@pytest.mark.slow
def test_cli_library_error_is_one_line_without_traceback_and_suggests_the_name():
    proc = subprocess.run(
        [sys.executable, "-m", "gnssframework", "plugins", "--describe", "eml-envelop"], capture_output=True, text=True
    )
    assert proc.returncode != 0 and "Traceback" not in proc.stderr
    assert proc.stderr.strip().splitlines() == [
        "error: --describe: no plugin named 'eml-envelop'; did you mean 'eml-envelope'?"
    ]


@pytest.mark.slow
def test_describe_prints_the_contract_and_the_parameter_table_from_params():
    from gnssframework.plugin_docs import parameter_rows

    out = subprocess.run(
        [sys.executable, "-m", "gnssframework", "plugins", "--describe", "eml-envelope"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    assert "unit: chips" in out
    cls = registry.get("discriminator", "eml-envelope")
    for name, field in cls.Params.model_fields.items():
        row = next(line for line in out.splitlines() if line.startswith(f"| `{name}` |"))
        assert f"`{field.default}`" in row and (field.description or "") in row
    spacing = next(r for r in parameter_rows(cls.Params) if r.name == "early_late_spacing_chips")
    assert spacing.bounds == "> 0, <= 1.0" and spacing.type == "float"


def test_help_shows_the_parameter_table():
    import pydoc

    text = pydoc.render_doc(registry.get("estimator", "ukf"), renderer=pydoc.plaintext)
    assert "Parameter table (generated from ``Params``)" in text
    assert "| `kappa` | float | `0.0` |" in text


def test_nested_plugin_parameters_show_their_kind_and_unit():
    from gnssframework.plugin_docs import parameter_rows

    rows = {r.name: r for r in parameter_rows(registry.get("channel_filter", "scalar").Params)}
    assert rows["phase_discriminator"].type == "discriminator plugin (rad)"
    assert rows["phase_discriminator"].default == "'costas-atan'"
    rows = {r.name: r for r in parameter_rows(registry.get("channel_filter", "iq-filter").Params)}
    assert rows["adapter"].type == "noise_adapter plugin or null"


# -- the layers that own a kind's base declare it (issue 36) ------------------------------------

#: Kinds whose base lives above the registry's layer, and where (the owning module declares it).
OWNED_BASES = {
    "metric": ("gnssframework.experiments.metrics", "Metric"),
    "scenario": ("gnssframework.experiments.scenarios", "Scenario"),
    "sample_source": ("gnssframework.receiver.frontend.source", "SampleSource"),
    "acquisition": ("gnssframework.receiver.acquisition.search", "Acquisition"),
}


@pytest.mark.slow
def test_a_fresh_process_finds_the_bases_the_upper_layers_declare():
    # Only the registry is imported: its entry points import the owning modules, which
    # declare the bases before their plugins register (none is refused, all are listed).
    code = (
        "import json, importlib\nfrom gnssframework import registry\n"
        "names = {k: registry.names(k) for k in ('scenario', 'sample_source', 'acquisition', 'metric')}\n"
        f"owned = {OWNED_BASES!r}\n"
        "same = {k: registry.base_class(k) is getattr(importlib.import_module(m), c)\n"
        "        for k, (m, c) in owned.items()}\n"
        "print(json.dumps([names, same, [str(f) for f in registry.failures()]]))"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    import json

    names, same, failures = json.loads(proc.stdout)
    assert failures == []
    assert same == {k: True for k in OWNED_BASES}
    assert {n for n in names["scenario"]} >= {"multipath", "sample-receiver", "scintillation", "vector-tracking"}
    assert {"ci8", "ri8", "cf32_le"} <= set(names["sample_source"]) and "pcps" in names["acquisition"]


def test_the_registry_holds_no_base_by_string():
    source = (ROOT / "gnssframework" / "registry.py").read_text()
    assert all(isinstance(base, type) for base in registry.BASES.values())
    assert not [m for m, _ in OWNED_BASES.values() if m in source]


def test_register_kind_refuses_an_unknown_kind_a_non_class_and_a_second_base():
    from gnssframework.errors import PluginError

    with pytest.raises(PluginError, match=r"'gadget' has no register_gadget hook"):
        registry.register_kind("gadget", object)
    with pytest.raises(PluginError, match=r"must be a class, got 'Metric'"):
        registry.register_kind("metric", "Metric")

    class Metric:  # another class of the same qualified name elsewhere: not the same base
        pass

    with pytest.raises(PluginError, match=r"'metric' already has the base gnssframework\.experiments\.metrics\.Metric"):
        registry.register_kind("metric", Metric)
    from gnssframework.experiments.metrics import Metric as real

    assert registry.register_kind("metric", real) is real and registry.base_class("metric") is real


def test_a_plugin_of_a_kind_whose_base_is_not_declared_is_refused(monkeypatch, scratch_registry):
    registry.names("estimator")  # loaded with every base declared
    monkeypatch.delitem(registry.BASES, "metric")
    module = types.SimpleNamespace(register_metric=gf.hookimpl(lambda register: register(dict)))
    registry.register_module(module, name="undeclared-kind", distribution="undeclared-dist")
    failure = registry.failures()[-1]
    assert failure.distribution == "undeclared-dist"
    assert "whose base class is not declared" in failure.error and "register_kind('metric'" in failure.error


def test_a_plugin_that_looks_the_registry_up_while_loading_is_a_failure_not_a_hang(monkeypatch):
    """An entry point whose module calls the registry at import waited forever on the lock its
    own loading held; now it is recorded as that plugin's load failure, the rest load."""
    import threading

    import gnssframework.registry as reg

    fresh = reg._Registry()

    class EntryPoint:
        name = "greedy"
        dist = type("Dist", (), {"name": "gnssframework-greedy", "version": "0.0"})()

        def load(self):
            return fresh.get("estimator", "ukf")  # what a module body calling registry.get does

    monkeypatch.setattr(reg.md, "entry_points", lambda group: [EntryPoint()])
    done = []
    worker = threading.Thread(target=lambda: done.append(fresh.ensure_loaded()), daemon=True)
    worker.start()
    worker.join(timeout=20)
    assert done, "ensure_loaded hung on its own lock"
    [failure] = fresh._failures
    assert failure.entry_point == "greedy" and "while being loaded" in failure.error
