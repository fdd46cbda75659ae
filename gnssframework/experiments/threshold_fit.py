r"""A curve fitted to a probability along a sweep, and the threshold read off it.

Linear interpolation between grid points (`gnssframework.experiments.threshold.crossing`)
reads a threshold off the *interpolated* curve: between two grid points the curve is taken
as a straight line, and the bootstrap's interval covers the interpolated curve's threshold,
not the loop's. Where the level is in a tail (0.1, 0.05) and the grid is coarse, the two
differ by much more than the interval (a logistic curve of scale 1.5 dB on a 5 dB grid:
1.4 dB at the level 0.1). Fitting one smooth curve to every point uses the whole sweep and
makes the interval cover the between-grid uncertainty, at the price of an assumed shape.

The model: at swept value :math:`x_i` the runs lose lock (:math:`k_i` of :math:`n_i`) with
probability

.. math:: \pi_i = F(\eta_i), \qquad \eta_i = \beta_0 + \beta_1 z_i,
          \qquad z_i = \frac{x_i - \bar x}{s_x},

a binomial generalised linear model whose inverse link :math:`F` sets the curve's shape
(`LINKS`):

========== ============================================ ==================================
link       :math:`F(\eta)`                              shape
========== ============================================ ==================================
logit      :math:`1/(1 + e^{-\eta})`                    symmetric, exponential tails
probit     :math:`\Phi(\eta)`                           symmetric, Gaussian tails
cloglog    :math:`1 - \exp(-e^{\eta})`                  rises to 1 fast, leaves 0 slowly
loglog     :math:`\exp(-e^{-\eta})`                     leaves 0 fast, rises to 1 slowly
========== ============================================ ==================================

With :math:`\beta_1 < 0` (loss falling with C/N0) ``cloglog``'s slow side is the
high-C/N0 tail: a Gumbel-shaped curve, and the shape of
:math:`P = 1 - \exp(-T/\bar\tau)` when the mean time to loss of lock :math:`\bar\tau` grows
exponentially along the sweep; ``loglog`` is its mirror.

Fitted by **Firth's penalised likelihood** (Firth 1993; Heinze and Schemper 2002; for
every link here Kosmidis and Firth 2021, Biometrika 108(1), prove the estimate finite):
maximise :math:`\ell(\beta) + \tfrac12 \log\det I(\beta)`, whose estimate exists where the
plain maximum-likelihood one does not. Along a C/N0 sweep the outcomes are often separated
(every run lost below one point, none above the next), where the plain estimate's slope is
infinite. With :math:`f = F'`, the weights
:math:`w_i = n_i f_i^2 / (\pi_i (1 - \pi_i))`, :math:`I = \sum_i w_i z_i z_i^\mathsf{T}`
(:math:`z_i = (1, z_i)`) and the leverages :math:`h_i = w_i z_i^\mathsf{T} I^{-1} z_i`,
the penalised likelihood's score is (Kosmidis and Firth 2009, the Jeffreys-prior
adjustment)

.. math:: U^*_j = \sum_i \Bigl(\frac{(k_i - n_i \pi_i) f_i}{\pi_i (1 - \pi_i)}
          + \frac{h_i}{2} \frac{\partial \ln w_i}{\partial \eta_i}\Bigr) z_{ij},
          \qquad \frac{\partial \ln w_i}{\partial \eta_i} = \frac{2 f'_i}{f_i}
          - \frac{f_i (1 - 2\pi_i)}{\pi_i (1 - \pi_i)},

(for the logit link :math:`(k_i - n_i\pi_i) + h_i(\tfrac12 - \pi_i)`), the gradient of
the penalised likelihood. Solved by Newton's iteration (the Hessian from forward differences
of :math:`U^*`; Fisher scoring's :math:`I^{-1} U^*` where it is not negative definite: scoring
alone crawls where a link fits badly), each step halved until the penalised likelihood does
not fall, converged when :math:`|I^{-1} U^*|` is below :data:`TOLERANCE`; batched over
curves (a bootstrap's resamples), 2x2 solves per curve and step, every quantity formed from
:math:`\ln F`, :math:`\ln(1 - F)` and :math:`\ln f` so that the tails neither underflow nor
overflow.

The threshold is where the fitted curve crosses the level ``level``,
:math:`x_t = \bar x + s_x (F^{-1}(\ell) - \beta_0) / \beta_1`, read as
`crossing` reads the interpolated one: *above the grid* (:math:`+\infty`) when the fitted
probability at the top point is at or above the level, *below the grid* (:math:`-\infty`)
when the crossing is below the bottom point or the fitted curve rises with :math:`x`.
Never extrapolated beyond the grid.

Goodness of fit: the deviance against the saturated model,
:math:`D = 2 \sum_i [k_i \ln(k_i / n_i\hat\pi_i) + (n_i - k_i)\ln((n_i - k_i)/(n_i(1 - \hat\pi_i)))]`,
against :math:`\chi^2` with (points - 2) degrees of freedom. Points at 0 or 1 far from the
crossing add almost nothing to it, so the test speaks for the transition only; a small
p-value says the curve does not have the link's shape there. Every link has two
parameters, so among links the smallest deviance is the largest (penalised-fit)
likelihood: `best_link_fit` picks, per curve, the link that fits best (a resample's choice
is its own).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy import special

__all__ = [
    "LINKS",
    "Link",
    "BinomialFit",
    "firth_binomial",
    "firth_logistic",
    "best_link_fit",
    "fitted_crossing",
    "deviance_test",
]

#: The iteration stops when every curve's scoring step is below this (standardised scale).
TOLERANCE = 1e-10
#: At most this many steps (a separated curve converges in about 15 with the logit link).
MAX_STEPS = 200
#: At most this many halvings of one step (the penalised likelihood must not fall).
MAX_HALVINGS = 40
#: Relative step of the forward differences that give Newton's Hessian.
FD_STEP = 1e-6
#: A step's largest element (standardised units): keeps the first steps of a steep curve sane.
MAX_STEP = 5.0
#: The linear predictor's bound inside the iteration: F and 1 - F are then 0 or 1 to double
#: precision for every link, while their logarithms stay finite.
ETA_BOUND = 30.0


@dataclass(frozen=True)
class Link:
    """A binomial link, given by its inverse :math:`F` (a distribution function) through the
    logarithms the fit needs: ``log_p`` :math:`\\ln F(\\eta)`, ``log_q``
    :math:`\\ln(1 - F(\\eta))`, ``log_f`` :math:`\\ln F'(\\eta)`, ``dlog_f``
    :math:`F''/F'`; ``cdf`` :math:`F` and ``quantile`` :math:`F^{-1}`."""

    name: str
    cdf: Callable[[np.ndarray], np.ndarray]
    quantile: Callable[[float], float]
    log_p: Callable[[np.ndarray], np.ndarray]
    log_q: Callable[[np.ndarray], np.ndarray]
    log_f: Callable[[np.ndarray], np.ndarray]
    dlog_f: Callable[[np.ndarray], np.ndarray]


def _log1mexp(a: np.ndarray) -> np.ndarray:
    """:math:`\\ln(1 - e^{-a})` for :math:`a > 0` (Maechler 2012's two branches)."""
    a = np.asarray(a, float)
    with np.errstate(divide="ignore"):
        return np.where(a < np.log(2.0), np.log(-np.expm1(-a)), np.log1p(-np.exp(-a)))


_HALF_LOG_2PI = 0.5 * np.log(2 * np.pi)


def _mirror(name: str, link: Link) -> Link:
    r"""The link of the mirrored distribution, :math:`F_m(\eta) = 1 - F(-\eta)` (loglog of
    cloglog): its logarithms are the original's with :math:`F` and :math:`1 - F` swapped at
    :math:`-\eta`, so the tails stay as accurate as the original's."""
    return Link(
        name,
        lambda e: np.exp(link.log_q(-e)),
        lambda p: -link.quantile(1.0 - p),
        lambda e: link.log_q(-e),
        lambda e: link.log_p(-e),
        lambda e: link.log_f(-e),
        lambda e: -link.dlog_f(-e),
    )


LINKS: dict[str, Link] = {
    "logistic": Link(
        "logistic",
        special.expit,
        lambda p: float(special.logit(p)),
        special.log_expit,
        lambda e: special.log_expit(-e),
        lambda e: special.log_expit(e) + special.log_expit(-e),
        lambda e: 1 - 2 * special.expit(e),
    ),
    "probit": Link(
        "probit",
        special.ndtr,
        lambda p: float(special.ndtri(p)),
        special.log_ndtr,
        lambda e: special.log_ndtr(-e),
        lambda e: -0.5 * e * e - _HALF_LOG_2PI,
        lambda e: -e,
    ),
    "cloglog": Link(
        "cloglog",
        lambda e: -np.expm1(-np.exp(e)),
        lambda p: float(np.log(-np.log1p(-p))),
        lambda e: _log1mexp(np.exp(e)),
        lambda e: -np.exp(e),
        lambda e: e - np.exp(e),
        lambda e: 1 - np.exp(e),
    ),
}
LINKS["loglog"] = _mirror("loglog", LINKS["cloglog"])


class BinomialFit:
    """Fitted curves: ``beta`` ``(..., 2)`` in the standardised scale, the scale
    (``centre``, ``spread``), the link (one `Link`, or per curve with `best_link_fit`), the
    Newton steps taken and whether every curve converged (steps below :data:`TOLERANCE`
    within :data:`MAX_STEPS`).

    ``probability(x)`` evaluates the fitted curves at swept values ``x``.
    """

    def __init__(
        self,
        beta: np.ndarray,
        centre: float,
        spread: float,
        steps: int,
        converged: bool,
        link: str | np.ndarray = "logistic",
    ) -> None:
        self.beta = beta
        self.centre = centre
        self.spread = spread
        self.steps = steps
        self.converged = converged
        self.link = link  # a link's name, or (...) names per curve
        #: with `best_link_fit`: every link's deviance per curve, ``{name: (...)}``
        self.link_deviances: dict[str, np.ndarray] = {}

    def _links(self) -> list[tuple[str, np.ndarray | None]]:
        """Each link with the mask of the curves it holds (None: all)."""
        if isinstance(self.link, str):
            return [(self.link, None)]
        return [(name, self.link == name) for name in LINKS if np.any(self.link == name)]

    def probability(self, x: np.ndarray) -> np.ndarray:
        """Fitted probability at ``x`` ``(points,)``: ``(points, ...)``."""
        z = (np.asarray(x, float) - self.centre) / self.spread
        b0, b1 = self.beta[..., 0], self.beta[..., 1]
        eta = b0[None, ...] + b1[None, ...] * z.reshape((-1,) + (1,) * b0.ndim)
        out = np.empty_like(eta)
        for name, mask in self._links():
            if mask is None:
                out = LINKS[name].cdf(eta)
            else:
                out[:, mask] = LINKS[name].cdf(eta[:, mask])
        return out

    def quantile(self, level: float) -> np.ndarray | float:
        """:math:`F^{-1}(\\ell)` of each curve's link."""
        if isinstance(self.link, str):
            return LINKS[self.link].quantile(level)
        out = np.zeros(self.link.shape)
        for name, mask in self._links():
            out[mask] = LINKS[name].quantile(level)
        return out


def _check(x: np.ndarray, events: np.ndarray, trials: np.ndarray | float) -> tuple[np.ndarray, ...]:
    x = np.asarray(x, float)
    k = np.asarray(events, float)
    if x.ndim != 1 or x.size < 2 or np.ptp(x) == 0:
        raise ValueError("threshold fit: x needs at least two distinct swept values")
    if k.shape[0] != x.size:
        raise ValueError(f"threshold fit: events has {k.shape[0]} points, x {x.size}")
    n = np.broadcast_to(np.asarray(trials, float).reshape((-1,) + (1,) * (k.ndim - 1)), k.shape)
    if np.any(k < 0) or np.any(k > n):
        raise ValueError("threshold fit: events outside [0, trials]")
    return x, k, n


def firth_binomial(
    x: np.ndarray, events: np.ndarray, trials: np.ndarray | float, link: str = "logistic"
) -> BinomialFit:
    """Firth-penalised binomial fits of ``events`` ``(points, ...)`` out of ``trials`` per point.

    Parameters
    ----------
    x
        ``(points,)`` swept values (at least two distinct).
    events
        ``(points, ...)`` event counts (loss of lock) per point, any trailing batch shape.
    trials
        runs per point: a number or ``(points,)``.
    link
        a key of `LINKS`.

    Returns
    -------
    BinomialFit
        ``beta`` ``(..., 2)``: intercept and slope in the standardised scale
        :math:`z = (x - \\bar x)/s_x` (module docstring).
    """
    if link not in LINKS:
        raise ValueError(f"threshold fit: unknown link {link!r}; allowed: {', '.join(LINKS)}")
    x, k, n = _check(x, events, trials)
    link_ = LINKS[link]
    centre, spread = float(x.mean()), float(x.std())
    z = ((x - centre) / spread).reshape((-1,) + (1,) * (k.ndim - 1))
    beta = np.zeros(k.shape[1:] + (2,))
    steps, converged = 0, False
    objective, score, info = _penalised(link_, beta, z, k, n)
    while steps < MAX_STEPS:
        if bool(np.all(np.abs(_solve(info, score)) < TOLERANCE)):
            converged = True
            break
        steps += 1
        step = _newton_step(link_, beta, z, k, n, score, info)
        # halved per curve until the penalised likelihood does not fall
        t = np.ones(step.shape[:-1] + (1,))
        for _ in range(MAX_HALVINGS):
            trial = beta + t * step
            new = _penalised(link_, trial, z, k, n)
            worse = new[0] < objective - 1e-12 * np.abs(objective)
            if not np.any(worse):
                break
            t = np.where(worse[..., None], 0.5 * t, t)
        beta, (objective, score, info) = trial, new
    return BinomialFit(beta, centre, spread, steps, converged, link)


def _penalised(
    f: Link, beta: np.ndarray, z: np.ndarray, k: np.ndarray, n: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """At ``beta`` ``(..., 2)``: the penalised log-likelihood ``(...)``, its gradient the
    modified score :math:`U^*` ``(..., 2)`` and the Fisher information ``(..., 3)`` as
    ``(a, b, c)`` of :math:`[[a, b], [b, c]]` (module docstring)."""
    eta = np.clip(beta[..., 0][None] + beta[..., 1][None] * z, -ETA_BOUND, ETA_BOUND)
    log_p, log_q, log_f = f.log_p(eta), f.log_q(eta), f.log_f(eta)
    ratio = np.exp(log_f - log_p - log_q)  # f / (pi (1 - pi))
    w = n * np.exp(2 * log_f - log_p - log_q)
    dlog_w = 2 * f.dlog_f(eta) - ratio * (1 - 2 * np.exp(log_p))
    a, b, c = w.sum(axis=0), (w * z).sum(axis=0), (w * z * z).sum(axis=0)
    det = a * c - b * b
    objective = (k * log_p + (n - k) * log_q).sum(axis=0) + 0.5 * np.log(det)
    h = w * (c - 2 * b * z + a * z * z) / det  # leverages
    r = k * ratio - n * np.exp(log_f - log_q) + 0.5 * h * dlog_w
    return objective, np.stack([r.sum(axis=0), (r * z).sum(axis=0)], axis=-1), np.stack([a, b, c], axis=-1)


def _solve(m: np.ndarray, u: np.ndarray) -> np.ndarray:
    """:math:`M^{-1} u` per curve, ``m`` ``(..., 3)`` a symmetric 2x2 matrix's ``(a, b, c)``."""
    a, b, c = m[..., 0], m[..., 1], m[..., 2]
    det = a * c - b * b
    return np.stack([(c * u[..., 0] - b * u[..., 1]) / det, (a * u[..., 1] - b * u[..., 0]) / det], axis=-1)


def _newton_step(
    f: Link, beta: np.ndarray, z: np.ndarray, k: np.ndarray, n: np.ndarray, score: np.ndarray, info: np.ndarray
) -> np.ndarray:
    """Newton's step on the penalised likelihood, its Hessian from forward differences of
    the modified score (Fisher scoring alone converges linearly, and slowly, where a link
    fits badly); Fisher scoring's :math:`I^{-1} U^*` where that Hessian is not negative
    definite. Bounded to :data:`MAX_STEP`."""
    h = FD_STEP * np.maximum(1.0, np.abs(beta))
    cols = []
    for j in range(2):
        db = np.zeros_like(beta)
        db[..., j] = h[..., j]
        cols.append((_penalised(f, beta + db, z, k, n)[1] - score) / h[..., j : j + 1])
    # minus the Hessian, symmetrised: (a, b, c)
    neg = np.stack([-cols[0][..., 0], -0.5 * (cols[0][..., 1] + cols[1][..., 0]), -cols[1][..., 1]], axis=-1)
    definite = (neg[..., 0] > 0) & (neg[..., 0] * neg[..., 2] - neg[..., 1] ** 2 > 0)
    step = _solve(np.where(definite[..., None], neg, info), score)
    big = np.max(np.abs(step), axis=-1, keepdims=True)
    return np.where(big > MAX_STEP, step * (MAX_STEP / np.maximum(big, MAX_STEP)), step)


def firth_logistic(x: np.ndarray, events: np.ndarray, trials: np.ndarray | float) -> BinomialFit:
    """`firth_binomial` with the logit link."""
    return firth_binomial(x, events, trials, "logistic")


def deviances(fit: BinomialFit, x: np.ndarray, events: np.ndarray, trials: np.ndarray | float) -> np.ndarray:
    """Deviance of each fitted curve against the saturated model ``(...)`` (module docstring)."""
    x, k, n = _check(x, events, trials)
    p = np.clip(fit.probability(x).reshape(k.shape), 1e-300, 1 - 1e-16)
    return 2 * np.sum(special.xlogy(k, k / (n * p)) + special.xlogy(n - k, (n - k) / (n * (1 - p))), axis=0)


def best_link_fit(
    x: np.ndarray, events: np.ndarray, trials: np.ndarray | float, links: tuple[str, ...] = tuple(LINKS)
) -> BinomialFit:
    """Per curve, the Firth fit of the link (of ``links``) with the smallest deviance
    (every link has two parameters, so this is the likelihood's choice); ``link`` of the
    result is an array of names ``(...)``, ``converged`` that of every link's fit,
    ``link_deviances`` every link's deviances."""
    fits = [firth_binomial(x, events, trials, name) for name in links]
    dev = np.stack([deviances(f, x, events, trials) for f in fits])  # (links, ...)
    choice = np.argmin(dev, axis=0)
    beta = np.take_along_axis(np.stack([f.beta for f in fits]), choice[None, ..., None], axis=0)[0]
    names = np.asarray(links, dtype=object)[choice]
    best = BinomialFit(
        beta,
        fits[0].centre,
        fits[0].spread,
        max(f.steps for f in fits),
        all(f.converged for f in fits),
        names if choice.ndim else str(names),
    )
    best.link_deviances = dict(zip(links, dev))
    return best


def fitted_crossing(fit: BinomialFit, x: np.ndarray, level: float) -> np.ndarray:
    """Threshold of each fitted curve at ``level`` (module docstring): ``(...)``,
    :math:`\\pm\\infty` outside the grid ``x``."""
    x = np.asarray(x, float)
    b0, b1 = fit.beta[..., 0], fit.beta[..., 1]
    top = fit.probability(x[-1:])[0]
    with np.errstate(divide="ignore", invalid="ignore"):
        xt = fit.centre + fit.spread * (fit.quantile(level) - b0) / b1
    inside = (b1 < 0) & (xt >= x[0]) & (xt <= x[-1])
    out = np.where(top >= level, np.inf, np.where(inside, xt, -np.inf))
    return out


def deviance_test(
    fit: BinomialFit, x: np.ndarray, events: np.ndarray, trials: np.ndarray | float
) -> tuple[float, int, float]:
    """Deviance of one fitted curve against the saturated model, its degrees of freedom
    (points - 2) and the chi-square p-value (module docstring)."""
    from scipy import stats  # heavy: imported where the test runs, not at the CLI's start

    x = np.asarray(x, float)
    dev = float(np.sum(deviances(fit, x, np.asarray(events, float), trials)))
    df = x.size - 2
    return dev, df, float(stats.chi2.sf(dev, df)) if df > 0 else float("nan")
