"""Built-in model augmentation: ``colored-ar1``."""

from __future__ import annotations

import dataclasses
from typing import Any, Literal
from collections.abc import Callable, Mapping

import numpy as np
from pydantic import Field, field_validator

from gnssframework.errors import ConfigError
from gnssframework.estimation import AugmentedProblem, Augmentation, LinearModel, NonlinearModel
from gnssframework.estimation.linalg import mat_vec, symmetrize
from gnssframework.plugin import PluginParams

__all__ = ["ColoredAR1"]


class ColoredAR1Params(PluginParams):
    psi: float | list[float] | None = Field(
        None,
        description="AR(1) coefficient of the measurement noise, one value or one per component, |psi| < 1; "
        "unset: the true coefficient, which a scenario that simulates the noise supplies (multipath)",
    )
    psi_estimator: Literal["truth", "lag1", "lag-ratio"] = Field(
        "truth",
        description="with psi unset, what a scenario that simulates the noise (multipath) supplies: 'truth' "
        "(default), the true coefficient (the paper's assumption); 'lag1', the lag-1 sample autocorrelation of a "
        "training record of the case's psi_training_epochs measurements (biased low by the white-noise share and "
        "by (1 + 4 psi)/n, Marriott & Pope 1954); 'lag-ratio', its lag-2 over lag-1 autocovariance (consistent "
        "under added white noise, Box & Jenkins' ARMA(1,1), with a larger variance); "
        "gnssframework.estimation.ar1_estimate. Ignored when psi is given",
    )
    cross_covariance: Literal["exact", "paper"] = Field(
        "exact",
        description="'exact' keeps the w/V* cross covariance M = Q H^T (decorrelated transition); "
        "'paper' drops it as Liu et al. (2020) do (M = 0: Q' = Q, no J term)",
    )

    @field_validator("psi", mode="before")
    @classmethod
    def _stationary(cls, value: Any) -> Any:
        """|psi| < 1 (a stationary AR(1)), checked when the config loads rather than after
        a comparison's first batches (a psi of 1e6 failed only at run time)."""
        for v in value if isinstance(value, list) else [value]:
            if v is None:
                continue
            if isinstance(v, (bool, str)) or not isinstance(v, (int, float)):
                raise ValueError(f"must be a number or a list of numbers, got {v!r}")
            if not abs(v) < 1:  # also NaN
                raise ValueError(f"must satisfy |psi| < 1 (a stationary AR(1)), got {v!r}")
        return value


def _linear_measurement(model) -> np.ndarray:
    """H of a model whose measurement function is linear (checked)."""
    if isinstance(model, LinearModel):
        return model.H
    n = model.dim_state
    H = model.jacobian_h(np.zeros(n))
    x = np.random.default_rng(0).standard_normal((3, n))  # a fixed probe, not a simulation draw
    if not np.allclose(model.h(x), mat_vec(H, x), rtol=1e-6, atol=1e-9):
        raise ConfigError("augmentation 'colored-ar1'", "needs a linear measurement function h (z = H x + v)")
    return H


@dataclasses.dataclass(frozen=True)
class _Decorrelated(LinearModel):
    """A step of the decorrelated model. Its noise is stated as the *raw* process noise
    Q and the differenced R* (what an adapter starts from and returns, see
    ``ColoredAR1``); ``with_noise`` recomputes J and Q' from them, so an adapted Q or R
    never replaces the decorrelated Q' by a raw Q."""

    rebuild: Callable | None = None
    raw_Q: np.ndarray | None = None

    def with_noise(self, Q=None, R=None):
        return self.rebuild(self.raw_Q if Q is None else Q, self.R if R is None else R)


@dataclasses.dataclass(frozen=True)
class _DecorrelatedNonlinear(NonlinearModel):
    """Nonlinear counterpart of ``_Decorrelated``."""

    rebuild: Callable | None = None
    raw_Q: np.ndarray | None = None

    def with_noise(self, Q=None, R=None):
        return self.rebuild(self.raw_Q if Q is None else Q, self.R if R is None else R)


