"""Each built-in plugin's docs page shows its parameter table (docs/hooks/plugin_params.py)."""

from __future__ import annotations

import importlib.util
import pathlib

import gnssframework as gf

DOCS = pathlib.Path(__file__).resolve().parents[1] / "docs"


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
    assert "| `alpha` | float | `0.001` | > 0, <= 1 |" in "\n".join(out[heading:])
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
