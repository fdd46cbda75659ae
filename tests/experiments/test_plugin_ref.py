"""Nested plugins as typed references: resolved and validated when the config is loaded."""

from __future__ import annotations

import pytest

import gnssframework as gf
from gnssframework.plugin_ref import PluginSpec, plugin_refs

from test_experiments import TINY, _write
from gnssframework.experiments import load_config

IQ = 'name = "iq-filter", params = { estimator = "ckf" }'


def _load(tmp_path, old, new):
    assert old in TINY
    return load_config(_write(tmp_path, TINY.replace(old, new)))


def test_a_typo_in_a_nested_discriminator_stops_load_config_with_the_path_and_the_closest(tmp_path):
    with pytest.raises(gf.ConfigError) as err:
        _load(
            tmp_path,
            '{ name = "discriminator" }',
            '{ name = "discriminator", params = { code_discriminator = "eml-envelop" } }',
        )
    msg = str(err.value)
    # One dotted path from the config's root to the nested field (issue 8: "field paths are
    # written one way").
    assert msg.startswith("candidates[0].channel_filter.params.code_discriminator: unknown discriminator 'eml-envelop'")
    assert "did you mean 'eml-envelope'?" in msg


def test_a_discriminator_in_the_wrong_unit_is_refused_naming_the_ones_that_fit():
    with pytest.raises(gf.ConfigError) as err:
        gf.registry.create("channel_filter", "scalar", phase_discriminator="atan2-fll")
    msg = str(err.value)
    assert "phase_discriminator: discriminator 'atan2-fll' does not fit: its unit is 'Hz'" in msg
    fit = msg.split("discriminators that do: ")[1].split(", ")
    assert fit == [n for n in gf.registry.names("discriminator") if gf.registry.get("discriminator", n).unit == "rad"]
    assert "costas-atan" in fit and "atan2-fll" not in fit


def test_a_nested_estimator_takes_parameters(tmp_path):
    config = _load(
        tmp_path, IQ, 'name = "iq-filter", params = { estimator = { name = "ukf", params = { alpha = 0.5 } } }'
    )
    ref = config.candidates[1].channel_filter
    plugin = gf.registry.create("channel_filter", ref.name, **ref.params)
    assert type(plugin.engine).name == "ukf" and plugin.engine.params.alpha == 0.5


def test_bad_nested_parameters_name_the_nested_field(tmp_path):
    with pytest.raises(gf.ConfigError) as err:
        _load(tmp_path, IQ, 'name = "iq-filter", params = { estimator = { name = "ukf", params = { alpha = -1 } } }')
    assert str(err.value) == (
        "candidates[1].channel_filter.params.estimator.params.alpha: Input should be greater than 0 (got -1)"
    )


def test_a_nested_parameter_beside_name_gets_the_params_hint():
    with pytest.raises(gf.ConfigError) as err:
        gf.registry.create("nav_filter", "ekf-pv", estimator={"name": "ukf", "alpha": 0.5})
    assert "params = { alpha = ... }" in str(err.value)


def test_nested_plugin_parameters_are_listed():
    assert plugin_refs(gf.registry.get("channel_filter", "scalar").Params) == {
        "code_discriminator": ("discriminator", "chips"),
        "phase_discriminator": ("discriminator", "rad"),
        "freq_discriminator": ("discriminator", "Hz"),
    }
    assert plugin_refs(gf.registry.get("channel_filter", "iq-filter").Params) == {
        "estimator": ("estimator", None),
        "adapter": ("noise_adapter", None),
        "code_discriminator": ("discriminator", "chips"),
    }


def test_a_default_name_is_resolved_too():
    plugin = gf.registry.create("nav_filter", "ekf-pv")
    assert plugin.params.estimator == PluginSpec("estimator", "ekf", {})


def test_a_linear_only_estimator_is_refused_where_the_model_is_nonlinear():
    assert gf.registry.get("estimator", "kf").linear_only
    for kind, name in (("nav_filter", "ekf-pv"), ("channel_filter", "iq-filter")):
        with pytest.raises(gf.ConfigError) as err:
            gf.registry.create(kind, name, estimator="kf")
        msg = str(err.value)
        assert "estimator 'kf' does not fit: it is linear-only" in msg
        fit = msg.split("estimators that do: ")[1].split(", ")
        assert "kf" not in fit and {"ekf", "ukf", "ckf"} <= set(fit)


