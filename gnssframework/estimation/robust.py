r"""Robust measurement updates (plugin kind ``robust_update``).

A robust update replaces the measurement covariance R of a Gaussian update by an
*effective* covariance computed from the residual at the current iterate of the update,
and the update is iterated to the fixed point (`gnssframework.estimation.iterated`).
Because it acts only on R, one robust update works with every engine (``kf``, ``ekf``,
``ukf``, ``ckf``, ``svd-ckf``) and on the engines' compiled moments.

At iterate $i$ (posterior $N(x_i, P_i)$) the plugin sees

- the residual $e_i = z - \hat h(x_i)$ (the engine's predicted measurement at the iterate),
- its spread $\Sigma_i = \operatorname{Cov}[h(x)]$ under $N(x_i, P_i)$ (linearised:
  $H P_i H^T$; sigma points: the statistical linear regression's),
- the model's R,

and returns $R_{\mathrm{eff}}$. Iteration 0 is always the plain update with R (the
least-squares start of iteratively reweighted least squares); iterations 1, 2, ... use
the plugin's $R_{\mathrm{eff}}$ from the previous iterate.

An M-estimator with weight function $w(r)$ on the whitened residual
$r = L^{-1} e$ ($R = L L^T$) returns $R_{\mathrm{eff}} = L\, W^{-1} L^T$,
$W = \operatorname{diag}(w(r_j))$: the fixed point is a stationary point of the
M-estimation MAP cost $\tfrac12 (x - m)^T P^{-1} (x - m) + \sum_j \rho(r_j(x))$
(Karlgaard & Schaub 2007 with the prior kept Gaussian; Huber 1964).
"""

from __future__ import annotations

import abc

import numpy as np

from ..plugin import Plugin

__all__ = ["RobustUpdate", "whitened_residual", "reweighted_noise"]


class RobustUpdate(Plugin, abc.ABC):
    """A robust measurement update: the effective R from the residual at an iterate.

    Subclasses implement `effective_noise`; ``iterations`` (the most iterations the update
    runs, 1 is the plain update) and ``tol`` (stopping rule, see
    `gnssframework.estimation.iterated`) come from their parameters.
    """

    kind = "robust_update"
    #: Whether iteration 0 consults the plugin too, with the innovation ``z - h(m)`` and
    #: the prior's spread (an innovation gate); otherwise iteration 0 is the plain update.
    gates_prior: bool = False

    @property
    def iterations(self) -> int:
        return int(getattr(self.params, "iterations", 10))

    @property
    def tol(self) -> float:
        return float(getattr(self.params, "tol", 1e-9))

    @abc.abstractmethod
    def effective_noise(self, residual: np.ndarray, spread: np.ndarray, R: np.ndarray) -> np.ndarray:
        """The effective measurement covariance ``(..., m, m)``.

        Parameters
        ----------
        residual
            ``(..., m)``: ``z - h(x_i)`` at the current iterate.
        spread
            ``(..., m, m)``: covariance of ``h(x)`` under the current posterior.
        R
            ``(..., m, m)``: the model's measurement covariance.
        """


def whitened_residual(residual: np.ndarray, R: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(r, L)``: ``r = L^{-1} e`` with ``L`` the lower Cholesky factor of ``R`` (batched)."""
    L = np.linalg.cholesky(R)
    L = np.broadcast_to(L, residual.shape[:-1] + L.shape[-2:])
    r = np.linalg.solve(L, residual[..., None])[..., 0]
    return r, L


def reweighted_noise(L: np.ndarray, weight: np.ndarray, R: np.ndarray) -> np.ndarray:
    """``L diag(1 / w) L^T``: R with each whitened component's variance divided by its weight
    (``R`` itself, bit for bit, where every weight is 1)."""
    Lw = L / weight[..., None, :]
    out = Lw @ np.swapaxes(L, -1, -2)
    out = 0.5 * (out + np.swapaxes(out, -1, -2))
    return np.where((weight == 1.0).all(axis=-1)[..., None, None], R, out)
