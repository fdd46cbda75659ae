r"""Compiled square-root RTS smoother terms (`gnssframework.estimation.smoother_sqrt`), batched.

`sqrt_terms`: per element one pass that writes the transpose of the stacked factor
$\begin{bmatrix} Y & S_Q \\ X & 0 \end{bmatrix}$ straight into the Householder workspace (no
NumPy concatenation of a ``(2n, N + n)`` array per element), factors it (`compiled.tria.householder`,
the same Householder pass as `compiled.tria`), solves $G L_{11} = L_{21}$ by back-substitution on the
triangular $L_{11}$ (no general LU) and factors $[L_{21} - G L_{11},\ L_{22}]$ in the same
pass. An element whose $L_{11}$ is numerically singular (smallest diagonal at most
$n \epsilon$ times the largest: `smoother_sqrt._root_gain`'s test) is flagged and left to the
NumPy path (its SVD pseudo-inverse).

`sqrt_step_root`: $S^s_k = \operatorname{tria}[D_k,\ G_k S^s_{k+1}]$ and $S^s_k S^{sT}_k$ of a
backward step in one pass.

Householder QR: Golub & Van Loan, *Matrix Computations*, 4th ed., alg. 5.2.1; the column
signs of the factors may differ from LAPACK's (the products are the same).
"""

from __future__ import annotations

import numpy as np

from . import split
from .specialise import jit_pair, prange, with_globals
from .tria import householder

__all__ = ["sqrt_terms", "sqrt_step_root"]

_CHUNKS = 64
_EPS = 2.220446049250313e-16  # np.finfo(float).eps
#: Sizes a specialised twin compiles as constants (`specialise`; 0: read from the arrays).
_FIXED_N = 0
_FIXED_NPTS = 0


