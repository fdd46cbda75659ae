r"""Built-in robust measurement updates: ``huber``, ``cauchy``, ``student-t``.

Each gives the effective measurement covariance of one iteration of the engine's update
(`gnssframework.estimation.robust`, `gnssframework.estimation.iterated`); the update is
iterated to the fixed point, so each works with every engine (kf, ekf, ukf, ckf, svd-ckf).
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from gnssframework.estimation.robust import RobustUpdate, reweighted_noise, whitened_residual
from gnssframework.plugin import PluginParams

__all__ = ["HuberUpdate", "CauchyUpdate", "StudentTUpdate", "InnovationGate", "huber_weight", "cauchy_weight"]

#: The factor on R of a measurement a gate rejects: its gain falls by this factor, so its
#: update is nil to rounding while the update's shapes and counts stay those of an update.
REJECTED_R_FACTOR = 1e12


class _IterationParams(PluginParams):
    iterations: int = Field(
        10, ge=2, le=200, description="most iterations of the reweighted update (iteration 0 is the Gaussian update)"
    )
    tol: float = Field(
        1e-9,
        ge=0,
        description="stopping rule: largest state step between iterations, in prior "
        "standard deviations (each batch element stops on its own)",
    )


class MEstimatorParams(_IterationParams):
    threshold: float = Field(
        1.345,
        gt=0,
        description="tuning constant c, in standard deviations of the whitened "
        "residual (Huber: 1.345 gives 95 % efficiency on Gaussian noise; Cauchy: 2.385)",
    )


def huber_weight(r: np.ndarray, c: float) -> np.ndarray:
    r"""Huber's weight $w(r) = \min(1, c / |r|)$ (Huber 1964; $\psi(r) = w(r)\, r$)."""
    a = np.abs(r)
    return np.where(a <= c, 1.0, c / np.maximum(a, c))


def cauchy_weight(r: np.ndarray, c: float) -> np.ndarray:
    r"""The Cauchy (Lorentzian) weight $w(r) = 1 / (1 + (r / c)^2)$, from
    $\rho(r) = \tfrac{c^2}{2} \log(1 + (r/c)^2)$."""
    return 1.0 / (1.0 + (r / c) ** 2)


class HuberUpdate(RobustUpdate):
    r"""Huber M-estimation update by iteratively reweighted R.

    With the whitened residual $r = L^{-1}(z - h(x_i))$, $R = L L^T$:
    $R_{\mathrm{eff}} = L\, \operatorname{diag}(1 / w(r_j))\, L^T$,
    $w(r) = \min(1, c/|r|)$ (Huber 1964; the Huber filter of Karlgaard & Schaub 2007
    with the prior kept Gaussian). Residuals within ``threshold`` keep their weight 1.
    """

    name = "huber"
    description = "Huber M-estimator: R reweighted by min(1, c/|r|) of the whitened residual"
    Params = MEstimatorParams

    def effective_noise(self, residual, spread, R):
        r, L = whitened_residual(residual, R)
        return reweighted_noise(L, huber_weight(r, self.params.threshold), R)


class CauchyParams(MEstimatorParams):
    threshold: float = Field(
        2.385,
        gt=0,
        description="tuning constant c, in standard deviations of the whitened "
        "residual (2.385 gives 95 % efficiency on Gaussian noise)",
    )


class CauchyUpdate(RobustUpdate):
    r"""Cauchy M-estimation update: as ``huber`` with $w(r) = 1 / (1 + (r/c)^2)$, a
    redescending weight (a gross outlier's weight falls as $c^2 / r^2$)."""

    name = "cauchy"
    description = "Cauchy M-estimator: R reweighted by 1/(1 + (r/c)^2) of the whitened residual"
    Params = CauchyParams

    def effective_noise(self, residual, spread, R):
        r, L = whitened_residual(residual, R)
        return reweighted_noise(L, cauchy_weight(r, self.params.threshold), R)


class StudentTParams(_IterationParams):
    dof: float = Field(
        3.0,
        gt=0,
        description="degrees of freedom nu of the Student-t measurement noise (small: heavy tails; large: Gaussian)",
    )


class StudentTUpdate(RobustUpdate):
    r"""Student-t measurement noise, variational Bayes update (Piché, Särkkä & Hartikainen 2012).

    The noise $v \mid \lambda \sim N(0, R/\lambda)$, $\lambda \sim \mathrm{Gamma}(\nu/2, \nu/2)$,
    is Student-t with $\nu$ degrees of freedom. The VB fixed point alternates
    $q(x) = N(x_i, P_i)$, the Gaussian update with $R / \bar\lambda$, and
    $q(\lambda) = \mathrm{Gamma}\big(\tfrac{\nu + m}{2}, \tfrac{\nu + \operatorname{tr}(R^{-1} D)}{2}\big)$,

    $$
    D = (z - h(x_i))(z - h(x_i))^T + \operatorname{Cov}[h(x)], \qquad
    \bar\lambda = \frac{\nu + m}{\nu + \operatorname{tr}(R^{-1} D)}, \qquad
    R_{\mathrm{eff}} = R / \bar\lambda .
    $$
    """

    name = "student-t"
    description = "Student-t noise, variational Bayes update (Piche, Sarkka & Hartikainen 2012)"
    Params = StudentTParams

    def effective_noise(self, residual, spread, R):
        nu, m = self.params.dof, residual.shape[-1]
        D = residual[..., :, None] * residual[..., None, :] + spread
        trace = np.trace(np.linalg.solve(np.broadcast_to(R, D.shape), D), axis1=-2, axis2=-1)
        lam = (nu + m) / (nu + trace)
        return R / lam[..., None, None]


class GateParams(PluginParams):
    false_alarm: float = Field(
        1e-3,
        gt=0,
        lt=1,
        description="probability that a measurement without an "
        "outlier is rejected: the gate is the chi-square quantile 1 - false_alarm with m "
        "degrees of freedom",
    )


class InnovationGate(RobustUpdate):
    r"""Chi-square innovation gate, the rule the navigation filters exclude with today.

    The whole measurement is rejected when its normalised innovation squared
    $\nu^T S^{-1} \nu$, $\nu = z - h(m)$, $S = \operatorname{Cov}[h(x)] + R$ under the
    prior, exceeds $\chi^2_m(1 - p_{\mathrm{fa}})$ (Bar-Shalom, Li & Kirubarajan 2001,
    sec. 5.4). A rejected measurement gets $R_{\mathrm{eff}} = 10^{12} R$: its gain, and so
    its update, is nil to rounding. One pass, no iteration.
    """

    name = "gate"
    description = "Chi-square innovation gate: reject the measurement whose NIS exceeds the quantile"
    Params = GateParams
    gates_prior = True

    @property
    def iterations(self) -> int:
        return 1

    def effective_noise(self, residual, spread, R):
        from scipy.stats import chi2  # here: scipy.stats' import costs every run of the CLI half a second

        S = spread + R
        nis = np.einsum("...i,...i->...", residual, np.linalg.solve(S, residual[..., None])[..., 0])
        rejected = nis > chi2.ppf(1.0 - self.params.false_alarm, residual.shape[-1])
        return np.where(rejected[..., None, None], REJECTED_R_FACTOR * R, R)
