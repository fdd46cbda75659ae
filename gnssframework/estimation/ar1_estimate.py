"""The AR(1) coefficient of a noise sequence estimated from samples, batch-first.

For measurement differencing (``colored-ar1``) the AR(1) coefficient psi must come from
somewhere; these are the two classical moment estimators from a training record.

- ``"lag1"``: the lag-1 sample autocorrelation
  $r_1 = \\sum_k d_k d_{k+1} / \\sum_k d_k^2$, $d = z - \\bar z$. For a pure AR(1) of
  length n, $E[r_1] \\approx \\psi - (1 + 4\\psi)/n$ (Marriott & Pope 1954; Kendall 1954,
  the mean estimated from the record) and $\\mathrm{Var}[r_1] \\approx (1 - \\psi^2)/n$
  (Bartlett 1946). With white noise of variance $\\sigma_w^2$ added to an AR(1) of
  stationary variance $\\sigma_c^2$ it estimates
  $\\rho_1 = \\psi \\sigma_c^2 / (\\sigma_c^2 + \\sigma_w^2)$, not psi (the sum is an
  ARMA(1,1) process): it is biased low by the white share.
- ``"lag-ratio"``: $r_2 / r_1$. For an ARMA(1,1) process, such as AR(1) plus white
  noise, $\\rho_k = \\rho_1 \\psi^{k-1}$ for $k \\ge 1$ (Box & Jenkins, *Time Series
  Analysis*, ARMA(1,1) autocorrelation), so the ratio is consistent for psi whatever
  the white share, at a larger variance than ``"lag1"``.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from ..errors import ConfigError

__all__ = ["ar1_coefficient", "lag1_mean_theory"]


def ar1_coefficient(z: np.ndarray, method: Literal["lag1", "lag-ratio"] = "lag1", axis: int = 0) -> np.ndarray:
    """The AR(1) coefficient of ``z`` along ``axis`` (time), one per remaining element.

    Parameters
    ----------
    z
        Samples, time on ``axis`` (at least 3), any trailing batch shape.
    method
        ``"lag1"`` (lag-1 sample autocorrelation) or ``"lag-ratio"`` (lag-2 over lag-1
        autocovariance); see the module docstring for their bias and variance.
    axis
        The time axis.

    Returns
    -------
    numpy.ndarray
        The estimates, ``z``'s shape without ``axis``. Not clipped: ``"lag-ratio"`` can
        leave (-1, 1) on short records.
    """
    d = np.moveaxis(np.asarray(z, dtype=float), axis, 0)
    if d.shape[0] < 3:
        raise ConfigError("z", f"an AR(1) estimate needs at least 3 samples in time, got {d.shape[0]}")
    d = d - d.mean(axis=0)
    c1 = np.sum(d[1:] * d[:-1], axis=0)
    phi: np.ndarray
    if method == "lag1":
        phi = c1 / np.sum(d * d, axis=0)
        return phi
    if method == "lag-ratio":
        phi = np.sum(d[2:] * d[:-2], axis=0) / c1
        return phi
    raise ConfigError("method", f"must be 'lag1' or 'lag-ratio', got {method!r}")


def lag1_mean_theory(psi: float, n: int, white_share: float = 0.0) -> float:
    """$E[r_1]$ to order 1/n: $\\rho - (1 + 4\\rho)/n$ with $\\rho = \\psi (1 - s)$,
    ``white_share`` $s = \\sigma_w^2 / (\\sigma_c^2 + \\sigma_w^2)$ (Marriott & Pope 1954
    for the pure AR(1), ``s = 0``; with white noise the O(1/n) term is the AR(1)'s,
    an approximation)."""
    rho = psi * (1.0 - white_share)
    return rho - (1.0 + 4.0 * rho) / n
