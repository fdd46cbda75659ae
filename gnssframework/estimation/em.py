r"""Learned noise: maximum-likelihood Q and R from recorded data by expectation-maximisation.

For the model $x_k = f(x_{k-1}) + w_k$, $z_k = h(x_k) + v_k$, $w_k \sim N(0, Q)$,
$v_k \sim N(0, R)$, from a known initial state $x_{-1} \sim N(m_{-1}, P_{-1})$, EM
(Shumway & Stoffer 1982; Särkkä, *Bayesian Filtering and Smoothing*, 2013, ch. 12) repeats

- **E-step**: a forward filter (``filter_sequence(..., store="smoother")``) and the RTS
  smoother (`smooth`) with the current $Q, R$ give $m^s_k, P^s_k$ and the lag-one
  covariance $P^s_{k,k-1} = P^s_k G_{k-1}^T$ (`SmoothedResult.lag_one_cov`); the filter's
  innovations give the log-likelihood $\ell(Q, R) = -\tfrac12 \sum_k [\log\det(2\pi S_k) +
  \nu_k^T S_k^{-1} \nu_k]$;
- **M-step**: the expected residual second moments under the smoothed posterior, with
  $F_k$ the Jacobian of $f$ at $m^s_{k-1}$ and $H_k$ of $h$ at $m^s_k$,

$$
\hat Q = \frac1K \sum_{k=0}^{K-1} \Big[e_k e_k^T + P^s_k - P^s_{k,k-1} F_k^T - F_k
  (P^s_{k,k-1})^T + F_k P^s_{k-1} F_k^T\Big], \quad e_k = m^s_k - f(m^s_{k-1}),
$$

$$
\hat R = \frac1{K'} \sum_{k:\,z_k \text{ present}} \Big[d_k d_k^T + H_k P^s_k H_k^T\Big],
  \quad d_k = z_k - h(m^s_k).
$$

For a linear model these are Särkkä's (2013, ch. 12) $\Sigma - C A^T - A C^T + A \Phi A^T$
and $D - B H^T - H B^T + H \Sigma H^T$ written as residuals, and each EM iteration never
decreases $\ell$. For a nonlinear model (EKF or sigma-point E-step) the same M-step with the
linearisation at the smoothed means is an **approximation** (the expectations of $f$ and $h$
are taken to first order, the smoother is the Gaussian approximation): $\ell$ is then the
filter's approximate likelihood and need not increase at every iteration.

Structure (``q_structure``, ``r_structure``): ``"full"`` (the M-step above),
``"diagonal"`` (its diagonal: the exact M-step over diagonal matrices), ``"scaled"``
($s\,Q_0$ with the shape $Q_0$ of the starting model known, $s = \operatorname{tr}(Q_0^{-1}
\hat Q)/n$, the exact M-step over the scale), ``"fixed"`` (kept). Every one is a
maximisation of the expected log-likelihood over its set, so the linear-model monotonicity
holds for each.

Batches. Runs along the batch dimensions are independent sequences. ``shared=False`` (the
default) learns a Q and R per run (each run's M-step and likelihood its own, all runs in one
batched filter and smoother pass); ``shared=True`` one Q and R for all (the M-step sums over
runs, the likelihood is the sum of the runs').
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple
from collections.abc import Callable

import numpy as np

from ..errors import ConfigError
from .boundary import check_argument
from .estimator import Estimator
from .linalg import symmetrize, transpose
from .sequence import filter_sequence
from .smoother import SmoothedResult, smooth
from .types import Gaussian, Model

__all__ = ["LearnedNoise", "learn_noise", "em_step", "log_likelihood", "STRUCTURES"]

#: The noise structures `learn_noise` knows.
STRUCTURES = ("full", "diagonal", "scaled", "fixed")


class LearnedNoise(NamedTuple):
    """What `learn_noise` returns (unpacks as ``Q, R, log_likelihood``).

    Attributes
    ----------
    Q, R
        The estimates ``(..., n, n)`` and ``(..., m, m)`` per run (``shared=False``) or
        ``(n, n)`` and ``(m, m)`` (``shared=True``).
    log_likelihood
        ``(iterations + 1, ...)``: the innovations log-likelihood of the starting noise,
        then after every M-step (per run, or summed over runs when shared); the last row is
        that of the returned Q and R.
    """

    Q: np.ndarray
    R: np.ndarray
    log_likelihood: np.ndarray


def log_likelihood(innovation: np.ndarray, innovation_cov: np.ndarray, present: np.ndarray | None = None) -> np.ndarray:
    r"""The prediction-error log-likelihood $-\tfrac12 \sum_k [m \log 2\pi + \log\det S_k +
    \nu_k^T S_k^{-1} \nu_k]$ of a filter's innovations, summed over axis 0 (time).

    Parameters
    ----------
    innovation, innovation_cov
        ``(K, ..., m)`` and ``(K, ..., m, m)`` (a `FilterResult`'s).
    present
        ``(K, ...)``: the steps whose measurement was used (missing ones add nothing).

    Returns
    -------
    np.ndarray
        ``(...)``, one per run.
    """
    m = innovation.shape[-1]
    L = np.linalg.cholesky(innovation_cov)
    white = np.linalg.solve(L, innovation[..., None])[..., 0]
    logdet = 2.0 * np.sum(np.log(np.diagonal(L, axis1=-2, axis2=-1)), axis=-1)
    term = -0.5 * (m * np.log(2.0 * np.pi) + logdet + np.sum(white * white, axis=-1))
    if present is not None:
        term = np.where(present, term, 0.0)
    total: np.ndarray = np.sum(term, axis=0)
    return total


@dataclass
class _Moments:
    """Summed M-step second moments and their counts, per run."""

    q_sum: np.ndarray  # (..., n, n)
    q_count: np.ndarray  # (...)
    r_sum: np.ndarray  # (..., m, m)
    r_count: np.ndarray  # (...)


def _expected_residuals(
    model_at: Callable[[int], Model],
    fixed: bool,
    zs: np.ndarray,
    sm: SmoothedResult,
    present: np.ndarray,
) -> _Moments:
    """The bracketed sums of the module docstring's M-step (over k), per run."""
    K = zs.shape[0]
    mean, cov = sm.mean, sm.cov
    prev_mean = np.concatenate([sm.initial.mean[None], mean[:-1]], axis=0)
    prev_cov = np.concatenate([sm.initial.cov[None], cov[:-1]], axis=0)
    lag = sm.lag_one_cov()
    if fixed:  # one model for every step: evaluate f, h and their Jacobians over (K, ...) at once
        md = model_at(0)
        fx, F = md.f(prev_mean), md.jacobian_f(prev_mean)
        hx, H = md.h(mean), md.jacobian_h(mean)
        res_x = getattr(md, "residual_x", None) or np.subtract
        res_z = getattr(md, "residual_z", None) or np.subtract
        e, d = res_x(mean, fx), res_z(zs, hx)
    else:
        parts = []
        for k in range(K):
            md = model_at(k)
            res_x = getattr(md, "residual_x", None) or np.subtract
            res_z = getattr(md, "residual_z", None) or np.subtract
            Fk, Hk = md.jacobian_f(prev_mean[k]), md.jacobian_h(mean[k])
            parts.append(
                (
                    res_x(mean[k], md.f(prev_mean[k])),
                    np.broadcast_to(Fk, lag.shape[1:]),
                    res_z(zs[k], md.h(mean[k])),
                    np.broadcast_to(Hk, mean.shape[1:-1] + Hk.shape[-2:]),
                )
            )
        e, F, d, H = (np.stack(p) for p in zip(*parts))
    FT = transpose(F)
    cross = lag @ FT
    q_terms = e[..., :, None] * e[..., None, :] + cov - cross - transpose(cross) + F @ prev_cov @ FT
    d = np.where(present[..., None], d, 0.0)
    r_terms = d[..., :, None] * d[..., None, :] + H @ cov @ transpose(H)
    r_terms = np.where(present[..., None, None], r_terms, 0.0)
    batch = mean.shape[1:-1]
    return _Moments(
        q_sum=np.sum(q_terms, axis=0),
        q_count=np.full(batch, float(K)),
        r_sum=np.sum(r_terms, axis=0),
        r_count=np.sum(present, axis=0).astype(float),
    )


def _structured(estimate: np.ndarray, previous: np.ndarray, shape0: np.ndarray, structure: str) -> np.ndarray:
    """The M-step's maximiser over the structure's set (module docstring)."""
    if structure == "full":
        return symmetrize(estimate)
    if structure == "diagonal":
        diagonal: np.ndarray = np.eye(estimate.shape[-1]) * np.diagonal(estimate, axis1=-2, axis2=-1)[..., None, :]
        return diagonal
    if structure == "scaled":
        n = estimate.shape[-1]
        s = np.trace(np.linalg.solve(shape0, estimate), axis1=-2, axis2=-1) / n
        return symmetrize(s[..., None, None] * shape0)
    return previous  # "fixed"


def _check_structure(name: str, value: str) -> None:
    if value not in STRUCTURES:
        raise ConfigError(name, f"got {value!r}; allowed: {', '.join(STRUCTURES)}")


def em_step(
    estimator: Estimator,
    model: Model | Callable[[int], Model],
    zs: np.ndarray,
    initial: Gaussian,
    Q: np.ndarray,
    R: np.ndarray,
    *,
    shared: bool = False,
    q_structure: str = "full",
    r_structure: str = "full",
    Q0: np.ndarray | None = None,
    R0: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One EM iteration (module docstring): E-step with ``Q, R``, then the M-step.

    Returns
    -------
    (np.ndarray, np.ndarray, np.ndarray)
        The new ``Q``, ``R`` and the log-likelihood of the given ``Q, R`` (per run, or summed
        when ``shared``).
    """
    fixed = not callable(model)

    def model_at(k: int) -> Model:
        md = model(k) if callable(model) else model
        return md.with_noise(Q=Q, R=R)

    result = filter_sequence(
        estimator, model_at(0) if fixed else model_at, zs, initial, missing="skip", store="smoother"
    )
    present = ~result.skipped
    ll = log_likelihood(result.innovation, result.innovation_cov, present)
    first = model_at(0)
    sm = smooth(result, residual_x=getattr(first, "residual_x", None))
    mom = _expected_residuals(model_at, fixed, zs, sm, present)
    if shared:
        axes = tuple(range(mom.q_count.ndim))
        q_hat = np.sum(mom.q_sum, axis=axes) / np.sum(mom.q_count)
        r_hat = np.sum(mom.r_sum, axis=axes) / max(np.sum(mom.r_count), 1.0)
        ll = np.sum(ll)
    else:
        q_hat = mom.q_sum / mom.q_count[..., None, None]
        r_hat = mom.r_sum / np.maximum(mom.r_count, 1.0)[..., None, None]
    Q0 = Q if Q0 is None else Q0
    R0 = R if R0 is None else R0
    Q_new = _structured(q_hat, np.broadcast_to(Q, q_hat.shape), np.broadcast_to(Q0, q_hat.shape), q_structure)
    R_new = _structured(r_hat, np.broadcast_to(R, r_hat.shape), np.broadcast_to(R0, r_hat.shape), r_structure)
    return Q_new, R_new, ll


def learn_noise(
    model: Model | Callable[[int], Model],
    zs: np.ndarray,
    initial: Gaussian,
    *,
    estimator: Estimator,
    iterations: int = 100,
    tol: float = 1e-9,
    shared: bool = False,
    q_structure: str = "full",
    r_structure: str = "full",
    Q: np.ndarray | None = None,
    R: np.ndarray | None = None,
) -> LearnedNoise:
    r"""Maximum-likelihood Q and R from recorded measurements by EM (module docstring).

    Parameters
    ----------
    model
        A `LinearModel` (exact EM) or `NonlinearModel` (linearised M-step, an
        approximation), or a callable ``k -> model`` for a time-varying one; its Q and R
        start the iteration (and give the shape of a ``"scaled"`` structure) unless ``Q``,
        ``R`` are given. A time-varying model's own Q and R are replaced by one learned
        constant pair.
    zs
        Measurements ``(K, ..., m)``, a batch of runs; NaN marks a missing measurement
        (skipped in the filter, left out of the R step).
    initial
        The state before ``zs[0]`` (known; not re-estimated).
    estimator
        The E-step's engine: ``kf`` for a linear model, ``ekf``, ``ukf``, ``ckf`` or
        ``svd-ckf`` for a nonlinear one.
    iterations
        At most this many EM iterations.
    tol
        Stop when no run's log-likelihood changed by more than ``tol * (1 + |l|)``.
    shared
        One Q and R for every run (True) or one per run (False, default).
    q_structure, r_structure
        ``"full"``, ``"diagonal"``, ``"scaled"`` or ``"fixed"``.
    Q, R
        Starting values (default: the model's), ``(n, n)``/``(m, m)`` or per run.

    Returns
    -------
    LearnedNoise
        ``(Q, R, log_likelihood)``; ``log_likelihood`` is the history, one row per
        evaluated iterate, the last that of the returned Q and R.

    Raises
    ------
    ConfigError
        An unknown structure, ``iterations < 0``, or a ``"scaled"`` shape that is not
        positive definite.

    Examples
    --------
    >>> import numpy as np
    >>> from gnssframework import registry
    >>> from gnssframework.estimation import Gaussian, LinearModel, learn_noise
    >>> rng = np.random.default_rng(1)
    >>> x = np.cumsum(rng.normal(0.0, 0.3, (1000, 1)), axis=0)  # a random walk, q = 0.09
    >>> zs = x + rng.normal(0.0, 1.0, x.shape)                 # seen with r = 1
    >>> model = LinearModel(np.eye(1), np.eye(1), [[1.0]], [[4.0]])  # started from q = 1, r = 4
    >>> kf = registry.create("estimator", "kf")
    >>> Q, R, ll = learn_noise(model, zs, Gaussian(np.zeros(1), np.eye(1)), estimator=kf, iterations=40)
    >>> bool(np.all(np.diff(ll) > 0)), round(float(Q[0, 0]), 1), round(float(R[0, 0]), 1)
    (True, 0.1, 1.0)
    """
    check_argument(estimator, "estimator", "learn_noise")
    check_argument(initial, "initial", "learn_noise")
    _check_structure("q_structure", q_structure)
    _check_structure("r_structure", r_structure)
    if isinstance(iterations, bool) or not isinstance(iterations, (int, np.integer)) or iterations < 0:
        raise ConfigError("iterations", f"must be an integer >= 0, got {iterations!r}")
    first = model(0) if callable(model) else model
    Q = np.asarray(first.Q if Q is None else Q, dtype=float)
    R = np.asarray(first.R if R is None else R, dtype=float)
    Q0, R0 = Q, R
    for name, shape, structure in (("Q", Q0, q_structure), ("R", R0, r_structure)):
        if structure == "scaled" and not np.all(np.linalg.eigvalsh(symmetrize(shape)) > 0):
            raise ConfigError(
                f"learn_noise {name}",
                f"a 'scaled' structure needs a positive definite starting {name} (its known shape)",
            )
    history = []
    for i in range(iterations + 1):
        Q_new, R_new, ll = em_step(
            estimator,
            model,
            zs,
            initial,
            Q,
            R,
            shared=shared,
            q_structure=q_structure,
            r_structure=r_structure,
            Q0=Q0,
            R0=R0,
        )
        history.append(ll)
        if i == iterations:
            break  # the last E-step only scores the returned Q, R
        if i > 0 and np.all(np.abs(history[-1] - history[-2]) <= tol * (1.0 + np.abs(history[-1]))):
            break
        Q, R = Q_new, R_new
    return LearnedNoise(Q=Q, R=R, log_likelihood=np.stack(history))
