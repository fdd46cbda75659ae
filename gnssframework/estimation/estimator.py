"""Base classes of the Gaussian filter engines (plugin kind ``estimator``).

An engine only has to say how it computes the predicted moments; the measurement
update is shared. Given the predicted measurement ``z_hat``, its covariance ``S`` (with
R) and the state-measurement cross covariance ``C``, every Gaussian filter updates as

$$
K = C S^{-1}, \\qquad x^+ = x^- + K (z - \\hat z), \\qquad P^+ = P^- - K S K^T
$$

(the linear KF overrides the covariance with the Joseph form). This is the general
Gaussian filter of Särkkä, *Bayesian Filtering and Smoothing* (2013), chapter 6.
"""

from __future__ import annotations

import abc
from typing import Any, Literal

import numpy as np

from .. import backend
from ..errors import ConfigError, InvalidMeasurementError, NotPositiveDefiniteError
from ..plugin import Plugin
from . import compiled as kernels
from .linalg import all_true, any_true, cholesky_masked, failing_indices, mat_vec, symmetrize
from .compiled_model import CompiledFunctions
from .iterated import iterated_update
from .smoother_sqrt import psd_root
from .types import Gaussian, Model, Update, residual_hook

#: A compiled point rule: (root kind, scale, centre point, mean weights, covariance weights).
KernelRule = tuple[int, float, bool, np.ndarray, np.ndarray]

__all__ = ["Estimator", "SigmaPointEstimator", "OnFailure", "OnMissing"]

OnFailure = Literal["raise", "skip", "symmetrize", "clip"]
OnMissing = Literal["raise", "skip"]


