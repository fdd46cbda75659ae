"""Dense linear algebra per batch element, compiled: finiteness tests, Cholesky, the
symmetric eigen-decomposition (Householder tridiagonalisation + implicit QR, Jacobi as
the fallback), triangular solves and products.

Each function works on one element's small matrices in place (no allocation, no view);
the batch drivers (`gnssframework.estimation.compiled.drivers`) and the loop checks
(`gnssframework.estimation.compiled.loop`) compose them. `helpers_of_size` gives the
twins specialised to one size (`gnssframework.estimation.compiled.specialise`).
"""

from __future__ import annotations

import math

import numpy as np

from .specialise import HAVE_NUMBA, jit, with_globals

__all__ = [
    "all_finite",
    "row_finite",
    "cholesky",
    "jacobi_eigh",
    "jacobi_eigh_into",
    "eigh",
    "eigh_into",
    "tridiagonal_eigh_into",
    "chol_solve_rows",
    "chol_solve_rows_into",
    "mul_into",
    "helpers_of_size",
]

#: Sizes of a specialised twin (0: read from the operands): state n, measurement m, and
#: the size k of a helper's square operand.
_FIXED_N = 0
_FIXED_M = 0
_FIXED_K = 0


@jit
def all_finite(a):
    """Every entry of the matrix ``a`` finite (explicit loops: ``ravel`` would make a
    view, and every view costs an atomic reference-count increment and decrement)."""
    k = _FIXED_K if _FIXED_K > 0 else a.shape[0]  # square in a specialised twin
    for i in range(k):
        for j in range(k if _FIXED_K > 0 else a.shape[1]):
            if not math.isfinite(a[i, j]):
                return False
    return True


@jit
def row_finite(a, b):
    """Every entry of row ``b`` of ``a`` finite (no view)."""
    for j in range(a.shape[1]):
        if not math.isfinite(a[b, j]):
            return False
    return True


@jit
def cholesky(A, L):
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


@jit
def jacobi_eigh(A, w, V):
    """``A = V diag(w) V^T`` (see `jacobi_eigh_into`)."""
    jacobi_eigh_into(A, w, V, np.empty(A.shape))


@jit
def jacobi_eigh_into(A, w, V, B):
    """Eigen-decomposition of the symmetric part of ``A`` by cyclic Jacobi rotations.

    ``A = V diag(w) V^T``. Jacobi's method is accurate to rounding in every
    eigenvalue relative to ``||A||`` and converges quadratically; for the 2-10 state
    matrices of a tracking filter a handful of sweeps beat LAPACK's call overhead
    (Golub & Van Loan, *Matrix Computations*, 4th ed., sec. 8.5). Each rotation
    updates only the two affected rows/columns of the symmetric matrix. ``B``: scratch
    of at least ``(n, n)``. The fallback of `eigh_into` (the tridiagonal QR is about
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


@jit
def eigh(A, w, V):
    """``A = V diag(w) V^T`` for the symmetric part of ``A`` (see `eigh_into`)."""
    eigh_into(A, w, V, np.empty((A.shape[0] + 2, A.shape[0])))


@jit
def eigh_into(A, w, V, W):
    """Eigen-decomposition of the symmetric part of ``A`` (n, n): ``A = V diag(w) V^T``.

    ``W`` is ``(n + 2, n)`` scratch. The work is `tridiagonal_eigh_into` (Householder
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
    if not tridiagonal_eigh_into(A, w, V, W):
        jacobi_eigh_into(A, w, V, W)


#: ``max|A|`` range in which `tridiagonal_eigh_into` needs no scaling: squares of
#: entries (and sums of n of them) neither overflow nor leave the normal range.
_TINY = 2.0**-400
_HUGE = 2.0**400


@jit
def _scaled_symmetric_into(A, V, W):
    """``W[:n] = sym(A) * scale`` and ``V = I``; returns ``(scale, max|A| * scale)``, the
    scale a power of two that brings ``max|A|`` to about 1 where it is outside
    ``[2^-400, 2^400]`` (else 1)."""
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
    for i in range(n):
        for j in range(n):
            W[i, j] = 0.5 * (A[i, j] + A[j, i]) * scale
            V[i, j] = 1.0 if i == j else 0.0
    return scale, amax * scale


@jit
def _householder_tridiagonal(W, w):
    """``T = Q^T A Q`` in place in ``W``, ``Q = H_0 ... H_{n-3}``, ``H_k = I - beta_k v_k
    v_k^T``: ``v_k`` below the diagonal of ``W``, the off-diagonal of T in row ``n``,
    ``beta_k`` in row ``n + 1`` (``w`` scratch)."""
    n = _FIXED_K if _FIXED_K > 0 else W.shape[1]
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


@jit
def _householder_accumulate(W, V, w):
    """``V = H_0 (H_1 (... H_{n-3}))`` from the reflections in ``W``, and ``w`` the
    diagonal of T."""
    n = _FIXED_K if _FIXED_K > 0 else W.shape[1]
    for k in range(n - 3, -1, -1):
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


@jit
def _implicit_qr(w, W, V, top):
    """Implicit symmetric QR with Wilkinson shifts on T (diagonal ``w``, off-diagonal row
    ``n`` of ``W``), rotations accumulated into ``V``'s columns; False if not converged
    after ``30 n`` steps."""
    n = _FIXED_K if _FIXED_K > 0 else W.shape[1]
    eps2 = 2.220446049250313e-16**2
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
    return True


@jit
def tridiagonal_eigh_into(A, w, V, W):
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
    scale, top = _scaled_symmetric_into(A, V, W)
    _householder_tridiagonal(W, w)
    _householder_accumulate(W, V, w)
    if not _implicit_qr(w, W, V, top):
        return False
    n = _FIXED_K if _FIXED_K > 0 else A.shape[0]
    inv = 1.0 / scale
    for i in range(n):
        w[i] *= inv
    return True


@jit
def chol_solve_rows(L, C, K):
    """``K = C S^{-1}`` row by row with ``S = L L^T`` (forward then back substitution)."""
    chol_solve_rows_into(L, C, K, np.empty((C.shape[0], C.shape[1] + 1)))


@jit
def chol_solve_rows_into(L, C, K, Y):
    """`chol_solve_rows` with scratch ``Y`` ``(n, m + 1)``.

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


@jit
def mul_into(A, Bm, out, transpose_b):
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


helpers_by_size: dict[int, dict] = {}


def helpers_of_size(k: int) -> dict:
    """The per-element helpers on ``k x k`` operands, specialised to that size (one set
    per size and process, shared by every driver that uses it)."""
    if not HAVE_NUMBA:
        return {}
    hit = helpers_by_size.get(k)
    if hit is None:
        size = {"_FIXED_K": k}
        steps = {
            name: jit(with_globals(fn.py_func, f"_{k}", **size))
            for name, fn in (
                ("_scaled_symmetric_into", _scaled_symmetric_into),
                ("_householder_tridiagonal", _householder_tridiagonal),
                ("_householder_accumulate", _householder_accumulate),
                ("_implicit_qr", _implicit_qr),
            )
        }
        tri = jit(with_globals(tridiagonal_eigh_into.py_func, f"_{k}", **size, **steps))
        hit = helpers_by_size[k] = {
            "all_finite": jit(with_globals(all_finite.py_func, f"_{k}", **size)),
            "cholesky": jit(with_globals(cholesky.py_func, f"_{k}", **size)),
            "eigh_into": jit(with_globals(eigh_into.py_func, f"_{k}", tridiagonal_eigh_into=tri)),
        }
    return hit
