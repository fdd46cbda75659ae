"""Batched linear algebra that reports *which* batch element failed.

numpy's batched ``cholesky`` raises one ``LinAlgError`` for a whole stack of matrices;
a filter that runs 8000 Monte Carlo runs at once must say which one broke. These
helpers return a boolean ``ok`` mask over the batch instead of raising, and the caller
turns a False into a named ``gnssframework.errors.NumericalError``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import backend
from .compiled import arrays as kernels

__all__ = [
    "symmetrize",
    "transpose",
    "cholesky_masked",
    "pd_mask",
    "clip_eigenvalues",
    "project_psd",
    "clamp_relative",
    "regularised",
    "failing_indices",
    "mat_vec",
    "outer",
    "to_float",
]


def to_float(value: Any) -> np.ndarray:
    """``np.asarray(value, dtype=float)`` that refuses what it would mangle: complex
    values (NumPy drops the imaginary part with a ``ComplexWarning``), text and ragged
    nests raise ``ValueError`` with a short reason. A NumPy masked array's masked
    entries become NaN (missing), not the values hidden under the mask."""
    if isinstance(value, np.ma.MaskedArray):
        value = np.ma.filled(value.astype(float) if not np.iscomplexobj(value) else value, np.nan)
    try:
        arr = np.asarray(value)
        complex_ = np.iscomplexobj(arr)
        out = None if complex_ else arr.astype(float, copy=False)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"is not a numeric array ({exc})") from None
    if out is None:  # complex
        raise ValueError("is complex; give the real and imaginary parts as separate measurements")
    return out


def transpose(a: np.ndarray) -> np.ndarray:
    """Batched ``A^T``: the last two axes swapped (a view)."""
    out: np.ndarray = np.swapaxes(a, -1, -2)
    return out


def symmetrize(a: np.ndarray) -> np.ndarray:
    """Return ``(A + A^T) / 2`` over the last two axes."""
    out: np.ndarray = 0.5 * (a + transpose(a))
    return out


def mat_vec(a: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Batched ``A @ x`` for matrices ``(..., p, q)`` and vectors ``(..., q)``."""
    out: np.ndarray = (a @ x[..., None])[..., 0]
    return out


