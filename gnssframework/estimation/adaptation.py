"""Interfaces of noise adapters and model augmentations, and the adapters' safeguards.

A ``NoiseAdapter`` re-estimates Q and/or R from a filter's innovations. The
published recursions (Sage-Husa, windowed innovation matching, maximum likelihood Q)
are unbiased only near convergence: run from a poorly initialised filter they return
negative or exploding covariances, and a filter fed those diverges. Every built-in
adapter therefore passes its raw estimate through the same ``Safeguards``:

1. *warm-up*: no adaptation during the first ``warmup`` updates (the innovations of a
   filter that has not converged say more about P0 than about R);
2. *PSD projection*: the raw (instantaneous or windowed) estimate's negative
   eigenvalues are set to zero;
3. *relative bounds*: the result is clamped, in the Loewner order, between a floor
   and a ceiling times the initial covariance, so it is always PD, finite and of a
   sane magnitude.

Defaults: R may shrink or grow by a factor 100 (``r_floor = 0.01``,
``r_ceiling = 100``); Q may grow by 100 but shrink only by 4 (``q_floor = 0.25``).
The asymmetry is deliberate. A collapsing Q is the classic way a Kalman filter
diverges: it trusts its model, stops following the measurements, its innovations
grow, and an R estimator reads them as measurement noise. With Q and R estimated
together (which is not identifiable from one innovation sequence), a low Q floor
lets classic Sage-Husa settle on Q at the floor and R 20x too large, and the error
grows tenfold on the constant-acceleration test in ``tests/estimation/test_adapters.py``.
"""

from __future__ import annotations

import abc
from dataclasses import dataclass
from collections.abc import Callable

import numpy as np
from pydantic import Field

from ..plugin import Plugin, PluginParams
from .. import backend
from .compiled import loop as compiled_loop
from .linalg import any_true, clamp_relative, pd_mask, project_psd, regularised, symmetrize
from .types import Gaussian, Model, Update

__all__ = [
    "AdaptationStep",
    "AdapterRun",
    "NoiseAdapter",
    "SafeguardParams",
    "Augmentation",
    "AugmentedProblem",
]


@dataclass(frozen=True)
class AdaptationStep:
    """What an adapter sees after the update of step ``step``.

    Attributes
    ----------
    previous
        Posterior of step ``k-1`` (the state that was predicted).
    prior
        Prediction of step ``k`` (includes the Q used).
    update
        The update of step ``k``.
    model
        The model used at step ``k`` (its ``Q`` and ``R`` are the ones in force).
    """

    step: int
    previous: Gaussian
    prior: Gaussian
    update: Update
    model: Model

    @property
    def predicted_measurement_spread(self) -> np.ndarray:
        """``S - R``: the spread of the predicted measurement alone (``H P H^T`` for a KF,
        ``sum w_i (Z_i - z_hat)(Z_i - z_hat)^T`` for a sigma-point filter)."""
        spread: np.ndarray = self.update.innovation_cov - self.model.R
        return spread

    @property
    def propagated_spread(self) -> np.ndarray:
        """``P[k|k-1] - Q``: ``Phi P[k-1] Phi^T`` for a KF, its sigma-point analogue otherwise."""
        spread: np.ndarray = self.prior.cov - self.model.Q
        return spread


class SafeguardParams(PluginParams):
    """Safeguards shared by every adapter (see the module docstring)."""

    warmup: int = Field(10, ge=0, description="updates before adaptation starts")
    r_floor: float = Field(0.01, gt=0, le=1, description="lower bound of R, times the initial R")
    r_ceiling: float = Field(100.0, ge=1, description="upper bound of R, times the initial R")
    q_floor: float = Field(0.25, gt=0, le=1, description="lower bound of Q, times the initial Q")
    q_ceiling: float = Field(100.0, ge=1, description="upper bound of Q, times the initial Q")


