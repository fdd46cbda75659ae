"""Issue 38: parameters that give a silent wrong number are refused at load, naming the
field: a number beyond what a filter's arithmetic holds (q0 = 1e300 gave an error RMS of
1e136), a boolean inside a number list (read as 1.0), a non-finite value (dt_s = inf), a
claim that can never hold (ratio_min > ratio_max). Each was accepted on main."""

from __future__ import annotations

import pytest

from gnssframework import registry
from gnssframework.errors import ConfigError
from gnssframework.experiments import load_config

from two_candidates import two_candidate_config


def _load(tmp_path, text):
    path = tmp_path / "c.toml"
    path.write_text(text)
    return load_config(path)


def _with_a_params(params: str) -> str:
    return two_candidate_config("p").replace(
        'nav_filter = { name = "position-ca" }\nestimator = { name = "kf" }',
        f'nav_filter = {{ name = "position-ca", params = {{ {params} }} }}\nestimator = {{ name = "kf" }}',
        1,
    )


@pytest.mark.parametrize(
    "params, field, says",
    [
        ("q0 = [1e300, 0.1, 0.01]", "candidates[0].nav_filter.params.q0[0]", "beyond"),
        ("q0 = [1.0, true, 0.01]", "candidates[0].nav_filter.params.q0[1]", "not a bool"),
        ("dt_s = inf", "candidates[0].nav_filter.params.dt_s", "finite"),
        ("r0 = nan", "candidates[0].nav_filter.params.r0", "finite"),
    ],
)
def test_filter_parameters_that_overflow_or_convert_are_refused(tmp_path, params, field, says):
    text = _with_a_params(params)
    assert params in text
    with pytest.raises(ConfigError) as err:
        _load(tmp_path, text)
    assert str(err.value).startswith(field) and says in str(err.value), str(err.value)


def test_plain_values_still_load(tmp_path):
    config = _load(tmp_path, _with_a_params("q0 = [2.0, 0.5, 1], dt_s = 0.5"))
    assert config.candidates[0].nav_filter.params["q0"] == [2.0, 0.5, 1]


def test_the_library_refuses_them_too():
    with pytest.raises(ConfigError, match=r"q0\[0\].*beyond"):
        registry.create("nav_filter", "position-ca", q0=[1e300, 0.1, 0.01])
    with pytest.raises(ConfigError, match=r"dt_s.*finite"):
        registry.create("nav_filter", "position-ca", dt_s=float("inf"))


def test_a_scenario_interval_must_be_finite(tmp_path):
    text = two_candidate_config("p", top="").replace('kind = "multipath"', 'kind = "multipath"\ndt_s = inf')
    with pytest.raises(ConfigError, match="dt_s.*finite"):
        _load(tmp_path, text)


@pytest.mark.parametrize(
    "bounds, says", [("ratio_min = 0.9\nratio_max = 0.5", "could never hold"), ("ratio_max = inf", "finite")]
)
def test_a_claim_that_can_never_hold_is_refused(tmp_path, bounds, says):
    claim = f'[[claims]]\ncandidate = "a"\nreference = "b"\nmetric = "lat_error_rmse"\n{bounds}\n'
    with pytest.raises(ConfigError) as err:
        _load(tmp_path, two_candidate_config("p", claims=claim))
    assert "claims[0]" in str(err.value) and says in str(err.value), str(err.value)