class Estimator(backend.BackendChoice, Plugin, abc.ABC):
    """A batched Gaussian filter: ``predict`` and ``update`` on ``Gaussian`` states."""

    kind = "estimator"

    #: Whether `update` may run fused (one compiled pass for the moments, gain and
    #: posterior): False in a class that overrides ``measurement_moments`` or
    #: ``posterior_cov`` below the engine that declares the fused rule (set per class).
    _fused_update_ok: bool = True

    # The path (compiled kernels or the NumPy reference) is chosen when the engine is
    # built (`gnssframework.backend.BackendChoice`); ``engine.backend = "numpy"`` chooses
    # again for this instance.

    def _use_kernels(self) -> bool:
        return self._uses_compiled

    def _linearised_twins(self, model: Model) -> CompiledFunctions | None:
        """The model's compiled functions where a KF/EKF step can run on them (linear ``f``
        and a compiled Jacobian of ``h``) under the compiled backend, else ``None``. The
        model's own Jacobians must be those of its twins (``CompiledFunctions``)."""
        compiled = getattr(model, "compiled", None)
        if compiled is None or not compiled.linear_f or compiled.h_jacobian is None or not self._use_kernels():
            return None
        twins: CompiledFunctions = compiled
        return twins

    def compiled_linear_predict(self, state: Gaussian, model: Model) -> Gaussian | None:
        """``(F x, F P F^T + Q)`` in one compiled pass with F the model's compiled linear
        ``f``, or ``None`` where that path does not apply (the caller then runs NumPy)."""
        compiled = self._linearised_twins(model)
        if compiled is None:
            return None
        return Gaussian(*kernels.linear_predict(state.mean, state.cov, compiled.f_params, model.Q))

    def compiled_linearised_moments(
        self, prior: Gaussian, model: Model
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """``(h(x), H P H^T + R, P H^T)`` with the model's compiled ``h`` and Jacobian H at
        the mean, or ``None`` where that path does not apply (the caller then runs NumPy)."""
        compiled = self._linearised_twins(model)
        if compiled is None:
            return None
        moments: tuple[np.ndarray, np.ndarray, np.ndarray] = kernels.ekf_moments(
            prior.mean, prior.cov, compiled, model.R
        )
        return moments

    def _raise_root_failure(self, status: np.ndarray, root_kind: int) -> None:
        """The fused kernels' failed square roots (``status == 0``) as the engine's error."""
        detail = "state covariance P is not finite" if root_kind == 1 else "state covariance P (Cholesky)"
        raise NotPositiveDefiniteError(self.name, failing_indices(status == 0), detail=detail)

    def _kernel_posterior(self) -> str | None:
        """Which posterior the update kernel may compute for this engine (``None``: NumPy).

        ``"standard"`` is ``P - K S K^T``; an engine that overrides ``posterior_cov``
        gets the NumPy path unless it names its form (the KF: ``"joseph"``).
        """
        return "standard" if type(self).posterior_cov is Estimator.posterior_cov else None

    # -- to implement -------------------------------------------------------------
    @abc.abstractmethod
    def predict(self, state: Gaussian, model: Model) -> Gaussian:
        """Propagate ``state`` through the transition of ``model`` (adds Q)."""

    @abc.abstractmethod
    def measurement_moments(self, prior: Gaussian, model: Model) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return ``(z_hat, S, C)``: predicted measurement, its covariance with R, and
        the state-measurement cross covariance."""

    # -- smoothing ----------------------------------------------------------------
    #: How the RTS smoother solves for its gain ``G = C (P^-)^{-1}`` after this engine
    #: (`gnssframework.estimation.smoother`): ``"solve"`` (a batched linear solve, no inverse) or
    #: ``"eigh"`` (through the symmetric eigen-decomposition of ``P^-``, the SVD-CKF's
    #: square root, which exists for a nearly singular ``P^-``) or ``"sqrt"`` (the square-root
    #: form, `gnssframework.estimation.smoother_sqrt`: the forward pass also keeps
    #: `transition_factors` and the backward pass carries the smoothed covariance as a factor).
    smoother_gain: str = "solve"

    def transition_factors(self, state: Gaussian, model: Model, prior: Gaussian) -> tuple[np.ndarray, np.ndarray]:
        r"""Factors ``(X, Y)`` of the prediction ``state -> prior``, ``(..., n, N)`` each, with
        $X X^T = P_k$, $X Y^T = C$ (`transition_cross_cov`) and $Y Y^T + Q = P^-_{k+1}$: what
        the square-root smoother (``smoother_gain = "sqrt"``) keeps.

        The linearised form: $X$ the symmetric root of $P_k$ (`smoother_sqrt.psd_root`), $Y = F X$
        with $F$ the Jacobian of $f$ at the mean. Computed on NumPy.
        """
        X = psd_root(state.cov)
        F = model.jacobian_f(state.mean)
        return X, F @ X

    def transition_cross_cov(self, state: Gaussian, model: Model, prior: Gaussian) -> np.ndarray:
        r"""Cross covariance ``C = Cov(x_k, x_{k+1}^-)`` of the prediction ``state -> prior``.

        The linearised form (KF and EKF; Särkkä 2013, ch. 8-9): $C = P_k F^T$ with
        $F = \partial f / \partial x$ at the mean ($F$ itself for a ``LinearModel``).
        Sigma-point engines override it with the points' form. ``prior`` is the
        predicted state (unused here). Computed on NumPy.

        Returns
        -------
        np.ndarray
            ``(..., n, n)``.
        """
        F = model.jacobian_f(state.mean)
        out: np.ndarray = state.cov @ np.swapaxes(F, -1, -2)
        return out

    # -- shared -------------------------------------------------------------------
    def _fused_rule(self, state: Gaussian, model: Model) -> KernelRule | None:
        """The point rule of a whole compiled predict/update with the model's compiled
        f/h, or ``None`` (this engine has none for this model)."""
        return None

    #: How `iterated_update` relinearises when the engine's ``iterations`` > 1:
    #: ``"gauss-newton"`` (IEKF) or ``"posterior-linearisation"`` (IPLF).
    iteration_kind: str = "gauss-newton"

    def _iteration_plan(self) -> tuple[int, float, Any] | None:
        """``(iterations, tol, robust)`` when the engine's parameters ask for an iterated or
        robust update (``iterations`` > 1 or a ``robust`` plugin), else ``None``."""
        params = getattr(self, "params", None)
        iterations = int(getattr(params, "iterations", 1) or 1)
        spec = getattr(params, "robust", None)
        if iterations <= 1 and spec is None:
            return None
        robust = None
        if spec is not None:
            cache = self.__dict__.get("_robust_cache")
            if cache is None or cache[0] is not spec:
                cache = self.__dict__["_robust_cache"] = (spec, spec.create())
            robust = cache[1]
        return iterations, float(getattr(params, "iteration_tol", 0.0)), robust

    def posterior_cov(self, prior: Gaussian, gain: np.ndarray, S: np.ndarray, model: Model) -> np.ndarray:
        """``P - K S K^T``, symmetrised. Engines may override (Joseph form)."""
        return symmetrize(prior.cov - gain @ S @ np.swapaxes(gain, -1, -2))

    def update(
        self,
        prior: Gaussian,
        z: np.ndarray,
        model: Model,
        *,
        on_failure: OnFailure = "raise",
        missing: OnMissing = "raise",
    ) -> Update:
        """Measurement update of a batch of priors.

        Parameters
        ----------
        prior
            Predicted state, batch shape ``B``.
        z
            Measurements ``(..., m)`` broadcastable to ``B + (m,)``.
        model
            The model whose ``h`` and ``R`` apply.
        on_failure
            What to do where the innovation covariance is not positive definite:
            ``"raise"`` a ``NotPositiveDefiniteError`` naming the batch element,
            or skip the update there (any other policy).
        missing
            ``"raise"`` an ``InvalidMeasurementError`` on a NaN/inf measurement,
            or ``"skip"`` the update of that element (a missing measurement).
        """
        z = np.asarray(z, dtype=float)
        if z.shape[:-1] != prior.batch_shape:
            batch = np.broadcast_shapes(prior.batch_shape, z.shape[:-1])
            if prior.batch_shape != batch:
                prior = Gaussian(np.broadcast_to(prior.mean, batch + prior.mean.shape[-1:]), prior.cov)
            z = np.broadcast_to(z, batch + z.shape[-1:])

        plan = self._iteration_plan()
        if plan is not None:  # iterated and/or robust: the loop of `iterated.iterated_update`
            iterations, tol, robust = plan
            return iterated_update(
                self,
                prior,
                z,
                model,
                on_failure=on_failure,
                missing=missing,
                iterations=iterations,
                tol=tol,
                iteration=self.iteration_kind,
                robust=robust,
                line_search=bool(getattr(self.params, "line_search", False)),
            )
        # The fused pass computes the moments and the posterior itself: an engine that
        # overrides either of them takes the path below, which calls its overrides.
        # A model with angle-aware residual hooks takes that path too (the fused pass
        # subtracts plainly).
        rule = self._fused_rule(prior, model) if self._fused_update_ok and not _hooked(model) else None
        if rule is not None:
            # The lean path: one compiled pass finds the missing measurements, the failed
            # roots and the non-PD S, and reports them as three counts.
            (mean, cov, gain, innovation, z_hat, S, C, status, ok, skipped, (n_bad_z, n_root, n_not_pd)) = (
                kernels.fused_update(prior.mean, prior.cov, z, None, rule, model.compiled, model.R)
            )
            if n_bad_z and missing != "skip":
                raise InvalidMeasurementError(self.name, failing_indices(np.isfinite(z).all(axis=-1)))
            if n_root:
                self._raise_root_failure(status, rule[0])
            if n_not_pd and on_failure == "raise":
                raise NotPositiveDefiniteError(self.name, failing_indices(ok), detail="innovation covariance S")
            return Update(Gaussian(mean, cov), innovation, S, gain, C, z_hat, skipped)
        finite_z = np.isfinite(z)
        bad_z = np.zeros(z.shape[:-1], dtype=bool) if all_true(finite_z) else ~finite_z.all(axis=-1)
        if any_true(bad_z):
            if missing != "skip":
                raise InvalidMeasurementError(self.name, failing_indices(~bad_z))
        z_hat, S, C = self.measurement_moments(prior, model)
        form = self._kernel_posterior() if self._use_kernels() and not _hooked(model) else None
        if form is not None:
            joseph = form == "joseph"
            H = model.H if joseph else None  # type: ignore[union-attr]  # "joseph": the KF's form, linear models
            mean, cov, gain, innovation, ok = kernels.update(
                prior.mean,
                prior.cov,
                z,
                z_hat,
                S,
                C,
                bad_z,
                joseph,
                H,
                model.R if joseph else None,
            )
            if on_failure == "raise" and not all_true(ok):
                raise NotPositiveDefiniteError(self.name, failing_indices(ok), detail="innovation covariance S")
            return Update(
                state=Gaussian(mean, cov),
                innovation=innovation,
                innovation_cov=S,
                gain=gain,
                cross_cov=C,
                predicted_measurement=z_hat,
                skipped=bad_z | ~ok,
            )
        L, ok = cholesky_masked(S)
        skip = bad_z | ~ok
        if on_failure == "raise" and not all_true(ok):
            raise NotPositiveDefiniteError(self.name, failing_indices(ok), detail="innovation covariance S")
        if any_true(skip):
            eye = np.eye(S.shape[-1])
            S_safe = np.where(skip[..., None, None], eye, S)
            z = np.where(skip[..., None], z_hat, z)
        else:
            S_safe = S
        # K^T = S^{-1} C^T: one batched solve, S symmetric.
        gain = np.swapaxes(np.linalg.solve(S_safe, np.swapaxes(C, -1, -2)), -1, -2)
        innovation = residual_hook(model, "z")(z, z_hat)
        mean = prior.mean + mat_vec(gain, innovation)
        cov = self.posterior_cov(prior, gain, S_safe, model)
        if any_true(skip):
            mean = np.where(skip[..., None], prior.mean, mean)
            cov = np.where(skip[..., None, None], prior.cov, cov)
        return Update(
            state=Gaussian(mean, cov),
            innovation=innovation,
            innovation_cov=S,
            gain=gain,
            cross_cov=C,
            predicted_measurement=z_hat,
            skipped=skip,
        )


def _hooked(model: Model) -> bool:
    """Whether ``model`` has angle-aware residual or mean hooks (NumPy path only)."""
    return bool(getattr(model, "angle_aware", False))


class SigmaPointEstimator(Estimator):
    """A filter that propagates a deterministic set of sigma points.

    Subclasses give the point rule through ``sigma_points``. The points carry
    their index on the *first* axis, ``(N, ..., n)``, so model functions broadcast
    per-element parameters naturally. The update redraws points from the prior
    (it does not reuse the propagated ones), which is what makes every rule exact
    on linear models.
    """

    iteration_kind = "posterior-linearisation"
    #: The square root `kernel_rule` describes: 0 the lower Cholesky factor (the default
    #: ``square_root``), 1 ``V sqrt(|w|)`` of the symmetric eigen-decomposition. A class
    #: that overrides ``square_root`` declares its root here.
    kernel_root: int = 0
    #: Whether `kernel_rule` still describes this class's points (set per class).
    _kernel_rule_ok: bool = True

    #: Methods a compiled rule stands for: overriding one without declaring the rule again
    #: (``kernel_rule`` or ``kernel_root`` in the same class) leaves the NumPy path.
    _RULE_METHODS = ("sigma_points", "square_root")
    #: Methods the fused update computes itself.
    _UPDATE_METHODS = ("measurement_moments", "posterior_cov")

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        own = vars(cls)
        if "kernel_rule" in own or "kernel_root" in own:
            cls._kernel_rule_ok = True
            cls._fused_update_ok = not any(name in own for name in cls._UPDATE_METHODS)
        else:
            if any(name in own for name in cls._RULE_METHODS):
                cls._kernel_rule_ok = False
            if any(name in own for name in cls._UPDATE_METHODS):
                cls._fused_update_ok = False

    @abc.abstractmethod
    def sigma_points(self, state: Gaussian) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return ``(X, wm, wc)``: points ``(N, ..., n)``, mean and covariance weights ``(N,)``."""

    def kernel_rule(self, n: int) -> tuple[int, float, bool, np.ndarray, np.ndarray] | None:
        """The point rule in the compiled kernels' terms, or ``None`` (NumPy path).

        Returns ``(root_kind, scale, center, wm, wc)``: root 0 = Cholesky, 1 = symmetric
        eigen-decomposition; points ``[m], m +/- scale * S_i``. The rule describes the
        ``sigma_points``/``square_root`` of the class that defines it; a subclass that
        overrides either without declaring ``kernel_rule`` or ``kernel_root`` again runs
        the NumPy path, and one that overrides ``measurement_moments`` or
        ``posterior_cov`` keeps its override (the update then does not run fused).
        """
        return None

    def _fused_rule(self, state: Gaussian, model: Model) -> KernelRule | None:
        """The point rule if predict/update can run fused with the model's compiled f/h."""
        if getattr(model, "compiled", None) is None or not self._use_kernels() or _hooked(model):
            return None
        return self._cached_rule(state.ndim_state)

    def _cached_rule(self, n: int) -> KernelRule | None:
        """`kernel_rule` with its weights as kernel operands, computed once per state size
        and parameter set (the kernels then take the weights as they are, every step)."""
        key = (n, id(getattr(self, "params", None)))
        cache = self.__dict__.setdefault("_rule_cache", {})
        hit = cache.get(key)
        if hit is None:
            rule = self.kernel_rule(n) if self._kernel_rule_ok else None
            if rule is not None:
                root_kind, scale, center, wm, wc = rule
                rule = (
                    int(root_kind),
                    float(scale),
                    bool(center),
                    kernels.vector_operand(wm),
                    kernels.vector_operand(wc),
                )
            hit = cache[key] = (rule, getattr(self, "params", None))  # holds params: its id stays unique
        rule_or_none: KernelRule | None = hit[0]
        return rule_or_none

    def _kernel_points(self, state: Gaussian) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """``(X, wm, wc)`` from the kernels, or ``None`` where the NumPy path applies."""
        if not self._use_kernels():
            return None
        rule = self._cached_rule(state.ndim_state)
        if rule is None:
            return None
        root_kind, scale, center, wm, wc = rule
        X, status = kernels.sigma_points(state.mean, state.cov, root_kind, scale, center)
        if any_true(status):
            self._raise_root_failure(status, root_kind)
        return X, wm, wc

    def square_root(self, cov: np.ndarray) -> np.ndarray:
        """Matrix square root ``S`` with ``S S^T = P`` (lower Cholesky by default).

        Raises
        ------
        NotPositiveDefiniteError
            Naming this filter and the batch elements whose P is not PD.
        """
        L, ok = cholesky_masked(cov)
        if not all_true(ok):
            raise NotPositiveDefiniteError(self.name, failing_indices(ok), detail="state covariance P (Cholesky)")
        return L

    @staticmethod
    def _moments(
        Y: np.ndarray, wm: np.ndarray, wc: np.ndarray, model: Model | None = None, space: str = "x"
    ) -> tuple[np.ndarray, np.ndarray]:
        """Weighted mean and deviations of transformed points ``(N, ..., p)``, through the
        model's mean and residual hooks of ``space`` (``"x"`` or ``"z"``) where it has them."""
        mean_fn = getattr(model, f"mean_{space}", None)
        mean = mean_fn(Y, wm) if mean_fn is not None else (wm @ Y.reshape(Y.shape[0], -1)).reshape(Y.shape[1:])
        return mean, residual_hook(model, space)(Y, mean)

    @staticmethod
    def _weighted_cov(dA: np.ndarray, dB: np.ndarray, wc: np.ndarray) -> np.ndarray:
        """``sum_i wc_i dA_i dB_i^T`` over the first axis, batched."""
        # (..., a, N) @ (..., N, b): one batched matmul, no Python loop over points.
        # Explicit transposes: np.moveaxis costs more than the arithmetic at batch 1.
        nd = dA.ndim
        a_last = dA.transpose(tuple(range(1, nd)) + (0,))
        b_mid = dB.transpose(tuple(range(1, nd - 1)) + (0, nd - 1))
        out: np.ndarray = (a_last * wc) @ b_mid
        return out

    def predict(self, state: Gaussian, model: Model) -> Gaussian:
        rule = self._fused_rule(state, model)
        if rule is not None:
            mean, cov, status = kernels.fused_predict(state.mean, state.cov, rule, model.compiled, model.Q)
            if status is not None:  # some root failed
                self._raise_root_failure(status, rule[0])
            return Gaussian(mean, cov)
        points = None if _hooked(model) else self._kernel_points(state)
        if points is not None:
            X, wm, wc = points
            mean, cov = kernels.predict_moments(model.f(X), wm, wc, model.Q)
            return Gaussian(mean, cov)
        X, wm, wc = self.sigma_points(state)
        Y = model.f(X)
        mean, dY = self._moments(Y, wm, wc, model, "x")
        cov = symmetrize(self._weighted_cov(dY, dY, wc) + model.Q)
        return Gaussian(mean, cov)

    def measurement_moments(self, prior: Gaussian, model: Model) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        points = None if _hooked(model) else self._kernel_points(prior)
        if points is not None:
            X, wm, wc = points
            moments: tuple[np.ndarray, np.ndarray, np.ndarray] = kernels.measurement_moments(
                X, model.h(X), prior.mean, wm, wc, model.R
            )
            return moments
        X, wm, wc = self.sigma_points(prior)
        Z = model.h(X)
        z_hat, dZ = self._moments(Z, wm, wc, model, "z")
        S = symmetrize(self._weighted_cov(dZ, dZ, wc) + model.R)
        C = self._weighted_cov(residual_hook(model, "x")(X, prior.mean), dZ, wc)
        return z_hat, S, C

    def transition_cross_cov(self, state: Gaussian, model: Model, prior: Gaussian) -> np.ndarray:
        r"""Cross covariance ``C = Cov(x_k, x_{k+1}^-)`` from this engine's sigma points.

        With points $\mathcal{X}_i$ of ``state`` and covariance weights $W_i^c$
        (Särkkä 2013, ch. 9, the unscented and general Gaussian RTS smoothers):

        $$
        C = \sum_i W_i^c\, (\mathcal{X}_i - m_k)\, (f(\mathcal{X}_i) - m^-_{k+1})^T
        $$

        through the model's ``residual_x`` hook where it has one. The same points as the
        prediction (this engine's rule), drawn by the compiled kernels where the prediction
        may be (`_kernel_points`), else on NumPy.
        """
        points = None if _hooked(model) else self._kernel_points(state)
        X, wm, wc = points if points is not None else self.sigma_points(state)
        residual = residual_hook(model, "x")
        dX = residual(X, state.mean)
        dY = residual(model.f(X), prior.mean)
        return self._weighted_cov(dX, dY, wc)

    def transition_factors(self, state: Gaussian, model: Model, prior: Gaussian) -> tuple[np.ndarray, np.ndarray]:
        r"""Factors ``(X, Y)`` ``(..., n, N)`` of the prediction from this engine's points:
        $X_{:,i} = \sqrt{W^c_i}\,(\mathcal X_i - m_k)$, $Y_{:,i} = \sqrt{W^c_i}\,(f(\mathcal X_i) -
        m^-_{k+1})$, so $X Y^T$ is `transition_cross_cov` (Arasaratnam & Haykin 2011, the
        square-root cubature RTS smoother). The points are drawn as `transition_cross_cov` draws them.

        Raises
        ------
        ConfigError
            A rule with a negative covariance weight (a UKF with small alpha): its weighted
            deviations have no real root.
        """
        points = None if _hooked(model) else self._kernel_points(state)
        X, wm, wc = points if points is not None else self.sigma_points(state)
        wc = np.asarray(wc, dtype=float)
        if (wc < 0).any():
            raise ConfigError(
                f"estimator {self.name!r}",
                "the square-root smoother (smoother_gain 'sqrt') needs "
                f"nonnegative covariance weights; this rule has {wc.min():.3g}: use form='solve'",
            )
        residual = residual_hook(model, "x")
        root_w = np.sqrt(wc)
        dX = residual(X, state.mean)
        dY = residual(model.f(X), prior.mean)
        nd = dX.ndim
        order = tuple(range(1, nd)) + (0,)  # (N, ..., n) -> (..., n, N)
        return dX.transpose(order) * root_w, dY.transpose(order) * root_w

    @staticmethod
    def _scaled_points(mean: np.ndarray, sqrt_cov: np.ndarray, scale: float) -> np.ndarray:
        """``[m, m + scale*S_i, m - scale*S_i]`` with ``S_i`` the columns of the root."""
        nd = sqrt_cov.ndim
        cols = sqrt_cov.transpose((nd - 1,) + tuple(range(nd - 1))) * scale  # (n, ..., n): column i first
        return np.concatenate([mean[None], mean + cols, mean - cols], axis=0)
