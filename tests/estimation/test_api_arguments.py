"""The library API refuses objects of the wrong kind at its boundaries (filter_sequence,
FilterStep) with a library error saying what to pass, refuses an empty batch, and a
sequential filter's checked_step before reset."""

from __future__ import annotations

import numpy as np
import pytest

import gnssframework as gf
from conftest import create

F = np.array([[1.0, 1.0], [0.0, 1.0]])
MODEL = gf.LinearModel(F, np.array([[1.0, 0.0]]), 0.01 * np.eye(2), np.eye(1))
INITIAL = gf.Gaussian(np.zeros((3, 2)), np.eye(2))
ZS = np.zeros((4, 3, 1))
WRONG = ["ukf", None, {"name": "ukf"}]


def _arguments(**change):
    args = {
        "estimator": create("estimator", "kf"),
        "model": MODEL,
        "zs": ZS,
        "initial": INITIAL,
        "adapter": None,
        "augmentation": None,
    }
    return {**args, **change}


def test_the_fixture_arguments_filter():
    res = gf.filter_sequence(**_arguments())
    assert res.mean.shape == (4, 3, 2)


@pytest.mark.parametrize(
    "argument, expected",
    [
        ("estimator", "expected an estimator plugin, e.g. gf.registry.create('estimator', 'ukf')"),
        ("model", "expected a gf.LinearModel or gf.NonlinearModel, or a callable k -> model"),
        ("initial", "expected a gf.Gaussian(mean, cov)"),
    ],
)
@pytest.mark.parametrize("value", WRONG, ids=["str", "None", "dict"])
def test_filter_sequence_names_an_object_argument_of_the_wrong_kind(argument, expected, value):
    with pytest.raises(gf.InvalidArgumentError) as err:
        gf.filter_sequence(**_arguments(**{argument: value}))
    assert isinstance(err.value, TypeError)  # what Python code expects of a wrong type
    assert str(err.value) == f"filter_sequence: {argument}: {expected}; got {type(value).__name__} {value!r}"


@pytest.mark.parametrize("argument", ["adapter", "augmentation"])
@pytest.mark.parametrize("value", ["innovation", {"name": "innovation"}], ids=["str", "dict"])
def test_filter_sequence_names_an_adapter_or_augmentation_of_the_wrong_kind(argument, value):
    with pytest.raises(gf.InvalidArgumentError, match=rf"^filter_sequence: {argument}: expected an? .* or None; got "):
        gf.filter_sequence(**_arguments(**{argument: value}))


def test_a_long_wrong_value_is_shortened_in_the_message():
    with pytest.raises(gf.InvalidArgumentError) as err:
        gf.filter_sequence(**_arguments(estimator="x" * 200))
    message = str(err.value)
    shown = message.split("got str ")[1]
    assert shown.startswith("'xxx") and shown.endswith("x...") and len(shown) == 40


@pytest.mark.parametrize("value", WRONG, ids=["str", "None", "dict"])
def test_filter_step_names_an_estimator_of_the_wrong_kind(value):
    with pytest.raises(gf.InvalidArgumentError, match=r"^FilterStep: estimator: expected an estimator plugin"):
        gf.FilterStep(value)


def test_filter_step_names_an_adapter_of_the_wrong_kind():
    with pytest.raises(gf.InvalidArgumentError, match=r"^FilterStep: adapter: expected a noise_adapter plugin"):
        gf.FilterStep(create("estimator", "kf"), "innovation")


@pytest.mark.parametrize("argument, value", [("initial", {"mean": [0, 0]}), ("initial", None), ("model", "MODEL")])
def test_filter_step_start_names_a_state_or_model_of_the_wrong_kind(argument, value):
    step = gf.FilterStep(create("estimator", "kf"))
    args = {"initial": INITIAL, "model": MODEL, argument: value}
    with pytest.raises(gf.InvalidArgumentError, match=rf"^kf: FilterStep.start: {argument}: expected "):
        step.start(args["initial"], args["model"])


@pytest.mark.parametrize("where, shape", [("zs", (4, 0, 1)), ("initial", (0, 2))])
def test_an_empty_batch_is_refused_not_returned_as_an_empty_result(where, shape):
    args = (
        _arguments(zs=np.zeros(shape))
        if where == "zs"
        else _arguments(initial=gf.Gaussian(np.zeros(shape), np.eye(2)), zs=np.zeros((4, 0, 1)))
    )
    with pytest.raises(gf.InvalidInputError, match=r"has an empty batch \(shape .*\): there is nothing to filter"):
        gf.filter_sequence(**args)


def test_filter_step_start_refuses_an_empty_batch():
    with pytest.raises(gf.InvalidInputError, match=r"^kf: initial mean: has an empty batch \(shape \(0, 2\)\)"):
        gf.FilterStep(create("estimator", "kf")).start(gf.Gaussian(np.zeros((0, 2)), np.eye(2)), MODEL)


def test_checked_step_before_reset_says_to_reset_first():
    hatch = gf.registry.create("channel_filter", "hatch", window=10)
    inputs = {"pseudorange_m": np.array([2.0e7]), "carrier_m": np.array([2.0e7])}
    with pytest.raises(gf.InvalidArgumentError) as err:
        hatch.checked_step(inputs)
    assert str(err.value) == (
        "channel_filter 'hatch': checked_step: called before reset(batch_shape, context); call reset first"
    )
    hatch.reset((1,), gf.RunContext(epoch_interval_s=1.0))
    assert np.isfinite(hatch.checked_step(inputs)["smoothed_m"]).all()


def test_a_subclass_that_overrides_reset_is_marked_too():
    class Louder(type(gf.registry.create("channel_filter", "hatch"))):
        name = "louder-hatch"

        def reset(self, batch_shape, context):
            super().reset(batch_shape, context)

    loud = Louder(window=10)
    with pytest.raises(gf.InvalidArgumentError):
        loud.checked_step({"pseudorange_m": np.array([2.0e7]), "carrier_m": np.array([2.0e7])})
    loud.reset((1,), gf.RunContext(epoch_interval_s=1.0))
    assert "smoothed_m" in loud.checked_step({"pseudorange_m": np.array([2.0e7]), "carrier_m": np.array([2.0e7])})
