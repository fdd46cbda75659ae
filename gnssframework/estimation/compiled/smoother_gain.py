"""Compiled RTS smoother gain of the ``"eigh"`` form (the SVD-CKF's), batched.

One pass per element: the symmetric eigen-decomposition of $P^-$ (`dense.eigh_into`, the
kernel the SVD-CKF takes its square root from) and $G = C V \\operatorname{diag}(1/w) V^T$
with eigenvalues below $n \\epsilon \\max |w|$ dropped, the arithmetic of
`gnssframework.estimation.smoother.smoother_gain` (``form="eigh"``) without NumPy's
per-matrix LAPACK call, which dominated the SVD-CKF's backward pass at large batches.
"""

from __future__ import annotations

import numpy as np

from . import split
from .dense import eigh_into
from .specialise import jit_pair, prange

__all__ = ["eigh_gain"]

_CHUNKS = 64
_EPS = 2.220446049250313e-16  # np.finfo(float).eps


def _eigh_gain_body(P, C, G):
    """``G[b] = C[b] V diag(1/w) V^T`` from ``P[b] = V diag(w) V^T``, small ``w`` dropped."""
    B, n, _ = P.shape
    chunks = min(B, _CHUNKS)
    for c in prange(chunks):
        w = np.empty(n)
        V = np.empty((n, n))
        W = np.empty((n + 2, n))
        T = np.empty((n, n))
        inv = np.empty(n)
        for b in range((c * B) // chunks, ((c + 1) * B) // chunks):
            eigh_into(P[b], w, V, W)
            top = 0.0
            for i in range(n):
                top = max(top, abs(w[i]))
            tol = n * _EPS * top
            for i in range(n):
                inv[i] = 1.0 / w[i] if w[i] > tol else 0.0
            for i in range(n):
                for j in range(n):
                    s = 0.0
                    for k in range(n):
                        s += C[b, i, k] * V[k, j]
                    T[i, j] = s * inv[j]
            for i in range(n):
                for j in range(n):
                    s = 0.0
                    for k in range(n):
                        s += T[i, k] * V[j, k]
                    G[b, i, j] = s


_eigh_gain_kernels = jit_pair(_eigh_gain_body)


def eigh_gain(cross_cov: np.ndarray, prior_cov: np.ndarray) -> np.ndarray:
    """The ``"eigh"`` gain of ``cross_cov`` ``(..., n, n)`` and ``prior_cov`` ``(..., n, n)``."""
    batch = np.broadcast_shapes(cross_cov.shape[:-2], prior_cov.shape[:-2])
    n = prior_cov.shape[-1]
    P = np.ascontiguousarray(np.broadcast_to(prior_cov, batch + (n, n)), dtype=float).reshape(-1, n, n)
    C = np.ascontiguousarray(np.broadcast_to(cross_cov, batch + (n, n)), dtype=float).reshape(-1, n, n)
    if not P.flags.writeable:
        P = P.copy()
    if not C.flags.writeable:
        C = C.copy()
    G = np.empty_like(C)
    split.pick(_eigh_gain_kernels, P.shape[0])(P, C, G)
    return G.reshape(batch + (n, n))
