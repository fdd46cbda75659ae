"""Compiled ``tria`` of the square-root smoother (`gnssframework.estimation.smoother_sqrt`), batched.

For each ``A[b]`` ``(p, q)``, ``q >= p``: Householder QR of ``A[b]^T = Q R`` (Golub & Van Loan,
*Matrix Computations*, 4th ed., alg. 5.2.1) and ``L[b] = R^T``, lower triangular with
``L L^T = A A^T``. NumPy's batched ``qr`` makes one LAPACK call per small matrix, which
dominated the square-root backward pass at large batches; this is one compiled pass per
element. The column signs of ``L`` may differ from LAPACK's (``L L^T`` is the same).
"""

from __future__ import annotations

import math

import numpy as np

from . import split
from .specialise import jit_pair, prange, step_jit

__all__ = ["tria", "householder"]

_CHUNKS = 64


def _householder(W, v, q, p):
    """In place: ``W[:q, :p]`` (``q >= p``) to ``R`` of its QR factorisation (upper triangle;
    ``v`` ``(q,)`` workspace)."""
    for k in range(p):
        s = 0.0
        for i in range(k + 1, q):
            s += W[i, k] * W[i, k]
        x0 = W[k, k]
        if s == 0.0:  # the column is already triangular below k
            continue
        norm = math.sqrt(x0 * x0 + s)
        alpha = -norm if x0 >= 0.0 else norm  # reflect x onto alpha e_k, no cancellation
        v[k] = x0 - alpha
        for i in range(k + 1, q):
            v[i] = W[i, k]
        vv = v[k] * v[k] + s
        W[k, k] = alpha
        for i in range(k + 1, q):
            W[i, k] = 0.0
        for j in range(k + 1, p):
            dot = 0.0
            for i in range(k, q):
                dot += v[i] * W[i, j]
            f = 2.0 * dot / vv
            for i in range(k, q):
                W[i, j] -= f * v[i]


householder = step_jit(_householder)


def _tria_body(A, L):
    """``L[b] = R^T`` of the QR factorisation of ``A[b]^T``."""
    B, p, q = A.shape
    chunks = min(B, _CHUNKS)
    for c in prange(chunks):
        W = np.empty((q, p))
        v = np.empty(q)
        for b in range((c * B) // chunks, ((c + 1) * B) // chunks):
            for i in range(q):
                for j in range(p):
                    W[i, j] = A[b, j, i]
            householder(W, v, q, p)
            for i in range(p):
                for j in range(p):
                    L[b, i, j] = W[j, i] if j <= i else 0.0


_tria_kernels = jit_pair(_tria_body)


def tria(a: np.ndarray) -> np.ndarray:
    """Lower-triangular ``L`` ``(..., p, p)`` with ``L L^T = a a^T`` for ``a`` ``(..., p, q)``, ``q >= p``."""
    p, q = a.shape[-2:]
    if q < p:
        raise ValueError(f"tria needs at least as many columns as rows, got {p}x{q}")
    batch = a.shape[:-2]
    A = np.ascontiguousarray(a, dtype=float).reshape(-1, p, q)
    if not A.flags.writeable:
        A = A.copy()
    L = np.empty((A.shape[0], p, p))
    split.pick(_tria_kernels, A.shape[0])(A, L)
    return L.reshape(batch + (p, p))
