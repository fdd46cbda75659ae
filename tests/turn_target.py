"""A 2-D constant-turn target ``[x, y, vx, vy]``, the third-party model of the compiled
path's tests (`test_compiled_seam`, `test_driver_identity`): its NumPy transition, two
jitted twins and a random batch of priors.

`turn_f` is the tutorial's form (``params = [[dt, omega]]``, sine and cosine taken
inside); `turn_row` takes them from ``params = [[sin, cos, omega]]`` (computed once, in
Python), so that it and `turn` do the same +, -, *, / in the same order: bitwise the
same images, which `test_driver_identity` relies on.
"""

from __future__ import annotations

import math

import numpy as np

from gnssframework import backend
from gnssframework.estimation import Gaussian

OMEGA, DT = 0.2, 0.1
SIN, COS = float(np.sin(OMEGA * DT)), float(np.cos(OMEGA * DT))
SENSOR = (-50.0, 20.0)
Q = np.diag([0.01, 0.01, 0.1, 0.1])


@backend.jit
def turn_f(params, X, k, Y):
    """Constant turn of [x, y, vx, vy] over params[0, 0] seconds at params[0, 1] rad/s."""
    dt, w = params[0, 0], params[0, 1]
    s, c = math.sin(w * dt), math.cos(w * dt)
    x, y, vx, vy = X[k, 0], X[k, 1], X[k, 2], X[k, 3]
    Y[k, 0] = x + (s * vx - (1.0 - c) * vy) / w
    Y[k, 1] = y + ((1.0 - c) * vx + s * vy) / w
    Y[k, 2] = c * vx - s * vy
    Y[k, 3] = s * vx + c * vy


@backend.jit
def turn_row(params, X, k, Y):
    """`turn_f` with ``params = [[sin, cos, omega]]``."""
    s, c, w = params[0, 0], params[0, 1], params[0, 2]
    x, y, vx, vy = X[k, 0], X[k, 1], X[k, 2], X[k, 3]
    Y[k, 0] = x + (s * vx - (1.0 - c) * vy) / w
    Y[k, 1] = y + ((1.0 - c) * vx + s * vy) / w
    Y[k, 2] = c * vx - s * vy
    Y[k, 3] = s * vx + c * vy


def turn(x: np.ndarray) -> np.ndarray:
    """The NumPy transition, batch-first: ``x`` ``(..., 4)``."""
    px, py, vx, vy = np.moveaxis(x, -1, 0)
    return np.stack(
        [
            px + (SIN * vx - (1.0 - COS) * vy) / OMEGA,
            py + ((1.0 - COS) * vx + SIN * vy) / OMEGA,
            COS * vx - SIN * vy,
            SIN * vx + COS * vy,
        ],
        axis=-1,
    )


TURN_F = turn(np.eye(4)).T  # the transition is linear: columns are the images of the unit vectors


def prior(batch: int, rng: np.random.Generator) -> Gaussian:
    """``batch`` priors near (100, 40) m moving at (3, -1) m/s, random PD covariances."""
    mean = np.array([100.0, 40.0, 3.0, -1.0]) + rng.standard_normal((batch, 4))
    A = rng.standard_normal((batch, 4, 4))
    return Gaussian(mean, A @ np.swapaxes(A, -1, -2) * 0.1 + np.eye(4))