def _terms_body(X, Y, S, G, D, regular):
    """``G[b]``, ``D[b]`` of the factors ``X[b]``, ``Y[b]`` ``(n, N)``, ``S[b]`` ``(n, n)``;
    ``regular[b]`` False (``G[b]``, ``D[b]`` unset) where ``L11`` is numerically singular."""
    B = X.shape[0]
    n = _FIXED_N if _FIXED_N > 0 else X.shape[1]
    N = _FIXED_NPTS if _FIXED_NPTS > 0 else X.shape[2]
    q = N + n
    p = 2 * n
    chunks = min(B, _CHUNKS)
    for c in prange(chunks):
        W = np.empty((q, p))
        v = np.empty(q)
        W2 = np.empty((p, n))
        g = np.empty((n, n))
        for b in range((c * B) // chunks, ((c + 1) * B) // chunks):
            # W = [[Y, S_Q], [X, 0]]^T
            for i in range(N):
                for j in range(n):
                    W[i, j] = Y[b, j, i]
                    W[i, n + j] = X[b, j, i]
            for i in range(n):
                for j in range(n):
                    W[N + i, j] = S[b, j, i]
                    W[N + i, n + j] = 0.0
            householder(W, v, q, p)
            # L = R^T: L11[i, j] = W[j, i], L21[i, j] = W[j, n + i], L22[i, j] = W[n + j, n + i]
            dmax = 0.0
            dmin = np.inf
            for i in range(n):
                d = abs(W[i, i])
                dmax = max(dmax, d)
                dmin = min(dmin, d)
            if not dmin > n * _EPS * dmax:
                regular[b] = False
                continue
            regular[b] = True
            # G L11 = L21, L11 lower: column j from n-1 down, g[r, j] = (L21[r, j] - sum_{k>j} g[r, k] L11[k, j]) / L11[j, j]
            for r in range(n):
                for j in range(n - 1, -1, -1):
                    s = W[j, n + r]
                    for k in range(j + 1, n):
                        s -= g[r, k] * W[j, k]
                    g[r, j] = s / W[j, j]
            # W2 = [L21 - G L11, L22]^T
            for r in range(n):
                for j in range(n):
                    s = 0.0
                    for k in range(j, n):
                        s += g[r, k] * W[j, k]
                    W2[j, r] = W[j, n + r] - s
                    W2[n + j, r] = W[n + j, n + r] if j <= r else 0.0
            householder(W2, v, p, n)
            for i in range(n):
                for j in range(n):
                    G[b, i, j] = g[i, j]
                    D[b, i, j] = W2[j, i] if j <= i else 0.0


_terms_by_size: dict = {}


def _terms_kernels(n: int, N: int):
    """The (serial, parallel) pair of `_terms_body` compiled for ``n`` states and ``N``
    columns of ``X``: the sizes as constants (LLVM unrolls the Householder loops; 35-40 %
    faster than the generic code at n = 5, N = 10, bitwise the same), one per size."""
    hit = _terms_by_size.get((n, N))
    if hit is None:
        hit = _terms_by_size[n, N] = jit_pair(with_globals(_terms_body, f"_{n}_{N}", _FIXED_N=n, _FIXED_NPTS=N))
    return hit


def _flat(a: np.ndarray, batch: tuple, tail: tuple) -> np.ndarray:
    out = np.ascontiguousarray(np.broadcast_to(a, batch + tail), dtype=float).reshape((-1,) + tail)
    return out if out.flags.writeable else out.copy()


def sqrt_terms(
    point_root: np.ndarray, image_root: np.ndarray, noise_root: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(G, D, regular)`` of `smoother_sqrt.sqrt_terms` for finite factors, batched over every
    leading axis; where ``regular`` is False, ``G`` and ``D`` are unset (the caller's NumPy path
    handles those elements)."""
    n, N = point_root.shape[-2:]
    batch = np.broadcast_shapes(point_root.shape[:-2], image_root.shape[:-2], noise_root.shape[:-2])
    X, Y, S = _flat(point_root, batch, (n, N)), _flat(image_root, batch, (n, N)), _flat(noise_root, batch, (n, n))
    B = X.shape[0]
    G, D = np.empty((B, n, n)), np.empty((B, n, n))
    regular = np.empty(B, dtype=np.bool_)
    split.pick(_terms_kernels(n, N), B)(X, Y, S, G, D, regular)
    return G.reshape(batch + (n, n)), D.reshape(batch + (n, n)), regular.reshape(batch)


def _step_body(G, D, R, root, cov):
    """``root[b] = tria[D[b], G[b] R[b]]`` and ``cov[b] = root[b] root[b]^T``."""
    B = G.shape[0]
    n = _FIXED_N if _FIXED_N > 0 else G.shape[1]
    chunks = min(B, _CHUNKS)
    for c in prange(chunks):
        W = np.empty((2 * n, n))
        v = np.empty(2 * n)
        for b in range((c * B) // chunks, ((c + 1) * B) // chunks):
            for i in range(n):
                for j in range(n):
                    W[j, i] = D[b, i, j]
                    s = 0.0
                    for k in range(n):
                        s += G[b, i, k] * R[b, k, j]
                    W[n + j, i] = s
            householder(W, v, 2 * n, n)
            for i in range(n):
                for j in range(n):
                    root[b, i, j] = W[j, i] if j <= i else 0.0
            for i in range(n):
                for j in range(i + 1):
                    s = 0.0
                    for k in range(j + 1):  # root lower: root[i, k] root[j, k], k <= min(i, j) = j
                        s += W[k, i] * W[k, j]
                    cov[b, i, j] = s
                    cov[b, j, i] = s


_step_by_size: dict = {}


def _step_kernels(n: int):
    """The (serial, parallel) pair of `_step_body` compiled for ``n`` states (as `_terms_kernels`)."""
    hit = _step_by_size.get(n)
    if hit is None:
        hit = _step_by_size[n] = jit_pair(with_globals(_step_body, f"_{n}", _FIXED_N=n))
    return hit


def sqrt_step_root(gain: np.ndarray, cond_root: np.ndarray, next_root: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r"""$S^s_k = \operatorname{tria}[D_k,\ G_k S^s_{k+1}]$ (lower triangular) and $S^s_k S^{sT}_k$
    (exactly symmetric), each ``(..., n, n)``, for finite inputs."""
    n = gain.shape[-1]
    batch = np.broadcast_shapes(gain.shape[:-2], cond_root.shape[:-2], next_root.shape[:-2])
    G, D, R = (_flat(a, batch, (n, n)) for a in (gain, cond_root, next_root))
    root, cov = np.empty_like(G), np.empty_like(G)
    split.pick(_step_kernels(n), G.shape[0])(G, D, R, root, cov)
    return root.reshape(batch + (n, n)), cov.reshape(batch + (n, n))
