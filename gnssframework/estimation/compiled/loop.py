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
`gnssframework.estimation.compiled.arrays.pd_mask` (the ``numba`` backend's), finiteness is
exact, and the symmetrisation and bound differences are the same floating-point
operations as `gnssframework.estimation.linalg.symmetrize` and ``clamp_relative``, so
the lean path returns bitwise what the reference path returns.

One kernel computes rather than tests: `guard`, the whole safeguard of a noise
adapter's estimate (symmetrise, PSD projection, Loewner clamp between ``floor`` and
``ceiling`` times the reference). In a 100-run vector loop some of the 800 adapted R
sit on a bound at nearly every step, so a test-only kernel sent every step down the
NumPy path (about 0.9 ms per step: a dozen batched calls around the few ``eigh``).
Its eigen-decompositions are `gnssframework.estimation.compiled.dense.eigh_into` (the
algorithm of LAPACK's ``dsytrd`` + ``dsteqr``) instead of LAPACK's, and its products
sum in index order, so it agrees with the reference to rounding (a test holds it to
1e-12 relative, norm-wise per matrix); an element it cannot take (not finite) sends
the whole call back to the reference, which names the failure.
"""

from __future__ import annotations

import math
import threading

import numpy as np

from . import pool, split
from .dense import all_finite as matrix_finite
from .dense import cholesky, eigh_into, helpers_of_size
from .specialise import HAVE_NUMBA, jit, with_globals

__all__ = ["all_finite", "state_bad_count", "guard", "InnovationWindow", "pcrb_stacked", "warm_up"]


#: The size of a specialised twin's matrices (0: read from the operands), see
#: `_guard_of_size`.
_FIXED_K = 0


@jit
def _vector_finite(a):
    """Every entry of the 1-D array ``a`` finite (``dense.all_finite`` takes matrices)."""
    for i in range(a.shape[0]):
        if not math.isfinite(a[i]):
            return False
    return True


@jit
def _all_finite_body(a):
    return _vector_finite(a)


@jit
def _state_bad_count_body(mean, cov, test_pd):
    """Elements whose mean or covariance is not finite, or (``test_pd``) whose covariance
    has no Cholesky factor of its lower triangle."""
    B, n = mean.shape
    L = np.empty((n, n))
    bad = 0
    for b in range(B):
        ok = _vector_finite(mean[b]) and matrix_finite(cov[b])
        if ok and test_pd:
            ok = cholesky(cov[b], L)
        bad += not ok
    return bad


@jit
def _clipped_spectrum_into(A, low, high, w, V, W, out):
    """``out = V clip(w, low, high) V^T`` with ``V diag(w) V^T`` the symmetric part of
    ``A`` (`gnssframework.estimation.linalg._clip_spectrum`: ``(v * w) @ v^T``, each
    entry summed over the eigenvalue index in order). ``W``: ``(k + 2, k)`` scratch."""
    k = _FIXED_K if _FIXED_K > 0 else A.shape[0]
    eigh_into(A, w, V, W)
    for i in range(k):
        w[i] = min(max(w[i], low), high)  # np.clip
    for i in range(k):
        for j in range(k):
            acc = 0.0
            for l in range(k):
                acc += (V[i, l] * w[l]) * V[j, l]
            out[i, j] = acc


@jit
def _mat_mul_into(A, B, out, transpose_b):
    """``out = A B`` (or ``A B^T``), each entry summed over the inner index in order."""
    k = _FIXED_K if _FIXED_K > 0 else A.shape[0]
    for i in range(k):
        for j in range(k):
            acc = 0.0
            for l in range(k):
                acc += A[i, l] * (B[j, l] if transpose_b else B[l, j])
            out[i, j] = acc


@jit
def _guard_body(raw, ref, G, G_inv, floor, ceiling, out):
    """``out[b]``: the safeguarded ``raw[b]`` (`gnssframework.estimation.adaptation.
    AdapterRun.guard`): symmetrised; PSD-projected where it has no Cholesky factor;
    where ``out[b] - floor ref`` or ``ceiling ref - out[b]`` is not PD, whitened with
    ``G^{-1}`` (``ref = G G^T``), its eigenvalues clipped to ``[floor, ceiling]`` and
    coloured back (``clamp_relative``). Returns the number of elements not finite (then
    ``out`` is not usable and the caller runs the reference)."""
    B = raw.shape[0]
    k = _FIXED_K if _FIXED_K > 0 else raw.shape[1]  # a constant in a size's twin
    D = np.empty((k, k))
    L = np.empty((k, k))
    T = np.empty((k, k))
    w = np.empty(k)
    V = np.empty((k, k))
    W = np.empty((k + 2, k))
    bad = 0
    for b in range(B):
        A = raw[b]
        S = out[b]
        for i in range(k):
            for j in range(k):
                S[i, j] = 0.5 * (A[i, j] + A[j, i])
        if not matrix_finite(S):
            bad += 1
            continue
        if not cholesky(S, L):  # project_psd, then clamp_relative's symmetrisation
            _clipped_spectrum_into(S, 0.0, math.inf, w, V, W, T)
            for i in range(k):
                for j in range(k):
                    S[i, j] = 0.5 * (T[i, j] + T[j, i])
        for i in range(k):
            for j in range(k):
                D[i, j] = S[i, j] - floor * ref[i, j]
        inside = matrix_finite(D) and cholesky(D, L)
        if inside:
            for i in range(k):
                for j in range(k):
                    D[i, j] = ceiling * ref[i, j] - S[i, j]
            inside = matrix_finite(D) and cholesky(D, L)
        if inside:
            continue
        _mat_mul_into(G_inv, S, T, False)
        _mat_mul_into(T, G_inv, D, True)  # white = G^-1 S G^-T
        _clipped_spectrum_into(D, floor, ceiling, w, V, W, T)
        _mat_mul_into(G, T, D, False)
        _mat_mul_into(D, G, T, True)  # G white' G^T
        for i in range(k):
            for j in range(k):
                S[i, j] = 0.5 * (T[i, j] + T[j, i])
    return bad


def _guard_of_size(k: int):
    """`_guard_body` compiled for ``k x k`` estimates (the size as a compile-time constant,
    the helpers specialised too: `gnssframework.estimation.with_globals`), bitwise
    the generic kernel; the channel filter's 6 correlator outputs are the hot case."""
    if not HAVE_NUMBA:
        return _guard_body
    h = helpers_of_size(k)
    size = {"_FIXED_K": k}
    spectrum = jit(with_globals(_clipped_spectrum_into.py_func, f"_{k}", eigh_into=h["eigh_into"], **size))
    return jit(
        with_globals(
            _guard_body.py_func,
            f"_{k}",
            matrix_finite=h["all_finite"],
            cholesky=h["cholesky"],
            _clipped_spectrum_into=spectrum,
            _mat_mul_into=jit(with_globals(_mat_mul_into.py_func, f"_{k}", **size)),
            **size,
        )
    )


_guard_6_body = _guard_of_size(6)
#: Estimate size -> its specialised guard kernel.
_GUARD_BY_SIZE = {6: _guard_6_body}


@jit
def _innovation_window_body(v, S, R, ring, slot, pushes, total, out):
    """Push ``v v^T`` into the window (ring ``(L, B, m, m)``, slot ``slot``, ``pushes``
    made before) and write ``mean(window) - (S - R)`` into ``out``: the NumPy lines of the
    innovation adapter (``total + item``, then ``- oldest`` once full, ``/ count``), the
    same operations in the same order on every entry, so bitwise their result."""
    B, m = v.shape
    size = ring.shape[0]
    full = pushes >= size
    count = pushes + 1 if pushes + 1 < size else size
    shared_r = R.shape[0] == 1
    for b in range(B):
        r = 0 if shared_r else b
        for i in range(m):
            for j in range(m):
                item = v[b, i] * v[b, j]
                t = total[b, i, j] + item
                if full:
                    t = t - ring[slot, b, i, j]
                ring[slot, b, i, j] = item
                total[b, i, j] = t
                out[b, i, j] = t / count - (S[b, i, j] - R[r, i, j])


@jit
def _pcrb_body(F, Q, roots, P0, update_first, out):
    """`gnssframework.receiver.tracking.pcrb.pcrb_linear` on stacked square roots ``(K, m, n)``:
    the same products and the same LU solve, in the same order, per step."""
    n = F.shape[0]
    m = roots.shape[1]
    P = P0.copy()
    eye = np.eye(n)
    eye_m = np.eye(m)
    Ft = np.ascontiguousarray(F.T)
    for k in range(roots.shape[0]):
        if k > 0 or not update_first:
            P = (F @ P) @ Ft + Q
        if m > 0:
            L = roots[k]
            Lt = np.ascontiguousarray(L.T)
            PHt = P @ Lt
            S = L @ PHt + eye_m
            K = np.ascontiguousarray(np.linalg.solve(S, np.ascontiguousarray(PHt.T)).T)
            A = eye - K @ L
            P = (A @ P) @ np.ascontiguousarray(A.T) + K @ np.ascontiguousarray(K.T)
        for i in range(n):
            for j in range(n):
                out[k, i, j] = 0.5 * (P[i, j] + P[j, i])
        P = out[k].copy()


def pcrb_stacked(F: np.ndarray, Q: np.ndarray, roots: np.ndarray, P0: np.ndarray, update_first: bool) -> np.ndarray:
    """The PCRB covariance recursion on measurement square roots stacked ``(K, m, n)``
    in one compiled call (`gnssframework.receiver.tracking.pcrb.pcrb_linear` is the reference)."""
    K, n = roots.shape[0], F.shape[0]
    out = np.empty((K, n, n))
    _pcrb_body(*(np.array(a, dtype=float, order="C") for a in (F, Q, roots, P0)), bool(update_first), out)
    return out


def _as_rows(a, shape: tuple[int, ...]) -> np.ndarray:
    """``a`` broadcast to ``shape`` as a writable C-contiguous float64 array (a copy only
    where it is not one already)."""
    if type(a) is np.ndarray and a.shape == shape and a.dtype == np.float64:
        flags = a.flags
        if flags.c_contiguous and flags.writeable:
            return a
        # A strided view of the right shape (a channel filter's state column): one C-order
        # copy, not the general broadcast below (about 5 us per operand here).
        return a.copy()
    return np.array(np.broadcast_to(np.asarray(a, dtype=float), shape), dtype=float, order="C")


def _rows(a: np.ndarray, tail: int) -> np.ndarray | None:
    """``a`` as a C-contiguous float64 ``(B, ...)`` view, or ``None`` (caller: NumPy path)."""
    if type(a) is not np.ndarray or a.dtype != np.float64 or not a.flags.c_contiguous or not a.flags.writeable:
        return None
    if a.ndim == tail + 1:
        return a
    if a.ndim < tail:
        return None
    return a.reshape((-1,) + a.shape[a.ndim - tail :])


def all_finite(a: np.ndarray) -> bool:
    """``bool(np.isfinite(a).all())`` in one compiled call (contiguous float64 input;
    anything else goes through NumPy)."""
    if HAVE_NUMBA and type(a) is np.ndarray and a.dtype == np.float64 and a.flags.c_contiguous and a.flags.writeable:
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
    test_pd = bool(test_pd)
    if test_pd and _split_here(m.shape[0]):  # the posterior test of a large batch: chunks, as the guard
        bad = _split_counts(m.shape[0], lambda lo, hi: _state_bad_count_body(m[lo:hi], P[lo:hi], True))
        return int(sum(bad))
    return int(_state_bad_count_body(m, P, test_pd))


def _split_here(B: int) -> bool:
    """Split a batch kernel between the calling thread and the helper (as the fused
    kernels do, `gnssframework.estimation.compiled.split.SPLIT`)?"""
    return (
        B >= split.PARALLEL_MIN_BATCH
        and split.SPLIT == "pool"
        and threading.current_thread() is threading.main_thread()
    )


def _split_counts(B: int, run) -> list[int]:
    """``run(lo, hi)`` over `split.SPLIT_CHUNKS` chunks of ``[0, B)`` on the calling
    thread and the helper (`gnssframework.estimation.compiled.pool`); the chunks' returns."""
    n = split.SPLIT_CHUNKS
    out = [0] * n

    def run_chunk(i: int) -> None:
        out[i] = run((i * B) // n, ((i + 1) * B) // n)

    pool.run_chunks(n, run_chunk)
    return out


#: Per reference (by the id of its ``(w, v)`` tuple, which an adapter keeps for the run):
#: ``(ref_eig, ref, G, G^-1, ref as a kernel operand)``; each entry holds its keys.
_guard_operands: dict[int, tuple] = {}


def _guard_operands_of(ref, ref_eig) -> tuple:
    """The kernel operands of a reference: ``G = v sqrt(w)`` and ``G^-1 = v^T / sqrt(w)``
    as ``clamp_relative`` forms them; ``G`` is ``None`` where the reference is not one
    shared ``(k, k)`` matrix (the caller then runs the reference path)."""
    w, v = ref_eig
    entry = (ref_eig, ref, None, None, None)
    if (
        type(ref) is np.ndarray
        and ref.ndim == 2
        and ref.dtype == np.float64
        and np.shape(w) == ref.shape[:1]
        and np.shape(v) == ref.shape
    ):
        root = np.sqrt(w)
        entry = (
            ref_eig,
            ref,
            np.ascontiguousarray(v * root[None, :]),
            np.ascontiguousarray(v.T / root[:, None]),
            _as_rows(ref, ref.shape),
        )
    if len(_guard_operands) >= 256:
        _guard_operands.clear()
    _guard_operands[id(ref_eig)] = entry
    return entry


def guard(
    raw: np.ndarray, ref: np.ndarray, ref_eig: tuple[np.ndarray, np.ndarray], floor: float, ceiling: float
) -> np.ndarray | None:
    """An adapter's whole safeguard (`AdapterRun.guard`) in one compiled pass.

    ``ref`` is the regularised reference ``v diag(w) v^T`` and ``ref_eig`` its ``(w, v)``
    (`gnssframework.estimation.linalg.regularised`), both shared by the batch. Returns
    the guarded estimate ``(..., k, k)``, equal to the reference path's to rounding, or
    ``None`` where the operands are not the kernel's layout or an element is not finite
    (the caller then runs the reference path, which names the failure).
    """
    R = _rows(raw, 2)
    if R is None:
        return None
    hit = _guard_operands.get(id(ref_eig))
    if hit is None or hit[0] is not ref_eig or hit[1] is not ref:
        hit = _guard_operands_of(ref, ref_eig)
    if hit[2] is None or hit[2].shape != R.shape[1:]:
        return None
    G, G_inv, ref_rows = hit[2:]
    out = np.empty(raw.shape)
    rows = out.reshape(R.shape)
    floor, ceiling = float(floor), float(ceiling)
    B = R.shape[0]
    body = _GUARD_BY_SIZE.get(R.shape[1], _guard_body)
    if _split_here(B):  # as the fused kernels: chunks for the calling thread and the helper (bitwise)
        bad = _split_counts(B, lambda lo, hi: body(R[lo:hi], ref_rows, G, G_inv, floor, ceiling, rows[lo:hi]))
        return None if any(bad) else out
    if body(R, ref_rows, G, G_inv, floor, ceiling, rows):
        return None
    return out


class InnovationWindow:
    """The innovation adapter's window (Zou et al. 2018, eq. 31) in one compiled pass per
    step: ``mean of the last L v v^T - (S - R)``, bitwise what the NumPy lines give
    (``outer``, a running total over a deque, ``S - R``), with the window kept as a ring
    of ``L`` arrays instead of a deque. `push` returns ``None`` where the operands do
    not fit (another batch shape than the first step's); `as_items` then hands the
    window over to the NumPy lines.
    """

    def __init__(self, size: int) -> None:
        self.size = size
        self.pushes = 0
        self.ring: np.ndarray | None = None
        self.total: np.ndarray | None = None

    def push(self, v: np.ndarray, S: np.ndarray, R: np.ndarray) -> np.ndarray | None:
        """``mean_vv - (S - R)`` after pushing ``v v^T`` (``v (..., m)``, ``S (..., m, m)``,
        ``R (m, m)`` or ``(..., m, m)``); ``None`` (nothing pushed) where they do not fit."""
        shape = np.shape(v)
        m = shape[-1]
        if self.ring is None:
            B = int(np.prod(shape[:-1], dtype=np.int64))
            self.ring = np.empty((self.size, B, m, m))
            self.total = np.zeros((B, m, m))
            self.batch = shape[:-1]
        if shape[:-1] != self.batch or np.shape(S) != shape + (m,) or np.shape(R)[-2:] != (m, m):
            return None
        vr = _as_rows(v, shape).reshape(-1, m)
        Sr = _as_rows(S, shape + (m,)).reshape(-1, m, m)
        if np.ndim(R) == 2:
            Rr = _as_rows(R, (m, m)).reshape(1, m, m)
        elif np.shape(R) == shape + (m,):
            Rr = _as_rows(R, shape + (m,)).reshape(-1, m, m)
        else:
            Rr = _as_rows(R, shape + (m,)).reshape(-1, m, m)  # broadcast to the batch
        out = np.empty(shape + (m,))
        _innovation_window_body(
            vr, Sr, Rr, self.ring, self.pushes % self.size, self.pushes, self.total, out.reshape(-1, m, m)
        )
        self.pushes += 1
        return out

    def as_items(self) -> tuple[list[np.ndarray], np.ndarray | float]:
        """The window's items, oldest first, and its running total, as the NumPy lines
        keep them (to continue there)."""
        if self.ring is None:
            return [], 0.0
        count = min(self.pushes, self.size)
        items = [
            self.ring[(self.pushes - count + i) % self.size].reshape(self.batch + self.ring.shape[2:]).copy()
            for i in range(count)
        ]
        return items, self.total.reshape(self.batch + self.ring.shape[2:]).copy()


_guard_loaded = False


def load_guard() -> None:
    """Compile or load `guard`'s kernel now (once per process): an adapter calls it when
    it starts, so the first step past its warm-up does not pay the load (about 10 ms)."""
    global _guard_loaded
    if not _guard_loaded and HAVE_NUMBA:
        for k in (2, *_GUARD_BY_SIZE):
            guard(np.broadcast_to(np.eye(k), (2, k, k)).copy(), np.eye(k), (np.ones(k), np.eye(k)), 0.5, 2.0)
        _guard_loaded = True


def warm_up() -> None:
    """Compile (or load from the disk cache) every kernel of this module once, with the
    operand types the filter step hands them (so forked workers compile nothing)."""
    if not HAVE_NUMBA:
        return
    m, P = np.zeros((2, 2)), np.broadcast_to(np.eye(2), (2, 2, 2)).copy()
    all_finite(m)
    state_bad_count(m, P, True)
    guard(P, np.eye(2), (np.ones(2), np.eye(2)), 0.5, 2.0)
    for k in _GUARD_BY_SIZE:  # the size-specialised guards
        guard(np.broadcast_to(np.eye(k), (2, k, k)).copy(), np.eye(k), (np.ones(k), np.eye(k)), 0.5, 2.0)
    window = InnovationWindow(2)
    for R in (np.eye(2), P):  # a shared R and one per element
        window.push(m, P, R)
    pcrb_stacked(np.eye(2), np.eye(2), np.ones((2, 2, 2)), np.eye(2), True)
