"""Compiled (numba) kernels behind the Gaussian filter engines.

The NumPy code in ``estimator.py`` is the reference implementation; these kernels do
the same arithmetic in one pass per batch element, without the temporaries and the
Python wrappers of NumPy's batched calls on tiny matrices. They cover

* the square root of P (lower Cholesky, or for ``svd-ckf`` the symmetric
  eigen-decomposition: Householder tridiagonalisation + implicit QR with Wilkinson
  shifts, as LAPACK does it, see `_eigh_into`) and the sigma/cubature points built from it;
* the weighted moments of transformed points (predicted mean and covariance + Q, or
  predicted measurement, innovation covariance + R and cross covariance);
* the measurement update: Cholesky of S, gain ``K = C S^{-1}``, posterior mean and
  covariance (``P - K S K^T`` or Joseph's form), with the skip/failure mask;
* a positive-definiteness test without the factor (`pd_mask`), which the filter step's
  posterior check and the noise adapters' bound tests use every step.

A model's NumPy ``f`` and ``h`` are evaluated between these kernels. A model that also
carries compiled twins (`gnssframework.estimation.CompiledFunctions`: jitted functions
defined next to the model, e.g. linear ``F x`` and ``H x`` here, the correlator channel
model in `gnssframework.signal.channel_model`, a plugin's own) runs a whole sigma-point
predict or update in one compiled pass per element (``fused_predict``,
``fused_update``), and the KF/EKF predict and measurement moments in compiled code
(``linear_predict``, ``ekf_moments``). The drivers of those passes are built per model
function (`_model_pair`): the function is a compile-time constant, so numba inlines it,
and this module knows no model. Results equal the NumPy path to rounding (a Hypothesis
test holds them to 1e-12 relative on random models).

Every input array reaches a kernel writable (read-only ones are copied), so each kernel
has one numba specialisation: the one `warm_up` compiles (a test checks that runs add none).

Backend choice: `gnssframework.backend` (``GNSSFRAMEWORK_BACKEND``, ``set_backend``; an
estimator's ``backend`` attribute overrides it for that instance).

Every kernel is compiled twice: a serial version for small batches (no thread launch)
and a ``parallel=True`` version whose ``prange`` splits the batch across cores from
:data:`PARALLEL_MIN_BATCH` elements on. Both are cached on disk (``cache=True``), so
only the first import on a machine pays the compile time. The fused predict and update
(the hot path of a batched channel filter) split a large batch differently by default
(:data:`SPLIT`): the calling thread and one helper thread take chunks of it as each
becomes free (`gnssframework.estimation.kernel_pool`), because numba's workers, asleep
between the calls of a filter loop, wake too late for the static split to gain (measured
on the 100-run vector loop: the parallel twin ran the update at about the serial speed,
the split at about 0.65 of it when the second core is free, and at the serial speed when
it is not). A model that declares its sizes (``CompiledFunctions.sizes``, the channel
filter's 5 states and 6 measurements) gets fused drivers with those sizes as constants,
bitwise the generic ones.
"""

from __future__ import annotations

import math
import os
import threading
import types as _types
import zlib

import numpy as np

from . import kernel_pool
from .compiled_model import CompiledFunctions, linear_f, linear_h, linear_h_jacobian

__all__ = [
    "HAVE_NUMBA",
    "PARALLEL_MIN_BATCH",
    "PD_MASK_PARALLEL_MIN_BATCH",
    "sigma_points",
    "predict_moments",
    "measurement_moments",
    "update",
    "pd_mask",
    "linear_predict",
    "ekf_moments",
    "fused_predict",
    "fused_update",
    "warm_up",
]

from ..backend import HAVE_NUMBA

if HAVE_NUMBA:
    import numba
    from numba import prange
else:  # pragma: no cover - exercised only where numba is missing
    numba = None
    prange = range

#: Batch size from which the ``parallel=True`` kernels are used.
PARALLEL_MIN_BATCH = 256
#: Most chunks a fused kernel splits its batch into (scratch arrays are per chunk).
_CHUNKS = 64


# -- compilation helpers ----------------------------------------------------------------


def _twin(fn, suffix: str):
    """A copy of ``fn`` with its own qualified name, so its disk cache entry is its own."""
    twin = _types.FunctionType(fn.__code__, fn.__globals__, fn.__name__ + suffix, fn.__defaults__, fn.__closure__)
    twin.__qualname__ = fn.__qualname__ + suffix
    return twin


#: Sizes of a specialised twin (0: read from the operands): state n, measurement m, and
#: the size k of a helper's square operand.
_FIXED_N = 0
_FIXED_M = 0
_FIXED_K = 0


def _with_globals(fn, suffix: str, **overrides):
    """A twin of the plain function ``fn`` whose globals are the module's with
    ``overrides``. numba freezes a global's value when it compiles, so an override of
    ``_FIXED_N``/``_FIXED_M``/``_FIXED_K`` makes that size a compile-time constant (LLVM
    then unrolls and keeps in registers what the generic code indexes at run time), and
    an override of a helper's name calls that helper's specialised twin. The arithmetic
    and its order are the generic code's own, so results are bitwise the same. The
    suffix gives the twin its own disk cache entry."""
    env = dict(fn.__globals__)
    env.update(overrides)
    twin = _types.FunctionType(fn.__code__, env, fn.__name__ + suffix, fn.__defaults__, fn.__closure__)
    twin.__qualname__ = fn.__qualname__ + suffix
    twin.__module__ = fn.__module__
    return twin


def _jit(fn):
    if not HAVE_NUMBA:
        return fn
    return numba.njit(cache=True, fastmath=False, nogil=True)(fn)


def _jit_pair(fn):
    """(serial, parallel) compiled versions of a batch driver that loops with prange."""
    if not HAVE_NUMBA:
        return fn, fn
    serial = numba.njit(cache=True, nogil=True)(_twin(fn, "_serial"))
    parallel = numba.njit(cache=True, nogil=True, parallel=True)(_twin(fn, "_parallel"))
    return serial, parallel


# -- per-element building blocks --------------------------------------------------------


@_jit
def _all_finite(a):
    """Every entry of the matrix ``a`` finite (explicit loops: ``ravel`` would make a
    view, and every view costs an atomic reference-count increment and decrement)."""
    k = _FIXED_K if _FIXED_K > 0 else a.shape[0]  # square in a specialised twin
    for i in range(k):
        for j in range(k if _FIXED_K > 0 else a.shape[1]):
            if not math.isfinite(a[i, j]):
                return False
    return True


@_jit
def _row_finite(a, b):
    """Every entry of row ``b`` of ``a`` finite (no view)."""
    for j in range(a.shape[1]):
        if not math.isfinite(a[b, j]):
            return False
    return True


@_jit
def _cholesky(A, L):
    """Lower Cholesky factor of the lower triangle of ``A`` into ``L``; False if not PD."""
    n = _FIXED_K if _FIXED_K > 0 else A.shape[0]
    for j in range(n):
        s = A[j, j]
        for k in range(j):
            s -= L[j, k] * L[j, k]
        if not (s > 0.0):
            return False
        d = math.sqrt(s)
        L[j, j] = d
        for i in range(j):
            L[i, j] = 0.0
        for i in range(j + 1, n):
            t = A[i, j]
            for k in range(j):
                t -= L[i, k] * L[j, k]
            L[i, j] = t / d
    return True


@_jit
def _jacobi_eigh(A, w, V):
    """``A = V diag(w) V^T`` (see `_jacobi_eigh_into`)."""
    _jacobi_eigh_into(A, w, V, np.empty(A.shape))


