"""Config and registration messages: unknown parameters, misplaced parameters, cross-field
rules, one way of writing field paths, classes with abstract methods left."""

from __future__ import annotations

import types

import pytest

import gnssframework as gf
from gnssframework.experiments import load_config
from gnssframework.plugin import field_path

from test_errors_transport import TINY

GOOD = TINY.replace('{ name = "NAME" }', '{ name = "ekf-pv" }')


def _load(tmp_path, text):
    path = tmp_path / "c.toml"
    path.write_text(text)
    return load_config(path)


def test_the_fixture_config_loads(tmp_path):
    assert _load(tmp_path, GOOD).candidates[0].nav_filter.name == "ekf-pv"


def test_parameter_beside_name_gets_a_hint_to_put_it_under_params(tmp_path):
    text = GOOD.replace('{ name = "ekf-pv" }', '{ name = "ekf-pv", clock = "ocxo" }')
    with pytest.raises(gf.ConfigError) as err:
        _load(tmp_path, text)
    msg = str(err.value)
    assert msg.startswith("candidates[0].nav_filter.clock: unknown parameter; valid: name, params")
    assert "params = { clock = ... }" in msg


def test_unknown_plugin_parameter_lists_the_valid_ones():
    with pytest.raises(gf.ConfigError) as err:
        gf.registry.create("estimator", "ukf", alpha=0.5, kapa=0.0)
    msg = str(err.value)
    assert "kapa: unknown parameter; valid: " in msg
    valid = msg.split("valid: ")[1].split("; ")[0].split(", ")
    assert set(valid) == set(gf.registry.get("estimator", "ukf").Params.model_fields)
    assert "kappa" in valid and msg.endswith("; did you mean 'kappa'?")


def test_unknown_top_level_field_lists_the_valid_ones(tmp_path):
    with pytest.raises(gf.ConfigError) as err:
        _load(tmp_path, "rnus = 3\n" + GOOD)
    assert str(err.value).startswith("rnus: unknown parameter; valid: ")
    assert "runs" in str(err.value) and "batch_size" in str(err.value)


@pytest.mark.parametrize(
    "change, message",
    [
        (("settle_s = 0.05", "settle_s = 0.2"), "scenario.settle_s: must be less than duration_s = 0.2 (got 0.2)"),
        (("settle_s = 0.05", "settle_s = 5.0"), "scenario.settle_s: must be less than duration_s = 0.2 (got 5.0)"),
        (("duration_s = 0.2", "duration_s = 0.005"), "scenario.settle_s: must be less than duration_s = 0.005"),
    ],
)
def test_cross_field_rules_are_validated(tmp_path, change, message):
    with pytest.raises(gf.ConfigError) as err:
        _load(tmp_path, GOOD.replace(*change))
    assert str(err.value).startswith(message)


def test_field_paths_use_brackets_for_indices_everywhere(tmp_path):
    with pytest.raises(gf.ConfigError) as err:
        _load(tmp_path, GOOD.replace('name = "c45"', 'name = "c 45"'))
    assert str(err.value).startswith("cases[0].name: ")
    assert field_path(("a", 0, "b", 2)) == "a[0].b[2]"


def test_registration_refuses_a_class_with_abstract_methods_left_naming_them(scratch_registry):
    class HalfDone(gf.Discriminator):
        name = "half-done"
        unit = "chips"

        def __call__(self, current, previous=None):
            return current.prompt.real

    module = types.SimpleNamespace(register_discriminator=gf.hookimpl(lambda register: register(HalfDone)))
    gf.registry.register_module(module, name="test-half-done")
    assert "half-done" not in gf.registry.names("discriminator")
    [failure] = [f for f in gf.registry.failures() if f.entry_point == "test-half-done"]
    assert "leaves abstract methods unimplemented: noise_variance" in failure.error


def test_several_invalid_fields_are_named_on_one_line_the_first_leading():
    with pytest.raises(gf.ConfigError) as err:
        gf.registry.create("estimator", "ukf", alpha=-5.0, kapa=0.0)
    msg = str(err.value)
    assert "\n" not in msg
    assert err.value.field in ("estimator 'ukf'.alpha", "estimator 'ukf'.kapa")
    assert "alpha: Input should be greater than" in msg and "kapa: unknown parameter" in msg and "; also " in msg
