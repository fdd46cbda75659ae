"""Explicit state, update and model types of the estimation core.

Everything is batch-first: a mean is ``(..., n)``, a covariance ``(..., n, n)``, a
measurement ``(..., m)``. The leading dimensions are channels, Monte Carlo runs or
both, and one call advances them all.

Model functions ``f`` and ``h`` must broadcast over *any* leading dimensions: sigma-point
engines evaluate them on arrays shaped ``(N, ..., n)`` whose first axis holds the N
sigma points, and numerical Jacobians on ``(n, ..., n)``. A per-element parameter held
in a closure (shape ``(..., k)``) therefore broadcasts from the right, as numpy does.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from collections.abc import Callable

from typing import Any

import numpy as np

from ..errors import ConfigError
from .compiled_model import CompiledFunctions, linear_f, linear_h, linear_h_jacobian
from .linalg import mat_vec, to_float

__all__ = [
    "Gaussian",
    "Update",
    "LinearModel",
    "NonlinearModel",
    "Model",
    "CompiledFunctions",
    "numerical_jacobian",
    "residual_hook",
]

ArrayFn = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class Gaussian:
    """A batch of Gaussian densities N(mean, cov).

    Parameters
    ----------
    mean
        Shape ``(..., n)``.
    cov
        Shape ``(..., n, n)``; broadcast against the mean's batch shape.
    """

    mean: np.ndarray
    cov: np.ndarray

    def __post_init__(self) -> None:
        mean, cov = self.mean, self.cov
        # Fast path (every filter step): float arrays whose shapes already agree.
        if (
            type(mean) is np.ndarray
            and type(cov) is np.ndarray
            and mean.dtype == np.float64
            and cov.dtype == np.float64
            and mean.ndim >= 1
            and cov.shape == mean.shape + mean.shape[-1:]
        ):
            return
        try:  # text, ragged or complex input is named, not a raw ValueError
            mean = to_float(mean)
        except ValueError as exc:
            raise ConfigError("Gaussian.mean", str(exc)) from None
        try:
            cov = to_float(cov)
        except ValueError as exc:
            raise ConfigError("Gaussian.cov", str(exc)) from None
        if mean.ndim < 1:
            raise ConfigError("Gaussian.mean", "needs shape (..., n), got a scalar")
        n = mean.shape[-1]
        if cov.ndim < 2 or cov.shape[-2:] != (n, n):
            raise ConfigError("Gaussian.cov", f"needs shape (..., {n}, {n}) to match the mean, got {cov.shape}")
        try:
            batch = np.broadcast_shapes(mean.shape[:-1], cov.shape[:-2])
        except ValueError:
            raise ConfigError(
                "Gaussian.cov", f"batch shape {cov.shape[:-2]} does not broadcast with the mean's {mean.shape[:-1]}"
            ) from None
        object.__setattr__(self, "mean", np.broadcast_to(mean, batch + (n,)))
        object.__setattr__(self, "cov", np.broadcast_to(cov, batch + (n, n)))

    @property
    def ndim_state(self) -> int:
        """State dimension n."""
        n: int = self.mean.shape[-1]
        return n

    @property
    def batch_shape(self) -> tuple[int, ...]:
        """Leading (batch) dimensions."""
        return self.mean.shape[:-1]

    def __getitem__(self, index: Any) -> Gaussian:
        """Select batch elements: ``state[3]``, ``state[:, 0]``."""
        if not isinstance(index, tuple):
            index = (index,)
        return Gaussian(self.mean[index], self.cov[index])


@dataclass(frozen=True)
class Update:
    """The result of one measurement update, batch-first.

    Attributes
    ----------
    state
        Posterior ``Gaussian``.
    innovation
        ``z - z_hat``, shape ``(..., m)``.
    innovation_cov
        ``S``, shape ``(..., m, m)``, including R.
    gain
        Kalman gain ``K = C S^{-1}``, shape ``(..., n, m)``.
    cross_cov
        State-measurement cross covariance ``C``, shape ``(..., n, m)``.
    predicted_measurement
        ``z_hat``, shape ``(..., m)``.
    skipped
        Boolean ``(...)``: True where the update was skipped (missing measurement or a
        recovery policy); there ``state`` is the prior.
    """

    state: Gaussian
    innovation: np.ndarray
    innovation_cov: np.ndarray
    gain: np.ndarray
    cross_cov: np.ndarray
    predicted_measurement: np.ndarray
    skipped: np.ndarray = field(default_factory=lambda: np.zeros((), dtype=bool))


def _check_square(name: str, a: np.ndarray) -> np.ndarray:
    a = np.asarray(a, dtype=float)
    if a.ndim < 2 or a.shape[-1] != a.shape[-2]:
        raise ConfigError(name, f"must be a square matrix (..., k, k), got shape {a.shape}")
    return a


@dataclass(frozen=True)
class LinearModel:
    """Linear-Gaussian model ``x' = F x + u + w``, ``z = H x + v``, ``w ~ N(0, Q)``, ``v ~ N(0, R)``.

    All matrices broadcast over the batch: give ``(n, n)`` for a shared model or
    ``(..., n, n)`` for one per element. ``u`` is an optional known input ``(..., n)``
    (``B u`` in the usual notation).
    """

    F: np.ndarray
    H: np.ndarray
    Q: np.ndarray
    R: np.ndarray
    u: np.ndarray | None = None

    def __post_init__(self) -> None:
        F = _check_square("LinearModel.F", self.F)
        Q = _check_square("LinearModel.Q", self.Q)
        R = _check_square("LinearModel.R", self.R)
        H = np.asarray(self.H, dtype=float)
        n, m = F.shape[-1], R.shape[-1]
        if Q.shape[-1] != n:
            raise ConfigError("LinearModel.Q", f"must be {n}x{n} like F, got {Q.shape[-2:]}")
        if H.ndim < 2 or H.shape[-2:] != (m, n):
            raise ConfigError("LinearModel.H", f"must be (..., {m}, {n}) to match R and F, got {H.shape}")
        for name, val in (("F", F), ("H", H), ("Q", Q), ("R", R)):
            object.__setattr__(self, name, val)

    @property
    def dim_state(self) -> int:
        n: int = self.F.shape[-1]
        return n

    @property
    def dim_meas(self) -> int:
        m: int = self.R.shape[-1]
        return m

    @property
    def compiled(self) -> CompiledFunctions | None:
        """``F x`` and ``H x`` for the fused kernels when F and H are shared and ``u`` is None."""
        if self.u is not None or self.F.ndim != 2 or self.H.ndim != 2:
            return None
        cached = self.__dict__.get("_compiled")
        if cached is None:
            cached = CompiledFunctions(linear_f, self.F, linear_h, self.H, linear_h_jacobian)
            object.__setattr__(self, "_compiled", cached)
        return cached

    def f(self, x: np.ndarray) -> np.ndarray:
        fx = mat_vec(self.F, x)
        return fx if self.u is None else fx + self.u

    def h(self, x: np.ndarray) -> np.ndarray:
        return mat_vec(self.H, x)

    def jacobian_f(self, x: np.ndarray) -> np.ndarray:
        """``F``, the same at every point."""
        return self.F

    def jacobian_h(self, x: np.ndarray) -> np.ndarray:
        """``H``, the same at every point."""
        return self.H

    def with_noise(self, Q: np.ndarray | None = None, R: np.ndarray | None = None) -> LinearModel:
        """Copy with new noise covariances (``None`` keeps the current one)."""
        return dataclasses.replace(self, Q=self.Q if Q is None else Q, R=self.R if R is None else R)


def _subtract(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    out: np.ndarray = a - b
    return out


def residual_hook(model: Any, space: str) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """The model's ``residual_x`` or ``residual_z`` hook (``space`` ``"x"`` or ``"z"``: an
    angle-aware difference, `gnssframework.estimation.angles`), or plain subtraction where
    it has none: the one lookup of the engines and of `iterated_update`."""
    hook: Callable[[np.ndarray, np.ndarray], np.ndarray] = getattr(model, f"residual_{space}", None) or _subtract
    return hook


def numerical_jacobian(fn: ArrayFn, x: np.ndarray, rel_step: float = 1e-6) -> np.ndarray:
    """Central-difference Jacobian of a vectorised ``fn`` at every batch element.

    All n perturbations are evaluated in one call: ``fn`` sees an array ``(2n, ..., n)``.
    The step is ``rel_step * max(1, |x_i|)``, near the cube root of machine epsilon
    times the scale, which balances truncation and rounding error for central
    differences.

    Returns
    -------
    np.ndarray
        ``(..., p, n)`` where p is the output dimension of ``fn``.
    """
    x = np.asarray(x, dtype=float)
    n = x.shape[-1]
    step = rel_step * np.maximum(1.0, np.abs(x))  # (..., n)
    eye = np.eye(n).reshape((n,) + (1,) * (x.ndim - 1) + (n,))
    delta = eye * step  # (n, ..., n)
    out = fn(np.concatenate([x + delta, x - delta], axis=0))  # (2n, ..., p)
    diff = (out[:n] - out[n:]) / (2.0 * np.moveaxis(step, -1, 0)[..., None])  # (n, ..., p)
    return np.moveaxis(diff, 0, -1)  # (..., p, n)


@dataclass(frozen=True)
class NonlinearModel:
    """Nonlinear model ``x' = f(x) + w``, ``z = h(x) + v`` with additive Gaussian noise.

    Parameters
    ----------
    f, h
        Vectorised over any leading dimensions (see the module docstring).
    Q, R
        Noise covariances ``(n, n)`` / ``(m, m)``, or per batch element.
    f_jacobian, h_jacobian
        Optional analytic Jacobians ``(..., n) -> (..., n, n)`` / ``(..., m, n)`` for the
        EKF; central differences are used when omitted.
    residual_x, residual_z, mean_x, mean_z
        Optional angle-aware differences ``(a, b) -> a - b`` and weighted means
        ``(points (N, ..., d), weights (N,)) -> (..., d)`` of states and measurements
        (`gnssframework.estimation.angles`); plain subtraction and averaging when omitted.
    """

    f: ArrayFn
    h: ArrayFn
    Q: np.ndarray
    R: np.ndarray
    f_jacobian: ArrayFn | None = None
    h_jacobian: ArrayFn | None = None
    #: Optional compiled twins of ``f`` and ``h`` (see ``CompiledFunctions``).
    compiled: CompiledFunctions | None = None
    residual_x: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None
    residual_z: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None
    mean_x: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None
    mean_z: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None

    @property
    def angle_aware(self) -> bool:
        """Whether the model has a residual or mean hook (the engines then run on NumPy)."""
        return any(h is not None for h in (self.residual_x, self.residual_z, self.mean_x, self.mean_z))

    def __post_init__(self) -> None:
        object.__setattr__(self, "Q", _check_square("NonlinearModel.Q", self.Q))
        object.__setattr__(self, "R", _check_square("NonlinearModel.R", self.R))
        if not callable(self.f) or not callable(self.h):
            raise ConfigError("NonlinearModel", "f and h must be callables")

    @property
    def dim_state(self) -> int:
        n: int = self.Q.shape[-1]
        return n

    @property
    def dim_meas(self) -> int:
        m: int = self.R.shape[-1]
        return m

    def jacobian_f(self, x: np.ndarray) -> np.ndarray:
        """``df/dx`` at ``x``: analytic when given, else central differences."""
        return self.f_jacobian(x) if self.f_jacobian is not None else numerical_jacobian(self.f, x)

    def jacobian_h(self, x: np.ndarray) -> np.ndarray:
        """``dh/dx`` at ``x``: analytic when given, else central differences."""
        return self.h_jacobian(x) if self.h_jacobian is not None else numerical_jacobian(self.h, x)

    def with_noise(self, Q: np.ndarray | None = None, R: np.ndarray | None = None) -> NonlinearModel:
        """Copy with new noise covariances (``None`` keeps the current one)."""
        return dataclasses.replace(self, Q=self.Q if Q is None else Q, R=self.R if R is None else R)


Model = LinearModel | NonlinearModel
