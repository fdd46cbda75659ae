"""Batch drivers of the compiled kernels: each runs one Gaussian rule (points, moments,
gain and posterior, or all of them fused) over a batch, one element at a time.

The Gaussian rules are written once, as per-element steps (`_points_into` with its
scratch `_points_scratch`, `_predict_moments_into`, `_innovation_moments_into`,
`_gain_mean_into`, `_posterior_into`, `_joseph_posterior_into`, `_keep_prior_into`, and
the KF/EKF predict `_linear_predict_into`), built per size by
`element_steps` and inlined into every driver that composes them: the plain drivers
(one rule per call, the model's f/h evaluated in NumPy between calls), the fused
predict and update (the model's compiled f/h between the steps), the KF/EKF predict and
the fused drivers' size-specialised twins. Every driver is a loop over chunks of
elements, scratch allocated per chunk, and steps per element; the EKF moments
(`_ekf_moments_body`) stay a single loop, which runs faster than the same as a step.
Each driver is compiled as a (serial, parallel) pair
(`specialise.jit_pair`); the fused drivers and the EKF moments are built per model
function and size by `_model_pair`.
"""

from __future__ import annotations

import math
import types as _types
import zlib

import numpy as np

from ..compiled_model import CompiledFunctions, linear_f, linear_h, linear_h_jacobian
from .dense import all_finite, chol_solve_rows_into, cholesky, eigh_into, helpers_of_size, mul_into, row_finite
from .specialise import HAVE_NUMBA, jit, jit_pair, prange, step_jit, with_globals

#: Most chunks a driver splits its batch into (scratch arrays are per chunk).
_CHUNKS = 64
#: Sizes of a specialised twin (0: read from the operands): state n, measurement m.
_FIXED_N = 0
_FIXED_M = 0

# The steps test the state covariance (n x n) and the innovation covariance (m x m)
# through these names, so that a specialised twin can bind each to its own size.
_all_finite_n = _all_finite_m = all_finite
_cholesky_n = _cholesky_m = cholesky


# -- the Gaussian rules, per element -----------------------------------------------------
#
# Each step reads the sizes through _FIXED_N/_FIXED_M and the n x n / m x m helpers
# through their names; `element_steps` compiles a set per size with numba's inlining
# forced, so a specialised driver composes steps that carry its constants. A step
# addresses points as an (N, B, n) batch and an element index: a plain driver hands it
# the batch and b, a fused driver its own (N, n) scratch viewed as a batch of one and 0
# (no copy and no strided slice per element, both slower).


def _points_scratch(n):
    """The scratch `_points_into` needs, allocated once per chunk of elements: the root,
    and the eigenvalues, eigenvectors and workspace of the eigen-decomposition."""
    return np.zeros((n, n)), np.empty(n), np.empty((n, n)), np.empty((n + 2, n))


def _points_into(mean, cov, b, root_kind, scale, center, Rt, w, V, Wk, X, e):
    """Sigma points ``X[:, e]`` (``X`` is ``(N, B, n)``) of element ``b``: ``[m], m + scale*S_i, m - scale*S_i``
    with ``S`` the root of ``P = cov[b]`` (``root_kind`` 0: lower Cholesky; 1: ``V sqrt(|w|)``
    from the eigen-decomposition). Returns the status: 0 ok, 1 P not finite, 2 P not
    positive definite (Cholesky)."""
    n = _FIXED_N if _FIXED_N > 0 else mean.shape[1]
    off = 1 if center else 0
    P = cov[b]
    Rt[:, :] = 0.0
    if not _all_finite_n(P):
        return 1
    if root_kind == 0:
        if not _cholesky_n(P, Rt):
            return 2
    else:
        eigh_into(P, w, V, Wk)
        for i in range(n):
            sw = math.sqrt(abs(w[i]))
            for j in range(n):
                Rt[j, i] = V[j, i] * sw
    if center:
        for j in range(n):
            X[0, e, j] = mean[b, j]
    for i in range(n):
        for j in range(n):
            dd = Rt[j, i] * scale
            X[off + i, e, j] = mean[b, j] + dd
            X[off + n + i, e, j] = mean[b, j] - dd
    return 0


