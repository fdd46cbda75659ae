"""Compiled checks of the filter step's lean path (issue 11: the single-run vector loop).

A filter step at small batch (one run of a vector loop: 8 channel filters, one
navigation filter) is bound by Python-level calls, each about a microsecond whatever
the array size. The checks `FilterStep` and the noise adapters' safeguards make every
step (is the prediction finite, is the posterior PD, is the adapted R PSD and inside its
bounds) cost three to eight NumPy calls each; here each is one compiled call returning
a count of failing batch elements.

Every kernel is a *test* that decides whether the step may take its common path; where
a count is not zero the caller runs the NumPy reference path, which finds the failing
elements, applies the recovery policy and names the failure. The tests themselves are
those of the reference path: the positive-definiteness test is the Cholesky test of
`gnssframework.estimation.kernels.pd_mask` (the ``numba`` backend's), finiteness is
exact, and the symmetrisation and bound differences are the same floating-point
operations as `gnssframework.estimation.linalg.symmetrize` and ``clamp_relative``, so
the lean path returns bitwise what the reference path returns.
"""

from __future__ import annotations

import numpy as np

from . import kernels
from .kernels import _all_finite, _cholesky, _jit

__all__ = ["all_finite", "state_bad_count", "guard_bad_count", "warm_up"]


@_jit
def _all_finite_body(a):
    return _all_finite(a)


@_jit
def _state_bad_count_body(mean, cov, test_pd):
    """Elements whose mean or covariance is not finite, or (``test_pd``) whose covariance
    has no Cholesky factor of its lower triangle."""
    B, n = mean.shape
    L = np.empty((n, n))
    bad = 0
    for b in range(B):
        ok = _all_finite(mean[b]) and _all_finite(cov[b])
        if ok and test_pd:
            ok = _cholesky(cov[b], L)
        bad += not ok
    return bad


@_jit
def _guard_bad_count_body(raw, ref, floor, ceiling, out):
    """``out[b] = (raw[b] + raw[b]^T) / 2``; counts the elements where ``out[b]`` is not
    finite and PD, or ``out[b] - floor ref`` or ``ceiling ref - out[b]`` is not PD."""
    B, k, _ = raw.shape
    D = np.empty((k, k))
    L = np.empty((k, k))
    bad = 0
    for b in range(B):
        A = raw[b]
        S = out[b]
        for i in range(k):
            for j in range(k):
                S[i, j] = 0.5 * (A[i, j] + A[j, i])
        ok = _all_finite(S) and _cholesky(S, L)
        if ok:
            for i in range(k):
                for j in range(k):
                    D[i, j] = S[i, j] - floor * ref[i, j]
            ok = _all_finite(D) and _cholesky(D, L)
        if ok:
            for i in range(k):
                for j in range(k):
                    D[i, j] = ceiling * ref[i, j] - S[i, j]
            ok = _all_finite(D) and _cholesky(D, L)
        bad += not ok
    return bad


def _rows(a: np.ndarray, tail: int) -> np.ndarray | None:
    """``a`` as a C-contiguous float64 ``(B, ...)`` view, or ``None`` (caller: NumPy path)."""
    if type(a) is not np.ndarray or a.dtype != np.float64 or not a.flags.c_contiguous or not a.flags.writeable:
        return None
    if a.ndim == tail + 1:
        return a
    if a.ndim < tail:
        return None
    return a.reshape((-1,) + a.shape[a.ndim - tail:])


def all_finite(a: np.ndarray) -> bool:
    """``bool(np.isfinite(a).all())`` in one compiled call (contiguous float64 input;
    anything else goes through NumPy)."""
    if (kernels.HAVE_NUMBA and type(a) is np.ndarray and a.dtype == np.float64 and a.flags.c_contiguous
            and a.flags.writeable):
        return bool(_all_finite_body(a.reshape(-1)))
    return bool(np.isfinite(a).all())


def state_bad_count(mean: np.ndarray, cov: np.ndarray, test_pd: bool) -> int | None:
    """How many batch elements of a Gaussian state have a non-finite mean or covariance
    (and, with ``test_pd``, a covariance that is not positive definite), or ``None`` when
    the arrays are not the kernel's layout (mean ``(..., n)``, covariance ``(..., n, n)``
    of the same batch, contiguous float64): the caller then tests with NumPy."""
    m = _rows(mean, 1)
    P = _rows(cov, 2)
    if m is None or P is None or m.shape[0] != P.shape[0] or P.shape[1:] != (m.shape[1], m.shape[1]):
        return None
    return int(_state_bad_count_body(m, P, bool(test_pd)))


def guard_bad_count(raw: np.ndarray, ref: np.ndarray, floor: float, ceiling: float
                    ) -> tuple[np.ndarray, int] | None:
    """The common case of an adapter's safeguard (`AdapterRun.guard`) in one pass.

    Returns ``(symmetrised raw, count)``: the count of elements that are not finite and
    PD or not inside ``[floor ref, ceiling ref]`` (Loewner order, Cholesky tests); where
    it is 0 the symmetrised estimate is what the reference path returns. ``None`` where
    the operands are not the kernel's layout (``raw (..., k, k)``, ``ref (k, k)`` shared).
    """
    R = _rows(raw, 2)
    if R is None or type(ref) is not np.ndarray or ref.shape != R.shape[1:] or ref.dtype != np.float64:
        return None
    out = np.empty(raw.shape)
    bad = _guard_bad_count_body(R, ref, float(floor), float(ceiling), out.reshape(R.shape))
    return out, int(bad)


def warm_up() -> None:
    """Compile (or load from the disk cache) every kernel of this module once, with the
    operand types the filter step hands them (so forked workers compile nothing)."""
    if not kernels.HAVE_NUMBA:
        return
    m, P = np.zeros((2, 2)), np.broadcast_to(np.eye(2), (2, 2, 2)).copy()
    all_finite(m)
    state_bad_count(m, P, True)
    guard_bad_count(P, np.eye(2), 0.5, 2.0)