@_jit
def _jacobi_eigh_into(A, w, V, B):
    """Eigen-decomposition of the symmetric part of ``A`` by cyclic Jacobi rotations.

    ``A = V diag(w) V^T``. Jacobi's method is accurate to rounding in every
    eigenvalue relative to ``||A||`` and converges quadratically; for the 2-10 state
    matrices of a tracking filter a handful of sweeps beat LAPACK's call overhead
    (Golub & Van Loan, *Matrix Computations*, 4th ed., sec. 8.5). Each rotation
    updates only the two affected rows/columns of the symmetric matrix. ``B``: scratch
    of at least ``(n, n)``. The fallback of `_eigh_into` (the tridiagonal QR is about
    twice as fast on the filters' 5x5 covariances: 4 Jacobi sweeps of 10 rotations
    against about 6 QR steps).
    """
    n = A.shape[0]
    for i in range(n):
        for j in range(n):
            B[i, j] = 0.5 * (A[i, j] + A[j, i])
            V[i, j] = 1.0 if i == j else 0.0
    for _sweep in range(60):
        off = 0.0
        diag = 0.0
        for i in range(n):
            diag += B[i, i] * B[i, i]
            for j in range(i + 1, n):
                off += B[i, j] * B[i, j]
        if off <= 1e-34 * diag or off == 0.0:
            break
        for p in range(n - 1):
            for q in range(p + 1, n):
                bpq = B[p, q]
                if bpq == 0.0:
                    continue
                theta = (B[q, q] - B[p, p]) / (2.0 * bpq)
                t = (1.0 if theta >= 0.0 else -1.0) / (abs(theta) + math.sqrt(theta * theta + 1.0))
                c = 1.0 / math.sqrt(t * t + 1.0)
                s = t * c
                for k in range(n):
                    if k != p and k != q:
                        bkp = B[k, p]
                        bkq = B[k, q]
                        nkp = c * bkp - s * bkq
                        nkq = s * bkp + c * bkq
                        B[k, p] = nkp
                        B[p, k] = nkp
                        B[k, q] = nkq
                        B[q, k] = nkq
                # The rotation annihilates (p, q) (Golub & Van Loan's symmetric Schur form).
                B[p, p] -= t * bpq
                B[q, q] += t * bpq
                B[p, q] = 0.0
                B[q, p] = 0.0
                for k in range(n):
                    vkp = V[k, p]
                    vkq = V[k, q]
                    V[k, p] = c * vkp - s * vkq
                    V[k, q] = s * vkp + c * vkq
    for i in range(n):
        w[i] = B[i, i]


@_jit
def _eigh(A, w, V):
    """``A = V diag(w) V^T`` for the symmetric part of ``A`` (see `_eigh_into`)."""
    _eigh_into(A, w, V, np.empty((A.shape[0] + 2, A.shape[0])))


@_jit
def _eigh_into(A, w, V, W):
    """Eigen-decomposition of the symmetric part of ``A`` (n, n): ``A = V diag(w) V^T``.

    ``W`` is ``(n + 2, n)`` scratch. The work is `_tridiagonal_eigh_into` (Householder
    tridiagonalisation, then implicit QR with Wilkinson shifts: the algorithm of
    LAPACK's ``dsytrd`` + ``dsteqr``, which NumPy's ``eigh`` runs on matrices this
    small); if that has not converged after ``30 n`` QR steps (it converges in about two
    per eigenvalue, so this means non-finite input) the cyclic Jacobi method finishes
    the job from the start.

    Why the svd-ckf result equals the NumPy reference (LAPACK ``eigh``) to rounding:
    both are backward stable, so each computes the exact eigen-decomposition of a
    matrix within a few ``eps ||A||`` of ``A``. Where the eigenvalues are distinct, the
    eigenvectors are unique up to sign and move by at most about
    ``eps ||A|| / gap`` (gap: distance to the nearest other eigenvalue; Davis-Kahan),
    and the cubature points ``m +- sqrt(n) sqrt(|w_i|) v_i`` are the same *set* whatever
    the sign of each ``v_i`` (the pair swaps) and whatever the order of the columns
    (the points are permuted; the cubature weights are all equal, so only the order of
    the sums changes). So the two point sets agree to ``eps ||A|| / gap`` relative (and
    ``eps sqrt(cond P)`` in the smallest directions), far below 1e-12 for the
    covariances filters carry (in the vector loop the relative gaps are above 4e-2 and
    cond P below 4e5 after the first step).

    Where eigenvalues are (nearly) equal, their eigenvectors are not determined: any
    orthonormal basis of the (near) invariant subspace is a valid answer, and which one
    comes out depends on the algorithm and on rounding. Any such basis gives a root of
    P (``S S^T = P`` holds), so the filter stays a cubature Kalman filter with the same
    first two moments, but on a nonlinear model its third- and higher-order terms can
    differ from the reference's by the rule's own truncation error, not by rounding. A
    diagonal P (an initial covariance, repeated variances included) is the exception:
    no rotation is ever applied to it, so its eigenvectors are the coordinate axes in
    both solvers.
    """
    if not _tridiagonal_eigh_into(A, w, V, W):
        _jacobi_eigh_into(A, w, V, W)


#: ``max|A|`` range in which `_tridiagonal_eigh_into` needs no scaling: squares of
#: entries (and sums of n of them) neither overflow nor leave the normal range.
_TINY = 2.0 ** -400
_HUGE = 2.0 ** 400