def _predict_moments_into(d, N, wm, wc, Q, q, mu, Acc, out_mean, out_cov, b):
    """``out_mean[b]`` = weighted mean and ``out_cov[b] = sum wc dY dY^T + Q`` (symmetrised)
    of the ``N`` transformed points in ``d`` ``(N, p)``, which it overwrites with their
    deviations. One 2-D array for points and deviations (faster than a (N, B, p) batch
    read beside a 2-D alias)."""
    p = _FIXED_N if _FIXED_N > 0 else d.shape[1]
    mu[:] = 0.0
    for k in range(N):
        for j in range(p):
            mu[j] += wm[k] * d[k, j]
    for k in range(N):
        for j in range(p):
            d[k, j] -= mu[j]
    # Point by point into the lower triangle: each entry sums in the order k = 0..N-1
    # (as a dot product would), but the entries' chains interleave in the pipeline.
    for i in range(p):
        for j in range(i + 1):
            Acc[i, j] = 0.0
    for k in range(N):
        for i in range(p):
            wy = wc[k] * d[k, i]
            for j in range(i + 1):
                Acc[i, j] += wy * d[k, j]
    for i in range(p):
        out_mean[b, i] = mu[i]
        for j in range(i + 1):
            cij = Acc[i, j] + 0.5 * (Q[q, i, j] + Q[q, j, i])
            out_cov[b, i, j] = cij
            out_cov[b, j, i] = cij


def _innovation_moments_into(X, Z, e, d, N, mean, b, wm, wc, R, r, mu, SAcc, CAcc, z_hat, Sb, Cb):
    """``z_hat[b]`` (and ``mu``), ``S = sum wc dZ dZ^T + R`` (symmetrised) and
    ``C = sum wc (X - m) dZ^T`` of the ``N`` points ``X[:, e]`` and their transforms
    ``Z[:, e]`` (``(N, B, n)`` and ``(N, B, m)``; deviations into ``d`` ``(N, m)``, which
    may be the same memory as ``Z[:, e]``)."""
    n = _FIXED_N if _FIXED_N > 0 else X.shape[2]
    m = _FIXED_M if _FIXED_M > 0 else Z.shape[2]
    mu[:] = 0.0
    for k in range(N):
        for j in range(m):
            mu[j] += wm[k] * Z[k, e, j]
    for k in range(N):
        for j in range(m):
            d[k, j] = Z[k, e, j] - mu[j]
    # S (lower triangle) and C point by point: each entry sums in the order
    # k = 0..N-1 with the same products as a dot product would, so the values are
    # bitwise those of one dot product per entry, but the chains interleave.
    for i in range(m):
        for j in range(i + 1):
            SAcc[i, j] = 0.0
    for i in range(n):
        for j in range(m):
            CAcc[i, j] = 0.0
    for k in range(N):
        for i in range(m):
            wz = wc[k] * d[k, i]
            for j in range(i + 1):
                SAcc[i, j] += wz * d[k, j]
        for i in range(n):
            wx = wc[k] * (X[k, e, i] - mean[b, i])
            for j in range(m):
                CAcc[i, j] += wx * d[k, j]
    for i in range(m):
        z_hat[b, i] = mu[i]
        for j in range(i + 1):
            sij = SAcc[i, j] + 0.5 * (R[r, i, j] + R[r, j, i])
            Sb[i, j] = sij
            Sb[j, i] = sij
    for i in range(n):
        for j in range(m):
            Cb[i, j] = CAcc[i, j]


def _gain_mean_into(L, Cb, K, ysolve, z, z_hat, mean, b, innovation, out_mean):
    """Gain ``K = C S^{-1}`` (from the Cholesky factor L of S) and ``x + K (z - z_hat)``."""
    n = _FIXED_N if _FIXED_N > 0 else K.shape[0]
    m = _FIXED_M if _FIXED_M > 0 else K.shape[1]
    chol_solve_rows_into(L, Cb, K, ysolve)
    for i in range(m):
        innovation[b, i] = z[b, i] - z_hat[b, i]
    for i in range(n):
        acc = 0.0
        for j in range(m):
            acc += K[i, j] * innovation[b, j]
        out_mean[b, i] = mean[b, i] + acc


