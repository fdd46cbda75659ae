"""A model's compiled twins of ``f`` and ``h``, as the compiled kernels call them.

A model may carry `CompiledFunctions`: jitted (`gnssframework.backend.jit`) functions
that compute its transition and measurement for one sigma point, defined next to the
model's NumPy ``f``/``h`` (the reference). The fused kernels compile one driver per
model function (the function is a compile-time constant of the driver, so numba
inlines it), which is how a third-party model brings its own fast path. The row
conventions (rows addressed by index: a row view would cost two atomic reference-count
updates per point):

* ``f(params, X, k, Y)``: ``Y[k, :] = f(X[k, :])``;
* ``h(params, X, k, Z, kz)``: ``Z[kz, :] = h(X[k, :])``;
* ``h_jacobian(params, X, k, J)``: ``J[:, :] = dh/dx`` at ``X[k, :]`` (the KF/EKF path).

``params`` is the model's 2-D float array of constants shared by the batch. This
module sits below the kernels and the model types (it imports neither).
"""

from __future__ import annotations

import math  # noqa: F401  (in the globals of the jitted functions' size-specialised twins)
from dataclasses import dataclass
from collections.abc import Callable

import numpy as np

from ..backend import jit
from ..errors import ConfigError

__all__ = ["CompiledFunctions", "linear_f", "linear_h", "linear_h_jacobian", "register_warm_up", "warm_up_models"]

#: State size of a size-specialised twin of `linear_f` (0: read from the operands).
_FIXED_K = 0


@jit
def linear_f(params: np.ndarray, X: np.ndarray, k: int, Y: np.ndarray) -> None:
    """``Y[k] = F X[k]`` with ``F = params`` ``(n, n)``."""
    n = _FIXED_K if _FIXED_K > 0 else X.shape[1]
    for i in range(n):
        acc = 0.0
        for j in range(n):
            acc += params[i, j] * X[k, j]
        Y[k, i] = acc


@jit
def linear_h(params: np.ndarray, X: np.ndarray, k: int, Z: np.ndarray, kz: int) -> None:
    """``Z[kz] = H X[k]`` with ``H = params`` ``(m, n)``."""
    m, n = params.shape
    for i in range(m):
        acc = 0.0
        for j in range(n):
            acc += params[i, j] * X[k, j]
        Z[kz, i] = acc


@jit
def linear_h_jacobian(params: np.ndarray, X: np.ndarray, k: int, J: np.ndarray) -> None:
    """``J = H`` (the same at every point)."""
    m, n = params.shape
    for i in range(m):
        for j in range(n):
            J[i, j] = params[i, j]


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and bool(np.array_equal(a, b))


@dataclass(frozen=True, eq=False, slots=True)
class CompiledFunctions:
    """Model functions the compiled kernels evaluate themselves (no call back to Python).

    A model that carries one lets a sigma-point filter run a whole predict or update in
    one compiled pass per batch element, and the KF/EKF (``f`` is `linear_f`, and
    ``h_jacobian`` given) run theirs in compiled code. The model's NumPy ``f``/``h`` (and
    its Jacobians) stay the reference: both must compute the same functions (tests hold
    the built-in ones to 1e-12).

    Parameters
    ----------
    f, h
        Jitted row functions (see the module docstring): ``f(params, X, k, Y)`` and
        ``h(params, X, k, Z, kz)``; `linear_f` / `linear_h` for ``F x`` / ``H x``.
    f_params, h_params
        2-D float arrays shared by the batch, handed to ``f`` and ``h`` as ``params``
        (F ``(n, n)`` for `linear_f`, H ``(m, n)`` for `linear_h`).
    h_jacobian
        Optional jitted ``h_jacobian(params, X, k, J)`` (``h_params`` again): lets the
        KF/EKF run its moments compiled. It must equal the model's NumPy Jacobian.
    sizes
        Optional ``(n, m)``: compile the fused drivers for this state and measurement
        size with both as constants (numba then unrolls what the generic driver indexes
        at run time; results are bitwise the same). For a filter's hot path.
    """

    f: Callable[..., None]
    f_params: np.ndarray
    h: Callable[..., None]
    h_params: np.ndarray
    h_jacobian: Callable[..., None] | None = None
    sizes: tuple[int, int] | None = None

    def __post_init__(self) -> None:
        for name in ("f", "h"):
            if not callable(getattr(self, name)):
                raise ConfigError(
                    f"CompiledFunctions.{name}", "must be a function compiled with gnssframework.backend.jit"
                )
        for name in ("f_params", "h_params"):
            a = np.ascontiguousarray(getattr(self, name), dtype=float)
            if a.ndim != 2:
                raise ConfigError(f"CompiledFunctions.{name}", f"must be a 2-D array, got shape {a.shape}")
            object.__setattr__(self, name, a)
        if self.sizes is not None:
            sizes = tuple(int(s) for s in self.sizes)
            if len(sizes) != 2 or min(sizes) < 1:
                raise ConfigError("CompiledFunctions.sizes", f"must be (states, measurements) >= 1, got {self.sizes!r}")
            object.__setattr__(self, "sizes", sizes)

    # Equal when the functions are the same and the parameters equal (a filter holding one
    # is compared whole when channels' filters merge into a batch: no __dict__, so the
    # jitted functions' own state is never walked).
    def __eq__(self, other: object) -> bool:
        if not isinstance(other, CompiledFunctions):
            return NotImplemented
        return (
            self.f is other.f
            and self.h is other.h
            and self.h_jacobian is other.h_jacobian
            and self.sizes == other.sizes
            and _same(self.f_params, other.f_params)
            and _same(self.h_params, other.h_params)
        )

    __hash__ = None  # type: ignore[assignment]  # mutable arrays inside

    @property
    def linear_f(self) -> bool:
        """True where ``f`` is ``F x`` with ``F = f_params`` (the KF/EKF predict applies)."""
        return self.f is linear_f


#: Models whose drivers `gnssframework.estimation.compiled.warm_up` compiles, with the
#: state and measurement sizes to run them at.
_warm_up: list[tuple[CompiledFunctions, int, int]] = []


def register_warm_up(example: CompiledFunctions, n: int, m: int) -> None:
    """Have the kernels' warm-up compile the drivers of ``example``'s functions at ``n``
    states and ``m`` measurements (its parameters must give finite values at states
    near zero). `gnssframework compare` warms up before forking its workers, so a model
    registered at import compiles once per machine, not once per worker."""
    _warm_up.append((example, int(n), int(m)))


def warm_up_models() -> tuple[tuple[CompiledFunctions, int, int], ...]:
    """The models registered with `register_warm_up`."""
    return tuple(_warm_up)
