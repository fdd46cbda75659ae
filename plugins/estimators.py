"""Built-in Gaussian filter engines: ``kf``, ``ekf``, ``ukf``, ``ckf``, ``svd-ckf``."""

from __future__ import annotations

from functools import lru_cache
from typing import ClassVar

import numpy as np
from pydantic import Field

from gnssframework.errors import ConfigError, NotPositiveDefiniteError
from gnssframework.estimation import Estimator, Gaussian, LinearModel, SigmaPointEstimator
from gnssframework.estimation.linalg import failing_indices, mat_vec, symmetrize
from gnssframework.plugin import PluginParams
from gnssframework.plugin_ref import PluginRef

__all__ = [
    "KalmanFilter",
    "ExtendedKalmanFilter",
    "UnscentedKalmanFilter",
    "CubatureKalmanFilter",
    "SvdCubatureKalmanFilter",
]


class EngineParams(PluginParams):
    """The parameters of an engine without tuning constants (none)."""

    no_parameters: ClassVar[str] = (
        "the engine is set by the model it is given (F, H or f, h, with Q and R) and the "
        "initial state; its rule has no tuning constant"
    )


class IteratedParams(PluginParams):
    """The parameters every nonlinear engine shares: its iterated and robust update."""

    iterations: int = Field(
        1,
        ge=1,
        le=100,
        description="most linearisations of the measurement update: 1 is the "
        "plain update; > 1 iterates (ekf: Gauss-Newton IEKF, sigma points: iterated posterior "
        "linearisation) until the step is below iteration_tol",
    )
    iteration_tol: float = Field(
        1e-9,
        ge=0,
        description="stopping rule of the iterations: largest state step in "
        "prior standard deviations (each batch element stops on its own)",
    )
    robust: PluginRef("robust_update") | None = Field(  # type: ignore[valid-type]  # an Annotated type built at run time
        None,
        description="robust_update plugin that reweights R from the residual (huber, cauchy, student-t); "
        "none: the Gaussian update",
    )


class ExtendedParams(IteratedParams):
    """The EKF's: its iterations may be damped by a line search (Gauss-Newton only)."""

    line_search: bool = Field(
        False,
        description="with iterations > 1 and no robust update: halve each "
        "Gauss-Newton step until the MAP cost does not increase (damped IEKF, Skoglund, "
        "Hendeby & Axehill 2015)",
    )


class LinearParams(PluginParams):
    """The Kalman filter's one parameter: its robust update (a linear update needs no iteration)."""

    robust: PluginRef("robust_update") | None = Field(  # type: ignore[valid-type]  # an Annotated type built at run time
        None,
        description="robust_update plugin that reweights R from the residual (huber, cauchy, student-t); "
        "none: the Gaussian update",
    )


def _transpose(a: np.ndarray) -> np.ndarray:
    return np.swapaxes(a, -1, -2)


class KalmanFilter(Estimator):
    r"""The linear Kalman filter (Kalman 1960) on a ``LinearModel``.

    $$
    x^- = F x + u, \quad P^- = F P F^T + Q, \\
    S = H P^- H^T + R, \quad K = P^- H^T S^{-1}, \\
    x^+ = x^- + K (z - H x^-), \quad
    P^+ = (I - K H) P^- (I - K H)^T + K R K^T
    $$

    The covariance update is Joseph's form, which stays symmetric PSD under rounding
    for any gain.
    """

    name = "kf"
    Params = LinearParams
    params: LinearParams  # self.params, as validated
    description = "Linear Kalman filter (Joseph-form covariance update)"
    #: Only for a LinearModel: nested-plugin parameters on nonlinear models refuse it.
    linear_only = True

    def _require_linear(self, model) -> LinearModel:
        if not isinstance(model, LinearModel):
            raise ConfigError("model", f"{self.name} needs a LinearModel; use 'ekf' or a sigma-point filter")
        return model

    def predict(self, state: Gaussian, model) -> Gaussian:
        model = self._require_linear(model)
        compiled = self.compiled_linear_predict(state, model)
        if compiled is not None:
            return compiled
        F = model.F
        return Gaussian(model.f(state.mean), symmetrize(F @ state.cov @ _transpose(F) + model.Q))

    def measurement_moments(self, prior: Gaussian, model):
        model = self._require_linear(model)
        compiled = self.compiled_linearised_moments(prior, model)
        if compiled is not None:
            return compiled
        H = model.H
        C = prior.cov @ _transpose(H)
        return mat_vec(H, prior.mean), symmetrize(H @ C + model.R), C

    def _kernel_posterior(self):
        return "joseph" if type(self).posterior_cov is KalmanFilter.posterior_cov else None

    def posterior_cov(self, prior, gain, S, model) -> np.ndarray:
        IKH = np.eye(prior.ndim_state) - gain @ model.H
        return symmetrize(IKH @ prior.cov @ _transpose(IKH) + gain @ model.R @ _transpose(gain))


