"""Run an estimator over a measurement sequence: ``filter_sequence``."""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import Callable, Union

import numpy as np

from ..errors import ConfigError, NotPositiveDefiniteError, NumericalError
from .adaptation import AdaptationStep, Augmentation, NoiseAdapter
from .estimator import Estimator, OnFailure, OnMissing
from .linalg import clip_eigenvalues, cholesky_masked, failing_indices, symmetrize
from .types import Gaussian, Model

__all__ = ["filter_sequence", "FilterResult", "RECOVERIES"]

#: Names of the recoveries counted in ``FilterResult.recoveries``.
RECOVERIES = ("missing", "skip_update", "symmetrize", "clip_eigenvalues")

_POLICIES = ("raise", "skip", "symmetrize", "clip")


@dataclass
class FilterResult:
    """Output of ``filter_sequence``, stacked over time on axis 0.

    Attributes
    ----------
    mean, cov
        Posterior ``(K, ..., n)`` and ``(K, ..., n, n)`` (``cov`` is None if not stored).
    innovation, innovation_cov
        ``(K, ..., m)`` and ``(K, ..., m, m)``.
    Q, R
        The covariances *used* at each step (an adapter's estimate after step k is used
        from step k+1), ``(K, ..., n, n)`` and ``(K, ..., m, m)``.
    skipped
        ``(K, ...)``: True where the update was skipped.
    epochs
        Original epoch of each step's estimate (differs from ``arange(K)`` after an
        augmentation such as ``colored-ar1``).
    recoveries
        Count of every recovery taken, keyed by ``RECOVERIES``.
    """

    mean: np.ndarray
    cov: np.ndarray | None
    innovation: np.ndarray
    innovation_cov: np.ndarray
    Q: np.ndarray
    R: np.ndarray
    skipped: np.ndarray
    epochs: np.ndarray
    recoveries: dict[str, int] = field(default_factory=dict)


def _check_policy(name: str, value: str, allowed: tuple[str, ...]) -> None:
    if value not in allowed:
        raise ConfigError(name, f"got {value!r}; allowed: {', '.join(allowed)}")


def _repair_posterior(
    state: Gaussian, prior: Gaussian, policy: OnFailure, counts: Counter, filter_name: str
) -> Gaussian:
    """Check the posterior of every batch element; apply ``policy`` where it fails."""
    finite_mean = np.isfinite(state.mean).all(axis=-1)
    ok = cholesky_masked(state.cov)[1] & finite_mean
    if ok.all():
        return state
    bad = ~ok
    if policy == "raise":
        raise NotPositiveDefiniteError(filter_name, failing_indices(ok), detail="posterior covariance P")
    mean, cov = state.mean, state.cov
    if policy == "skip" or not finite_mean.all():
        revert = bad if policy == "skip" else ~finite_mean
        counts["skip_update"] += int(revert.sum())
        mean = np.where(revert[..., None], prior.mean, mean)
        cov = np.where(revert[..., None, None], prior.cov, cov)
        bad = bad & ~revert
    if bad.any() and policy == "symmetrize":
        cov = np.where(bad[..., None, None], symmetrize(cov), cov)
        counts["symmetrize"] += int(bad.sum())
    elif bad.any() and policy == "clip":
        scale = np.abs(np.trace(cov, axis1=-2, axis2=-1)) / cov.shape[-1]
        floor = 1e-9 * np.where(np.isfinite(scale) & (scale > 0), scale, 1.0)
        cov = np.where(bad[..., None, None], clip_eigenvalues(np.nan_to_num(cov), floor), cov)
        counts["clip_eigenvalues"] += int(bad.sum())
    ok = cholesky_masked(cov)[1]
    if not ok.all():
        raise NotPositiveDefiniteError(
            filter_name, failing_indices(ok), detail=f"posterior covariance P, still after recovery {policy!r}"
        )
    return Gaussian(mean, cov)