@_jit
def _tridiagonal_eigh_into(A, w, V, W):
    """Householder tridiagonalisation and implicit symmetric QR with Wilkinson shifts.

    Golub & Van Loan, *Matrix Computations*, 4th ed., algorithms 8.3.1 (tridiagonal
    form, backward accumulation of the Householder product) and 8.3.2 (implicit QR step
    with the Wilkinson shift), deflating where ``|e_i| <= eps sqrt(|d_i| |d_i+1|)`` (the
    test of LAPACK's ``dsteqr``, which keeps small eigenvalues of graded matrices
    accurate) or ``|e_i| <= eps^2 max|A|`` (so exactly singular blocks deflate). A
    matrix with ``max|A|`` outside ``[2^-400, 2^400]`` is scaled by a power of two to
    ``max|A| ~ 1`` first (exact, so the result is the same as unscaled), so squares of
    entries neither overflow nor underflow. ``W`` ``(n + 2, n)``: rows ``0..n-1`` the
    working matrix (Householder vectors below its diagonal), row ``n`` the off-diagonal
    ``e``, row ``n + 1`` the Householder scalars. Returns False if it has not
    converged after ``30 n`` QR steps (``w``, ``V`` then undefined).
    """
    n = _FIXED_K if _FIXED_K > 0 else A.shape[0]
    amax = 0.0
    for i in range(n):
        for j in range(n):
            a = abs(A[i, j])
            if a > amax:
                amax = a
    scale = 1.0
    if amax > 0.0 and math.isfinite(amax) and not (_TINY < amax < _HUGE):
        scale = math.ldexp(1.0, -math.frexp(amax)[1])  # 2**-k, max|A| * scale in [0.5, 1)
    top = amax * scale
    for i in range(n):
        for j in range(n):
            W[i, j] = 0.5 * (A[i, j] + A[j, i]) * scale
            V[i, j] = 1.0 if i == j else 0.0
    # -- tridiagonal form: T = Q^T A Q, Q = H_0 ... H_{n-3}, H_k = I - beta_k v_k v_k^T
    for k in range(n - 2):
        tail = 0.0
        for i in range(k + 2, n):
            tail += W[i, k] * W[i, k]
        x0 = W[k + 1, k]
        if tail == 0.0:  # column already reduced: no reflection (keeps a diagonal P exact)
            W[n, k] = x0
            W[n + 1, k] = 0.0
            continue
        alpha = math.sqrt(x0 * x0 + tail)
        if x0 < 0.0:
            alpha = -alpha  # v_0 = x_0 + sign(x_0) ||x||: no cancellation
        v0 = x0 + alpha
        W[k + 1, k] = v0
        beta = 2.0 / (v0 * v0 + tail)
        W[n, k] = -alpha
        W[n + 1, k] = beta
        # Symmetric rank-2 update of the trailing block: A22 -= v u^T + u v^T with
        # p = beta A22 v, u = p - (beta/2)(v^T p) v (w is free scratch until the end).
        for i in range(k + 1, n):
            acc = 0.0
            for j in range(k + 1, n):
                acc += W[i, j] * W[j, k]
            w[i] = beta * acc
        kk = 0.0
        for i in range(k + 1, n):
            kk += W[i, k] * w[i]
        kk *= 0.5 * beta
        for i in range(k + 1, n):
            w[i] -= kk * W[i, k]
        for i in range(k + 1, n):
            for j in range(k + 1, i + 1):
                val = W[i, j] - W[i, k] * w[j] - w[i] * W[j, k]
                W[i, j] = val
                W[j, i] = val
    if n >= 2:
        W[n, n - 2] = W[n - 1, n - 2]
    for k in range(n - 3, -1, -1):  # V = H_0 (H_1 (... H_{n-3}))
        beta = W[n + 1, k]
        if beta == 0.0:
            continue
        for j in range(k + 1, n):
            acc = 0.0
            for i in range(k + 1, n):
                acc += W[i, k] * V[i, j]
            acc *= beta
            for i in range(k + 1, n):
                V[i, j] -= acc * W[i, k]
    for i in range(n):
        w[i] = W[i, i]
    # -- implicit QR on (d = w, e = W[n]); rotations accumulate into V's columns
    eps2 = 2.220446049250313e-16 ** 2
    floor2 = eps2 * eps2 * top * top
    hi = n - 1
    steps = 0
    while hi > 0:
        lo = hi
        while lo > 0:
            t = W[n, lo - 1] * W[n, lo - 1]  # squared tests: no square roots in the scan
            if t <= eps2 * abs(w[lo - 1] * w[lo]) or t <= floor2:
                W[n, lo - 1] = 0.0
                break
            lo -= 1
        if lo == hi:
            hi -= 1
            continue
        if steps >= 30 * n:
            return False
        steps += 1
        g = 0.5 * (w[hi - 1] - w[hi])
        f = W[n, hi - 1]
        r = math.sqrt(g * g + f * f)
        mu = w[hi] - f * f / (g + (r if g >= 0.0 else -r))
        x = w[lo] - mu
        z = W[n, lo]
        for k in range(lo, hi):
            r = math.sqrt(x * x + z * z)
            if r == 0.0:
                c = 1.0
                s = 0.0
            else:
                ir = 1.0 / r
                c = x * ir
                s = -z * ir
            if k > lo:
                W[n, k - 1] = r
            a = w[k]
            b = w[k + 1]
            f = W[n, k]
            cs = c * s
            w[k] = c * c * a - 2.0 * cs * f + s * s * b
            w[k + 1] = s * s * a + 2.0 * cs * f + c * c * b
            W[n, k] = cs * (a - b) + (c * c - s * s) * f
            if k < hi - 1:
                x = W[n, k]
                z = -s * W[n, k + 1]
                W[n, k + 1] = c * W[n, k + 1]
            for i in range(n):
                vk = V[i, k]
                vk1 = V[i, k + 1]
                V[i, k] = c * vk - s * vk1
                V[i, k + 1] = s * vk + c * vk1
    inv = 1.0 / scale
    for i in range(n):
        w[i] *= inv
    return True


@_jit
def _chol_solve_rows(L, C, K):
    """``K = C S^{-1}`` row by row with ``S = L L^T`` (forward then back substitution)."""
    _chol_solve_rows_into(L, C, K, np.empty((C.shape[0], C.shape[1] + 1)))


@_jit
def _chol_solve_rows_into(L, C, K, Y):
    """`_chol_solve_rows` with scratch ``Y`` ``(n, m + 1)``.

    Every row's substitutions run together (the row index innermost), so the n
    independent dependency chains overlap in the CPU's pipeline; each entry still
    sums its terms in the textbook order, so the result is bitwise that of solving the
    rows one after the other.
    """
    n = _FIXED_N if _FIXED_N > 0 else C.shape[0]
    m = _FIXED_M if _FIXED_M > 0 else C.shape[1]
    for i in range(m):
        for r in range(n):
            Y[r, m] = C[r, i]
        for k in range(i):
            lik = L[i, k]
            for r in range(n):
                Y[r, m] -= lik * Y[r, k]
        d = L[i, i]
        for r in range(n):
            Y[r, i] = Y[r, m] / d
    for i in range(m - 1, -1, -1):
        for r in range(n):
            Y[r, m] = Y[r, i]
        for k in range(i + 1, m):
            lki = L[k, i]
            for r in range(n):
                Y[r, m] -= lki * K[r, k]
        d = L[i, i]
        for r in range(n):
            K[r, i] = Y[r, m] / d


@_jit
def _mul_into(A, Bm, out, transpose_b):
    """``out = A Bm`` (or ``A Bm^T``). Each entry sums ``A[i, k] Bm[k, j]`` over k = 0, 1, ...
    from 0.0, as a dot product would (so bitwise the same), with k outermost within a row
    so that the row's independent accumulation chains overlap in the pipeline."""
    rows, inner = A.shape
    cols = Bm.shape[0] if transpose_b else Bm.shape[1]
    for i in range(rows):
        for j in range(cols):
            out[i, j] = 0.0
        for k in range(inner):
            a = A[i, k]
            if transpose_b:
                for j in range(cols):
                    out[i, j] += a * Bm[j, k]
            else:
                for j in range(cols):
                    out[i, j] += a * Bm[k, j]


# -- batch drivers ----------------------------------------------------------------------

# The fused drivers test the state covariance (n x n) and the innovation covariance
# (m x m) through these names, so that a specialised twin can bind each to its own size.
_all_finite_n = _all_finite_m = _all_finite
_cholesky_n = _cholesky_m = _cholesky