def outer(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Batched outer product ``a b^T`` of ``(..., p)`` and ``(..., q)``."""
    out: np.ndarray = a[..., :, None] * b[..., None, :]
    return out


def cholesky_masked(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lower Cholesky factor of every matrix in a stack, with a success mask.

    Parameters
    ----------
    a
        Symmetric matrices, shape ``(..., n, n)``. Only the lower triangle is read.

    Returns
    -------
    L
        Lower factors ``(..., n, n)``; identity where the factorisation failed.
    ok
        Boolean ``(...)``: True where ``a`` is finite and positive definite.
    """
    a = np.asarray(a, dtype=float)
    finite = np.isfinite(a).all(axis=(-2, -1))
    if finite.all():
        try:
            return np.linalg.cholesky(a), np.ones(a.shape[:-2], dtype=bool)
        except np.linalg.LinAlgError:
            pass
    # Failure path: find the bad elements with one batched eigvalsh, factor the rest in
    # one batched call. (Callers such as the adapters' bound tests expect failures, so
    # this must stay vectorised.)
    eye = np.broadcast_to(np.eye(a.shape[-1]), a.shape)
    ok = finite.copy()
    safe = np.where(ok[..., None, None], a, eye)
    ok &= np.linalg.eigvalsh(safe).min(axis=-1) > 0
    safe = np.where(ok[..., None, None], safe, eye)
    try:
        return np.linalg.cholesky(safe), ok
    except np.linalg.LinAlgError:
        pass
    # eigvalsh said PD but Cholesky disagrees (eigenvalues at rounding level): per element.
    L = np.empty_like(safe)
    flat_L = L.reshape(-1, *a.shape[-2:])
    flat_ok = ok.reshape(-1)
    for i, m in enumerate(safe.reshape(-1, *a.shape[-2:])):
        try:
            flat_L[i] = np.linalg.cholesky(m)
        except np.linalg.LinAlgError:
            flat_L[i] = np.eye(a.shape[-1])
            flat_ok[i] = False
    return L, ok


def pd_mask(a: np.ndarray) -> np.ndarray:
    """Boolean ``(...)``: True where ``a[...]`` ``(..., n, n)`` is finite and positive
    definite (lower triangle read, as `cholesky_masked`).

    A test without the factor: the compiled kernel (one pass, no allocation per
    element) under the ``numba`` backend, ``cholesky_masked`` under ``numpy``. The two
    agree except on matrices whose smallest eigenvalue is at rounding level.
    """
    a = np.asarray(a, dtype=float)
    if backend.compiled():
        return kernels.pd_mask(a)
    return cholesky_masked(a)[1]


#: Up to this many elements a mask is tested through a Python list: a NumPy reduction
#: costs about 2 us per call on a few elements, the list 0.4 us (hot-path checks).
_SMALL_MASK = 64


def any_true(mask: np.ndarray) -> bool:
    """``bool(mask.any())`` for a boolean or integer mask, cheaper on small ones."""
    if mask.size > _SMALL_MASK:
        return bool(mask.any())
    return any(mask.ravel().tolist())


def all_true(mask: np.ndarray) -> bool:
    """``bool(mask.all())`` for a boolean or integer mask, cheaper on small ones."""
    if mask.size > _SMALL_MASK:
        return bool(mask.all())
    return all(mask.ravel().tolist())


def failing_indices(ok: np.ndarray) -> list[tuple[int, ...]]:
    """Index tuples of the False entries of a batch mask (``[()]`` for a scalar)."""
    ok = np.asarray(ok)
    if ok.ndim == 0:
        return [] if ok else [()]
    return [tuple(int(i) for i in idx) for idx in zip(*np.nonzero(~ok))]


def _clip_spectrum(a: np.ndarray, low: float | np.ndarray, high: float | np.ndarray) -> np.ndarray:
    """Symmetrise ``a`` and clip its eigenvalues into ``[low, high]`` (broadcast over the batch)."""
    w, v = np.linalg.eigh(symmetrize(a))
    w = np.clip(w, np.asarray(low)[..., None], np.asarray(high)[..., None])
    out: np.ndarray = (v * w[..., None, :]) @ np.swapaxes(v, -1, -2)
    return out


def clip_eigenvalues(a: np.ndarray, floor: float | np.ndarray) -> np.ndarray:
    """Symmetrise and raise every eigenvalue to at least ``floor``.

    ``floor`` broadcasts over the batch; it is an absolute value in the units of ``a``.
    """
    return _clip_spectrum(a, floor, np.inf)


def project_psd(a: np.ndarray) -> np.ndarray:
    """Nearest (Frobenius) positive semi-definite matrix: negative eigenvalues set to 0."""
    return clip_eigenvalues(a, 0.0)


def regularised(reference: np.ndarray, rel: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """Eigen-decomposition of a PSD reference with eigenvalues floored at ``rel`` times the largest."""
    w, v = np.linalg.eigh(symmetrize(reference))
    return np.maximum(w, rel * np.max(np.abs(w), axis=-1, keepdims=True)), v


def clamp_relative(
    a: np.ndarray,
    reference: np.ndarray,
    floor: float,
    ceiling: float,
    rel_regularisation: float = 1e-6,
    reference_eig: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """Clamp ``a`` between ``floor * reference`` and ``ceiling * reference``.

    The bounds hold in the Loewner order: with ``reference = G G^T``, the eigenvalues of
    ``G^{-1} a G^{-T}`` are clipped to ``[floor, ceiling]``. This keeps an adapted noise
    covariance PD, finite and of the right order of magnitude whatever its shape.

    A singular reference (a process noise ``Gamma q Gamma^T`` of lower rank, as in a
    constant-acceleration model) has its eigenvalues raised to ``rel_regularisation``
    times its largest one, so directions it does not excite may carry at most
    ``ceiling * rel_regularisation`` of its scale.

    Elements already inside the bounds are returned unchanged without an eigen-
    decomposition: two Cholesky tests (``a - floor ref`` and ``ceiling ref - a``
    positive definite) decide it, and only the others pay for ``eigh``.

    ``reference_eig`` is ``regularised(reference, rel_regularisation)`` when the caller
    keeps it (an adapter clamps against the same reference every step).
    """
    a = symmetrize(np.asarray(a, dtype=float))
    w, v = regularised(reference, rel_regularisation) if reference_eig is None else reference_eig
    ref = (v * w[..., None, :]) @ np.swapaxes(v, -1, -2)
    inside = pd_mask(a - floor * ref) & pd_mask(ceiling * ref - a)
    if inside.all():
        return a
    out = a.copy()
    bad = ~inside
    shape = a.shape
    w_b = np.broadcast_to(w, shape[:-1])[bad]
    v_b = np.broadcast_to(v, shape)[bad]
    G = v_b * np.sqrt(w_b)[..., None, :]
    G_inv = np.swapaxes(v_b, -1, -2) / np.sqrt(w_b)[..., :, None]
    white = _clip_spectrum(G_inv @ a[bad] @ np.swapaxes(G_inv, -1, -2), floor, ceiling)
    out[bad] = symmetrize(G @ white @ np.swapaxes(G, -1, -2))
    return out