class ExtendedKalmanFilter(Estimator):
    r"""Extended Kalman filter: linearise ``f`` and ``h`` at the current mean.

    $$
    x^- = f(x), \quad P^- = F P F^T + Q, \quad F = \partial f / \partial x |_{x} \\
    \hat z = h(x^-), \quad S = H P^- H^T + R, \quad C = P^- H^T, \quad
    H = \partial h / \partial x |_{x^-}
    $$

    Jacobians come from the model (analytic when given, central differences
    otherwise). On a ``LinearModel`` it is the Kalman filter.
    """

    name = "ekf"
    Params = ExtendedParams
    params: ExtendedParams  # self.params, as validated
    description = "Extended Kalman filter (analytic or central-difference Jacobians)"

    def predict(self, state: Gaussian, model) -> Gaussian:
        compiled = self.compiled_linear_predict(state, model)
        if compiled is not None:
            return compiled
        F = model.jacobian_f(state.mean)
        return Gaussian(model.f(state.mean), symmetrize(F @ state.cov @ _transpose(F) + model.Q))

    def measurement_moments(self, prior: Gaussian, model):
        compiled = self.compiled_linearised_moments(prior, model)
        if compiled is not None:
            return compiled
        H = model.jacobian_h(prior.mean)
        C = prior.cov @ _transpose(H)
        return model.h(prior.mean), symmetrize(H @ C + model.R), C


class UnscentedParams(IteratedParams):
    alpha: float = Field(
        1e-3,
        gt=0,
        description="spread of the points around the mean (> 1 spreads them beyond "
        "sqrt(n + kappa) standard deviations, as FilterPy and Stone Soup allow)",
    )
    beta: float = Field(2.0, ge=0, description="prior knowledge of the distribution (2 is optimal for Gaussians)")
    kappa: float = Field(0.0, description="secondary scaling; n + kappa must stay positive")


@lru_cache(maxsize=64)
def _merwe_weights(n: int, alpha: float, beta: float, kappa: float) -> tuple[float, np.ndarray, np.ndarray]:
    lam = alpha**2 * (n + kappa) - n
    c = n + lam
    wm = np.full(2 * n + 1, 1.0 / (2.0 * c))
    wc = wm.copy()
    wm[0] = lam / c
    wc[0] = lam / c + 1.0 - alpha**2 + beta
    wm.setflags(write=False)
    wc.setflags(write=False)
    return float(np.sqrt(c)), wm, wc


