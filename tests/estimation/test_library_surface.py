"""The library as a notebook user meets it: a FilterResult that says what it holds and
when, typed plugin classes beside registry.create, and shape errors naming the expected
shape."""

from __future__ import annotations

import inspect

import numpy as np
import pytest

import gnssframework as gf
import gnssframework.estimators as estimators
import gnssframework.noise_adapters as noise_adapters
from conftest import builtin_names
from gnssframework.errors import ConfigError, InvalidArgumentError, InvalidInputError
from gnssframework.estimation import Gaussian, LinearModel, filter_sequence
from gnssframework.plugin_classes import class_name

F = np.array([[1.0, 0.1], [0.0, 1.0]])
H = np.array([[1.0, 0.0]])
MODEL = LinearModel(F=F, H=H, Q=np.eye(2) * 1e-3, R=np.eye(1) * 0.25)


def _initial(batch: int) -> Gaussian:
    return Gaussian(np.zeros((batch, 2)), np.broadcast_to(np.eye(2), (batch, 2, 2)).copy())


def _zs(k: int = 20, batch: int = 5) -> np.ndarray:
    return np.random.default_rng(1).standard_normal((k, batch, 1))


def test_filter_result_repr_is_one_line_summary_with_times():
    t = 100.0 + 0.1 * np.arange(20)
    result = filter_sequence(estimators.KF(), MODEL, _zs(), _initial(5), time_s=t)
    text = repr(result)
    assert "\n" not in text and len(text) < 250
    assert text.startswith("FilterResult(20 steps, batch 5, n=2, m=1, 100 to 101.9 s")
    assert "skipped updates 0 of 100" in text
    np.testing.assert_array_equal(result.time_s, t)
    html = result._repr_html_()
    assert html.startswith("<table>") and "<td style='text-align:left'>100 to 101.9 s</td>" in html


def test_filter_result_without_times_says_it_has_epochs_only():
    result = filter_sequence(estimators.KF(), MODEL, _zs(), _initial(5), store_cov=False)
    assert result.time_s is None
    assert "epochs 0 to 19 (no time_s given)" in repr(result) and "not stored" in repr(result)


def test_missing_measurements_are_counted_in_the_summary():
    zs = _zs()
    zs[3, 2] = np.nan
    result = filter_sequence(estimators.KF(), MODEL, zs, _initial(5), missing="skip")
    assert "skipped updates 1 of 100" in repr(result)


def test_times_of_the_wrong_length_are_named():
    with pytest.raises(InvalidInputError, match=r"time_s: needs one finite time per measurement step, shape \(20,\)"):
        filter_sequence(estimators.KF(), MODEL, _zs(), _initial(5), time_s=np.arange(3.0))


def test_zs_without_its_measurement_axis_names_the_expected_shape():
    with pytest.raises(InvalidInputError) as err:
        filter_sequence(estimators.KF(), MODEL, _zs()[..., 0], _initial(5))
    assert "(K, batch, m) = (20, 5, 1): zs[..., None]" in str(err.value)
    with pytest.raises(InvalidInputError, match=r"K scalar measurements are zs\[:, None\]"):
        filter_sequence(estimators.KF(), MODEL, _zs()[:, 0, 0], _initial(1))


def test_a_name_where_an_object_is_expected_says_what_to_pass():
    with pytest.raises(InvalidArgumentError) as err:
        filter_sequence(estimators.KF(), MODEL, _zs(), _initial(5), adapter="innovation")
    assert "gf.registry.create('noise_adapter', 'innovation')" in str(err.value) and "got str 'innovation'" in str(
        err.value
    )


def test_typed_classes_are_the_registered_plugins_with_signatures():
    ukf = estimators.UKF(alpha=0.5)
    assert type(ukf) is gf.registry.get("estimator", "ukf") and ukf.params.alpha == 0.5
    assert ukf.params == gf.registry.create("estimator", "ukf", alpha=0.5).params
    signature = inspect.signature(estimators.UKF)
    assert list(signature.parameters) == list(gf.registry.get("estimator", "ukf").Params.model_fields)
    assert signature.parameters["alpha"].kind is inspect.Parameter.KEYWORD_ONLY
    assert signature.parameters["alpha"].default == gf.registry.get("estimator", "ukf").Params().alpha
    assert estimators.SVDCKF is gf.registry.get("estimator", "svd-ckf")
    assert noise_adapters.SageHusa is gf.registry.get("noise_adapter", "sage-husa")
    assert {class_name(n) for n in builtin_names("estimator")} <= set(dir(estimators))
    with pytest.raises(ConfigError, match="alpha"):
        estimators.UKF(alpha=-1.0)


def test_an_unknown_class_suggests_the_closest():
    with pytest.raises(AttributeError, match="did you mean 'UKF'"):
        estimators.UFK  # noqa: B018
