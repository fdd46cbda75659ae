"""Run an estimator over a measurement sequence: ``filter_sequence``."""

from __future__ import annotations

from dataclasses import dataclass, field
from collections.abc import Callable

from typing import Any

import numpy as np

from ..errors import ConfigError, InvalidInputError
from .adaptation import Augmentation, NoiseAdapter
from .boundary import as_sequence, check_argument, check_model_functions, checked_model_at, to_float
from .estimator import Estimator, OnFailure, OnMissing
from .linalg import transpose
from .smoother_sqrt import psd_root
from .step import RECOVERIES, FilterStep, StepResult
from .types import Gaussian, Model

__all__ = ["filter_sequence", "FilterResult", "SmootherInputs", "RECOVERIES", "STORE_OPTIONS"]

#: What ``filter_sequence(store=...)`` can keep besides the posteriors.
STORE_OPTIONS = ("smoother",)


@dataclass
class SmootherInputs:
    """What a backward (RTS) pass needs beyond the filtered posteriors, stacked over steps.

    Step ``k`` predicted from the posterior of step ``k-1`` (from ``initial`` at ``k = 0``).

    Attributes
    ----------
    prior_mean, prior_cov
        Predicted ``x_{k|k-1}``: ``(K, ..., n)`` and ``(K, ..., n, n)``, with the Q in force
        at step k (an adapter's estimate included).
    cross_cov
        ``C_k = Cov(x_{k-1|k-1}, x_{k|k-1})`` ``(K, ..., n, n)``: ``P F^T`` for KF/EKF,
        from the sigma points for the sigma-point engines
        (`gnssframework.estimation.Estimator.transition_cross_cov`).
    initial
        The initial state the first step predicted from (batch-broadcast).
    gain_form
        The engine's ``smoother_gain`` (``"solve"``, ``"eigh"`` or ``"sqrt"``).
    factors
        For a square-root engine (``gain_form == "sqrt"``), the factors of each prediction
        (`gnssframework.estimation.smoother_sqrt`): ``(X, Y, S_Q)``, ``(K, ..., n, N)``,
        ``(K, ..., n, N)`` and ``(K, ..., n, n)``, with ``X X^T = P_{k-1}``, ``X Y^T = C_k`` and
        ``Y Y^T + S_Q S_Q^T = P^-_k`` (`Estimator.transition_factors`); None otherwise.
    """

    prior_mean: np.ndarray
    prior_cov: np.ndarray
    cross_cov: np.ndarray
    initial: Gaussian
    gain_form: str
    factors: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None


Factors = tuple[np.ndarray, np.ndarray, np.ndarray]


def transition_terms(
    estimator: Estimator,
    previous: Gaussian,
    r: StepResult,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, Factors | None]:
    """What a backward pass keeps of one step ``previous -> r``: the prediction's mean and
    covariance and ``estimator.transition_cross_cov``, each broadcast to the posterior's batch
    (a state shared by the runs may be predicted with a Q per run), and for a square-root
    engine (``smoother_gain == "sqrt"``) the factors ``(X, Y, S_Q)`` of `SmootherInputs`
    (then ``C = X Y^T``, from the same points).

    Returns
    -------
    tuple
        ``(prior_mean, prior_cov, cross_cov, factors)``, ``(..., n)``, ``(..., n, n)``,
        ``(..., n, n)`` and the factors or None.
    """
    batch = r.posterior.batch_shape
    if previous.batch_shape != batch:
        previous = Gaussian(
            np.broadcast_to(previous.mean, batch + previous.mean.shape[-1:]),
            np.broadcast_to(previous.cov, batch + previous.cov.shape[-2:]),
        )
    # r.model is the model the prediction used (the adapter's Q in force at this step).
    factors: Factors | None = None
    if estimator.smoother_gain == "sqrt":
        X, Y = estimator.transition_factors(previous, r.model, r.prior)
        X = np.broadcast_to(X, batch + X.shape[-2:])
        Y = np.broadcast_to(Y, batch + Y.shape[-2:])
        noise = psd_root(r.model.Q)
        factors = (X, Y, np.broadcast_to(noise, batch + noise.shape[-2:]))
        cross = X @ transpose(Y)
    else:
        cross = estimator.transition_cross_cov(previous, r.model, r.prior)
    return (
        np.broadcast_to(r.prior.mean, batch + r.prior.mean.shape[-1:]),
        np.broadcast_to(r.prior.cov, batch + r.prior.cov.shape[-2:]),
        np.broadcast_to(cross, batch + cross.shape[-2:]),
        factors,
    )


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
    time_s
        Time of each step's estimate (s), ``(K,)``: the ``time_s`` given to
        ``filter_sequence`` at ``epochs``; ``None`` when no times were given.

    Its ``repr`` is a one-line summary (shapes, times, skipped updates, recoveries), and a
    notebook shows the same as a small table (``_repr_html_``); the arrays are attributes.
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
    time_s: np.ndarray | None = None
    #: Predictions and cross covariances for `gnssframework.estimation.smooth`
    #: (``filter_sequence(..., store="smoother")``), else ``None``.
    smoother_inputs: SmootherInputs | None = None

    def summary(self) -> dict[str, str]:
        """What the result holds, as ``{label: text}`` (``repr`` and the notebook view)."""
        k = self.mean.shape[0]
        batch = self.mean.shape[1:-1]
        if self.time_s is not None and np.size(self.time_s):
            span = f"{float(self.time_s[0]):g} to {float(self.time_s[-1]):g} s"
        else:
            span = f"epochs {int(self.epochs[0])} to {int(self.epochs[-1])} (no time_s given)"
        taken = {name: n for name, n in self.recoveries.items() if n}
        return {
            "steps": str(k),
            "batch": "x".join(map(str, batch)) if batch else "none",
            "state n": str(self.mean.shape[-1]),
            "measurement m": str(self.innovation.shape[-1]),
            "time": span,
            "covariances": "stored" if self.cov is not None else "not stored (store_cov=False)",
            "skipped updates": f"{int(np.count_nonzero(self.skipped))} of {self.skipped.size}",
            "recoveries": ", ".join(f"{name} {n}" for name, n in taken.items()) or "none",
        }

    def __repr__(self) -> str:
        info = self.summary()
        return (
            f"FilterResult({info['steps']} steps, batch {info['batch']}, n={info['state n']}, "
            f"m={info['measurement m']}, {info['time']}, covariances {info['covariances']}, skipped updates "
            f"{info['skipped updates']}, recoveries {info['recoveries']})"
        )

    def _repr_html_(self) -> str:
        from html import escape

        rows = "".join(
            f"<tr><th style='text-align:left'>{escape(label)}</th><td style='text-align:left'>{escape(text)}</td></tr>"
            for label, text in self.summary().items()
        )
        return f"<table><caption>FilterResult</caption>{rows}</table>"