class AdapterRun(abc.ABC):
    """Per-sequence state of an adapter; created by ``NoiseAdapter.start``."""

    def __init__(self, params: SafeguardParams, Q0: np.ndarray, R0: np.ndarray) -> None:
        self.params = params
        self.Q0 = np.asarray(Q0, dtype=float)
        self.R0 = np.asarray(R0, dtype=float)
        self.Q = self.Q0
        self.R = self.R0
        self.updates = 0

    @staticmethod
    def compiled_innovation_window(size: int) -> compiled_loop.InnovationWindow | None:
        """The compiled running mean of the last ``size`` innovation estimates
        (`gnssframework.estimation.compiled.loop.InnovationWindow`) under the compiled
        backend, else ``None`` (the adapter keeps its NumPy window)."""
        return compiled_loop.InnovationWindow(size) if backend.compiled() else None

    @staticmethod
    def load_compiled_guard() -> None:
        """Compile or load the compiled `guard` now under the compiled backend: an
        adapter calls it when it starts, so the first step past its warm-up does not pay
        the load (a one-time cost per process)."""
        if backend.compiled():
            compiled_loop.load_guard()

    def guard(self, raw: np.ndarray, reference: np.ndarray, floor: float, ceiling: float) -> np.ndarray:
        """PSD-project a raw estimate, then clamp it relative to ``reference``.

        Elements that are already PSD and inside the bounds pass unchanged; the
        projection's ``eigh`` runs only on the others (a Cholesky test finds them).
        Under the ``numba`` backend one compiled pass does all of it
        (`gnssframework.estimation.compiled.loop.guard`, equal to these steps to rounding);
        the steps below run under ``numpy`` and where an estimate is not finite.
        """
        # The reference (Q0 or R0) is fixed for the run: its eigen-decomposition and the
        # matrix clamp_relative rebuilds from it are kept.
        cache = self.__dict__.setdefault("_reference_eig", {})
        kept = cache.get(id(reference))
        if kept is None or kept[0] is not reference:
            eig = regularised(reference)
            w, v = eig
            kept = cache[id(reference)] = (
                reference,
                eig,
                (v * w[..., None, :]) @ np.swapaxes(v, -1, -2),
                backend.compiled(),
            )
        if kept[3]:
            lean = compiled_loop.guard(raw, kept[2], kept[1], floor, ceiling)
            if lean is not None:
                return lean
        raw = symmetrize(raw)
        psd = pd_mask(raw)
        if not psd.all():
            raw = raw.copy()
            raw[~psd] = project_psd(raw[~psd])
        return clamp_relative(raw, reference, floor, ceiling, reference_eig=kept[1])

    def step(self, ctx: AdaptationStep) -> tuple[np.ndarray, np.ndarray]:
        """Take step ``k``'s innovation; return the ``(Q, R)`` to use from step ``k+1``."""
        self.updates += 1
        Q, R = self.estimate(ctx)
        if self.updates > self.params.warmup:
            skipped = np.asarray(ctx.update.skipped)
            any_skipped = any_true(skipped)
            # A skipped update carries no information: keep the old estimate there.
            if Q is not None:
                Q = self.guard(Q, self.Q0, self.params.q_floor, self.params.q_ceiling)
                self.Q = np.where(skipped[..., None, None], self.Q, Q) if any_skipped else Q
            if R is not None:
                R = self.guard(R, self.R0, self.params.r_floor, self.params.r_ceiling)
                self.R = np.where(skipped[..., None, None], self.R, R) if any_skipped else R
        return self.Q, self.R

    @abc.abstractmethod
    def estimate(self, ctx: AdaptationStep) -> tuple[np.ndarray | None, np.ndarray | None]:
        """Raw (unguarded) estimates of Q and R after step ``ctx.step``; ``None`` for a
        covariance this adapter does not estimate. Called every step, also during
        warm-up, so that windows and recursions fill."""


class NoiseAdapter(Plugin, abc.ABC):
    """Plugin kind ``noise_adapter``: re-estimates Q and/or R from the innovations."""

    kind = "noise_adapter"
    Params = SafeguardParams
    params: SafeguardParams  # self.params, as validated

    @abc.abstractmethod
    def start(self, Q0: np.ndarray, R0: np.ndarray) -> AdapterRun:
        """Begin adapting a sequence whose initial covariances are ``Q0`` and ``R0``."""


@dataclass(frozen=True)
class AugmentedProblem:
    """A rewritten filtering problem.

    Attributes
    ----------
    zs
        Measurements to filter, ``(K', ..., m')``.
    model_at
        ``model_at(k)`` is the model of step ``k`` (it may depend on earlier
        measurements, as the decorrelated colored-noise model does).
    epochs
        ``epochs[k]``: the index of the original epoch whose state the estimate of step
        ``k`` refers to.
    """

    zs: np.ndarray
    model_at: Callable[[int], Model]
    epochs: np.ndarray


class Augmentation(Plugin, abc.ABC):
    """Plugin kind ``augmentation``: rewrites a model (and its measurements) before filtering."""

    kind = "augmentation"

    @abc.abstractmethod
    def apply(self, model: Model, zs: np.ndarray) -> AugmentedProblem:
        """Rewrite ``model`` and the measurement sequence ``zs`` ``(K, ..., m)``."""
