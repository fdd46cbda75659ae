"""Issue 38: library calls that got the wrong thing fail with one library error saying
what was expected, never an AttributeError/TypeError/KeyError from deep inside (each
case below raised a raw Python error on main), and a masked array's mask is honoured."""

from __future__ import annotations

import numpy as np
import pytest

import gnssframework as gf
from gnssframework import registry
from gnssframework.errors import ConfigError, InvalidArgumentError, InvalidInputError, InvalidMeasurementError
from gnssframework.interfaces import RunContext

F = np.array([[1.0, 1.0], [0.0, 1.0]])
MODEL = gf.LinearModel(F, np.array([[1.0, 0.0]]), 0.01 * np.eye(2), np.eye(1))
INITIAL = gf.Gaussian(np.zeros(2), np.eye(2))
ZS = np.zeros((5, 1))


def test_a_positional_parameter_to_create_is_named():
    with pytest.raises(ConfigError, match=r"estimator 'ukf': parameters are keywords.*0.5.*alpha"):
        registry.create("estimator", "ukf", 0.5)


def test_an_estimator_class_instead_of_an_instance_is_named():
    with pytest.raises(InvalidArgumentError, match=r"estimator: .*got the class KalmanFilter, not an instance"):
        gf.filter_sequence(registry.get("estimator", "kf"), MODEL, ZS, INITIAL)


@pytest.mark.parametrize("returned", [None, "x", 3.0])
def test_a_model_callable_returning_no_model_is_named_with_its_step(returned):
    def model_at(k):
        return MODEL if k < 2 else returned

    with pytest.raises(InvalidArgumentError, match=r"model: the callable returned .* at step 2"):
        gf.filter_sequence(registry.create("estimator", "kf"), model_at, ZS, INITIAL)


@pytest.mark.parametrize("name", ["ekf", "ukf", "ckf"])
def test_a_nonlinear_function_returning_none_is_named(name):
    model = gf.NonlinearModel(lambda x: None, lambda x: x[..., :1], 0.01 * np.eye(2), np.eye(1))
    with pytest.raises(InvalidArgumentError, match=r"model.f: returned NoneType None"):
        gf.filter_sequence(registry.create("estimator", name), model, ZS, INITIAL)
    model = gf.NonlinearModel(lambda x: x, lambda x: x, 0.01 * np.eye(2), np.eye(1))  # h of the wrong size
    with pytest.raises(InvalidArgumentError, match=r"model.h: .*shape \(\.\.\., 1\)"):
        gf.filter_sequence(registry.create("estimator", name), model, ZS, INITIAL)


def test_a_masked_measurement_is_missing_not_its_hidden_value():
    zs = np.ma.masked_array(np.ones((5, 1)), mask=np.zeros((5, 1), bool))
    zs.data[2] = 1e6  # hidden under the mask: must not reach the filter
    zs.mask[2] = True
    kf = registry.create("estimator", "kf")
    with pytest.raises(InvalidMeasurementError, match="step 2"):  # missing, under the default missing="raise"
        gf.filter_sequence(kf, MODEL, zs, INITIAL)
    skipped = gf.filter_sequence(kf, MODEL, zs, INITIAL, missing="skip")
    plain = np.ones((5, 1))
    plain[2] = np.nan
    expect = gf.filter_sequence(kf, MODEL, plain, INITIAL, missing="skip")
    assert skipped.skipped[2].all() and np.array_equal(skipped.mean, expect.mean)
    assert np.abs(skipped.mean).max() < 10


def _smoother():
    filt = registry.create("channel_filter", "hatch")
    filt.reset((1,), RunContext())
    return filt


@pytest.mark.parametrize(
    "inputs, says",
    [
        (
            {"pseudorange_m": np.array(["2e7"]), "carrier_m": np.array([1.0])},
            "inputs['pseudorange_m']: must be numbers",
        ),
        ({"pseudorange_m": "2e7", "carrier_m": np.array([1.0])}, "inputs['pseudorange_m']: must be numbers"),
        ({"pseudorange_m": np.array([2e7])}, "inputs['carrier_m']: missing"),
    ],
)
def test_a_smoothers_bad_inputs_are_named(inputs, says):
    with pytest.raises(InvalidInputError) as err:
        _smoother().checked_step(inputs)
    assert "channel_filter 'hatch'" in str(err.value) and says in str(err.value), str(err.value)


def test_a_smoother_reads_a_masked_epoch_as_missing():
    masked = _smoother()
    plain = _smoother()
    for k in range(3):
        code = np.ma.masked_array([2e7 + k], mask=[k == 1])
        code.data[:] = 2e7 + k if k != 1 else 9e9
        a = masked.checked_step({"pseudorange_m": code, "carrier_m": np.array([float(k)])})
        b = plain.checked_step(
            {"pseudorange_m": np.array([2e7 + k if k != 1 else np.nan]), "carrier_m": np.array([float(k)])}
        )
        assert np.array_equal(a["smoothed_m"], b["smoothed_m"], equal_nan=True)
