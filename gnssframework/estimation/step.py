"""One public filter step: predict -> update -> adapt, with the recovery policies.

Every sequential filter in the library runs its Gaussian filter through `FilterStep`:
`filter_sequence`, and the built-in channel and navigation filters (``iq-filter``,
``kf-smoother``, ``kf-carrier-loop``, ``ekf-pv``, ``position-ca``). A plugin that does
the same gets, without writing them:

- **boundary checks** (`FilterStep.start`): a NaN/inf initial mean or a non-finite or
  indefinite initial covariance is refused naming the initial mean or covariance and
  the batch element; a measurement of the wrong length is refused naming it;
- **named failures**: every `NumericalError` names the filter, the batch element and
  the step; an overflow (measurements of 1e300, say) is reported as a non-finite
  prediction or posterior by name, never as a raw NumPy ``RuntimeWarning``;
- **recovery policies** ``on_failure`` and ``missing``, each recovery counted in
  `FilterStep.recoveries`;
- **noise adaptation**: the adapter sees every step, its estimate after step k is in
  force from step k+1, and it holds its estimate on batch elements whose update was
  skipped (`gnssframework.estimation.adaptation.AdapterRun.step`).

Examples
--------
>>> import numpy as np
>>> from gnssframework import registry
>>> from gnssframework.estimation import FilterStep, Gaussian, LinearModel
>>> model = LinearModel(np.eye(1), np.eye(1), [[0.1]], [[1.0]])
>>> fs = FilterStep(registry.create("estimator", "kf"))
>>> state = fs.start(Gaussian(np.zeros(1), np.eye(1)), model)
>>> out = fs(state, np.array([2.0]), model)
>>> round(float(out.posterior.mean[0]), 4)  # gain 1.1 / 2.1
1.0476
>>> fs.start(Gaussian(np.array([np.nan]), np.eye(1)), model)
Traceback (most recent call last):
...
gnssframework.errors.InvalidInitialStateError: kf: invalid initial state at batch element (): initial mean is NaN or inf
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

from typing import Any

import numpy as np

from ..errors import (
    ConfigError,
    InvalidInitialStateError,
    InvalidInputError,
    NonFiniteError,
    NotPositiveDefiniteError,
    NumericalError,
)
from .. import backend
from .compiled import loop as compiled_loop
from .adaptation import AdapterRun, AdaptationStep, NoiseAdapter
from .adapter_guard import adapt_checked
from .boundary import as_measurement, check_argument
from .estimator import Estimator, OnFailure, OnMissing
from .linalg import all_true, any_true, cholesky_masked, clip_eigenvalues, failing_indices, pd_mask, symmetrize
from .types import Gaussian, Model, Update

__all__ = ["FilterStep", "StepResult", "RECOVERIES", "POLICIES", "check_initial"]

#: Names of the recoveries counted in ``FilterStep.recoveries`` and ``FilterResult.recoveries``.
RECOVERIES = ("missing", "skip_update", "symmetrize", "clip_eigenvalues")
#: Allowed ``on_failure`` policies.
POLICIES = ("raise", "skip", "symmetrize", "clip")


def _check_policy(name: str, value: str, allowed: tuple[str, ...]) -> None:
    if value not in allowed:
        raise ConfigError(name, f"got {value!r}; allowed: {', '.join(allowed)}")


def check_initial(initial: Gaussian, filter_name: str, model: Model | None = None) -> None:
    """Refuse an initial state that no filter can start from, saying what is wrong.

    Raises
    ------
    InvalidInputError
        The initial state's batch is empty or its dimension differs from the model's
        (names ``initial mean``).
    InvalidInitialStateError
        Naming ``initial mean`` (NaN or inf) or ``initial covariance`` (not finite,
        not symmetric positive definite) and every failing batch element.
    """
    if 0 in initial.batch_shape:
        raise InvalidInputError(
            filter_name, "initial mean", f"has an empty batch (shape {initial.mean.shape}): there is nothing to filter"
        )
    if model is not None and initial.ndim_state != model.Q.shape[-1]:
        raise InvalidInputError(
            filter_name, "initial mean", f"has {initial.ndim_state} states but the model's Q is {model.Q.shape[-2:]}"
        )
    finite_mean = np.isfinite(initial.mean).all(axis=-1)
    if not finite_mean.all():
        raise InvalidInitialStateError(filter_name, failing_indices(finite_mean), detail="initial mean is NaN or inf")
    cov = initial.cov
    with np.errstate(invalid="ignore"):
        asym = np.abs(cov - np.swapaxes(cov, -1, -2)).max(axis=(-2, -1))
        sym = asym <= 1e-9 * np.abs(cov).max(axis=(-2, -1))
    ok = cholesky_masked(cov)[1] & sym
    if not ok.all():
        raise InvalidInitialStateError(
            filter_name, failing_indices(ok), detail="initial covariance is not finite, symmetric and positive definite"
        )


def _repair_posterior(
    state: Gaussian, prior: Gaussian, policy: OnFailure, counts: Counter[str], filter_name: str, lean: bool = False
) -> Gaussian:
    """Check the posterior of every batch element; apply ``policy`` where it fails.

    ``lean`` (the ``numba`` backend): one compiled test of the whole posterior first; the
    per-element masks below only when it finds a failing element."""
    if lean and compiled_loop.state_bad_count(state.mean, state.cov, True) == 0:
        return state
    pd = pd_mask(state.cov)  # compiled test, no factor kept (the lean step)
    if all_true(pd) and all_true(np.isfinite(state.mean)):
        return state
    finite_mean = np.isfinite(state.mean).all(axis=-1)
    ok = pd & finite_mean
    bad = ~ok
    if policy == "raise":
        if not finite_mean.all():
            raise NonFiniteError(
                filter_name,
                failing_indices(finite_mean),
                detail="posterior mean (overflow from a huge measurement or innovation?)",
            )
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
    ok = pd_mask(cov)
    if not ok.all():
        raise NotPositiveDefiniteError(
            filter_name, failing_indices(ok), detail=f"posterior covariance P, still after recovery {policy!r}"
        )
    return Gaussian(mean, cov)


def _check_prior(prior: Gaussian, state: Gaussian, filter_name: str, lean: bool = False) -> None:
    """A prediction from a finite state that is not finite is an overflow in f, Q or the
    sigma-point weights (a state of magnitude 1e300 after a 1e300 measurement)."""
    if lean and compiled_loop.state_bad_count(prior.mean, prior.cov, False) == 0:
        return
    if all_true(np.isfinite(prior.mean)) and all_true(np.isfinite(prior.cov)):
        return  # the per-element mask only when something is not finite
    ok = np.isfinite(prior.mean).all(axis=-1) & np.isfinite(prior.cov).all(axis=(-2, -1))
    if not all_true(ok):
        bad = failing_indices(ok)
        size = float(np.max(np.abs(state.mean)))
        raise NonFiniteError(
            filter_name,
            bad,
            detail=f"prediction, from a finite state of magnitude up to {size:.3g}: "
            "an overflow, or NaN/inf in the model (F, Q, a known input u)",
        )


@dataclass(frozen=True)
class StepResult:
    """What one `FilterStep` call returns.

    Attributes
    ----------
    prior
        The prediction of this step (the given state when ``predict=False``).
    update
        The measurement update (innovation, S, gain, ``skipped``).
    posterior
        The posterior after the recovery policy.
    model
        The model in force at this step (with the adapter's Q and R).
    skipped
        ``(...)``: True where the update was skipped (missing measurement or recovery).
    """

    prior: Gaussian
    update: Update
    posterior: Gaussian
    model: Model
    skipped: np.ndarray


class FilterStep:
    """The predict -> update -> adapt step every sequential filter calls.

    Parameters
    ----------
    estimator
        Any ``estimator`` plugin.
    adapter
        Optional ``noise_adapter`` plugin; its estimate after step k is used from step k+1.
    on_failure
        Where a covariance fails: ``"raise"`` (default), ``"skip"`` the update,
        ``"symmetrize"`` or ``"clip"`` eigenvalues of the posterior. A non-PD innovation
        covariance always skips under a non-raise policy. Each recovery is counted.
    missing
        ``"raise"`` on NaN/inf measurements or ``"skip"`` their update (counted).
    name
        The filter named in errors (default: the estimator's name; plugins give
        ``"iq-filter (svd-ckf)"``).

    Attributes
    ----------
    recoveries
        Count of every recovery since `start`, keyed by `RECOVERIES`.
    step_index
        Index of the next step (named in errors).
    """

    def __init__(
        self,
        estimator: Estimator,
        adapter: NoiseAdapter | None = None,
        *,
        on_failure: OnFailure = "raise",
        missing: OnMissing = "raise",
        name: str | None = None,
    ) -> None:
        _check_policy("on_failure", on_failure, POLICIES)
        _check_policy("missing", missing, ("raise", "skip"))
        check_argument(estimator, "estimator", "FilterStep")
        check_argument(adapter, "adapter", "FilterStep")
        self.estimator = estimator
        self.adapter = adapter
        self.on_failure = on_failure
        self.missing = missing
        self.name = name or estimator.name
        self.recoveries: Counter[str] = Counter({k: 0 for k in RECOVERIES})
        self.step_index = 0
        self._adapted = 0
        self._run: AdapterRun | None = None
        self._Q: np.ndarray | None = None
        self._R: np.ndarray | None = None
        self._in_force_cache: tuple[Any, ...] | None = None
        self._hold: np.ndarray | None = None  # steps left on the model's own noise, per element
        self._lean = backend.compiled()

    def start(self, initial: Gaussian, model: Model | None = None, *, first_step: int = 0) -> Gaussian:
        """Begin a sequence from ``initial``: check it, reset the counts, start the adapter.

        Parameters
        ----------
        initial
            The state the first step predicts from (or updates, with ``predict=False``).
        model
            The model of the first step: the adapter starts from its Q and R, and the
            initial state's dimension is checked against it. Required with an adapter.
        first_step
            Index of the first step, as named in errors (a filter whose first epoch
            only initialises starts at 1).

        Raises
        ------
        InvalidInitialStateError, InvalidInputError
            Naming the initial mean or covariance (and the batch element).
        """
        check_argument(initial, "initial", f"{self.name}: FilterStep.start")
        if model is not None:
            check_argument(model, "model", f"{self.name}: FilterStep.start")
        check_initial(initial, self.name, model)
        # The backend of the step's compiled checks, chosen once per sequence.
        self._lean = backend.compiled()
        self.recoveries = Counter({k: 0 for k in RECOVERIES})
        self.step_index = first_step
        self._adapted = 0
        self._Q = self._R = None
        self._hold = None
        self._run = None
        if self.adapter is not None:
            if model is None:
                raise ConfigError("FilterStep.start", "needs the model to start the noise adapter")
            self._run = self.adapter.start(model.Q, model.R)
        return initial

    def restart_adapter(self, model: Model, *, from_model_noise: bool = False, restart_warmup: bool = True) -> None:
        """Restart the noise adapter (its window and recursion) when a filter resets part
        of its state and its past innovations no longer describe the noise. Does nothing
        without an adapter.

        Parameters
        ----------
        model
            The step's model.
        from_model_noise
            Start from the model's own Q and R (the adapted ones are dropped at once)
            instead of the Q and R now in force.
        restart_warmup
            Count the step index handed to the adapter from 0 again; ``False`` keeps it
            running. The built-in adapters count their warm-up in the updates of each run,
            so a filter that restarts them more often than their warm-up never adapts
            either way (the ``iq-filter`` reset mode relies on that: R stays the model's).
        """
        if self.adapter is not None:
            current = model if from_model_noise else self.in_force(model)
            if from_model_noise:
                self._Q = self._R = None
            self._run = self.adapter.start(current.Q, current.R)
            if restart_warmup:
                self._adapted = 0

    def hold_model_noise(self, elements: np.ndarray, steps: int) -> None:
        """For the next ``steps`` steps the batch ``elements`` (bool, broadcast to the state's
        batch shape) use the model's own Q and R instead of the adapter's, while the adapter
        goes on for every element: a filter that starts some elements again
        (`ChannelFilter.restart`) holds them there until a windowed adapter's window (e.g.
        ``innovation``'s, ``steps`` its length) holds their new innovations only. A recursive
        adapter (Sage-Husa's) still remembers the old ones through its forgetting factor.
        Does nothing without an adapter."""
        if self.adapter is None or steps <= 0:
            return
        new = np.where(np.asarray(elements, bool), int(steps), 0)
        self._hold = new if self._hold is None else np.maximum(self._hold, new)

    def in_force(self, model: Model) -> Model:
        """``model`` with the adapter's latest Q and R (unchanged before it has estimated;
        the model's own for the elements `hold_model_noise` holds)."""
        if self._Q is None:
            return model
        if self._hold is not None and self._R is not None:  # not cached: the held elements change per step
            held = (self._hold > 0)[..., None, None]
            return model.with_noise(Q=np.where(held, model.Q, self._Q), R=np.where(held, model.R, self._R))
        # predict and update of one step use the same model: build it once.
        hit = self._in_force_cache
        if hit is not None and hit[0] is model and hit[1] is self._Q and hit[2] is self._R:
            cached: Model = hit[3]
            return cached
        out = model.with_noise(Q=self._Q, R=self._R)
        self._in_force_cache = (model, self._Q, self._R, out)
        return out

    def _named(self, exc: NumericalError) -> NumericalError:
        return type(exc)(self.name, exc.batch_indices, self.step_index, exc.detail)

    def predict(self, state: Gaussian, model: Model) -> Gaussian:
        """The first half of a step: predict ``state`` through ``model`` (with the adapter's
        Q). Split from `update` for filters that need the prior before they build the
        measurement (decision-directed data wipe-off)."""
        try:
            # Overflow and invalid operations are detected on the results, by name; a raw
            # NumPy RuntimeWarning would say neither which filter nor which element.
            with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
                prior = self.estimator.predict(state, self.in_force(model))
                _check_prior(prior, state, self.estimator.name, self._lean)
        except NumericalError as exc:
            raise self._named(exc) from None
        return prior

    def update(self, prior: Gaussian, z: np.ndarray, model: Model, *, previous: Gaussian | None = None) -> StepResult:
        """The second half of a step: update ``prior`` with ``z`` ``(..., m)``, apply the
        recovery policy, let the adapter see the step, and advance `step_index`.

        ``previous`` is the state the prior was predicted from (given to the adapter;
        defaults to ``prior`` for a step without prediction).

        Raises
        ------
        NumericalError
            Naming the filter, the batch element and the step.
        InvalidInputError
            If ``z`` does not have the model's measurement length.
        """
        mk = self.in_force(model)
        m = mk.R.shape[-1]
        if not (
            type(z) is np.ndarray
            and z.dtype == np.float64
            and z.ndim == len(prior.batch_shape) + 1
            and z.shape[-1] == m
            and z.shape[:-1] == prior.batch_shape
        ):
            # Anything but a float array of exactly the state's batch shape is checked here.
            z = as_measurement(z, m, prior.batch_shape, self.name, self.step_index)
        try:
            with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
                upd = self.estimator.update(prior, z, mk, on_failure=self.on_failure, missing=self.missing)
                posterior = _repair_posterior(
                    upd.state, prior, self.on_failure, self.recoveries, self.estimator.name, self._lean
                )
        except NumericalError as exc:
            raise self._named(exc) from None
        skipped = np.asarray(upd.skipped)
        if any_true(skipped):  # nothing to count on the common step
            missing_now = ~np.isfinite(z).all(axis=-1) if self.missing == "skip" else np.zeros((), bool)
            self.recoveries["missing"] += int(np.sum(missing_now & skipped))
            self.recoveries["skip_update"] += int(np.sum(skipped & ~missing_now))
        if self._run is not None and self.adapter is not None:  # a run only with an adapter
            previous = prior if previous is None else previous
            # Overflow in the adapter (an innovation of 1e300) is refused by name, not a NumPy warning.
            self._Q, self._R = adapt_checked(
                self._run,
                AdaptationStep(self._adapted, previous, prior, upd, mk),
                self.name,
                self.adapter.name,
                self.step_index,
            )
            self._adapted += 1
        if self._hold is not None:  # one step of the hold spent
            self._hold = self._hold - 1
            if not any_true(self._hold > 0):
                self._hold = None
        self.step_index += 1
        if skipped.shape != posterior.batch_shape:
            skipped = np.broadcast_to(skipped, posterior.batch_shape)
        return StepResult(prior, upd, posterior, mk, skipped)

    def __call__(self, state: Gaussian, z: np.ndarray, model: Model, *, predict: bool = True) -> StepResult:
        """One whole step: `predict` ``state`` (unless ``predict=False``: the state is
        already the prior, as at a filter's first epoch), then `update` with ``z``.

        Raises
        ------
        NumericalError
            Naming the filter, the batch element and the step.
        InvalidInputError
            If ``z`` does not have the model's measurement length.
        """
        prior = self.predict(state, model) if predict else state
        return self.update(prior, z, model, previous=state)
