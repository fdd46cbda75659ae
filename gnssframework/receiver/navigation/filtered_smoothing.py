r"""The receiver's navigation-filter positions post-processed forward-backward.

`filtered.filter_epochs` runs a navigation filter forward over a recording's epochs;
with ``smooth`` its states become the Rauch-Tung-Striebel fixed-interval estimates,
each using every epoch of its run before and after it (Särkkä 2013, ch. 8):

.. math::

    G_k = C_{k+1} (P^-_{k+1})^{-1},\quad m^s_k = m_k + G_k (m^s_{k+1} - m^-_{k+1}),\quad
    P^s_k = P_k + G_k (P^s_{k+1} - P^-_{k+1}) G_k^T ,

with the filter's own transition: :math:`m^-_{k+1} = F m_k`,
:math:`P^-_{k+1} = F P_k F^T + Q`, :math:`C_{k+1} = P_k F^T` (``transition(T)``, exact for a
filter whose state is the published ``[r, v, b, d]``: ``ekf-pv``). The backward step is
the core's (`gnssframework.estimation.smoother.rts_step`, `smoother_gain`), the one every
engine's smoother uses. A run the harness restarted (an epoch without satellites) is
smoothed on its own.
"""

from __future__ import annotations

import numpy as np

from ...errors import ConfigError
from ...estimation.smoother import rts_step, smoother_gain
from ...estimation.types import Gaussian
from ...interfaces import NavFilter

__all__ = ["check_smoothable", "smooth_runs"]


def check_smoothable(nav: NavFilter, name: str, interval_s: float) -> tuple[np.ndarray, np.ndarray]:
    """The filter's ``F`` and ``Q`` over ``interval_s``, refused in one line (field ``smooth``)
    when it has none or its state is not the 8 published states."""
    transition = getattr(nav, "transition", None)
    if transition is None:
        raise ConfigError("smooth", f"nav_filter {name!r} has no transition(T): its positions cannot be smoothed")
    F, Q = (np.asarray(a, float) for a in transition(interval_s))
    if F.shape != (8, 8):
        raise ConfigError(
            "smooth",
            f"nav_filter {name!r} has {F.shape[0]} states; smoothing takes a filter whose state is the "
            "published [x, y, z, vx, vy, vz, b, d] (ekf-pv)",
        )
    return F, Q


def smooth_runs(
    states: np.ndarray, covs: np.ndarray, run_starts: list[int], F: np.ndarray, Q: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """RTS-smoothed ``states`` ``(K, 8)`` and ``covs`` ``(K, 8, 8)`` of a filter's forward
    pass, each run (from an index of ``run_starts`` to the next) on its own."""
    xs, Ps = np.array(states, float), np.array(covs, float)
    bounds = list(run_starts) + [len(xs)]
    for a, b in zip(bounds[:-1], bounds[1:]):
        if b - a < 2:
            continue
        x, P = xs[a:b], Ps[a:b]
        prior_mean = x[:-1] @ F.T
        prior_cov = F @ P[:-1] @ F.T + Q
        cross = P[:-1] @ F.T
        gains = smoother_gain(cross, prior_cov)
        smoothed = Gaussian(x[-1], P[-1])
        for k in range(b - a - 2, -1, -1):
            smoothed = rts_step(Gaussian(x[k], P[k]), prior_mean[k], prior_cov[k], cross[k], smoothed, gains[k])
            xs[a + k], Ps[a + k] = smoothed.mean, smoothed.cov
    return xs, Ps
