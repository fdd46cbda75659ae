"""Compile (or load from numba's disk cache) every kernel before a run needs it."""

from __future__ import annotations

import numpy as np

from ..compiled_model import CompiledFunctions, linear_f, linear_h, linear_h_jacobian
from .arrays import (
    ekf_moments,
    fused_predict,
    fused_update,
    linear_predict,
    measurement_moments,
    pd_mask,
    predict_moments,
    sigma_points,
    update,
)
from .specialise import HAVE_NUMBA
from .split import PARALLEL_MIN_BATCH, PD_MASK_PARALLEL_MIN_BATCH

__all__ = ["warm_up"]


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

    from ..compiled_model import warm_up_models

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
