"""Generated documentation stays in step with the code."""

import importlib.util
import pathlib

ROOT = pathlib.Path(__file__).resolve().parents[2]


def test_config_reference_page_is_up_to_date():
    spec = importlib.util.spec_from_file_location("gen", ROOT / "docs" / "gen_config_reference.py")
    gen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen)
    committed = (ROOT / "docs" / "experiments" / "config-reference.md").read_text()
    assert committed == gen.render(), "run: python docs/gen_config_reference.py"


def test_plugin_parameter_page_is_up_to_date():
    spec = importlib.util.spec_from_file_location("gen_params", ROOT / "docs" / "gen_plugin_parameters.py")
    gen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen)
    committed = (ROOT / "docs" / "api" / "plugin-parameters.md").read_text()
    assert committed == gen.render(), "run: python docs/gen_plugin_parameters.py"
