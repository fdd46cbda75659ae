"""The Gaussian rules per batch element, compiled: square root, points, moments, gain
and posterior, each written once.

The fused drivers (`gnssframework.estimation.compiled.drivers`) are these steps in
order. A size-specialised driver calls twins of them built by `steps_of_size` with the
sizes as constants (a step compiled apart from its driver would not see the driver's
constants; the last attempt at shared helpers lost 15-20 % that way). Every step keeps
the arithmetic and its order of the code it replaced, so results are bitwise the same.
"""

from __future__ import annotations

import math

from .dense import all_finite, chol_solve_rows_into, cholesky, eigh_into, helpers_of_size
from .specialise import HAVE_NUMBA, jit, with_globals

__all__ = ["root_into", "points_into", "center_into", "spread_into", "measurement_moments_into",
           "keep_prior_into", "gain_posterior_into", "steps_of_size"]

#: Sizes of a specialised twin (0: read from the operands): state n, measurement m.
_FIXED_N = 0
_FIXED_M = 0
# The state (n x n) and innovation (m x m) covariance tests, bound per size in a twin.
_all_finite_n = all_finite
_cholesky_n = cholesky


@jit
def root_into(P, root_kind, R, w, V, Wk):
    """A square root of ``P`` into ``R``: 0 the lower Cholesky factor, 1 ``V sqrt(|w|)`` of
    the symmetric eigen-decomposition (``w``, ``V``, ``Wk`` scratch). Returns the status:
    0 ok, 1 P not finite, 2 P not positive definite (Cholesky)."""
    n = _FIXED_N if _FIXED_N > 0 else P.shape[0]
    R[:, :] = 0.0
    if not _all_finite_n(P):
        return 1
    if root_kind == 0:
        if not _cholesky_n(P, R):
            return 2
    else:
        eigh_into(P, w, V, Wk)
        for i in range(n):
            sw = math.sqrt(abs(w[i]))
            for j in range(n):
                R[j, i] = V[j, i] * sw
    return 0


@jit
def points_into(mean, b, R, scale, center, X):
    """Points of element ``b``: ``[m], m + scale R_i, m - scale R_i`` (``R_i`` the columns)."""
    n = _FIXED_N if _FIXED_N > 0 else mean.shape[1]
    off = 1 if center else 0
    if center:
        for j in range(n):
            X[0, j] = mean[b, j]
    for i in range(n):
        for j in range(n):
            dd = R[j, i] * scale
            X[off + i, j] = mean[b, j] + dd
            X[off + n + i, j] = mean[b, j] - dd


@jit
def center_into(Y, wm, mu):
    """``mu = sum_k wm_k Y_k``, then ``Y_k -= mu`` (the deviations, in place)."""
    N, p = Y.shape
    mu[:] = 0.0
    for k in range(N):
        for j in range(p):
            mu[j] += wm[k] * Y[k, j]
    for k in range(N):
        for j in range(p):
            Y[k, j] -= mu[j]


@jit
def spread_into(Y, wc, Q, q, mu, Acc, b, out_mean, out_cov):
    """The predicted moments of element ``b``: ``mu`` and ``sum_k wc_k dY_k dY_k^T + Q``
    (symmetrised) from the deviations ``Y``. Point by point into the lower triangle:
    each entry sums in the order k = 0..N-1 (as a dot product would), but the entries'
    chains interleave in the pipeline."""
    N = Y.shape[0]
    n = _FIXED_N if _FIXED_N > 0 else Y.shape[1]
    for i in range(n):
        for j in range(i + 1):
            Acc[i, j] = 0.0
    for k in range(N):
        for i in range(n):
            wy = wc[k] * Y[k, i]
            for j in range(i + 1):
                Acc[i, j] += wy * Y[k, j]
    for i in range(n):
        out_mean[b, i] = mu[i]
        for j in range(i + 1):
            cij = Acc[i, j] + 0.5 * (Q[q, i, j] + Q[q, j, i])
            out_cov[b, i, j] = cij
            out_cov[b, j, i] = cij


