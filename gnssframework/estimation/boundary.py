"""Boundary check of the measurement a caller hands to `FilterStep`, refused with a
library error that names it.

`FilterStep.start` checks the initial state (`gnssframework.estimation.step.check_initial`);
`FilterStep.update` checks each measurement's type and shape here. NaN/inf measurements
are left to the estimators' ``missing`` policy. A model with an indefinite ``R`` is not
refused here: it shows as a non-positive-definite innovation covariance, which the
``on_failure`` policies may recover.
"""

from __future__ import annotations

import numpy as np

from typing import Any
from collections.abc import Callable

from ..errors import InvalidArgumentError, InvalidInputError
from .linalg import to_float
from .types import Gaussian, LinearModel, NonlinearModel

__all__ = ["as_measurement", "as_sequence", "to_float", "check_argument", "checked_model_at", "check_model_functions"]


def _has(*methods: str) -> Callable[[Any], bool]:
    return lambda value: all(callable(getattr(value, m, None)) for m in methods)


def _is_gaussian(value: Any) -> bool:
    return isinstance(value, Gaussian)


def _is_model(value: Any) -> bool:
    return isinstance(value, (LinearModel, NonlinearModel)) or (callable(value) and not isinstance(value, type))


#: What each object argument of the estimation calls must be: (words for the message, test).
_ARGUMENTS: dict[str, tuple[str, Callable[[Any], bool]]] = {
    "estimator": ("an estimator plugin, e.g. gf.registry.create('estimator', 'ukf')", _has("predict", "update")),
    "adapter": (
        "a noise_adapter plugin, e.g. gf.registry.create('noise_adapter', 'innovation'), or None",
        lambda v: v is None or _has("start")(v),
    ),
    "augmentation": (
        "an augmentation plugin, e.g. gf.registry.create('augmentation', 'colored-ar1'), or None",
        lambda v: v is None or _has("apply")(v),
    ),
    "initial": ("a gf.Gaussian(mean, cov)", _is_gaussian),
    "model": ("a gf.LinearModel or gf.NonlinearModel, or a callable k -> model", _is_model),
}


def _describe(value: Any) -> str:
    text = repr(value)
    return f"{type(value).__name__} {text if len(text) <= 40 else text[:37] + '...'}"


def check_argument(value: Any, argument: str, call: str) -> None:
    """Refuse an object argument of the wrong kind (a string, None or a dict for an
    estimator, model, adapter, augmentation or initial state) with
    `InvalidArgumentError` saying what to pass, instead of an ``AttributeError`` deep in
    a filter. ``argument`` is a key of the table above, also the name in the message."""
    expected, ok = _ARGUMENTS[argument]
    if isinstance(value, type) and argument != "model":  # the plugin class, not an instance of it
        raise InvalidArgumentError(
            call,
            argument,
            f"expected {expected}; got the class {value.__name__}, not an "
            "instance: create one (gf.registry.create(kind, name, **params))",
        )
    if not ok(value):
        raise InvalidArgumentError(call, argument, f"expected {expected}; got {_describe(value)}")


def checked_model_at(model_at: Callable[[int], Any], call: str) -> Callable[[int], Any]:
    """``model_at`` (a caller's ``k -> model``) whose every result is checked to be a
    `LinearModel` or `NonlinearModel`: a callable that returns ``None`` (a missing
    ``return``) or anything else is an `InvalidArgumentError` naming the step."""

    def checked(k: int) -> LinearModel | NonlinearModel:
        try:
            model = model_at(k)
        except TypeError as exc:  # a callable of another signature
            raise InvalidArgumentError(call, "model", f"the callable k -> model failed at step {k}: {exc}") from None
        if not isinstance(model, (LinearModel, NonlinearModel)):
            raise InvalidArgumentError(
                call,
                "model",
                f"the callable returned {_describe(model)} at step {k}; expected a gf.LinearModel or gf.NonlinearModel",
            )
        return model

    return checked


def check_model_functions(model: Any, mean: np.ndarray, call: str) -> None:
    """Call a `NonlinearModel`'s ``f`` and ``h`` once on ``mean`` (the initial state) and
    refuse, naming the function, a result that is not a numeric array of the model's
    dimension (a function that returns ``None``, a missing ``return``), instead of an
    ``AttributeError`` deep in an estimator. A `LinearModel` has nothing to check."""
    if not isinstance(model, NonlinearModel):
        return
    for fn, size, what in ((model.f, model.Q.shape[-1], "f"), (model.h, model.R.shape[-1], "h")):
        try:
            out = fn(np.asarray(mean, dtype=float))
        except Exception as exc:  # noqa: BLE001 - the caller's function: say which one failed, and how
            raise InvalidArgumentError(
                call, f"model.{what}", f"failed on the initial mean: {type(exc).__name__}: {exc}"
            ) from None
        shape = getattr(out, "shape", None)
        if (
            out is None
            or shape is None
            or not shape
            or shape[-1] != size
            or getattr(out, "dtype", np.dtype(object)).kind not in "biuf"
        ):
            raise InvalidArgumentError(
                call,
                f"model.{what}",
                f"returned {_describe(out)} for the initial mean; expected a float array of shape (..., {size})",
            )


def as_sequence(zs: Any, filter_name: str) -> np.ndarray:
    """A measurement sequence as a float array, or `InvalidInputError` naming ``zs``."""
    try:
        return to_float(zs)
    except ValueError as exc:
        raise InvalidInputError(filter_name, "zs", str(exc)) from None


def as_measurement(z: Any, m: int, batch_shape: tuple[int, ...], filter_name: str, step: int) -> np.ndarray:
    """``z`` as a float array of shape ``(..., m)`` whose batch broadcasts with the state's.

    Raises
    ------
    InvalidInputError
        Naming ``measurement z``: not numeric, wrong length or a batch shape that does not
        broadcast with the state's.
    """
    try:
        z = to_float(z)
    except ValueError as exc:
        raise InvalidInputError(filter_name, "measurement z", f"{exc} at step {step}") from None
    if z.ndim < 1 or z.shape[-1] != m:
        raise InvalidInputError(
            filter_name,
            "measurement z",
            f"has shape {z.shape} at step {step}; the model's R is {m}x{m}, so z needs shape (..., {m})",
        )
    try:
        np.broadcast_shapes(z.shape[:-1], batch_shape)
    except ValueError:
        raise InvalidInputError(
            filter_name,
            "measurement z",
            f"has batch shape {z.shape[:-1]} at step {step}, which "
            f"does not broadcast with the state's batch shape {batch_shape}",
        ) from None
    out: np.ndarray = z
    return out