def _check_arguments(estimator: Any, model: Any, initial: Any, adapter: Any, augmentation: Any) -> None:
    """The object arguments are of the right kind (a string or dict is named, not an
    AttributeError deep in a filter)."""
    for value, argument in (
        (estimator, "estimator"),
        (model, "model"),
        (initial, "initial"),
        (adapter, "adapter"),
        (augmentation, "augmentation"),
    ):
        check_argument(value, argument, "filter_sequence")


def filter_sequence(
    estimator: Estimator,
    model: Model | Callable[[int], Model],
    zs: np.ndarray,
    initial: Gaussian,
    adapter: NoiseAdapter | None = None,
    augmentation: Augmentation | None = None,
    *,
    on_failure: OnFailure = "raise",
    missing: OnMissing = "raise",
    store_cov: bool = True,
    time_s: np.ndarray | None = None,
    store: str | None = None,
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
    time_s
        Optional time of each measurement ``zs[k]`` (s), ``(K,)``; the result carries the
        times of its estimates (``FilterResult.time_s``).
    store
        ``"smoother"`` also keeps the predicted means and covariances and the cross
        covariances ``Cov(x_{k-1|k-1}, x_{k|k-1})`` (`SmootherInputs`,
        ``FilterResult.smoother_inputs``) that `gnssframework.estimation.smooth` needs;
        ``None`` (default) keeps only the posteriors. Needs ``store_cov=True``.

    Raises
    ------
    InvalidArgumentError
        An estimator, model, initial state, adapter or augmentation of the wrong kind (a
        string, None or a dict), saying what to pass.
    InvalidInputError
        ``zs`` is not ``(K, ..., m)`` with K >= 1, a non-empty batch and the model's m, or the initial mean
        does not have the model's dimension (names the input).
    InvalidInitialStateError
        The initial mean is NaN/inf or its covariance is not finite and positive
        definite (names which, and the batch element).
    NumericalError
        Naming the filter, the batch element and the step.

    Notes
    -----
    Each step is one call of `gnssframework.estimation.step.FilterStep`, the step every
    sequential plugin runs, so a plugin and ``filter_sequence`` fail, recover and adapt
    the same way.
    """
    _check_arguments(estimator, model, initial, adapter, augmentation)
    if store is not None and store not in STORE_OPTIONS:
        raise ConfigError("store", f"got {store!r}; allowed: None, {', '.join(map(repr, STORE_OPTIONS))}")
    if store == "smoother" and not store_cov:
        raise ConfigError("store", "'smoother' needs the posterior covariances: leave store_cov=True")
    step = FilterStep(estimator, adapter, on_failure=on_failure, missing=missing)
    zs = as_sequence(zs, estimator.name)  # text, ragged or complex: named, not a raw ValueError
    if zs.ndim < 2:
        raise InvalidInputError(
            estimator.name,
            "zs",
            f"needs shape (K, batch..., m), got {zs.shape}"
            + ("; K scalar measurements are zs[:, None]" if zs.ndim == 1 else ""),
        )
    if zs.shape[0] == 0:
        raise InvalidInputError(
            estimator.name,
            "zs",
            f"is a zero-length measurement sequence (shape {zs.shape}): there is nothing to filter",
        )
    if 0 in zs.shape[1:-1]:
        raise InvalidInputError(
            estimator.name, "zs", f"has an empty batch (shape {zs.shape}): there is nothing to filter"
        )
    times = None if time_s is None else _times(time_s, zs.shape[0], estimator.name)  # of the steps as given
    if augmentation is not None:
        if callable(model):  # models are dataclasses, not callables
            raise ConfigError("augmentation", "needs a fixed model, not a callable")
        problem = augmentation.apply(model, zs)
        zs, model_at, epochs = problem.zs, problem.model_at, problem.epochs
    else:
        model_at = checked_model_at(model, "filter_sequence") if callable(model) else (lambda k: model)
        epochs = np.arange(zs.shape[0])

    m0 = model_at(0)
    check_model_functions(m0, initial.mean, "filter_sequence")
    m = m0.R.shape[-1]
    if zs.shape[-1] != m:
        hint = (
            f"; a batch of {zs.shape[-1]} sequences of {m} measurement{'s' if m > 1 else ''} is "
            f"(K, batch, m) = {(zs.shape[0], zs.shape[-1], m)}" + (": zs[..., None]" if m == 1 else "")
            if zs.ndim == 2
            else ""
        )
        raise InvalidInputError(
            estimator.name,
            "zs",
            f"has {zs.shape[-1]} measurements per step (shape {zs.shape}) "
            f"but the model's R is {m}x{m}; expected (K, batch..., m){hint}",
        )
    try:
        np.broadcast_shapes(initial.batch_shape, zs.shape[1:-1])
    except ValueError:
        raise InvalidInputError(
            estimator.name,
            "zs",
            f"batch shape {zs.shape[1:-1]} does not broadcast with the initial state's {initial.batch_shape}",
        ) from None
    state = step.start(initial, m0)
    out: dict[str, list[Any]] = {
        k: []
        for k in (
            "mean",
            "cov",
            "innovation",
            "innovation_cov",
            "Q",
            "R",
            "skipped",
            "prior_mean",
            "prior_cov",
            "cross_cov",
            "factors",
        )
    }
    start = state
    for k in range(zs.shape[0]):
        r = step(state, zs[k], m0 if k == 0 else model_at(k))
        posterior, mk = r.posterior, r.model
        if store == "smoother":
            for key, value in zip(
                ("prior_mean", "prior_cov", "cross_cov", "factors"), transition_terms(estimator, state, r)
            ):
                out[key].append(value)
        out["mean"].append(posterior.mean)
        if store_cov:
            out["cov"].append(posterior.cov)
        out["innovation"].append(r.update.innovation)
        out["innovation_cov"].append(r.update.innovation_cov)
        batch = posterior.batch_shape
        out["Q"].append(np.broadcast_to(mk.Q, batch + mk.Q.shape[-2:]))
        out["R"].append(np.broadcast_to(mk.R, batch + mk.R.shape[-2:]))
        out["skipped"].append(r.skipped)
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
        recoveries=dict(step.recoveries),
        time_s=None if times is None else times[np.asarray(epochs)],
        smoother_inputs=None
        if store != "smoother"
        else SmootherInputs(
            prior_mean=np.stack(out["prior_mean"]),
            prior_cov=np.stack(out["prior_cov"]),
            cross_cov=np.stack(out["cross_cov"]),
            initial=start,
            gain_form=estimator.smoother_gain,
            factors=_stacked_factors(out["factors"]),
        ),
    )


def _stacked_factors(steps: list[Factors | None]) -> Factors | None:
    """The per-step factors stacked over steps, or None when the engine keeps none."""
    if not steps or steps[0] is None:
        return None
    X, Y, S = (np.stack([f[i] for f in steps if f is not None]) for i in range(3))
    return X, Y, S


def _times(time_s: Any, k: int, filter_name: str) -> np.ndarray:
    """``time_s`` as a finite ``(K,)`` float array, or `InvalidInputError` naming it."""
    try:
        t = to_float(time_s)
    except ValueError as exc:
        raise InvalidInputError(filter_name, "time_s", str(exc)) from None
    if t.shape != (k,) or not np.all(np.isfinite(t)):
        raise InvalidInputError(
            filter_name,
            "time_s",
            f"needs one finite time per measurement step, shape ({k},); "
            f"got shape {t.shape}" + ("" if t.shape != (k,) else " with NaN or inf"),
        )
    return t