def _posterior_into(K, Sb, P, KS, KSK, out_cov, b):
    """``sym(P - K S K^T)`` of element ``b``."""
    n = _FIXED_N if _FIXED_N > 0 else K.shape[0]
    m = _FIXED_M if _FIXED_M > 0 else K.shape[1]
    # K S, then (K S) K^T in full (both triangles are needed for the symmetrised
    # posterior); k outermost within a row, so the chains interleave, same sums.
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


def _keep_prior_into(mean, b, P, Cb, K, innovation, out_mean, out_cov):
    """A skipped element: the prior, zero innovation and ``K = C`` (the NumPy path's values)."""
    n = _FIXED_N if _FIXED_N > 0 else K.shape[0]
    m = _FIXED_M if _FIXED_M > 0 else K.shape[1]
    for i in range(m):
        innovation[b, i] = 0.0
    for i in range(n):
        out_mean[b, i] = mean[b, i]
        for j in range(m):
            K[i, j] = Cb[i, j]
        for j in range(n):
            out_cov[b, i, j] = P[i, j]


def _joseph_posterior_into(K, Hh, Rr, P, A, AP, KR, M, M2, out_cov, b):
    """Joseph's form ``sym((I - K H) P (I - K H)^T + K R K^T)`` of element ``b``."""
    n = _FIXED_N if _FIXED_N > 0 else K.shape[0]
    mul_into(K, Hh, A, False)  # K H, then A = I - K H
    for i in range(n):
        for j in range(n):
            A[i, j] = (1.0 if i == j else 0.0) - A[i, j]
    mul_into(A, P, AP, False)
    mul_into(K, Rr, KR, False)  # K R
    mul_into(AP, A, M, True)
    mul_into(KR, K, M2, True)
    for i in range(n):
        for j in range(i + 1):
            v = 0.5 * ((M[i, j] + M2[i, j]) + (M[j, i] + M2[j, i]))
            out_cov[b, i, j] = v
            out_cov[b, j, i] = v


def _linear_predict_into(mean, cov, b, F, Q, q, FP, M, out_mean, out_cov):
    """``F x`` and ``sym(F P F^T + Q)`` of element ``b`` (the KF/EKF prediction)."""
    n = _FIXED_N if _FIXED_N > 0 else mean.shape[1]
    for i in range(n):
        acc = 0.0
        for j in range(n):
            acc += F[i, j] * mean[b, j]
        out_mean[b, i] = acc
        for k in range(n):
            acc = 0.0
            for j in range(n):
                acc += F[i, j] * cov[b, j, k]
            FP[i, k] = acc
    for i in range(n):
        for l in range(n):
            acc = 0.0
            for k in range(n):
                acc += FP[i, k] * F[l, k]
            M[i, l] = acc + Q[q, i, l]
    for i in range(n):
        for l in range(i + 1):
            v = 0.5 * (M[i, l] + M[l, i])
            out_cov[b, i, l] = v
            out_cov[b, l, i] = v


_STEPS = (
    _points_scratch,
    _points_into,
    _predict_moments_into,
    _innovation_moments_into,
    _gain_mean_into,
    _posterior_into,
    _joseph_posterior_into,
    _keep_prior_into,
    _linear_predict_into,
)
_steps_by_size: dict[tuple[int, int], dict] = {}


def element_steps(n: int = 0, m: int = 0, helpers: dict | None = None) -> dict:
    """The per-element steps compiled for ``n`` states and ``m`` measurements as constants
    (0: read from the operands), calling ``helpers`` (names bound to size-specialised
    Cholesky, eigh, solve; none: the generic ones), inlined into their caller."""
    key = (n, m)
    hit = _steps_by_size.get(key)
    if hit is None:
        over = {"_FIXED_N": n, "_FIXED_M": m, **(helpers or {})}
        hit = _steps_by_size[key] = {fn.__name__: step_jit(with_globals(fn, f"_{n}_{m}", **over)) for fn in _STEPS}
    return hit


# -- plain drivers: one rule per call, the model's f/h evaluated in NumPy between them --