def filter_sequence(
    estimator: Estimator,
    model: Union[Model, Callable[[int], Model]],
    zs: np.ndarray,
    initial: Gaussian,
    adapter: NoiseAdapter | None = None,
    augmentation: Augmentation | None = None,
    *,
    on_failure: OnFailure = "raise",
    missing: OnMissing = "raise",
    store_cov: bool = True,
) -> FilterResult:
    """Filter a batch of measurement sequences: predict then update at every step.

    Parameters
    ----------
    estimator
        Any ``estimator`` plugin.
    model
        A model, or a callable ``k -> model`` for a time-varying one.
    zs
        Measurements ``(K, ..., m)``; NaN marks a missing measurement if
        ``missing="skip"``.
    initial
        Posterior at the epoch *before* ``zs[0]``: step 0 predicts from it.
    adapter
        Optional noise adapter; its estimate after step k is used from step k+1.
    augmentation
        Optional model rewrite (e.g. ``colored-ar1``) applied before filtering.
    on_failure
        Policy where a covariance fails: ``"raise"`` (default), ``"skip"`` the update,
        ``"symmetrize"`` or ``"clip"`` eigenvalues of the posterior. A non-PD innovation
        covariance always skips under a non-raise policy. Each recovery is counted.
    missing
        ``"raise"`` on NaN/inf measurements or ``"skip"`` their update (counted).
    store_cov
        Keep the posterior covariances (``(K, ..., n, n)`` can be large).

    Raises
    ------
    NumericalError
        Naming the filter, the batch element and the step.
    """
    _check_policy("on_failure", on_failure, _POLICIES)
    _check_policy("missing", missing, ("raise", "skip"))
    zs = np.asarray(zs, dtype=float)
    if zs.ndim < 2:
        raise ConfigError("zs", f"needs shape (K, ..., m), got {zs.shape}")
    if augmentation is not None:
        if callable(model):  # models are dataclasses, not callables
            raise ConfigError("augmentation", "needs a fixed model, not a callable")
        problem = augmentation.apply(model, zs)
        zs, model_at, epochs = problem.zs, problem.model_at, problem.epochs
    else:
        model_at = model if callable(model) else (lambda k: model)
        epochs = np.arange(zs.shape[0])

    counts: Counter = Counter({k: 0 for k in RECOVERIES})
    state = _repair_posterior(initial, initial, on_failure, counts, estimator.name)
    run = None
    Q_est = R_est = None
    if adapter is not None:
        m0 = model_at(0)
        run = adapter.start(m0.Q, m0.R)
    out: dict[str, list] = {k: [] for k in ("mean", "cov", "innovation", "innovation_cov", "Q", "R", "skipped")}
    for k in range(zs.shape[0]):
        mk = model_at(k)
        if Q_est is not None:
            mk = mk.with_noise(Q=Q_est, R=R_est)
        try:
            prior = estimator.predict(state, mk)
            upd = estimator.update(prior, zs[k], mk, on_failure=on_failure, missing=missing)
            posterior = _repair_posterior(upd.state, prior, on_failure, counts, estimator.name)
        except NumericalError as exc:
            raise exc.at_step(k) from None
        skipped = np.asarray(upd.skipped)
        missing_now = ~np.isfinite(zs[k]).all(axis=-1) if missing == "skip" else np.zeros_like(skipped)
        counts["missing"] += int(np.sum(missing_now & skipped))
        counts["skip_update"] += int(np.sum(skipped & ~missing_now))
        out["mean"].append(posterior.mean)
        if store_cov:
            out["cov"].append(posterior.cov)
        out["innovation"].append(upd.innovation)
        out["innovation_cov"].append(upd.innovation_cov)
        batch = posterior.batch_shape
        out["Q"].append(np.broadcast_to(mk.Q, batch + mk.Q.shape[-2:]))
        out["R"].append(np.broadcast_to(mk.R, batch + mk.R.shape[-2:]))
        out["skipped"].append(np.broadcast_to(skipped, batch))
        if run is not None:
            Q_est, R_est = run.step(AdaptationStep(k, state, prior, upd, mk))
        state = posterior
    return FilterResult(
        mean=np.stack(out["mean"]),
        cov=np.stack(out["cov"]) if store_cov else None,
        innovation=np.stack(out["innovation"]),
        innovation_cov=np.stack(out["innovation_cov"]),
        Q=np.stack(out["Q"]),
        R=np.stack(out["R"]),
        skipped=np.stack(out["skipped"]),
        epochs=np.asarray(epochs),
        recoveries=dict(counts),
    )
