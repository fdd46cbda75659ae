r"""Survival estimates of right-censored lifetimes: the Kaplan-Meier product-limit estimator.

A tracking run that has not lost lock by the end of its case is *censored*: its time to
loss of lock is only known to exceed the observed span. The Kaplan-Meier estimator
(Kaplan & Meier, J. Amer. Statist. Assoc. 53, 1958) of the survival function
:math:`S(t) = P(T > t)` is

.. math:: \hat S(t) = \prod_{t_i \le t} \left(1 - \frac{d_i}{n_i}\right)

over the distinct event times :math:`t_i` (:math:`d_i` events, :math:`n_i` lifetimes
still at risk just before :math:`t_i`; a lifetime censored at :math:`t_i` counts as at
risk there). Its variance is Greenwood's formula
:math:`\hat S^2 \sum_{t_i \le t} d_i / (n_i (n_i - d_i))`.

The mean lifetime is not identifiable beyond the last observation; what the data give is
the *restricted mean* :math:`\mu_\tau = \int_0^\tau \hat S(t)\,dt` up to a horizon
:math:`\tau`. When every censored lifetime is censored at the same horizon (a case's
fixed duration), :math:`\mu_\tau` equals the plain mean of :math:`\min(T_i, \tau)`.
Under an exponential model the maximum-likelihood mean is the total time at risk over
the number of events, :math:`\sum_i \min(T_i, c_i) / \sum_i \delta_i`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["KaplanMeier", "kaplan_meier", "exponential_mean_mle"]


@dataclass(frozen=True)
class KaplanMeier:
    """A Kaplan-Meier estimate: the survival just after each distinct event time."""

    times: np.ndarray  #: distinct event times, increasing
    survival: np.ndarray  #: :math:`\hat S` just after each of ``times``
    variance: np.ndarray  #: Greenwood variance of ``survival``
    at_risk: np.ndarray  #: :math:`n_i`
    events: np.ndarray  #: :math:`d_i`

    def __call__(self, t: np.ndarray | float) -> np.ndarray:
        """:math:`\\hat S(t)` (right-continuous step function; 1 before the first event)."""
        idx = np.searchsorted(self.times, np.asarray(t, float), side="right")
        return np.concatenate(([1.0], self.survival))[idx]

    def restricted_mean(self, horizon: float) -> float:
        """:math:`\\int_0^\\tau \\hat S(t)\\,dt` with :math:`\\tau` = ``horizon``."""
        edges = np.concatenate(([0.0], self.times[self.times < horizon], [horizon]))
        levels = np.concatenate(([1.0], self.survival[self.times < horizon]))
        return float(np.sum(levels * np.diff(edges)))


def kaplan_meier(durations: np.ndarray, observed: np.ndarray) -> KaplanMeier:
    """Kaplan-Meier estimate from lifetimes ``durations`` (time of the event, or of the
    censoring) and ``observed`` (True: the event happened at that time; False: censored).

    Raises
    ------
    ValueError
        If the arrays differ in shape, are empty or hold a non-finite or negative time.
    """
    d = np.asarray(durations, float).ravel()
    e = np.asarray(observed, bool).ravel()
    if d.shape != e.shape or d.size == 0:
        raise ValueError(f"durations and observed must be non-empty and of one shape (got {d.shape}, {e.shape})")
    if not np.all(np.isfinite(d)) or np.any(d < 0):
        raise ValueError("durations must be finite and non-negative")
    times, events = np.unique(d[e], return_counts=True)
    events = events.astype(float)
    at_risk = (d.size - np.searchsorted(np.sort(d), times, side="left")).astype(float)  # n_i = #{d >= t_i}
    factors = 1.0 - events / at_risk
    survival = np.cumprod(factors)
    with np.errstate(divide="ignore", invalid="ignore"):
        terms = np.where(at_risk > events, events / (at_risk * (at_risk - events)), np.inf)
        variance = np.where(survival == 0, 0.0, survival**2 * np.cumsum(terms))
    return KaplanMeier(times, survival, variance, at_risk, events)


def exponential_mean_mle(durations: np.ndarray, observed: np.ndarray) -> float:
    """Maximum-likelihood mean of exponential lifetimes under right censoring: time at
    risk over events (``inf`` without an event)."""
    d = np.asarray(durations, float)
    n = int(np.sum(np.asarray(observed, bool)))
    return float(np.sum(d) / n) if n else float("inf")
