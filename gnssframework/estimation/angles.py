"""Angle-aware residuals and means: the hooks of a model with angle states or measurements.

A bearing of +179° predicted for a measured -179° is 2° off, not 358°; the mean of sigma
points at +179° and -179° is 180°, not 0°. A `NonlinearModel` takes four optional hooks,
as FilterPy's ``residual_x``/``residual_z`` and ``x_mean_fn``/``z_mean_fn`` (Labbe 2015,
ch. 10) and Stone Soup's ``Bearing`` type do:

``residual_z(a, b)``
    ``a - b`` of measurements ``(..., m)``: every innovation ``z - z_hat`` and every
    sigma point's deviation from the predicted measurement.
``residual_x(a, b)``
    ``a - b`` of states ``(..., n)``: the sigma points' deviations from a mean.
``mean_z(points, weights)`` and ``mean_x(points, weights)``
    The weighted mean of points ``(N, ..., d)`` with weights ``(N,)`` (sigma-point
    engines; the EKF needs no mean).

`angle_residual` and `angle_mean` build them for the components that are angles (radians);
a model with a hook runs on the NumPy path (the compiled kernels subtract and average
linearly). The posterior mean is ``x + K residual_z(z, z_hat)``: wrap an angle state in
``f`` if it must stay in ``(-pi, pi]``.

Examples
--------
>>> res = angle_residual(0)
>>> float(res(np.array([np.pi - 0.01]), np.array([-np.pi + 0.01]))[0].round(6))
-0.02
>>> mean = angle_mean(0)
>>> abs(float(mean(np.array([[np.pi - 0.1], [-np.pi + 0.1]]), np.array([0.5, 0.5]))[0]))
3.141592653589793
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

__all__ = ["wrap_angle", "angle_residual", "angle_mean", "Residual", "WeightedMean"]

Residual = Callable[[np.ndarray, np.ndarray], np.ndarray]
WeightedMean = Callable[[np.ndarray, np.ndarray], np.ndarray]


def wrap_angle(x_rad: np.ndarray) -> np.ndarray:
    """Angles wrapped into ``[-pi, pi)``.

    Examples
    --------
    >>> wrap_angle(np.array([3 * np.pi / 2, -3 * np.pi / 2])).round(4).tolist()
    [-1.5708, 1.5708]
    """
    return (np.asarray(x_rad, dtype=float) + np.pi) % (2 * np.pi) - np.pi


def angle_residual(*indices: int) -> Residual:
    """``a - b`` with the components ``indices`` (angles, rad) wrapped into ``[-pi, pi)``."""
    picked = list(indices)

    def residual(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        d: np.ndarray = np.asarray(a, dtype=float) - np.asarray(b, dtype=float)
        d[..., picked] = wrap_angle(d[..., picked])
        return d

    return residual


def angle_mean(*indices: int) -> WeightedMean:
    """Weighted mean over the first axis of points ``(N, ..., d)``: linear for most
    components, circular (``atan2`` of the weighted sines and cosines) for ``indices``."""
    picked = list(indices)

    def mean(points: np.ndarray, weights: np.ndarray) -> np.ndarray:
        p = np.asarray(points, dtype=float)
        w = np.asarray(weights, dtype=float).reshape((-1,) + (1,) * (p.ndim - 1))
        out: np.ndarray = np.sum(w * p, axis=0)
        angles = p[..., picked]
        out[..., picked] = np.arctan2(np.sum(w * np.sin(angles), axis=0), np.sum(w * np.cos(angles), axis=0))
        return out

    return mean
