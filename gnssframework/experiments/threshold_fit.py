r"""A logistic curve fitted to a probability along a sweep, and the threshold read off it.

Linear interpolation between grid points (`gnssframework.experiments.threshold.crossing`)
reads a threshold off the *interpolated* curve: between two grid points the curve is taken
as a straight line, and the bootstrap's interval covers the interpolated curve's threshold,
not the loop's. Where the level is in a tail (0.1, 0.05) and the grid is coarse, the two
differ by much more than the interval (a logistic curve of scale 1.5 dB on a 5 dB grid:
1.4 dB at the level 0.1). Fitting one smooth curve to every point uses the whole sweep and
makes the interval cover the between-grid uncertainty, at the price of an assumed shape.

The model: at swept value :math:`x_i` the runs lose lock (:math:`k_i` of :math:`n_i`) with
probability

.. math:: \pi_i = \sigma(\beta_0 + \beta_1 z_i), \qquad \sigma(u) = \frac{1}{1 + e^{-u}},
          \qquad z_i = \frac{x_i - \bar x}{s_x},

fitted by **Firth's penalised likelihood** (Firth 1993; Heinze and Schemper 2002):
maximise :math:`\ell(\beta) + \tfrac12 \log\det I(\beta)`, whose estimate exists where the
plain maximum-likelihood one does not. Along a C/N0 sweep the outcomes are often separated
(every run lost below one point, none above the next), where the plain estimate's slope is
infinite. Newton's iteration on the modified score

.. math:: U^*_j = \sum_i \bigl(k_i - n_i \pi_i + h_i (\tfrac12 - \pi_i)\bigr) z_{ij},
          \qquad h_i = w_i\, z_i^\mathsf{T} I^{-1} z_i, \quad w_i = n_i \pi_i (1 - \pi_i),
          \quad I = \sum_i w_i z_i z_i^\mathsf{T},

with :math:`z_i = (1, z_i)`, batched over curves (a bootstrap's resamples): one 2x2 solve
per curve and step.

The threshold is where the fitted curve crosses the level ``level``,
:math:`x_t = \bar x + s_x (\operatorname{logit}\ell - \beta_0) / \beta_1`, read as
`crossing` reads the interpolated one: *above the grid* (:math:`+\infty`) when the fitted
probability at the top point is at or above the level, *below the grid* (:math:`-\infty`)
when the crossing is below the bottom point or the fitted curve rises with :math:`x`.
Never extrapolated beyond the grid.

Goodness of fit: the deviance against the saturated model,
:math:`D = 2 \sum_i [k_i \ln(k_i / n_i\hat\pi_i) + (n_i - k_i)\ln((n_i - k_i)/(n_i(1 - \hat\pi_i)))]`,
against :math:`\chi^2` with (points - 2) degrees of freedom. Points at 0 or 1 far from the
crossing add almost nothing to it, so the test speaks for the transition only; a small
p-value says the curve is not logistic in :math:`x` there and the interpolated threshold
should be preferred.
"""

from __future__ import annotations

import numpy as np
from scipy import special

__all__ = ["LogisticFit", "firth_logistic", "fitted_crossing", "deviance_test"]

#: Newton's iteration stops when every curve's step is below this (in the standardised scale).
TOLERANCE = 1e-10
#: At most this many Newton steps (a separated curve converges in about 15).
MAX_STEPS = 100
#: A step's largest element (standardised units): keeps the first steps of a steep curve sane.
MAX_STEP = 5.0


class LogisticFit:
    """Fitted curves: ``beta`` ``(..., 2)`` in the standardised scale, the scale
    (``centre``, ``spread``), the Newton steps taken and whether every curve converged
    (steps below :data:`TOLERANCE` within :data:`MAX_STEPS`).

    ``probability(x)`` evaluates the fitted curves at swept values ``x``.
    """

    def __init__(self, beta: np.ndarray, centre: float, spread: float, steps: int, converged: bool) -> None:
        self.beta = beta
        self.centre = centre
        self.spread = spread
        self.steps = steps
        self.converged = converged

    def probability(self, x: np.ndarray) -> np.ndarray:
        """Fitted probability at ``x`` ``(points,)``: ``(points, ...)``."""
        z = (np.asarray(x, float) - self.centre) / self.spread
        b0, b1 = self.beta[..., 0], self.beta[..., 1]
        return special.expit(b0[None, ...] + b1[None, ...] * z.reshape((-1,) + (1,) * b0.ndim))