def test_a_candidate_component_may_be_a_bare_name_like_a_nested_reference(tmp_path):
    bare = _load(tmp_path, 'channel_filter = { name = "discriminator" }', 'channel_filter = "discriminator"')
    table = load_config(_write(tmp_path, TINY, "table.toml"))
    # One reference type: a candidate's plugin is a PluginSpec, as a nested reference is.
    assert bare.candidates[0].channel_filter == PluginSpec("channel_filter", "discriminator", {})
    assert bare.model_dump()["candidates"][0]["channel_filter"] == {"name": "discriminator", "params": {}}
    assert bare.identity() == table.identity()  # the same comparison, the same stored results
    with pytest.raises(gf.ConfigError) as err:
        _load(tmp_path, 'channel_filter = { name = "discriminator" }', 'channel_filter = "discriminatr"')
    assert str(err.value).startswith("candidates[0].channel_filter.name: ") and "'discriminator'" in str(err.value)


def test_the_json_schema_takes_a_bare_name_and_refuses_an_unknown_one():
    import jsonschema  # test-only oracle: an independent JSON-schema validator
    import tomllib

    from gnssframework.config_schema import comparison_schema

    validator = jsonschema.Draft202012Validator(comparison_schema())
    data = tomllib.loads(
        TINY.replace('channel_filter = { name = "discriminator" }', 'channel_filter = "discriminator"')
    )
    assert not list(validator.iter_errors(data))
    data["candidates"][0]["channel_filter"] = "discriminatr"
    assert list(validator.iter_errors(data))


def test_a_nested_adapter_takes_its_own_window_over_the_owners(tmp_path):
    # It used to crash with a raw TypeError (the window passed twice), at load_config.
    config = _load(
        tmp_path,
        IQ,
        'name = "iq-filter", params = { window = 30, adapter = { name = "innovation", params = { window = 5 } } }',
    )
    ref = config.candidates[1].channel_filter
    assert gf.registry.create("channel_filter", ref.name, **ref.params).adapter.params.window == 5
    assert gf.registry.create("channel_filter", "iq-filter", window=30).adapter.params.window == 30


def test_a_nested_value_the_harness_owns_must_agree_with_it():
    """The owner's harness value is used; a nested parameter that says otherwise is refused,
    naming it, instead of being silently replaced."""
    ctx = gf.RunContext(coherent_time_s=0.001, early_late_spacing_chips=1.0)
    loop = gf.registry.create(
        "channel_filter", "scalar", phase_discriminator={"name": "costas-atan", "params": {"coherent_time_s": 0.02}}
    )
    with pytest.raises(gf.ConfigError) as err:
        loop.reset((1,), ctx)
    assert str(err.value).startswith(
        "discriminator 'costas-atan'.coherent_time_s: is 0.02 but its owner runs with 0.001"
    )
    same = gf.registry.create(
        "channel_filter", "scalar", phase_discriminator={"name": "costas-atan", "params": {"coherent_time_s": 0.001}}
    )
    same.reset((1,), ctx)
    assert same.phase_disc.params.coherent_time_s == 0.001
    loop = gf.registry.create("channel_filter", "scalar")
    loop.reset((1,), gf.RunContext(coherent_time_s=0.004, early_late_spacing_chips=0.5))
    assert loop.phase_disc.params.coherent_time_s == 0.004  # unset: the harness's value
    assert loop.dll.disc.params.early_late_spacing_chips == 0.5


def test_recreated_changes_only_the_named_parameters_and_keeps_nested_references():
    from gnssframework import registry
    from gnssframework.plugin_ref import recreated

    loop = registry.create("channel_filter", "kf-carrier-loop", q=[0.01, 0.1], r=5.0, angle_unit="deg")
    fast = recreated(loop, r=1.0)
    assert fast is not loop and fast.params.r == 1.0 and loop.params.r == 5.0
    rest = lambda p: {k: v for k, v in p.model_dump().items() if k != "r"}  # noqa: E731
    assert rest(fast.params) == rest(loop.params)
    # A nested plugin reference comes back as the same reference with its own parameters.
    iq = registry.create("channel_filter", "iq-filter", estimator={"name": "ukf", "params": {"alpha": 0.5}})
    wider = recreated(iq, window=40)
    assert wider.params.window == 40 and iq.params.window != 40
    assert (wider.params.estimator.name, wider.params.estimator.params) == ("ukf", {"alpha": 0.5})
