"""A parameter whose config name is no Python identifier (``lambda``) is a field with an
alias: a config and Python both reach it, and errors, --describe and the schema name it
the config's way."""

from __future__ import annotations

import types

import pytest
from pydantic import Field

import gnssframework as gf
from gnssframework.cli import main
from gnssframework.config_schema import plugin_ref_schema
from gnssframework.errors import ConfigError
from gnssframework.plugin import PluginParams

KF = gf.registry.get("estimator", "kf")


class _FadingParams(PluginParams):
    lam: float = Field(1.0, gt=0, le=1, alias="lambda", description="forgetting factor")


class FadingKF(KF):
    """A Kalman filter with a forgetting factor (only its parameters matter here)."""

    name = "fading-alias"
    description = "Kalman filter with a forgetting factor lambda"
    Params = _FadingParams


@pytest.fixture
def fading(scratch_registry):
    module = types.SimpleNamespace(register_estimator=gf.hookimpl(lambda register: register(FadingKF)))
    scratch_registry.register_module(module, "fading-alias")
    return FadingKF


def test_config_name_and_python_name_both_set_the_parameter(fading):
    assert gf.registry.create("estimator", "fading-alias", **{"lambda": 0.9}).params.lam == 0.9
    assert gf.registry.create("estimator", "fading-alias", lam=0.8).params.lam == 0.8
    assert fading(lam=0.7).params.lam == 0.7


@pytest.mark.parametrize("given", [{"lambda": 2.0}, {"lam": 2.0}])
def test_errors_name_the_config_name_either_way(fading, given):
    with pytest.raises(ConfigError) as err:
        gf.registry.create("estimator", "fading-alias", **given)
    assert err.value.field.endswith(".lambda") and "less than or equal to 1" in str(err.value)


def test_an_unknown_parameter_lists_and_suggests_the_config_name(fading):
    with pytest.raises(ConfigError) as err:
        gf.registry.create("estimator", "fading-alias", lamda=0.5)
    assert "valid: lambda; did you mean 'lambda'?" in str(err.value)


def test_a_string_for_the_number_is_refused_under_the_config_name(fading):
    with pytest.raises(ConfigError, match=r"lambda: must be a number"):
        gf.registry.create("estimator", "fading-alias", **{"lambda": "0.5"})


def test_describe_and_schema_name_it_lambda(fading, capsys):
    assert main(["plugins", "--describe", "fading-alias"]) == 0
    out = capsys.readouterr().out
    assert "| `lambda` | float | `1.0` | > 0, <= 1 | forgetting factor (Python keyword: lam) |" in out
    schema = plugin_ref_schema("estimator")
    text = str(schema)
    assert "'lambda'" in text and "'lam'" not in text