def firth_logistic(x: np.ndarray, events: np.ndarray, trials: np.ndarray | float) -> LogisticFit:
    """Firth-penalised logistic fits of ``events`` ``(points, ...)`` out of ``trials`` per point.

    Parameters
    ----------
    x
        ``(points,)`` swept values (at least two distinct).
    events
        ``(points, ...)`` event counts (loss of lock) per point, any trailing batch shape.
    trials
        runs per point: a number or ``(points,)``.

    Returns
    -------
    LogisticFit
        ``beta`` ``(..., 2)``: intercept and slope in the standardised scale
        :math:`z = (x - \\bar x)/s_x` (module docstring).
    """
    x = np.asarray(x, float)
    k = np.asarray(events, float)
    if x.ndim != 1 or x.size < 2 or np.ptp(x) == 0:
        raise ValueError("threshold fit: x needs at least two distinct swept values")
    if k.shape[0] != x.size:
        raise ValueError(f"threshold fit: events has {k.shape[0]} points, x {x.size}")
    n = np.broadcast_to(np.asarray(trials, float).reshape((-1,) + (1,) * (k.ndim - 1)), k.shape)
    if np.any(k < 0) or np.any(k > n):
        raise ValueError("threshold fit: events outside [0, trials]")
    centre, spread = float(x.mean()), float(x.std())
    z = ((x - centre) / spread).reshape((-1,) + (1,) * (k.ndim - 1))
    beta = np.zeros(k.shape[1:] + (2,))
    steps, converged = 0, False
    while steps < MAX_STEPS and not converged:
        steps += 1
        p = special.expit(beta[..., 0][None] + beta[..., 1][None] * z)
        w = n * p * (1 - p)
        # Fisher information [[a, b], [b, c]] per curve, its inverse, the leverages
        a, b, c = w.sum(axis=0), (w * z).sum(axis=0), (w * z * z).sum(axis=0)
        det = a * c - b * b
        h = w * (c - 2 * b * z + a * z * z) / det
        r = k - n * p + h * (0.5 - p)
        u0, u1 = r.sum(axis=0), (r * z).sum(axis=0)
        step = np.stack([(c * u0 - b * u1) / det, (a * u1 - b * u0) / det], axis=-1)
        big = np.max(np.abs(step), axis=-1, keepdims=True)
        step = np.where(big > MAX_STEP, step * (MAX_STEP / np.maximum(big, MAX_STEP)), step)
        beta = beta + step
        converged = bool(np.all(np.abs(step) < TOLERANCE))
    return LogisticFit(beta, centre, spread, steps, converged)


def fitted_crossing(fit: LogisticFit, x: np.ndarray, level: float) -> np.ndarray:
    """Threshold of each fitted curve at ``level`` (module docstring): ``(...)``,
    :math:`\\pm\\infty` outside the grid ``x``."""
    x = np.asarray(x, float)
    b0, b1 = fit.beta[..., 0], fit.beta[..., 1]
    top = fit.probability(x[-1:])[0]
    with np.errstate(divide="ignore", invalid="ignore"):
        xt = fit.centre + fit.spread * (special.logit(level) - b0) / b1
    inside = (b1 < 0) & (xt >= x[0]) & (xt <= x[-1])
    out = np.where(top >= level, np.inf, np.where(inside, xt, -np.inf))
    return out


def deviance_test(
    fit: LogisticFit, x: np.ndarray, events: np.ndarray, trials: np.ndarray | float
) -> tuple[float, int, float]:
    """Deviance of one fitted curve against the saturated model, its degrees of freedom
    (points - 2) and the chi-square p-value (module docstring)."""
    from scipy import stats  # heavy: imported where the test runs, not at the CLI's start

    x = np.asarray(x, float)
    k = np.asarray(events, float)
    n = np.broadcast_to(np.asarray(trials, float), k.shape)
    p = np.clip(fit.probability(x).reshape(k.shape), 1e-300, 1 - 1e-16)
    dev = 2 * float(np.sum(special.xlogy(k, k / (n * p)) + special.xlogy(n - k, (n - k) / (n * (1 - p)))))
    df = x.size - 2
    return dev, df, float(stats.chi2.sf(dev, df)) if df > 0 else float("nan")