class ColoredAR1(Augmentation):
    r"""Measurement differencing for AR(1) measurement noise (Bryson & Henrikson 1968).

    Model: $x_{k+1} = F x_k + w_k$, $z_k = H x_k + V_k$,
    $V_k = \psi V_{k-1} + \xi_k$, $w \sim N(0, Q)$, $\xi \sim N(0, R)$.
    The differenced measurement (Liu et al. 2020, eqs. 8-11)

    $$
    z^*_k = z_{k+1} - \psi z_k = H^* x_k + V^*_k, \quad H^* = H F - \psi H, \\
    V^*_k = H w_k + \xi_{k+1}, \quad R^* = H Q H^T + R
    $$

    has white noise, but $V^*_k$ is correlated with the process noise
    $w_k$ (cross covariance $M = Q H^T$), which the paper drops. We keep it
    by decorrelating the transition (Simon, *Optimal State Estimation*, 2006, §7.1):
    with $J = M R^{*-1}$,

    $$
    x_{k+1} = F x_k + J (z^*_k - H^* x_k) + w'_k, \quad
    Q' = Q - M R^{*-1} M^T, \quad E[w'_k V^{*T}_k] = 0
    $$

    Epochs: step k of the rewritten problem updates with $z^*_k$, which
    contains $z_{k+1}$; its estimate is of the state at epoch **k** given the
    measurements through epoch **k+1** (a one-step-lagged estimate). There are K-1 steps
    for K measurements; ``FilterResult.epochs`` is ``0 .. K-2``.
    For sigma-point filters the model keeps ``f`` as given; ``h`` must be linear.

    With a noise adapter: the step models state their noise as the raw Q and the
    differenced R* (the adapter starts from these), and ``with_noise(Q, R*)`` recomputes
    J and Q' from the adapted values every step, so an adapter whose weights are 0
    reproduces the non-adaptive filter exactly.
    """

    name = "colored-ar1"
    description = "Measurement differencing for AR(1) colored measurement noise, with the w/V* cross term"
    Params = ColoredAR1Params
    params: ColoredAR1Params  # self.params, as validated

    def assumed_psi(self, context: Mapping[str, Any]) -> float | None:
        r"""The AR(1) coefficient this augmentation assumes in a case: ``psi`` if given,
        else the case's true ``psi`` (``psi_estimator = "truth"``) or what the estimator
        converges to on a long training record: the lag-1 autocorrelation of the measured
        AR(1) + white noise for ``lag1``,

        $$
        \rho_1 = \psi\, \frac{\sigma_c^2}{\sigma_c^2 + \sigma_w^2},
        $$

        and ``psi`` for ``lag-ratio`` (consistent under the added white noise; Box &
        Jenkins' ARMA(1,1)). A finite record of n epochs biases ``lag1`` lower still, by
        about $(1 + 4\rho_1)/n$ (Marriott & Pope 1954) and more near |psi| = 1, and a
        run's estimate has its sampling error, SD $\sqrt{(1-\rho_1^2)/n}$ per record
        (Bartlett 1946). ``None`` when the case's psi is unknown."""
        given = self.params.psi
        if given is not None:
            return float(np.mean(given))
        psi = context.get("psi")
        if psi is None:
            return None
        if self.params.psi_estimator != "lag1":
            return float(psi)
        return float(
            psi * context["colored_variance_m2"] / (context["colored_variance_m2"] + context["white_variance_m2"])
        )

    def assumptions(self, context: Mapping[str, Any]) -> dict[str, tuple[Any, str]]:
        r"""The colored-noise model: AR(1), how psi is had (given, the case's true one, or
        estimated), the cross-covariance form, the assumed psi against the true one, and
        the factor $1/(1-\psi^2)$ from the driving-noise variance (the nav filter's R0)
        to the AR(1) stationary variance the filter then assumes,
        $\sigma^2 = \sigma_\xi^2 / (1 - \psi^2)$."""
        p = self.params
        how = (
            "given"
            if p.psi is not None
            else "true (the case's)"
            if p.psi_estimator == "truth"
            else f"estimated ({p.psi_estimator}; its long-record limit)"
        )
        cross = "paper (dropped, M = 0)" if p.cross_covariance == "paper" else "exact (M = Q Hᵀ)"
        out = {
            "measurement-noise model": (f"AR(1), psi {how}", "-"),
            "process/measurement cross covariance": (cross, "-"),
        }
        psi = self.assumed_psi(context)
        if psi is not None:
            out["AR(1) psi"] = (psi, "-")
            if context.get("psi"):
                out["AR(1) psi / true psi"] = (psi / context["psi"], "-")
            out["stationary / driving variance, 1/(1 − psi²)"] = (1.0 / (1.0 - psi**2), "-")
        return out

    def apply(self, model, zs: np.ndarray) -> AugmentedProblem:
        zs = np.asarray(zs, dtype=float)
        if zs.shape[0] < 2:
            raise ConfigError("zs", "colored-ar1 needs at least two epochs")
        m = model.dim_meas
        if self.params.psi is None:
            raise ConfigError(
                "augmentation 'colored-ar1'.psi",
                "is not set; give the AR(1) coefficient (only a "
                "scenario that simulates the noise, e.g. multipath, fills in the true one)",
            )
        psi = np.broadcast_to(np.asarray(self.params.psi, dtype=float), (m,))
        if np.any(np.abs(psi) >= 1):
            raise ConfigError("augmentation 'colored-ar1'.psi", f"must satisfy |psi| < 1, got {self.params.psi}")
        H = _linear_measurement(model)
        Psi = np.diag(psi)
        zs_star = zs[1:] - psi * zs[:-1]
        R_star0 = symmetrize(H @ model.Q @ np.swapaxes(H, -1, -2) + model.R)

        def decorrelation(Q: np.ndarray, R_star: np.ndarray, z_prev: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            """J and Q' from the (raw) process noise Q and the differenced R*. Where the
            previous differenced measurement is missing (NaN/inf: its update is skipped
            under ``missing="skip"``) there is nothing to decorrelate with: J = 0, Q' = Q."""
            if self.params.cross_covariance == "paper":  # Liu et al. (2020) drop M
                return np.zeros(Q.shape[:-2] + (Q.shape[-1], H.shape[-2])), Q
            M = Q @ np.swapaxes(H, -1, -2)  # E[w V*^T]
            J = np.swapaxes(np.linalg.solve(R_star, np.swapaxes(M, -1, -2)), -1, -2)
            seen = np.isfinite(z_prev).all(axis=-1)
            if not seen.all():
                J = np.where(seen[..., None, None], J, 0.0)
            return J, symmetrize(Q - J @ np.swapaxes(M, -1, -2))

        if isinstance(model, LinearModel):
            F = model.F
            H_star = H @ F - Psi @ H

            def build(k: int, Q: np.ndarray, R_star: np.ndarray) -> LinearModel:
                if k == 0:  # predicting into epoch 0: w_{-1} is not correlated with V*_0
                    return _Decorrelated(F, H_star, Q, R_star, u=model.u, rebuild=lambda Q, R: build(0, Q, R), raw_Q=Q)
                J, Q_dec = decorrelation(Q, R_star, zs_star[k - 1])
                u = mat_vec(J, np.nan_to_num(zs_star[k - 1], nan=0.0, posinf=0.0, neginf=0.0))
                u = u if model.u is None else u + model.u
                return _Decorrelated(
                    F - J @ H_star, H_star, Q_dec, R_star, u=u, rebuild=lambda Q, R: build(k, Q, R), raw_Q=Q
                )

        else:
            f = model.f

            def h_star(x: np.ndarray) -> np.ndarray:
                return mat_vec(H, f(x)) - psi * mat_vec(H, x)

            def build(k: int, Q: np.ndarray, R_star: np.ndarray) -> NonlinearModel:
                if k == 0:
                    return _DecorrelatedNonlinear(f, h_star, Q, R_star, rebuild=lambda Q, R: build(0, Q, R), raw_Q=Q)
                J, Q_dec = decorrelation(Q, R_star, zs_star[k - 1])
                z_prev = np.nan_to_num(zs_star[k - 1], nan=0.0, posinf=0.0, neginf=0.0)

                def f_dec(x: np.ndarray) -> np.ndarray:
                    return f(x) + mat_vec(J, z_prev - h_star(x))

                return _DecorrelatedNonlinear(
                    f_dec, h_star, Q_dec, R_star, rebuild=lambda Q, R: build(k, Q, R), raw_Q=Q
                )

        def model_at(k: int):
            return build(k, model.Q, R_star0)

        return AugmentedProblem(zs=zs_star, model_at=model_at, epochs=np.arange(zs.shape[0] - 1))
