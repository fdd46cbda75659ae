"""The compiled kernels on batch-first arrays: operands made kernel-ready, the batch
flattened, the right driver picked and run (`split`), the results reshaped.

These are what the engines call; each equals a step of the NumPy reference path
(`gnssframework.estimation.estimator`) to rounding.
"""

from __future__ import annotations

import numpy as np

from . import drivers, split

__all__ = [
    "sigma_points",
    "predict_moments",
    "measurement_moments",
    "update",
    "pd_mask",
    "linear_predict",
    "ekf_moments",
    "fused_predict",
    "fused_update",
    "vector_operand",
]


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


def vector_operand(a) -> np.ndarray:
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
            return _operand(a.reshape((-1,) + a.shape[a.ndim - tail :]))
    a = np.asarray(a, dtype=float)
    shape = batch + a.shape[a.ndim - tail :]
    if a.shape != shape:
        a = np.broadcast_to(a, shape)
    return _operand(np.ascontiguousarray(a).reshape((-1,) + shape[len(batch) :]))


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


def _noise_batch(batch: tuple[int, ...], noise) -> tuple[int, ...]:
    """The batch of a prediction whose state has ``batch`` and whose Q ``(..., n, n)`` may
    have leading dimensions of its own (one Q per run with a state shared by the runs)."""
    own = np.shape(noise)[:-2]
    if not own or own == batch:
        return batch
    return np.broadcast_shapes(batch, own)


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
    split.pick(drivers._sigma_points_kernels, B)(m, P, root_kind, float(scale), bool(center), X, status)
    if len(batch) == 1:
        return X, status
    return X.reshape((N,) + batch + (n,)), status.reshape(batch)


def predict_moments(Y: np.ndarray, wm: np.ndarray, wc: np.ndarray, Q: np.ndarray):
    """Mean ``(..., p)`` and covariance ``(..., p, p)`` of points ``(N, ..., p)`` plus Q."""
    N = Y.shape[0]
    batch = _noise_batch(Y.shape[1:-1], Q)
    p = Y.shape[-1]
    if Y.shape[1:-1] != batch:
        own = Y.shape[1:-1]
        Y = np.broadcast_to(Y.reshape((N,) + (1,) * (len(batch) - len(own)) + own + (p,)), (N,) + batch + (p,))
    Yf = np.ascontiguousarray(Y, dtype=float).reshape(N, -1, p)
    B = Yf.shape[1]
    mean = np.empty((B, p))
    cov = np.empty((B, p, p))
    split.pick(drivers._predict_moments_kernels, B)(
        _operand(Yf), vector_operand(wm), vector_operand(wc), _flat_shared(Q, batch), mean, cov
    )
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
    split.pick(drivers._measurement_moments_kernels, B)(
        _operand(Xf),
        _operand(Zf),
        _flat(prior_mean, batch, 1),
        vector_operand(wm),
        vector_operand(wc),
        _flat_shared(R, batch),
        z_hat,
        S,
        C,
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
            (m, n), (np.zeros((1, m, n)), np.zeros((1, m, m)))
        )
    mean = np.empty((B, n))
    cov = np.empty((B, n, n))
    gain = np.empty((B, n, m))
    innovation = np.empty((B, m))
    ok = np.empty(B, dtype=np.bool_)
    args = (
        pm,
        _flat(prior_cov, batch, 2),
        _flat(z, batch, 1),
        _flat(z_hat, batch, 1),
        _flat(S, batch, 2),
        _flat(C, batch, 2),
        _flat_mask(bad_z, batch),
        bool(joseph),
        Hf,
        Rf,
        mean,
        cov,
        gain,
        innovation,
        ok,
    )
    by_work = split.split_by_work(B, n, m)
    split.run_split(
        drivers._update_kernels,
        B,
        args,
        lambda: (0, 1, 2, 3, 4, 5, 6) + tuple(i for i in (8, 9) if args[i].shape[0] == B) + tuple(range(10, 15)),
        by_work=by_work,
        chunks=split.work_chunks(B, n, m) if by_work else None,
    )
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
    split.pick(drivers._pd_mask_kernels, A.shape[0], max(split.PARALLEL_MIN_BATCH, split.PD_MASK_PARALLEL_MIN_BATCH))(
        A, ok
    )
    return ok.reshape(batch)


