"""Each built-in plugin's docs page shows its parameter table (docs/hooks/plugin_params.py)."""

from __future__ import annotations

import importlib.util
import pathlib

import gnssframework as gf

DOCS = pathlib.Path(__file__).resolve().parents[2] / "docs"


def _hook():
    spec = importlib.util.spec_from_file_location("plugin_params_hook", DOCS / "hooks" / "plugin_params.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_hook_puts_the_table_after_the_directive_and_its_options():
    page = "# `ukf`\n\n::: plugins.estimators.UnscentedKalmanFilter\n    options:\n      show_root_heading: false\n\nAfter."
    out = _hook().on_page_markdown(page, None, None, None).split("\n")
    heading = out.index("## Parameters of `ukf`")
    assert out[heading - 2] == "      show_root_heading: false"  # the options block stays whole
    assert "| `alpha` | float | `0.001` | > 0 |" in "\n".join(out[heading:])  # no upper bound: FilterPy takes alpha > 1
    assert out[-1] == "After."


def test_hook_leaves_pages_without_a_plugin_directive_alone():
    page = "::: gnssframework.estimation.step\n\ntext"
    assert _hook().on_page_markdown(page, None, None, None) == page


def test_every_built_in_plugin_has_a_page_that_gets_its_table():
    text = "\n".join(p.read_text() for p in DOCS.rglob("*.md"))
    missing = []
    for info in gf.registry.describe():
        module = info.cls.__module__
        if not module.startswith("gnssframework_plugins."):
            continue
        directive = f"::: plugins.{module.removeprefix('gnssframework_plugins.')}.{info.cls.__qualname__}"
        if directive not in text:
            missing.append(f"{info.kind} {info.name!r}: add a docs page with `{directive}`")
    assert not missing, "\n".join(missing)


def test_the_tutorial_lists_every_nested_plugin_parameter_of_the_built_ins():
    """The table of nested references is generated into the tutorial, so it holds every
    built-in PluginRef parameter with its kind and unit (a hand-written table had fallen
    behind: iq-filter's code_discriminator and position-ca's estimator were missing)."""
    from gnssframework.plugin_ref import plugin_refs

    hook = _hook()
    page = (DOCS / "tutorial" / "from-plugin-to-comparison.md").read_text()
    assert hook.NESTED_MARKER in page
    rendered = hook.on_page_markdown(page, None, None, None)
    table = rendered.split("| plugin | kind | nested parameter | default | takes |")[1].split("\n\n")[0]
    rows = {
        tuple(c.strip().strip("`") for c in line.strip("|").split("|"))
        for line in table.splitlines()
        if line.startswith("| `")
    }
    expected = set()
    for info in gf.registry.describe():
        if info.distribution != "gnssframework":
            continue
        for field, (kind, unit) in plugin_refs(info.cls.Params).items():
            expected.add((info.name, field))
            row = next(r for r in rows if r[0] == info.name and r[2] == field)
            assert row[4].startswith(kind) and (unit is None or f"unit '{unit}'" in row[4]), row
    assert {(r[0], r[2]) for r in rows} == expected
    assert ("iq-filter", "code_discriminator") in expected and ("position-ca", "estimator") in expected
    ekf = next(r for r in rows if r[0] == "ekf-pv")
    assert ekf[3] == "ekf" and "handles nonlinear models" in ekf[4]
