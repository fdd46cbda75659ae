r"""Iterated measurement updates: IEKF, iterated posterior linearisation, robust reweighting.

Every iteration is a Kalman update of the *prior* $N(m, P)$ with a linear measurement
model $z \approx A x + b + v$, $v \sim N(0, \Omega + R_i)$, built at the current
iterate $N(x_i, P_i)$ from the engine's own ``measurement_moments`` (the seam every
engine has, compiled or not). With $(\bar z_i, S_i, C_i)$ the moments at the iterate,

$$
A_i = C_i^T P_{\ell}^{-1}, \quad \Omega_i = S_i - R - A_i P_{\ell} A_i^T, \\
\hat z = \bar z_i + A_i (m - x_i), \quad S = A_i P A_i^T + \Omega_i + R_i, \quad C = P A_i^T, \\
K = C S^{-1}, \quad x_{i+1} = m + K (z - \hat z), \quad P_{i+1} = P - K S K^T .
$$

- **Gauss-Newton (IEKF)**, the ``ekf`` (``iteration = "gauss-newton"``): the moments are
  taken at $N(x_i, P)$, so $A_i = H(x_i)$, and $\Omega_i = 0$. Then
  $x_{i+1} = m + K_i (z - h(x_i) - H_i (m - x_i))$: the Gauss-Newton iteration on the MAP
  cost $\tfrac12 \|x - m\|^2_{P^{-1}} + \tfrac12 \|z - h(x)\|^2_{R^{-1}}$
  (Bell & Cathey, IEEE TAC 1993).
- **Iterated posterior linearisation (IPLF)**, the sigma-point engines
  (``iteration = "posterior-linearisation"``): the moments are the statistical linear
  regression of h with respect to the current posterior approximation,
  $P_{\ell} = P_i$ (García-Fernández, Svensson, Morelande & Särkkä, IEEE TSP 2015).

Iteration 0 linearises at the prior ($x_0 = m$, $P_0 = P$) and is exactly the
engine's plain update. The batch iterates together: an element whose step
$\max_j |x_{i+1,j} - x_{i,j}| / \sqrt{P_{jj}}$ falls to ``tol`` or below is frozen (its
result no longer changes), and the loop ends when every element is frozen or after
``iterations`` updates. A `gnssframework.estimation.robust.RobustUpdate` replaces R by
its effective covariance $R_i$ from iteration 1 on (from iteration 0, with the innovation
and the prior's spread, for a gate: ``gates_prior``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from ..errors import InvalidMeasurementError, NotPositiveDefiniteError
from .linalg import any_true, all_true, cholesky_masked, failing_indices, mat_vec, symmetrize
from .types import Gaussian, Model, Update, residual_hook

if TYPE_CHECKING:
    from .robust import RobustUpdate


class Engine(Protocol):
    """What the loop reads of an engine (`estimator.Estimator` has it; described here, not
    imported: the engines call this module)."""

    @property
    def name(self) -> str: ...

    def measurement_moments(self, prior: Gaussian, model: Model) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...

    def posterior_cov(self, prior: Gaussian, gain: np.ndarray, S: np.ndarray, model: Model) -> np.ndarray: ...


#: A model's residual hook: ``residual(a, b)`` is ``a - b`` in its space.
Residual = Callable[[np.ndarray, np.ndarray], np.ndarray]

__all__ = ["iterated_update", "ITERATION_KINDS"]

#: How an engine relinearises between iterations.
ITERATION_KINDS = ("gauss-newton", "posterior-linearisation")


def _t(a: np.ndarray) -> np.ndarray:
    out: np.ndarray = np.swapaxes(a, -1, -2)
    return out


def _where(mask: np.ndarray, new: np.ndarray, old: np.ndarray) -> np.ndarray:
    extra = new.ndim - mask.ndim
    out: np.ndarray = np.where(mask.reshape(mask.shape + (1,) * extra), new, old)
    return out


#: Most step halvings of the damped Gauss-Newton iteration (a step of 2^-20 of the full one).
LINE_SEARCH_HALVINGS = 20


def _map_cost(
    engine: Engine, model: Model, prior: Gaussian, z: np.ndarray, x: np.ndarray, res_x: Residual, res_z: Residual
) -> np.ndarray:
    r"""$\tfrac12 \|x - m\|^2_{P^{-1}} + \tfrac12 \|z - h(x)\|^2_{R^{-1}}$ per batch element,
    with $h(x)$ from the engine's moments at $N(x, P)$ (the EKF's $h$ at $x$)."""
    h_x = engine.measurement_moments(Gaussian(x, prior.cov), model)[0]
    d, e = res_x(x, prior.mean), res_z(z, h_x)
    R = np.broadcast_to(model.R, e.shape + e.shape[-1:])
    cost: np.ndarray = 0.5 * (
        np.einsum("...i,...i->...", d, np.linalg.solve(prior.cov, d[..., None])[..., 0])
        + np.einsum("...i,...i->...", e, np.linalg.solve(R, e[..., None])[..., 0])
    )
    return cost


def _damped(
    engine: Engine,
    model: Model,
    prior: Gaussian,
    z: np.ndarray,
    x: np.ndarray,
    x_full: np.ndarray,
    active: np.ndarray,
    res_x: Residual,
    res_z: Residual,
) -> np.ndarray:
    """The Gauss-Newton step from ``x`` towards ``x_full``, halved per batch element until
    the MAP cost does not increase (Skoglund, Hendeby & Axehill, FUSION 2015: the IEKF with
    a backtracking line search). Elements that no step improves stay at ``x``."""
    cost_here = _map_cost(engine, model, prior, z, x, res_x, res_z)
    step = res_x(x_full, x)
    alpha = np.ones(cost_here.shape)
    searching = np.broadcast_to(active, cost_here.shape).copy()
    for _ in range(LINE_SEARCH_HALVINGS):
        trial = x + alpha[..., None] * step
        worse = searching & ~(_map_cost(engine, model, prior, z, trial, res_x, res_z) <= cost_here)
        if not any_true(worse):
            break
        alpha = np.where(worse, 0.5 * alpha, alpha)
        searching = worse
    else:
        alpha = np.where(searching, 0.0, alpha)
    out: np.ndarray = x + alpha[..., None] * step
    return out


def iterated_update(
    engine: Engine,
    prior: Gaussian,
    z: np.ndarray,
    model: Model,
    *,
    on_failure: str = "raise",
    missing: str = "raise",
    iterations: int = 1,
    tol: float = 0.0,
    iteration: str = "gauss-newton",
    robust: RobustUpdate | None = None,
    line_search: bool = False,
) -> Update:
    """The iterated (and optionally robust) update of ``engine`` (see the module docstring).

    Parameters
    ----------
    engine
        An ``Estimator``: its ``measurement_moments`` give the linearisation.
    prior, z, model
        As ``Estimator.update`` (``z`` already broadcast to the prior's batch).
    iterations
        Most linearisations (1: the plain update). Relinearisation happens only when > 1;
        a robust update alone reweights R on the prior's linearisation.
    tol
        Stopping rule on the step in prior standard deviations (per batch element).
    iteration
        ``"gauss-newton"`` (IEKF) or ``"posterior-linearisation"`` (IPLF).
    robust
        Optional `RobustUpdate`; the loop then runs ``max(iterations, robust.iterations)``.
    line_search
        Gauss-Newton only, without a robust update: damp each step by halving it (up to
        `LINE_SEARCH_HALVINGS` times) until the MAP cost does not increase (`_map_cost`).
    """
    relinearise = iterations > 1
    n_iter = max(iterations, robust.iterations if robust is not None else 1)
    if robust is not None:
        tol = min(tol, robust.tol) if relinearise else robust.tol
    m, P, R = prior.mean, prior.cov, model.R
    batch = prior.batch_shape
    finite_z = np.isfinite(z)
    bad_z = np.zeros(batch, dtype=bool) if all_true(finite_z) else ~finite_z.all(axis=-1)
    if any_true(bad_z) and missing != "skip":
        raise InvalidMeasurementError(engine.name, failing_indices(~bad_z))
    res_z, res_x = residual_hook(model, "z"), residual_hook(model, "x")

    z_bar0, S0, C0 = engine.measurement_moments(prior, model)
    z = np.where(bad_z[..., None], z_bar0, z) if any_true(bad_z) else z
    spread0 = symmetrize(S0 - R)
    A0 = _t(np.linalg.solve(P, C0)) if (robust is not None and not relinearise) else None
    std = np.sqrt(np.diagonal(P, axis1=-2, axis2=-1))

    x, Pi = m, P
    active = ~bad_z
    out: dict[str, Any] | None = None
    omega: np.ndarray | float
    residual_i: np.ndarray | None
    spread_i: np.ndarray | None
    for it in range(n_iter):
        if it == 0:
            z_hat, spread_prior, C = z_bar0, spread0, C0
            residual_i, spread_i = None, None
        elif relinearise:
            P_lin = P if iteration == "gauss-newton" else Pi
            z_bar, S_i, C_i = engine.measurement_moments(Gaussian(x, P_lin), model)
            A = _t(np.linalg.solve(P_lin, C_i))
            if iteration == "gauss-newton":
                omega = 0.0
                spread_i = symmetrize(A @ Pi @ _t(A))
            else:
                omega = symmetrize(S_i - R - A @ P_lin @ _t(A))
                spread_i = symmetrize(S_i - R)
            z_hat = z_bar + mat_vec(A, res_x(m, x))
            spread_prior = symmetrize(A @ P @ _t(A) + omega)
            C = P @ _t(A)
            residual_i = res_z(z, z_bar)
        else:  # robust reweighting on the prior's linearisation
            assert A0 is not None  # set whenever robust reweights without relinearising
            residual_i = res_z(z, z_bar0) - mat_vec(A0, res_x(x, m))
            spread_i = symmetrize(A0 @ (Pi - P) @ _t(A0) + spread0)
        if robust is None or (it == 0 and not robust.gates_prior):
            R_i = R
        elif it == 0:  # a gate: the innovation and the prior's spread (S = spread + R)
            R_i = robust.effective_noise(res_z(z, z_bar0), spread0, R)
        else:
            assert residual_i is not None and spread_i is not None  # set from the second pass on
            R_i = robust.effective_noise(residual_i, spread_i, R)
        if relinearise and it > 0:
            S = symmetrize(spread_prior + R_i)
        else:  # the prior's linearisation: S0 itself, plus the change of R (exactly S0 where R is kept)
            S = S0 if R_i is R else S0 + (R_i - R)
        L, ok = cholesky_masked(S)
        if on_failure == "raise" and not all_true(ok | bad_z):
            raise NotPositiveDefiniteError(engine.name, failing_indices(ok | bad_z), detail="innovation covariance S")
        S_safe = np.where((~ok)[..., None, None], np.eye(S.shape[-1]), S) if not all_true(ok) else S
        gain = _t(np.linalg.solve(S_safe, _t(C)))
        innovation = res_z(z, z_hat)
        x_new = m + mat_vec(gain, innovation)
        if line_search and relinearise and robust is None and iteration == "gauss-newton":
            x_new = _damped(engine, model, prior, z, x, x_new, active, res_x, res_z)
        # The engine's own posterior form (the KF's Joseph form, with the effective R).
        P_new = engine.posterior_cov(prior, gain, S_safe, model if R_i is R else model.with_noise(R=R_i))
        if out is None:
            out = dict(x=x_new, P=P_new, innovation=innovation, S=S, gain=gain, C=C, z_hat=z_hat, ok=ok)
            step_ok = ok
        else:
            new = dict(x=x_new, P=P_new, innovation=innovation, S=S, gain=gain, C=C, z_hat=z_hat, ok=ok)
            upd = active & ok  # an element whose S fails keeps its last good iterate
            out = {k: _where(upd, new[k], out[k]) for k in out}
            step_ok = upd
        step = np.max(np.abs(res_x(out["x"], x)) / std, axis=-1)
        active = active & step_ok & (step > tol)
        x, Pi = out["x"], out["P"]
        if not any_true(active):
            break
    assert out is not None  # n_iter >= 1
    skip = bad_z | ~out["ok"]
    mean, cov = out["x"], out["P"]
    if any_true(skip):
        mean = np.where(skip[..., None], m, mean)
        cov = np.where(skip[..., None, None], P, cov)
    return Update(Gaussian(mean, cov), out["innovation"], out["S"], out["gain"], out["C"], out["z_hat"], skip)