def linear_predict(mean, cov, F, Q):
    """``(F x, sym(F P F^T + Q))`` batch-first, F ``(n, n)`` shared by the batch."""
    batch = _noise_batch(mean.shape[:-1], Q)
    n = mean.shape[-1]
    m_ = _flat(mean, batch, 1)
    B = m_.shape[0]
    out_mean = np.empty((B, n))
    out_cov = np.empty((B, n, n))
    split.pick(drivers._linear_predict_kernels, B)(
        m_, _flat(cov, batch, 2), vector_operand(F), _flat_shared(Q, batch), out_mean, out_cov
    )
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
    args = (m_, _flat(cov, batch, 2), vector_operand(compiled.h_params), Rf, z_hat, S, C)
    by_work = split.split_by_work(B, n, m)
    split.run_split(
        drivers._ekf_pair(compiled),
        B,
        args,
        lambda: (0, 1) + ((3,) if Rf.shape[0] == B else ()) + (4, 5, 6),
        by_work=by_work,
        chunks=split.work_chunks(B, n, m) if by_work else None,
    )
    return z_hat.reshape(batch + (m,)), S.reshape(batch + (m, m)), C.reshape(batch + (n, m))


def fused_predict(mean, cov, rule, compiled, Q):
    """Whole sigma-point predict with the model's compiled ``f``: mean, cov, status."""
    root_kind, scale, center, wm, wc = rule
    batch = _noise_batch(mean.shape[:-1], Q)
    n = mean.shape[-1]
    m_ = _flat(mean, batch, 1)
    B = m_.shape[0]
    out_mean = np.empty((B, n))
    out_cov = np.empty((B, n, n))
    status = np.empty(B, dtype=np.int8)
    counts = np.empty(1, dtype=np.int64)
    Qf = _flat_shared(Q, batch)
    args = (
        m_,
        _flat(cov, batch, 2),
        root_kind,
        scale,
        center,
        vector_operand(wm),
        vector_operand(wc),
        vector_operand(compiled.f_params),
        Qf,
        out_mean,
        out_cov,
        status,
    )
    split.run_split(
        drivers._predict_pair(compiled, n),
        B,
        args,
        lambda: (0, 1, 8, 9, 10, 11) if Qf.shape[0] == B else (0, 1, 9, 10, 11),
        counts,
    )
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
    outs = (
        np.empty((B, n)),
        np.empty((B, n, n)),
        np.empty((B, n, m)),
        np.empty((B, m)),
        np.empty((B, m)),
        np.empty((B, m, m)),
        np.empty((B, n, m)),
    )
    status = np.empty(B, dtype=np.int8)
    ok = np.empty(B, dtype=np.bool_)
    skipped = np.empty(B, dtype=np.bool_)
    counts = np.empty(3, dtype=np.int64)
    bad = _no_bad_z(B) if bad_z is None else _flat_mask(bad_z, batch)
    Rf = _flat_shared(R, batch)
    args = (
        m_,
        _flat(cov, batch, 2),
        _flat(z, batch, 1),
        bad,
        root_kind,
        scale,
        center,
        vector_operand(wm),
        vector_operand(wc),
        vector_operand(compiled.h_params),
        Rf,
        *outs,
        status,
        ok,
        skipped,
    )
    split.run_split(
        drivers._update_pair(compiled, n, m),
        B,
        args,
        lambda: (0, 1, 2, 3) + ((10,) if Rf.shape[0] == B else ()) + tuple(range(11, 21)),
        counts,
    )
    if len(batch) == 1:
        return (*outs, status, ok, skipped, counts.tolist())
    tails = ((n,), (n, n), (n, m), (m,), (m,), (m, m), (n, m))
    return tuple(o.reshape(batch + t) for o, t in zip(outs, tails)) + (
        status.reshape(batch),
        ok.reshape(batch),
        skipped.reshape(batch),
        counts.tolist(),
    )
