"""A fading-memory Kalman filter, registered as the estimator ``fading-kf``."""

from __future__ import annotations

import numpy as np
from pydantic import Field

import gnssframework as gf
from gnssframework.estimation.linalg import symmetrize


class FadingMemoryKF(gf.Estimator):
    r"""Kalman filter with fading memory (Sorenson & Sacks 1971).

    The predicted covariance is inflated by $\alpha^2 \ge 1$,

    $$
    P^- = \alpha^2 F P F^T + Q,
    $$

    so old measurements are discounted geometrically and the filter follows
    unmodelled dynamics. $\alpha = 1$ is the Kalman filter.
    """

    name = "fading-kf"
    description = "Kalman filter with fading memory (alpha >= 1 inflates P each step)"

    class Params(gf.PluginParams):
        alpha: float = Field(1.02, ge=1.0, le=2.0, description="fading factor")

    def predict(self, state: gf.Gaussian, model: gf.LinearModel) -> gf.Gaussian:
        F = model.F
        cov = self.params.alpha**2 * F @ state.cov @ np.swapaxes(F, -1, -2) + model.Q
        return gf.Gaussian(model.f(state.mean), symmetrize(cov))

    def measurement_moments(self, prior: gf.Gaussian, model: gf.LinearModel):
        H = model.H
        C = prior.cov @ np.swapaxes(H, -1, -2)
        return model.h(prior.mean), symmetrize(H @ C + model.R), C


@gf.hookimpl
def register_estimator(register):
    register(FadingMemoryKF)