@jit
def measurement_moments_into(X, Z, mean, b, wc, R, r, mu, SAcc, CAcc, z_hat, Sb, Cb):
    """``z_hat = mu``, ``S = sum wc dZ dZ^T + R`` (symmetrised) and ``C = sum wc (X - m)
    dZ^T`` of element ``b`` from the deviations ``Z``. S (lower triangle) and C point by
    point: each entry sums in the order k = 0..N-1 with the same products as a dot
    product would, so the values are bitwise those of one dot product per entry, but
    the chains interleave."""
    N = Z.shape[0]
    n = _FIXED_N if _FIXED_N > 0 else X.shape[1]
    m = _FIXED_M if _FIXED_M > 0 else Z.shape[1]
    for i in range(m):
        for j in range(i + 1):
            SAcc[i, j] = 0.0
    for i in range(n):
        for j in range(m):
            CAcc[i, j] = 0.0
    for k in range(N):
        for i in range(m):
            wz = wc[k] * Z[k, i]
            for j in range(i + 1):
                SAcc[i, j] += wz * Z[k, j]
        for i in range(n):
            wx = wc[k] * (X[k, i] - mean[b, i])
            for j in range(m):
                CAcc[i, j] += wx * Z[k, j]
    for i in range(m):
        z_hat[b, i] = mu[i]
        for j in range(i + 1):
            sij = SAcc[i, j] + 0.5 * (R[r, i, j] + R[r, j, i])
            Sb[i, j] = sij
            Sb[j, i] = sij
    for i in range(n):
        for j in range(m):
            Cb[i, j] = CAcc[i, j]


@jit
def keep_prior_into(mean, b, P, Cb, K, innovation, out_mean, out_cov):
    """A skipped update of element ``b``: the prior, zero innovation and ``K = C`` (the
    NumPy path's values: the update solved against S = I)."""
    n = _FIXED_N if _FIXED_N > 0 else mean.shape[1]
    m = _FIXED_M if _FIXED_M > 0 else Cb.shape[1]
    for i in range(m):
        innovation[b, i] = 0.0
    for i in range(n):
        out_mean[b, i] = mean[b, i]
        for j in range(m):
            K[i, j] = Cb[i, j]
        for j in range(n):
            out_cov[b, i, j] = P[i, j]


@jit
def gain_posterior_into(L, Cb, Sb, K, ysolve, KS, KSK, z, mu, mean, b, P, innovation, out_mean, out_cov):
    """Gain ``K = C S^{-1}`` (``S = L L^T``), posterior mean ``m + K (z - mu)`` and
    covariance ``P - K S K^T`` (symmetrised) of element ``b``. K S, then (K S) K^T in full
    (both triangles are needed for the symmetrised posterior); k outermost within a row,
    so the chains interleave, same sums."""
    n = _FIXED_N if _FIXED_N > 0 else mean.shape[1]
    m = _FIXED_M if _FIXED_M > 0 else Cb.shape[1]
    chol_solve_rows_into(L, Cb, K, ysolve)
    for i in range(m):
        innovation[b, i] = z[b, i] - mu[i]
    for i in range(n):
        acc = 0.0
        for j in range(m):
            acc += K[i, j] * innovation[b, j]
        out_mean[b, i] = mean[b, i] + acc
    for i in range(n):
        for j in range(m):
            KS[i, j] = 0.0
        for k in range(m):
            kik = K[i, k]
            for j in range(m):
                KS[i, j] += kik * Sb[k, j]
    for i in range(n):
        for j in range(n):
            KSK[i, j] = 0.0
        for k in range(m):
            ksik = KS[i, k]
            for j in range(n):
                KSK[i, j] += ksik * K[j, k]
    for i in range(n):
        for j in range(i + 1):
            v = 0.5 * ((P[i, j] - KSK[i, j]) + (P[j, i] - KSK[j, i]))
            out_cov[b, i, j] = v
            out_cov[b, j, i] = v


_STEPS = ("root_into", "points_into", "center_into", "spread_into", "measurement_moments_into",
          "keep_prior_into", "gain_posterior_into")
_steps_by_size: dict[tuple[int, int], dict] = {}


def steps_of_size(n: int, m: int, solve=None) -> dict:
    """Twins of every step with ``n`` states and ``m`` measurements (0: generic) as
    constants, and the dense helpers they call specialised too (``solve``: the driver's
    specialised `chol_solve_rows_into`); one set per sizes and process."""
    if not HAVE_NUMBA:
        return {}
    hit = _steps_by_size.get((n, m))
    if hit is None:
        over = {"_FIXED_N": n, "_FIXED_M": m}
        if n:
            hn = helpers_of_size(n)
            over.update({"_all_finite_n": hn["all_finite"], "_cholesky_n": hn["cholesky"],
                         "eigh_into": hn["eigh_into"]})
        if solve is not None:
            over["chol_solve_rows_into"] = solve
        suffix = f"_{n}_{m}"
        hit = _steps_by_size[(n, m)] = {name: jit(with_globals(globals()[name].py_func, suffix, **over))
                                        for name in _STEPS}
    return hit