def _sigma_points_body(mean, cov, root_kind, scale, center, X, status):
    """Points ``(N, B, n)`` for every element: ``[m], m + scale*S_i, m - scale*S_i``.

    ``root_kind`` 0: lower Cholesky; 1: ``V sqrt(|w|)`` from the eigen-decomposition.
    ``status[b]``: 0 ok, 1 P not finite, 2 P not positive definite (Cholesky).
    """
    B, n = mean.shape
    off = 1 if center else 0
    chunks = min(B, _CHUNKS)
    for c in prange(chunks):
      # Scratch allocated once per chunk of elements, not once per element.
      R = np.zeros((n, n))
      w = np.empty(n)
      V = np.empty((n, n))
      Wk = np.empty((n + 2, n))
      for b in range((c * B) // chunks, ((c + 1) * B) // chunks):
        P = cov[b]
        R[:, :] = 0.0
        if not _all_finite(P):
            status[b] = 1
            continue
        if root_kind == 0:
            if not _cholesky(P, R):
                status[b] = 2
                continue
        else:
            _eigh_into(P, w, V, Wk)
            for i in range(n):
                sw = math.sqrt(abs(w[i]))
                for j in range(n):
                    R[j, i] = V[j, i] * sw
        status[b] = 0
        if center:
            for j in range(n):
                X[0, b, j] = mean[b, j]
        for i in range(n):
            for j in range(n):
                d = R[j, i] * scale
                X[off + i, b, j] = mean[b, j] + d
                X[off + n + i, b, j] = mean[b, j] - d


def _predict_moments_body(Y, wm, wc, Q, mean, cov):
    """Weighted mean and ``sum wc dY dY^T + Q`` (symmetrised) of points ``(N, B, p)``.

    The covariance accumulates point by point (each entry sums over k = 0..N-1 in
    order, as a dot product would: the same values, with the chains interleaved)."""
    N, B, p = Y.shape
    shared_q = Q.shape[0] == 1
    chunks = min(B, _CHUNKS)
    for c in prange(chunks):
      mu = np.empty(p)
      d = np.empty((N, p))
      Acc = np.empty((p, p))
      for b in range((c * B) // chunks, ((c + 1) * B) // chunks):
        q = 0 if shared_q else np.int64(b)
        mu[:] = 0.0
        for k in range(N):
            for j in range(p):
                mu[j] += wm[k] * Y[k, b, j]
        for k in range(N):
            for j in range(p):
                d[k, j] = Y[k, b, j] - mu[j]
        for i in range(p):
            for j in range(i + 1):
                Acc[i, j] = 0.0
        for k in range(N):
            for i in range(p):
                wd = wc[k] * d[k, i]
                for j in range(i + 1):
                    Acc[i, j] += wd * d[k, j]
        for i in range(p):
            mean[b, i] = mu[i]
            for j in range(i + 1):
                cij = Acc[i, j] + 0.5 * (Q[q, i, j] + Q[q, j, i])
                cov[b, i, j] = cij
                cov[b, j, i] = cij


def _measurement_moments_body(X, Z, prior_mean, wm, wc, R, z_hat, S, C):
    """``z_hat``, ``S = sum wc dZ dZ^T + R`` (symmetrised) and ``C = sum wc (X - m) dZ^T``
    (accumulated point by point, as `_predict_moments_body`)."""
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
        r = 0 if shared_r else np.int64(b)
        mu[:] = 0.0
        for k in range(N):
            for j in range(m):
                mu[j] += wm[k] * Z[k, b, j]
        for k in range(N):
            for j in range(m):
                d[k, j] = Z[k, b, j] - mu[j]
        for i in range(m):
            for j in range(i + 1):
                SAcc[i, j] = 0.0
        for i in range(n):
            for j in range(m):
                CAcc[i, j] = 0.0
        for k in range(N):
            for i in range(m):
                wd = wc[k] * d[k, i]
                for j in range(i + 1):
                    SAcc[i, j] += wd * d[k, j]
            for i in range(n):
                wx = wc[k] * (X[k, b, i] - prior_mean[b, i])
                for j in range(m):
                    CAcc[i, j] += wx * d[k, j]
        for i in range(m):
            z_hat[b, i] = mu[i]
            for j in range(i + 1):
                sij = SAcc[i, j] + 0.5 * (R[r, i, j] + R[r, j, i])
                S[b, i, j] = sij
                S[b, j, i] = sij
        for i in range(n):
            for j in range(m):
                C[b, i, j] = CAcc[i, j]


def _update_body(prior_mean, prior_cov, z, z_hat, S, C, bad_z, joseph, H, R, mean, cov, gain, innovation, ok):
    """Gain, posterior and skip mask; ``ok[b]`` False where S is not finite/PD.

    Skipped elements (``bad_z`` or not ok) keep the prior and report the NumPy path's
    values: zero innovation and ``K = C`` (the update solved against S = I).
    """
    B, n = prior_mean.shape
    m = z.shape[1]
    shared_h = H.shape[0] == 1
    shared_r = R.shape[0] == 1
    chunks = min(B, _CHUNKS)
    for c in prange(chunks):
      # Scratch once per chunk of elements; every product through _mul_into.
      L = np.zeros((m, m))
      Y = np.empty((n, m + 1))
      KS = np.empty((n, m))
      M = np.empty((n, n))
      A = np.empty((n, n))
      AP = np.empty((n, n))
      M2 = np.empty((n, n))
      for b in range((c * B) // chunks, ((c + 1) * B) // chunks):
        Sb = S[b]
        good = _all_finite(Sb) and _cholesky(Sb, L)
        ok[b] = good
        K = gain[b]
        if bad_z[b] or not good:
            for i in range(m):
                innovation[b, i] = 0.0
            for i in range(n):
                mean[b, i] = prior_mean[b, i]
                for j in range(m):
                    K[i, j] = C[b, i, j]
                for j in range(n):
                    cov[b, i, j] = prior_cov[b, i, j]
            continue
        _chol_solve_rows_into(L, C[b], K, Y)
        for i in range(m):
            innovation[b, i] = z[b, i] - z_hat[b, i]
        for i in range(n):
            acc = 0.0
            for j in range(m):
                acc += K[i, j] * innovation[b, j]
            mean[b, i] = prior_mean[b, i] + acc
        P = prior_cov[b]
        if not joseph:
            _mul_into(K, Sb, KS, False)  # K S
            _mul_into(KS, K, M, True)  # (K S) K^T; entry (j, i) is the other order's sum
            for i in range(n):
                for j in range(i + 1):
                    v = 0.5 * ((P[i, j] - M[i, j]) + (P[j, i] - M[j, i]))
                    cov[b, i, j] = v
                    cov[b, j, i] = v
        else:
            h = 0 if shared_h else np.int64(b)
            r = 0 if shared_r else np.int64(b)
            _mul_into(K, H[h], A, False)  # K H, then A = I - K H
            for i in range(n):
                for j in range(n):
                    A[i, j] = (1.0 if i == j else 0.0) - A[i, j]
            _mul_into(A, P, AP, False)
            _mul_into(K, R[r], KS, False)  # K R
            _mul_into(AP, A, M, True)
            _mul_into(KS, K, M2, True)
            for i in range(n):
                for j in range(i + 1):
                    v = 0.5 * ((M[i, j] + M2[i, j]) + (M[j, i] + M2[j, i]))
                    cov[b, i, j] = v
                    cov[b, j, i] = v


# -- the model's compiled functions ---------------------------------------------------

# The drivers below call a model's compiled f, h and Jacobian through these names; a
# model's drivers (`_model_pair`) bind each to that model's jitted function, so numba
# inlines it. The defaults are the linear ones (what the drivers warm up with).
_apply_f_row = linear_f
_apply_h_row = linear_h
_apply_h_jacobian = linear_h_jacobian


def _linear_predict_body(mean, cov, F, Q, out_mean, out_cov):
    """``F x`` and ``sym(F P F^T + Q)`` per element (the KF/EKF prediction, F shared)."""
    B, n = mean.shape
    shared_q = Q.shape[0] == 1
    chunks = min(B, _CHUNKS)
    for c in prange(chunks):
        FP = np.empty((n, n))
        M = np.empty((n, n))
        for b in range((c * B) // chunks, ((c + 1) * B) // chunks):
            q = 0 if shared_q else np.int64(b)
            P = cov[b]
            for i in range(n):
                acc = 0.0
                for j in range(n):
                    acc += F[i, j] * mean[b, j]
                out_mean[b, i] = acc
                for k in range(n):
                    acc = 0.0
                    for j in range(n):
                        acc += F[i, j] * P[j, k]
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


def _fused_predict_body(mean, cov, root_kind, scale, center, wm, wc, f_params, Q, out_mean, out_cov, status, counts):
    """One predict per element: root, points, compiled ``f``, moments + Q; ``counts[0]``:
    elements whose root failed (``status`` not 0)."""
    B = mean.shape[0]
    # A specialised twin (`_specialised_pair`) has the state dimension as a compile-time constant.
    n = _FIXED_N if _FIXED_N > 0 else mean.shape[1]
    N = 2 * n + (1 if center else 0)
    off = 1 if center else 0
    shared_q = Q.shape[0] == 1
    chunks = min(B, _CHUNKS)
    for c in prange(chunks):
      # Scratch allocated once per chunk of elements, not once per element.
      R = np.zeros((n, n))
      w = np.empty(n)
      V = np.empty((n, n))
      Wk = np.empty((n + 2, n))
      X = np.empty((N, n))
      Y = np.empty((N, n))
      mu = np.empty(n)
      Acc = np.empty((n, n))
      for b in range((c * B) // chunks, ((c + 1) * B) // chunks):
        P = cov[b]
        R[:, :] = 0.0
        if not _all_finite_n(P):
            status[b] = 1
            continue
        if root_kind == 0:
            if not _cholesky_n(P, R):
                status[b] = 2
                continue
        else:
            _eigh_into(P, w, V, Wk)
            for i in range(n):
                sw = math.sqrt(abs(w[i]))
                for j in range(n):
                    R[j, i] = V[j, i] * sw
        status[b] = 0
        if center:
            for j in range(n):
                X[0, j] = mean[b, j]
        for i in range(n):
            for j in range(n):
                dd = R[j, i] * scale
                X[off + i, j] = mean[b, j] + dd
                X[off + n + i, j] = mean[b, j] - dd
        for k in range(N):
            _apply_f_row(f_params, X, k, Y)
        q = 0 if shared_q else np.int64(b)
        mu[:] = 0.0
        for k in range(N):
            for j in range(n):
                mu[j] += wm[k] * Y[k, j]
        for k in range(N):
            for j in range(n):
                Y[k, j] -= mu[j]
        # Point by point into the lower triangle: each entry sums in the order k = 0..N-1
        # (as a dot product would), but the entries' chains interleave in the pipeline.
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
    counts[0] = 0
    for b in range(B):
        counts[0] += status[b] != 0


def _fused_update_body(mean, cov, z, bad_z, root_kind, scale, center, wm, wc, h_params, R,
                       out_mean, out_cov, gain, innovation, z_hat, S, C, status, ok, skipped, counts):
    """One measurement update per element: root, points, compiled ``h``, moments, gain, posterior.

    An element whose ``z`` is not finite counts as ``bad_z`` too. ``skipped[b]``: bad z
    or S not PD; ``counts``: elements with bad z, a failed root (``status``), S not PD
    (so the caller tests three integers instead of reducing three masks).
    """
    B = mean.shape[0]
    n = _FIXED_N if _FIXED_N > 0 else mean.shape[1]  # constants in a specialised twin
    m = _FIXED_M if _FIXED_M > 0 else z.shape[1]
    N = 2 * n + (1 if center else 0)
    off = 1 if center else 0
    shared_r = R.shape[0] == 1
    chunks = min(B, _CHUNKS)
    for c in prange(chunks):
      Rt = np.zeros((n, n))
      w = np.empty(n)
      V = np.empty((n, n))
      Wk = np.empty((n + 2, n))
      X = np.empty((N, n))
      Z = np.empty((N, m))
      mu = np.empty(m)
      L = np.zeros((m, m))
      KS = np.empty((n, m))
      ysolve = np.empty((n, m + 1))
      SAcc = np.empty((m, m))
      CAcc = np.empty((n, m))
      KSK = np.empty((n, n))
      for b in range((c * B) // chunks, ((c + 1) * B) // chunks):
        P = cov[b]
        Rt[:, :] = 0.0
        ok[b] = False
        if not _all_finite_n(P):
            status[b] = 1
            continue
        if root_kind == 0:
            if not _cholesky_n(P, Rt):
                status[b] = 2
                continue
        else:
            _eigh_into(P, w, V, Wk)
            for i in range(n):
                sw = math.sqrt(abs(w[i]))
                for j in range(n):
                    Rt[j, i] = V[j, i] * sw
        status[b] = 0
        if center:
            for j in range(n):
                X[0, j] = mean[b, j]
        for i in range(n):
            for j in range(n):
                dd = Rt[j, i] * scale
                X[off + i, j] = mean[b, j] + dd
                X[off + n + i, j] = mean[b, j] - dd
        for k in range(N):
            _apply_h_row(h_params, X, k, Z, k)
        r = 0 if shared_r else np.int64(b)
        mu[:] = 0.0
        for k in range(N):
            for j in range(m):
                mu[j] += wm[k] * Z[k, j]
        for k in range(N):
            for j in range(m):
                Z[k, j] -= mu[j]
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
                wz = wc[k] * Z[k, i]
                for j in range(i + 1):
                    SAcc[i, j] += wz * Z[k, j]
            for i in range(n):
                wx = wc[k] * (X[k, i] - mean[b, i])
                for j in range(m):
                    CAcc[i, j] += wx * Z[k, j]
        Sb = S[b]
        for i in range(m):
            z_hat[b, i] = mu[i]
            for j in range(i + 1):
                sij = SAcc[i, j] + 0.5 * (R[r, i, j] + R[r, j, i])
                Sb[i, j] = sij
                Sb[j, i] = sij
        Cb = C[b]
        for i in range(n):
            for j in range(m):
                Cb[i, j] = CAcc[i, j]
        good = _all_finite_m(Sb) and _cholesky_m(Sb, L)
        ok[b] = good
        K = gain[b]
        if bad_z[b] or not good or not _row_finite(z, b):
            for i in range(m):
                innovation[b, i] = 0.0
            for i in range(n):
                out_mean[b, i] = mean[b, i]
                for j in range(m):
                    K[i, j] = Cb[i, j]
                for j in range(n):
                    out_cov[b, i, j] = P[i, j]
            continue
        _chol_solve_rows_into(L, Cb, K, ysolve)
        for i in range(m):
            innovation[b, i] = z[b, i] - mu[i]
        for i in range(n):
            acc = 0.0
            for j in range(m):
                acc += K[i, j] * innovation[b, j]
            out_mean[b, i] = mean[b, i] + acc
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
    counts[:] = 0
    for b in range(B):  # serial, after the parallel loop
        bz = bad_z[b] or not _row_finite(z, b)
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
            ok[b] = _all_finite(A[b]) and _cholesky(A[b], L)


_sigma_points_kernels = _jit_pair(_sigma_points_body)
_predict_moments_kernels = _jit_pair(_predict_moments_body)
_measurement_moments_kernels = _jit_pair(_measurement_moments_body)
_update_kernels = _jit_pair(_update_body)
_pd_mask_kernels = _jit_pair(_pd_mask_body)
_linear_predict_kernels = _jit_pair(_linear_predict_body)


_helpers_by_size: dict[int, dict] = {}


def _helpers_of_size(k: int) -> dict:
    """The per-element helpers on ``k x k`` operands, specialised to that size (one set
    per size and process, shared by every driver that uses it)."""
    if not HAVE_NUMBA:
        return {}
    hit = _helpers_by_size.get(k)
    if hit is None:
        size = {"_FIXED_K": k}
        tri = _jit(_with_globals(_tridiagonal_eigh_into.py_func, f"_{k}", **size))
        hit = _helpers_by_size[k] = {
            "all_finite": _jit(_with_globals(_all_finite.py_func, f"_{k}", **size)),
            "cholesky": _jit(_with_globals(_cholesky.py_func, f"_{k}", **size)),
            "eigh_into": _jit(_with_globals(_eigh_into.py_func, f"_{k}", _tridiagonal_eigh_into=tri)),
            "linear_f": _jit(_with_globals(linear_f.py_func, f"_{k}", **size)),
        }
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
        hit = _model_drivers[key] = (body, body) if not functions else (_with_globals(body, "", **functions),) * 2
        return hit
    over = dict(functions)
    suffix = "".join("_" + _tag(fn) for _, fn in key[1])
    if n:
        hn = _helpers_of_size(n)
        over.update({"_FIXED_N": n, "_all_finite_n": hn["all_finite"], "_cholesky_n": hn["cholesky"],
                     "_eigh_into": hn["eigh_into"]})
        if over.get("_apply_f_row") is linear_f:
            over["_apply_f_row"] = hn["linear_f"]
        suffix += f"_{n}"
    if m:
        hm = _helpers_of_size(m)
        solve = _jit(_with_globals(_chol_solve_rows_into.py_func, f"_{n}_{m}", _FIXED_N=n, _FIXED_M=m))
        over.update({"_FIXED_M": m, "_all_finite_m": hm["all_finite"], "_cholesky_m": hm["cholesky"],
                     "_chol_solve_rows_into": solve})
        suffix += f"_{m}"
    hit = _model_drivers[key] = _jit_pair(_with_globals(body, suffix, **over))
    return hit


def _sizes_of(compiled: CompiledFunctions, n: int, m: int = 0) -> tuple[int, int]:
    """The sizes a model's drivers are specialised to for this call ((0, 0): generic)."""
    sizes = compiled.sizes
    if sizes is None or sizes[0] != n or (m and sizes[1] != m):
        return 0, 0
    return n, (sizes[1] if m else 0)


def _predict_pair(compiled: CompiledFunctions, n: int):
    return _model_pair(_fused_predict_body, {"_apply_f_row": compiled.f}, _sizes_of(compiled, n)[0])


def _update_pair(compiled: CompiledFunctions, n: int, m: int):
    return _model_pair(_fused_update_body, {"_apply_h_row": compiled.h}, *_sizes_of(compiled, n, m))


def _ekf_pair(compiled: CompiledFunctions):
    return _model_pair(_ekf_moments_body, {"_apply_h_row": compiled.h, "_apply_h_jacobian": compiled.h_jacobian})


#: Batch size from which `pd_mask` runs in parallel: its element costs ~0.1 us, so the
#: ~60 us of a parallel launch pays only from a few thousand elements (measured: at 800,
#: serial 77 us against parallel 98 us; at 8000, 714 against 365 us).
PD_MASK_PARALLEL_MIN_BATCH = 2048


#: How a fused predict/update runs from `PARALLEL_MIN_BATCH` on: ``"pool"`` splits the
#: batch into `_SPLIT_CHUNKS` chunks that the calling thread and one helper thread take
#: as each becomes free (`gnssframework.estimation.kernel_pool`: the call never waits
#: for a sleeping thread to wake), ``"numba"`` runs the ``parallel=True`` twin.
SPLIT = "pool"
#: Chunks per split: each costs a kernel call and a few slices, and a helper that wakes
#: late finds fewer to take. Measured on the 100-run vector loop (svd-ckf, quiet
#: machine): 4 chunks 283-287x real time, 8 269-275x, 16 243-253x.
_SPLIT_CHUNKS = 4


#: Work (batch x n x m^2) from which the KF/EKF update and moments split their batch
#: like the fused kernels: that of `PARALLEL_MIN_BATCH` channel-filter elements (5
#: states, 6 measurements). ``ekf-pv``'s 100 runs x (8 states, 16 measurements) pass it.
SPLIT_MIN_WORK = PARALLEL_MIN_BATCH * 5 * 6 * 6


def _run_split(pair, B: int, args: tuple, batched, counts: np.ndarray | None = None, by_work: bool = False,
               chunks: int | None = None) -> None:
    """``kernel(*args[, counts])`` of a driver pair: serial below `PARALLEL_MIN_BATCH`
    (unless ``by_work``), above it split by `SPLIT` (``"pool"``: chunks on the calling
    thread and the helper; ``"numba"``: the parallel twin; only from the main thread).
    ``batched()``: indices of the arguments whose first axis is the batch (sliced per
    chunk; asked only when splitting); ``counts`` is summed over the chunks. Every
    element runs the same serial code whichever thread takes it (bitwise)."""
    if B < PARALLEL_MIN_BATCH and not by_work:  # the common small batch: no more tests
        kernel = pair[0]
    elif SPLIT != "pool":
        kernel = pair[0] if by_work and B < PARALLEL_MIN_BATCH else _pick(pair, B)
    elif threading.current_thread() is not threading.main_thread():
        kernel = pair[0]
    else:
        kernel = None
    if kernel is not None:
        kernel(*args) if counts is None else kernel(*args, counts)
        return
    idx = batched()
    n = min(_SPLIT_CHUNKS, B) if chunks is None else chunks
    per_chunk = None if counts is None else np.zeros((n, counts.shape[0]), dtype=np.int64)
    serial = pair[0]

    def run_chunk(i: int) -> None:
        lo, hi = (i * B) // n, ((i + 1) * B) // n
        chunk = [a[lo:hi] if j in idx else a for j, a in enumerate(args)]
        serial(*chunk) if per_chunk is None else serial(*chunk, per_chunk[i])

    kernel_pool.run_chunks(n, run_chunk)
    if counts is not None:
        counts[:] = per_chunk.sum(axis=0)


def _split_by_work(B: int, n: int, m: int) -> bool:
    """True where a batch of ``B`` updates of ``n`` states / ``m`` measurements is worth
    splitting below `PARALLEL_MIN_BATCH` (see `SPLIT_MIN_WORK`)."""
    return 2 <= B < PARALLEL_MIN_BATCH and B * n * m * m >= SPLIT_MIN_WORK


def _work_chunks(B: int, n: int, m: int) -> int | None:
    """Chunks for a split by work: about twice `SPLIT_MIN_WORK` each (each chunk costs a
    kernel call and a few slices, so small work is not cut finer; measured on ``ekf-pv``
    at 100 runs, 2 to 8 chunks ran alike), 2 to `_SPLIT_CHUNKS`; None (the default) from
    `PARALLEL_MIN_BATCH` on."""
    if B >= PARALLEL_MIN_BATCH:
        return None
    return max(2, min(_SPLIT_CHUNKS, B * n * m * m // (2 * SPLIT_MIN_WORK)))


def _pick(pair, batch: int, min_batch: int | None = None):
    if batch >= (PARALLEL_MIN_BATCH if min_batch is None else min_batch) and \
            threading.current_thread() is threading.main_thread():
        return pair[1]
    return pair[0]


# -- array-level wrappers ---------------------------------------------------------------


def _operand(a: np.ndarray) -> np.ndarray:
    """A kernel *input* as a writable array (a copy only where it is read-only).

    numba compiles one specialisation per writeable flag; handing every input writable
    (outputs are fresh writable arrays too) gives each kernel a single signature, the
    one `warm_up` compiles, so no forked worker compiles again whatever arrays a filter
    passes. Writable is the cheap side: a filter's state comes writable from the
    previous step's kernel, so the check costs one flag read (a read-only view per
    operand cost about a microsecond per call). No kernel writes an input."""
    return a if a.flags.writeable else a.copy()


#: The float64 dtype instance: ``a.dtype is _F64`` is the cheap test of the common case
#: (an equal but distinct dtype instance just takes the general path).
_F64 = np.dtype(np.float64)


def _vec(a) -> np.ndarray:
    """A small shared operand (weights, model parameters) as a contiguous float array."""
    if type(a) is np.ndarray and a.dtype is _F64:
        flags = a.flags  # one flags object, not two (each costs ~0.1 us)
        if flags.writeable and flags.c_contiguous:
            return a
    return _operand(np.ascontiguousarray(a, dtype=float))


def _flat(a: np.ndarray, batch: tuple[int, ...], tail: int) -> np.ndarray:
    """``a`` broadcast to ``batch + tail dims`` as a C-contiguous ``(B, ...)`` kernel operand."""
    if type(a) is np.ndarray and a.dtype is _F64 and a.shape[:-tail] == batch:
        flags = a.flags
        if flags.c_contiguous:
            # The common case, a (B, ...) array straight from the previous step: no reshape.
            if a.ndim == tail + 1:
                return a if flags.writeable else a.copy()
            return _operand(a.reshape((-1,) + a.shape[a.ndim - tail:]))
    a = np.asarray(a, dtype=float)
    shape = batch + a.shape[a.ndim - tail:]
    if a.shape != shape:
        a = np.broadcast_to(a, shape)
    return _operand(np.ascontiguousarray(a).reshape((-1,) + shape[len(batch):]))


def _flat_mask(mask: np.ndarray, batch: tuple[int, ...]) -> np.ndarray:
    """A boolean batch mask as a contiguous ``(B,)`` kernel operand."""
    if type(mask) is np.ndarray and mask.shape == batch and mask.flags.c_contiguous:
        return _operand(mask.reshape(-1))
    return _operand(np.ascontiguousarray(np.broadcast_to(mask, batch)).reshape(-1))


#: ``(1, k, l)`` kernel views of shared matrix operands (a model's Q and R), by id; each
#: entry holds its array, so an id is never reused while cached. A view shares the array's
#: memory, so an in-place change of Q or R is seen as before.
_shared_views: dict[int, tuple[np.ndarray, np.ndarray]] = {}
_SHARED_VIEWS_MAX = 256


def _flat_shared(a: np.ndarray, batch: tuple[int, ...]) -> np.ndarray:
    """A matrix operand ``(k, l)`` shared by the batch as ``(1, k, l)``, else ``(B, k, l)``."""
    hit = _shared_views.get(id(a))
    if hit is not None and hit[0] is a:
        return hit[1]
    if type(a) is np.ndarray and a.ndim == 2 and a.dtype == np.float64 and a.flags.c_contiguous:
        view = _operand(a[None])
        if len(_shared_views) >= _SHARED_VIEWS_MAX:
            _shared_views.clear()
        _shared_views[id(a)] = (a, view)
        return view
    a = np.asarray(a, dtype=float)
    if a.ndim == 2:
        return _operand(np.ascontiguousarray(a)[None])
    return _flat(a, batch, 2)


def sigma_points(mean: np.ndarray, cov: np.ndarray, root_kind: int, scale: float, center: bool):
    """Sigma points ``(N, ..., n)`` and a status ``(...)`` (0 ok, 1 not finite, 2 not PD)."""
    batch = mean.shape[:-1]
    n = mean.shape[-1]
    m = _flat(mean, batch, 1)
    P = _flat(cov, batch, 2)
    B = m.shape[0]
    N = 2 * n + (1 if center else 0)
    X = np.empty((N, B, n))
    status = np.empty(B, dtype=np.int8)
    _pick(_sigma_points_kernels, B)(m, P, root_kind, float(scale), bool(center), X, status)
    if len(batch) == 1:
        return X, status
    return X.reshape((N,) + batch + (n,)), status.reshape(batch)


def predict_moments(Y: np.ndarray, wm: np.ndarray, wc: np.ndarray, Q: np.ndarray):
    """Mean ``(..., p)`` and covariance ``(..., p, p)`` of points ``(N, ..., p)`` plus Q."""
    N = Y.shape[0]
    batch = Y.shape[1:-1]
    p = Y.shape[-1]
    Yf = np.ascontiguousarray(Y, dtype=float).reshape(N, -1, p)
    B = Yf.shape[1]
    mean = np.empty((B, p))
    cov = np.empty((B, p, p))
    _pick(_predict_moments_kernels, B)(_operand(Yf), _vec(wm), _vec(wc), _flat_shared(Q, batch), mean, cov)
    if len(batch) == 1:
        return mean, cov
    return mean.reshape(batch + (p,)), cov.reshape(batch + (p, p))


def measurement_moments(X: np.ndarray, Z: np.ndarray, prior_mean: np.ndarray, wm, wc, R: np.ndarray):
    """``(z_hat, S, C)`` of points X ``(N, ..., n)`` and their images Z ``(N, ..., m)``."""
    N = X.shape[0]
    batch = X.shape[1:-1]
    n = X.shape[-1]
    m = Z.shape[-1]
    Xf = np.ascontiguousarray(X, dtype=float).reshape(N, -1, n)
    Zf = np.ascontiguousarray(np.broadcast_to(Z, (N,) + batch + (m,)), dtype=float).reshape(N, -1, m)
    B = Xf.shape[1]
    z_hat = np.empty((B, m))
    S = np.empty((B, m, m))
    C = np.empty((B, n, m))
    _pick(_measurement_moments_kernels, B)(
        _operand(Xf), _operand(Zf), _flat(prior_mean, batch, 1), _vec(wm), _vec(wc),
        _flat_shared(R, batch), z_hat, S, C,
    )
    if len(batch) == 1:
        return z_hat, S, C
    return z_hat.reshape(batch + (m,)), S.reshape(batch + (m, m)), C.reshape(batch + (n, m))


#: Zero (1, m, n) / (1, m, m) operands standing for H and R where the update does not
#: read them (posterior ``P - K S K^T``), by size: allocated once, never written.
_unused_operands: dict[tuple[int, int], tuple[np.ndarray, np.ndarray]] = {}


def update(prior_mean, prior_cov, z, z_hat, S, C, bad_z, joseph: bool = False, H=None, R=None):
    """Posterior mean, covariance, gain, innovation and the S-is-PD mask, batch-first."""
    batch = prior_mean.shape[:-1]
    n = prior_mean.shape[-1]
    m = z.shape[-1]
    pm = _flat(prior_mean, batch, 1)
    B = pm.shape[0]
    if joseph:
        Hf, Rf = _flat_shared(H, batch), _flat_shared(R, batch)
    else:
        Hf, Rf = _unused_operands.get((m, n)) or _unused_operands.setdefault(
            (m, n), (np.zeros((1, m, n)), np.zeros((1, m, m))))
    mean = np.empty((B, n))
    cov = np.empty((B, n, n))
    gain = np.empty((B, n, m))
    innovation = np.empty((B, m))
    ok = np.empty(B, dtype=np.bool_)
    args = (pm, _flat(prior_cov, batch, 2), _flat(z, batch, 1), _flat(z_hat, batch, 1), _flat(S, batch, 2),
            _flat(C, batch, 2), _flat_mask(bad_z, batch), bool(joseph), Hf, Rf, mean, cov, gain, innovation, ok)
    by_work = _split_by_work(B, n, m)
    _run_split(_update_kernels, B, args, lambda: (0, 1, 2, 3, 4, 5, 6) + tuple(
        i for i in (8, 9) if args[i].shape[0] == B) + tuple(range(10, 15)), by_work=by_work,
        chunks=_work_chunks(B, n, m) if by_work else None)
    if len(batch) == 1:
        return mean, cov, gain, innovation, ok
    return (
        mean.reshape(batch + (n,)),
        cov.reshape(batch + (n, n)),
        gain.reshape(batch + (n, m)),
        innovation.reshape(batch + (m,)),
        ok.reshape(batch),
    )


def pd_mask(a: np.ndarray) -> np.ndarray:
    """Boolean ``(...)``: True where the matrix ``a[...]`` ``(..., n, n)`` is finite and
    positive definite (its lower triangle has a Cholesky factor). A test only: no factor
    is returned, so nothing is allocated per element."""
    batch = a.shape[:-2]
    A = _flat(a, batch, 2)
    ok = np.empty(A.shape[0], dtype=np.bool_)
    _pick(_pd_mask_kernels, A.shape[0], max(PARALLEL_MIN_BATCH, PD_MASK_PARALLEL_MIN_BATCH))(A, ok)
    return ok.reshape(batch)


def linear_predict(mean, cov, F, Q):
    """``(F x, sym(F P F^T + Q))`` batch-first, F ``(n, n)`` shared by the batch."""
    batch = mean.shape[:-1]
    n = mean.shape[-1]
    m_ = _flat(mean, batch, 1)
    B = m_.shape[0]
    out_mean = np.empty((B, n))
    out_cov = np.empty((B, n, n))
    _pick(_linear_predict_kernels, B)(m_, _flat(cov, batch, 2), _vec(F),
                                      _flat_shared(Q, batch), out_mean, out_cov)
    return out_mean.reshape(batch + (n,)), out_cov.reshape(batch + (n, n))


def ekf_moments(mean, cov, compiled, R):
    """The EKF's ``(z_hat, S, C)`` with the compiled h and its analytic Jacobian at the mean."""
    batch = mean.shape[:-1]
    n = mean.shape[-1]
    m = R.shape[-1]
    m_ = _flat(mean, batch, 1)
    B = m_.shape[0]
    z_hat, S, C = np.empty((B, m)), np.empty((B, m, m)), np.empty((B, n, m))
    Rf = _flat_shared(R, batch)
    args = (m_, _flat(cov, batch, 2), _vec(compiled.h_params), Rf, z_hat, S, C)
    by_work = _split_by_work(B, n, m)
    _run_split(_ekf_pair(compiled), B, args, lambda: (0, 1) + ((3,) if Rf.shape[0] == B else ()) + (4, 5, 6),
               by_work=by_work, chunks=_work_chunks(B, n, m) if by_work else None)
    return z_hat.reshape(batch + (m,)), S.reshape(batch + (m, m)), C.reshape(batch + (n, m))


def fused_predict(mean, cov, rule, compiled, Q):
    """Whole sigma-point predict with the model's compiled ``f``: mean, cov, status."""
    root_kind, scale, center, wm, wc = rule
    batch = mean.shape[:-1]
    n = mean.shape[-1]
    m_ = _flat(mean, batch, 1)
    B = m_.shape[0]
    out_mean = np.empty((B, n))
    out_cov = np.empty((B, n, n))
    status = np.empty(B, dtype=np.int8)
    counts = np.empty(1, dtype=np.int64)
    Qf = _flat_shared(Q, batch)
    args = (m_, _flat(cov, batch, 2), root_kind, scale, center, _vec(wm), _vec(wc),
            _vec(compiled.f_params), Qf, out_mean, out_cov, status)
    _run_split(_predict_pair(compiled, n), B, args,
               lambda: (0, 1, 8, 9, 10, 11) if Qf.shape[0] == B else (0, 1, 9, 10, 11), counts)
    if counts[0] == 0:
        status = None  # every root exists
    elif len(batch) != 1:
        status = status.reshape(batch)
    if len(batch) == 1:
        return out_mean, out_cov, status
    return out_mean.reshape(batch + (n,)), out_cov.reshape(batch + (n, n)), status


#: All-False ``bad_z`` operands by batch size (kernel inputs, never written).
_no_bad_z_cache: dict[int, np.ndarray] = {}


def _no_bad_z(B: int) -> np.ndarray:
    hit = _no_bad_z_cache.get(B)
    if hit is None:
        if len(_no_bad_z_cache) >= _SHARED_VIEWS_MAX:
            _no_bad_z_cache.clear()
        hit = _no_bad_z_cache[B] = np.zeros(B, dtype=np.bool_)
    return hit


def fused_update(mean, cov, z, bad_z, rule, compiled, R):
    """Whole sigma-point update with the model's compiled ``h``.

    ``bad_z``: elements to skip (``None``: none given); an element whose ``z`` is not
    finite is skipped too. Returns ``(mean, cov, gain, innovation, z_hat, S, C, status,
    ok, skipped, counts)``, batch-first; ``counts`` = ``(bad z, failed root, S not PD)``
    as Python integers.
    """
    root_kind, scale, center, wm, wc = rule
    batch = mean.shape[:-1]
    n = mean.shape[-1]
    m = z.shape[-1]
    m_ = _flat(mean, batch, 1)
    B = m_.shape[0]
    outs = (np.empty((B, n)), np.empty((B, n, n)), np.empty((B, n, m)), np.empty((B, m)),
            np.empty((B, m)), np.empty((B, m, m)), np.empty((B, n, m)))
    status = np.empty(B, dtype=np.int8)
    ok = np.empty(B, dtype=np.bool_)
    skipped = np.empty(B, dtype=np.bool_)
    counts = np.empty(3, dtype=np.int64)
    bad = _no_bad_z(B) if bad_z is None else _flat_mask(bad_z, batch)
    Rf = _flat_shared(R, batch)
    args = (m_, _flat(cov, batch, 2), _flat(z, batch, 1), bad,
            root_kind, scale, center, _vec(wm), _vec(wc), _vec(compiled.h_params),
            Rf, *outs, status, ok, skipped)
    _run_split(_update_pair(compiled, n, m), B, args,
               lambda: (0, 1, 2, 3) + ((10,) if Rf.shape[0] == B else ()) + tuple(range(11, 21)), counts)
    if len(batch) == 1:
        return (*outs, status, ok, skipped, counts.tolist())
    tails = ((n,), (n, n), (n, m), (m,), (m,), (m, m), (n, m))
    return tuple(o.reshape(batch + t) for o, t in zip(outs, tails)) + (
        status.reshape(batch), ok.reshape(batch), skipped.reshape(batch), counts.tolist())


def _warm_up_model(compiled: CompiledFunctions, n: int, m: int, B: int) -> None:
    """Run every driver of ``compiled`` once at ``n`` states, ``m`` measurements, batch ``B``."""
    mean, cov = np.zeros((B, n)), np.broadcast_to(np.eye(n), (B, n, n))
    for kind in (0, 1):
        w = np.full(2 * n + (kind == 0), 1.0 / (2 * n + (kind == 0)))
        rule = (kind, 1.0, kind == 0, w, w)
        fused_predict(mean, cov, rule, compiled, np.eye(n))
        fused_update(mean, cov, np.zeros((B, m)), np.zeros(B, bool), rule, compiled, np.eye(m))
    if compiled.linear_f and compiled.h_jacobian is not None:
        ekf_moments(mean, cov, compiled, np.eye(m))


def warm_up() -> float:
    """Compile (or load from the disk cache) every kernel on a tiny problem; seconds taken.

    Besides the generic kernels, the drivers of every model registered with
    `gnssframework.estimation.compiled_model.register_warm_up` (the built-in channel
    and navigation models register theirs when imported). Worker processes call it once
    at start so no filter step pays the compile time.
    """
    import time

    from .compiled_model import warm_up_models

    if not HAVE_NUMBA:
        return 0.0
    t0 = time.perf_counter()
    linear = CompiledFunctions(linear_f, np.eye(2), linear_h, np.eye(2), linear_h_jacobian)
    for B in (1, PARALLEL_MIN_BATCH):
        mean = np.zeros((B, 2))
        cov = np.broadcast_to(np.eye(2), (B, 2, 2))
        for kind in (0, 1):
            X, _ = sigma_points(mean, cov, kind, 1.0, kind == 0)
        X, _ = sigma_points(mean, cov, 0, 1.0, False)
        w = np.full(4, 0.25)
        predict_moments(X, w, w, np.eye(2))
        z_hat, S, C = measurement_moments(X, X, mean, w, w, np.eye(2))
        for joseph in (False, True):
            update(mean, cov, mean, z_hat, S, C, np.zeros(B, bool), joseph, np.eye(2), np.eye(2))
        _warm_up_model(linear, 2, 2, B)
        for compiled, n, m in warm_up_models():
            _warm_up_model(compiled, n, m, B)
        pd_mask(cov)
        pd_mask(np.broadcast_to(np.eye(2), (max(B, PD_MASK_PARALLEL_MIN_BATCH), 2, 2)))  # its parallel twin
        linear_predict(mean, cov, np.eye(2), np.eye(2))
    return time.perf_counter() - t0
