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

from ..errors import InvalidInputError

__all__ = ["as_measurement"]


def as_measurement(z, m: int, batch_shape: tuple[int, ...], filter_name: str, step: int) -> np.ndarray:
    """``z`` as a float array of shape ``(..., m)`` whose batch broadcasts with the state's.

    Raises
    ------
    InvalidInputError
        Naming ``measurement z``: not numeric, wrong length or a batch shape that does not
        broadcast with the state's.
    """
    try:
        z = np.asarray(z, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(filter_name, "measurement z", f"is not numeric at step {step} ({exc})") from None
    if z.ndim < 1 or z.shape[-1] != m:
        raise InvalidInputError(filter_name, "measurement z", f"has shape {z.shape} at step {step}; "
                                f"the model's R is {m}x{m}, so z needs shape (..., {m})")
    try:
        np.broadcast_shapes(z.shape[:-1], batch_shape)
    except ValueError:
        raise InvalidInputError(filter_name, "measurement z", f"has batch shape {z.shape[:-1]} at step {step}, which "
                                f"does not broadcast with the state's batch shape {batch_shape}") from None
    return z