def _sigma_points_body(mean, cov, root_kind, scale, center, X, status):
    """Points ``(N, B, n)`` for every element (`_points_into`); ``status[b]`` its status."""
    B, n = mean.shape
    chunks = min(B, _CHUNKS)
    for c in prange(chunks):
        R, w, V, Wk = _points_scratch(n)  # once per chunk of elements, not once per element
        for b in range((c * B) // chunks, ((c + 1) * B) // chunks):
            status[b] = _points_into(mean, cov, b, root_kind, scale, center, R, w, V, Wk, X, b)


def _predict_moments_body(Y, wm, wc, Q, mean, cov):
    """Weighted mean and ``sum wc dY dY^T + Q`` (symmetrised) of points ``(N, B, p)``
    (`_predict_moments_into`)."""
    N, B, p = Y.shape
    shared_q = Q.shape[0] == 1
    chunks = min(B, _CHUNKS)
    for c in prange(chunks):
        mu = np.empty(p)
        d = np.empty((N, p))
        Acc = np.empty((p, p))
        for b in range((c * B) // chunks, ((c + 1) * B) // chunks):
            for k in range(N):
                for j in range(p):
                    d[k, j] = Y[k, b, j]
            _predict_moments_into(d, N, wm, wc, Q, 0 if shared_q else np.int64(b), mu, Acc, mean, cov, b)


def _measurement_moments_body(X, Z, prior_mean, wm, wc, R, z_hat, S, C):
    """``z_hat``, ``S = sum wc dZ dZ^T + R`` (symmetrised) and ``C = sum wc (X - m) dZ^T``
    (`_innovation_moments_into`)."""
    N, B, m = Z.shape
    n = X.shape[2]
    shared_r = R.shape[0] == 1
    chunks = min(B, _CHUNKS)
    for c in prange(chunks):
        mu = np.empty(m)
        d = np.empty((N, m))
        SAcc = np.empty((m, m))
        CAcc = np.empty((n, m))
        for b in range((c * B) // chunks, ((c + 1) * B) // chunks):
            _innovation_moments_into(
                X,
                Z,
                b,
                d,
                N,
                prior_mean,
                b,
                wm,
                wc,
                R,
                0 if shared_r else np.int64(b),
                mu,
                SAcc,
                CAcc,
                z_hat,
                S[b],
                C[b],
            )


def _update_body(prior_mean, prior_cov, z, z_hat, S, C, bad_z, joseph, H, R, mean, cov, gain, innovation, ok):
    """Gain, posterior (``P - K S K^T`` or Joseph's form) and skip mask; ``ok[b]`` False
    where S is not finite/PD. Skipped elements (``bad_z`` or not ok) keep the prior and
    report the NumPy path's values: zero innovation and ``K = C`` (`_keep_prior_into`).
    """
    B, n = prior_mean.shape
    m = z.shape[1]
    shared_h = H.shape[0] == 1
    shared_r = R.shape[0] == 1
    chunks = min(B, _CHUNKS)
    for c in prange(chunks):
        L = np.zeros((m, m))
        Y = np.empty((n, m + 1))
        KS = np.empty((n, m))
        M = np.empty((n, n))
        A = np.empty((n, n))
        AP = np.empty((n, n))
        M2 = np.empty((n, n))
        for b in range((c * B) // chunks, ((c + 1) * B) // chunks):
            Sb, Cb, K, P = S[b], C[b], gain[b], prior_cov[b]
            good = _all_finite_m(Sb) and _cholesky_m(Sb, L)
            ok[b] = good
            if bad_z[b] or not good:
                _keep_prior_into(prior_mean, b, P, Cb, K, innovation, mean, cov)
                continue
            _gain_mean_into(L, Cb, K, Y, z, z_hat, prior_mean, b, innovation, mean)
            if not joseph:
                _posterior_into(K, Sb, P, KS, M, cov, b)
            else:
                _joseph_posterior_into(
                    K, H[0 if shared_h else np.int64(b)], R[0 if shared_r else np.int64(b)], P, A, AP, KS, M, M2, cov, b
                )


# -- the model's compiled functions ---------------------------------------------------

# The drivers below call a model's compiled f, h and Jacobian through these names; a
# model's drivers (`_model_pair`) bind each to that model's jitted function, so numba
# inlines it. The defaults are the linear ones (what the drivers warm up with).
_apply_f_row = linear_f
_apply_h_row = linear_h
_apply_h_jacobian = linear_h_jacobian


def _linear_predict_body(mean, cov, F, Q, out_mean, out_cov):
    """``F x`` and ``sym(F P F^T + Q)`` per element, F shared (`_linear_predict_into`)."""
    B, n = mean.shape
    shared_q = Q.shape[0] == 1
    chunks = min(B, _CHUNKS)
    for c in prange(chunks):
        FP = np.empty((n, n))
        M = np.empty((n, n))
        for b in range((c * B) // chunks, ((c + 1) * B) // chunks):
            _linear_predict_into(mean, cov, b, F, Q, 0 if shared_q else np.int64(b), FP, M, out_mean, out_cov)


def _ekf_moments_body(mean, cov, h_params, R, z_hat, S, C):
    """``h(x)``, ``S = sym(H P H^T + R)`` and ``C = P H^T`` with H the Jacobian at x."""
    B, n = mean.shape
    m = z_hat.shape[1]
    shared_r = R.shape[0] == 1
    chunks = min(B, _CHUNKS)
    for c in prange(chunks):
        J = np.empty((m, n))
        M = np.empty((m, m))
        for b in range((c * B) // chunks, ((c + 1) * B) // chunks):
            r = 0 if shared_r else np.int64(b)
            _apply_h_row(h_params, mean, b, z_hat, b)
            _apply_h_jacobian(h_params, mean, b, J)
            P = cov[b]
            Cb = C[b]
            for i in range(n):
                for j in range(m):
                    acc = 0.0
                    for k in range(n):
                        acc += P[i, k] * J[j, k]
                    Cb[i, j] = acc
            for i in range(m):
                for j in range(m):
                    acc = 0.0
                    for k in range(n):
                        acc += J[i, k] * Cb[k, j]
                    M[i, j] = acc + R[r, i, j]
            for i in range(m):
                for j in range(i + 1):
                    v = 0.5 * (M[i, j] + M[j, i])
                    S[b, i, j] = v
                    S[b, j, i] = v


# -- fused drivers: every step of a predict or update in one pass, the model's compiled f/h between them --


def _fused_predict_body(mean, cov, root_kind, scale, center, wm, wc, f_params, Q, out_mean, out_cov, status, counts):
    """One predict per element: points (`_points_into`), compiled ``f``, moments + Q
    (`_predict_moments_into`); ``counts[0]``: elements whose root failed (``status`` not 0)."""
    B = mean.shape[0]
    # A specialised twin (`_model_pair`) has the state dimension as a compile-time constant.
    n = _FIXED_N if _FIXED_N > 0 else mean.shape[1]
    N = 2 * n + (1 if center else 0)
    shared_q = Q.shape[0] == 1
    chunks = min(B, _CHUNKS)
    for c in prange(chunks):
        R, w, V, Wk = _points_scratch(n)  # once per chunk of elements, not once per element
        X = np.empty((N, n))
        Y = np.empty((N, n))
        # The steps address points as (N, B, n) batches: these views are a batch of one.
        X1 = X.reshape((N, 1, n))
        mu = np.empty(n)
        Acc = np.empty((n, n))
        for b in range((c * B) // chunks, ((c + 1) * B) // chunks):
            status[b] = _points_into(mean, cov, b, root_kind, scale, center, R, w, V, Wk, X1, 0)
            if status[b] != 0:
                continue
            for k in range(N):
                _apply_f_row(f_params, X, k, Y)
            _predict_moments_into(Y, N, wm, wc, Q, 0 if shared_q else np.int64(b), mu, Acc, out_mean, out_cov, b)
    counts[0] = 0
    for b in range(B):
        counts[0] += status[b] != 0


def _fused_update_body(
    mean,
    cov,
    z,
    bad_z,
    root_kind,
    scale,
    center,
    wm,
    wc,
    h_params,
    R,
    out_mean,
    out_cov,
    gain,
    innovation,
    z_hat,
    S,
    C,
    status,
    ok,
    skipped,
    counts,
):
    """One measurement update per element: points, compiled ``h``, moments, gain, posterior
    (`_points_into`, `_innovation_moments_into`, `_gain_mean_into`, `_posterior_into`).

    An element whose ``z`` is not finite counts as ``bad_z`` too. ``skipped[b]``: bad z
    or S not PD; ``counts``: elements with bad z, a failed root (``status``), S not PD
    (so the caller tests three integers instead of reducing three masks).
    """
    B = mean.shape[0]
    n = _FIXED_N if _FIXED_N > 0 else mean.shape[1]  # constants in a specialised twin
    m = _FIXED_M if _FIXED_M > 0 else z.shape[1]
    N = 2 * n + (1 if center else 0)
    shared_r = R.shape[0] == 1
    chunks = min(B, _CHUNKS)
    for c in prange(chunks):
        Rt, w, V, Wk = _points_scratch(n)
        X = np.empty((N, n))
        Z = np.empty((N, m))
        X1 = X.reshape((N, 1, n))  # batches of one, as the steps address points
        Z1 = Z.reshape((N, 1, m))
        mu = np.empty(m)
        L = np.zeros((m, m))
        KS = np.empty((n, m))
        ysolve = np.empty((n, m + 1))
        SAcc = np.empty((m, m))
        CAcc = np.empty((n, m))
        KSK = np.empty((n, n))
        for b in range((c * B) // chunks, ((c + 1) * B) // chunks):
            P = cov[b]
            ok[b] = False
            status[b] = _points_into(mean, cov, b, root_kind, scale, center, Rt, w, V, Wk, X1, 0)
            if status[b] != 0:
                continue
            for k in range(N):
                _apply_h_row(h_params, X, k, Z, k)
            Sb, Cb, K = S[b], C[b], gain[b]
            _innovation_moments_into(
                X1, Z1, 0, Z, N, mean, b, wm, wc, R, 0 if shared_r else np.int64(b), mu, SAcc, CAcc, z_hat, Sb, Cb
            )
            good = _all_finite_m(Sb) and _cholesky_m(Sb, L)
            ok[b] = good
            if bad_z[b] or not good or not row_finite(z, b):
                _keep_prior_into(mean, b, P, Cb, K, innovation, out_mean, out_cov)
                continue
            _gain_mean_into(L, Cb, K, ysolve, z, z_hat, mean, b, innovation, out_mean)
            _posterior_into(K, Sb, P, KS, KSK, out_cov, b)
    counts[:] = 0
    for b in range(B):  # serial, after the parallel loop
        bz = bad_z[b] or not row_finite(z, b)
        skipped[b] = bz or not ok[b]
        counts[0] += bz
        counts[1] += status[b] != 0
        counts[2] += status[b] == 0 and not ok[b]


def _pd_mask_body(A, ok):
    """``ok[b]``: ``A[b]`` finite and its lower triangle Cholesky-factorable (PD)."""
    B, n, _ = A.shape
    chunks = min(B, _CHUNKS)
    for c in prange(chunks):
        L = np.empty((n, n))
        for b in range((c * B) // chunks, ((c + 1) * B) // chunks):
            ok[b] = all_finite(A[b]) and cholesky(A[b], L)


if HAVE_NUMBA:  # the generic drivers call the generic steps (the plain functions without numba)
    globals().update(element_steps())
_sigma_points_kernels = jit_pair(_sigma_points_body)
_predict_moments_kernels = jit_pair(_predict_moments_body)
_measurement_moments_kernels = jit_pair(_measurement_moments_body)
_update_kernels = jit_pair(_update_body)
_pd_mask_kernels = jit_pair(_pd_mask_body)
_linear_predict_kernels = jit_pair(_linear_predict_body)


_linear_f_by_size: dict[int, object] = {}


def _linear_f_of_size(n: int):
    """`linear_f` with the state size ``n`` as a constant (one per size and process)."""
    hit = _linear_f_by_size.get(n)
    if hit is None:
        hit = _linear_f_by_size[n] = jit(with_globals(linear_f.py_func, f"_{n}", _FIXED_K=n))
    return hit


def _tag(fn) -> str:
    """A name for a model function's drivers that changes when its code does, so their
    disk cache entries are its own (numba's cache checks only the driver's source file)."""
    py = getattr(fn, "py_func", fn)
    code = py.__code__
    consts = tuple(c.co_code if isinstance(c, _types.CodeType) else c for c in code.co_consts)
    key = f"{py.__module__}.{py.__qualname__}".encode() + code.co_code + repr(consts).encode()
    return "".join(ch if ch.isalnum() else "_" for ch in py.__name__) + f"_{zlib.crc32(key):08x}"


#: (driver, model functions, sizes) -> (serial, parallel) drivers bound to them.
_model_drivers: dict[tuple, tuple] = {}


def _model_pair(body, functions: dict, n: int = 0, m: int = 0):
    """(serial, parallel) twins of the driver ``body`` that call the given model functions
    (``{"_apply_h_row": h, ...}``), compiled for ``n`` states and ``m`` measurements as
    constants where these are not 0. One pair per driver, functions and sizes; the
    functions are compile-time constants, so numba inlines them, and each twin inlines
    its own size constants (separately compiled generic helpers would not see them)."""
    key = (body.__name__, tuple(sorted(functions.items(), key=lambda kv: kv[0])), n, m)
    hit = _model_drivers.get(key)
    if hit is not None:
        return hit
    if not HAVE_NUMBA:
        hit = _model_drivers[key] = (body, body) if not functions else (with_globals(body, "", **functions),) * 2
        return hit
    over = dict(functions)
    suffix = "".join("_" + _tag(fn) for _, fn in key[1])
    if n:
        hn = helpers_of_size(n)
        over.update(
            {
                "_FIXED_N": n,
                "_all_finite_n": hn["all_finite"],
                "_cholesky_n": hn["cholesky"],
                "eigh_into": hn["eigh_into"],
            }
        )
        if over.get("_apply_f_row") is linear_f:
            over["_apply_f_row"] = _linear_f_of_size(n)
        suffix += f"_{n}"
    if m:
        hm = helpers_of_size(m)
        solve = jit(with_globals(chol_solve_rows_into.py_func, f"_{n}_{m}", _FIXED_N=n, _FIXED_M=m))
        over.update(
            {
                "_FIXED_M": m,
                "_all_finite_m": hm["all_finite"],
                "_cholesky_m": hm["cholesky"],
                "chol_solve_rows_into": solve,
            }
        )
        suffix += f"_{m}"
    if n and body in (_fused_predict_body, _fused_update_body):
        # The steps this twin composes, compiled with its sizes and its sized helpers.
        over.update(
            element_steps(
                n,
                m,
                {
                    k: over[k]
                    for k in ("_all_finite_n", "_cholesky_n", "eigh_into", "chol_solve_rows_into")
                    if k in over
                },
            )
        )
    hit = _model_drivers[key] = jit_pair(with_globals(body, suffix, **over))
    return hit


def _sizes_of(compiled: CompiledFunctions, n: int, m: int = 0) -> tuple[int, int]:
    """The sizes a model's drivers are specialised to for this call ((0, 0): generic)."""
    sizes = compiled.sizes
    if sizes is None or sizes[0] != n or (m and sizes[1] != m):
        return 0, 0
    return n, (sizes[1] if m else 0)


#: (driver, model functions, call sizes, declared sizes) -> its pair: the per-call lookup
#: (one hash of a small tuple; `_model_pair`'s own key sorts and is built once).
_pairs: dict[tuple, tuple] = {}


def _predict_pair(compiled: CompiledFunctions, n: int):
    key = (0, compiled.f, n, compiled.sizes)
    hit = _pairs.get(key)
    if hit is None:
        hit = _pairs[key] = _model_pair(_fused_predict_body, {"_apply_f_row": compiled.f}, _sizes_of(compiled, n)[0])
    return hit


def _update_pair(compiled: CompiledFunctions, n: int, m: int):
    key = (1, compiled.h, n, m, compiled.sizes)
    hit = _pairs.get(key)
    if hit is None:
        hit = _pairs[key] = _model_pair(_fused_update_body, {"_apply_h_row": compiled.h}, *_sizes_of(compiled, n, m))
    return hit


def _ekf_pair(compiled: CompiledFunctions):
    key = (2, compiled.h, compiled.h_jacobian)
    hit = _pairs.get(key)
    if hit is None:
        hit = _pairs[key] = _model_pair(
            _ekf_moments_body, {"_apply_h_row": compiled.h, "_apply_h_jacobian": compiled.h_jacobian}
        )
    return hit