class UnscentedKalmanFilter(SigmaPointEstimator):
    r"""Unscented Kalman filter with van der Merwe's scaled sigma points.

    With $\lambda = \alpha^2 (n + \kappa) - n$ the 2n+1 points are
    $x$ and $x \pm \sqrt{n+\lambda}\, S_i$ (columns of the Cholesky root of
    P), with weights

    $$
    W_0^m = \frac{\lambda}{n+\lambda}, \quad
    W_0^c = \frac{\lambda}{n+\lambda} + 1 - \alpha^2 + \beta, \quad
    W_i^m = W_i^c = \frac{1}{2(n+\lambda)}
    $$

    (van der Merwe, *Sigma-Point Kalman Filters*, PhD thesis, 2004). These are the
    weights Liu et al. (2020) mean; its printed eq. 14 has two typos.
    """

    name = "ukf"
    description = "Unscented Kalman filter, Merwe scaled sigma points (alpha, beta, kappa)"
    Params = UnscentedParams
    params: UnscentedParams  # self.params, as validated

    def sigma_points(self, state: Gaussian):
        n = state.ndim_state
        p = self.params
        if n + p.kappa <= 0:
            raise ConfigError("estimator 'ukf'.kappa", f"n + kappa must be > 0 (n = {n}, kappa = {p.kappa})")
        scale, wm, wc = _merwe_weights(n, p.alpha, p.beta, p.kappa)
        X = self._scaled_points(state.mean, self.square_root(state.cov), scale)
        return X, wm, wc

    def kernel_rule(self, n: int):
        # Valid for this class's points and any subclass that declares its root
        # (`SigmaPointEstimator.kernel_root`); others run the NumPy path.
        p = self.params
        if n + p.kappa <= 0:
            raise ConfigError("estimator 'ukf'.kappa", f"n + kappa must be > 0 (n = {n}, kappa = {p.kappa})")
        scale, wm, wc = _merwe_weights(n, p.alpha, p.beta, p.kappa)
        return self.kernel_root, scale, True, wm, wc


@lru_cache(maxsize=64)
def _cubature_weights(n: int) -> np.ndarray:
    w = np.full(2 * n, 1.0 / (2 * n))
    w.setflags(write=False)
    return w


class CubatureKalmanFilter(SigmaPointEstimator):
    r"""Cubature Kalman filter (Arasaratnam & Haykin, IEEE TAC 2009).

    The third-degree spherical-radial rule: 2n points $x + \sqrt{n}\, S \xi_i$,
    $\xi \in [I, -I]$, weights $1/(2n)$, S the Cholesky root of P. It is
    the UKF with $\alpha = 1, \beta = 0, \kappa = 0$.
    """

    name = "ckf"
    Params = IteratedParams
    params: IteratedParams  # self.params, as validated
    description = "Cubature Kalman filter, 2n third-degree spherical-radial points (Cholesky root)"

    def sigma_points(self, state: Gaussian):
        n = state.ndim_state
        w = _cubature_weights(n)
        X = self._scaled_points(state.mean, self.square_root(state.cov), np.sqrt(n))[1:]
        return X, w, w

    def kernel_rule(self, n: int):
        w = _cubature_weights(n)
        return self.kernel_root, float(np.sqrt(n)), False, w, w


class SvdCubatureKalmanFilter(CubatureKalmanFilter):
    r"""Cubature Kalman filter with the square root of P from its SVD.

    $P = U \operatorname{diag}(s) V^T$ gives the root $U \operatorname{diag}(\sqrt{s})$
    (Zou, Lian and Dan 2018, eqs. 11-25). Unlike Cholesky it exists for every symmetric
    P, so the filter keeps running on the nearly singular covariances that rounding
    produces. For a PSD P
    the root differs from Cholesky's by an orthogonal rotation: the cubature points
    differ, so on a *nonlinear* model the two filters agree only to the rule's third
    degree of accuracy, while on a linear model both return the Kalman filter's numbers.
    """

    name = "svd-ckf"
    description = "Cubature Kalman filter with an SVD square root (Zou et al. 2018)"
    #: The kernels' root for this ``square_root``: ``V sqrt(|w|)`` of the eigen-decomposition.
    kernel_root = 1
    #: The RTS smoother in square-root form (`gnssframework.estimation.smoother_sqrt`): the
    #: smoothed covariance carried as a factor from the points' weighted deviations.
    smoother_gain = "sqrt"

    def square_root(self, cov: np.ndarray) -> np.ndarray:
        finite = np.isfinite(cov).all(axis=(-2, -1))
        if not finite.all():
            raise NotPositiveDefiniteError(
                self.name, failing_indices(finite), detail="state covariance P is not finite"
            )
        # For a symmetric P the SVD is its eigendecomposition with s = |w| (Hermitian
        # SVD, as numpy computes it): U sqrt(S) = V sqrt(|w|). Column order and signs
        # do not change the cubature point set, so eigh alone gives the same filter.
        w, v = np.linalg.eigh(symmetrize(cov))
        return v * np.sqrt(np.abs(w))[..., None, :]
