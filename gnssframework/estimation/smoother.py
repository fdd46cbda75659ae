r"""Rauch-Tung-Striebel smoothing: fixed-interval (`smooth`) and fixed-lag (`fixed_lag_smooth`,
`FixedLagSmoother`), for every engine, batched over runs.

Every Gaussian filter's forward pass, run with ``filter_sequence(..., store="smoother")``,
keeps what the backward pass needs at each step $k+1$: the filtered $m_k, P_k$, the
predicted $m^-_{k+1}, P^-_{k+1}$ (with the Q in force at that step) and the cross
covariance $C_{k+1} = \operatorname{Cov}(x_k, x^-_{k+1})$. The backward pass is then the same
for the linear, the extended and the sigma-point forms (Särkkä, *Bayesian Filtering and
Smoothing*, 2013: ch. 8 for the linear RTS smoother, ch. 9 for the extended, unscented and
general Gaussian RTS smoothers, all of this form):

$$
G_k = C_{k+1}\, (P^-_{k+1})^{-1}, \qquad
m^s_k = m_k + G_k\,(m^s_{k+1} - m^-_{k+1}), \qquad
P^s_k = P_k + G_k\,(P^s_{k+1} - P^-_{k+1})\,G_k^T,
$$

from $m^s_{K-1} = m_{K-1}$, $P^s_{K-1} = P_{K-1}$. The engines differ only in $C$: $P_k F^T$
for KF/EKF ($F$ the Jacobian at $m_k$), $\sum_i W^c_i (\mathcal X_i - m_k)(f(\mathcal X_i) -
m^-_{k+1})^T$ for the UKF, CKF and SVD-CKF, from the same points as their prediction.

Numerics. The gain is never formed from an inverse: ``"solve"`` (KF, EKF, UKF, CKF) solves
$P^-_{k+1} G_k^T = C_{k+1}^T$ in one batched solve; ``"eigh"`` (``Estimator.smoother_gain``)
goes through $P^-_{k+1} = V \operatorname{diag}(w) V^T$, the
eigen-decomposition the SVD-CKF takes its square root from, $G_k = C V \operatorname{diag}(1/w)
V^T$ with eigenvalues below $n\,\epsilon\,\max w$ dropped (a pseudo-inverse where $P^-$ is
numerically singular), and writes the covariance as the sum of two PSD terms,

$$
P^s_k = \underbrace{(P_k - G_k C_{k+1}^T)}_{\operatorname{Cov}(x_k \mid x_{k+1})}
      + G_k P^s_{k+1} G_k^T ,
$$

the first term's rounding-negative eigenvalues set to zero (its square root exists), so
$P^s_k$ stays symmetric PSD. ``"sqrt"`` (the SVD-CKF's default) carries $P^s_k$ as a factor
from the forward pass's factors, one QR per step and no subtraction
(`gnssframework.estimation.smoother_sqrt`, Arasaratnam & Haykin 2011). In exact arithmetic
the three forms are the equation above. Every covariance is symmetrised.

Time-varying and adapted noise. The smoother uses the stored per-step predictions, so a Q
that changes with k (a callable model) or that a noise adapter estimated online (its estimate
after step k in force from step k+1) enters the backward pass exactly as the forward filter
used it; the smoother does not re-estimate Q or R. An augmentation (``colored-ar1``) smooths
the augmented problem's states, at ``FilterResult.epochs``.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from functools import cached_property
from collections.abc import Callable

from typing import Any

import numpy as np

from .. import backend
from ..errors import ConfigError
from .compiled import smoother_gain as compiled_gain
from .adaptation import NoiseAdapter
from .boundary import check_argument
from .estimator import Estimator, OnFailure, OnMissing
from .linalg import all_true, mat_vec, pd_mask, project_psd, symmetrize, transpose
from .sequence import FilterResult, SmootherInputs, transition_terms
from .smoother_sqrt import psd_root, sqrt_rts_step_cov, sqrt_terms
from .step import FilterStep
from .types import Gaussian, Model

__all__ = [
    "SmoothedResult",
    "LagEstimate",
    "FixedLagSmoother",
    "smooth",
    "fixed_lag_smooth",
    "smoother_gain",
    "GAIN_FORMS",
]

#: The forms the smoother knows (``Estimator.smoother_gain``): two gain solves of the covariance
#: form and the square-root form (`gnssframework.estimation.smoother_sqrt`).
GAIN_FORMS = ("solve", "eigh", "sqrt")

Residual = Callable[[np.ndarray, np.ndarray], np.ndarray]


@dataclass
class SmoothedResult:
    """Output of `smooth`, stacked over time on axis 0 like `FilterResult`.

    Attributes
    ----------
    mean, cov
        Smoothed ``m^s_k`` ``(K, ..., n)`` and ``P^s_k`` ``(K, ..., n, n)``: the state at step k
        given every measurement of the sequence.
    gain
        Smoother gains ``G_k`` ``(K-1, ..., n, n)``, ``k = 0 .. K-2``.
    initial
        The initial state (the one step 0 predicted from) given every measurement (`smooth`;
        `fixed_lag_smooth` returns it as given).
    epochs, time_s
        As in the `FilterResult` smoothed.
    initial_gain
        ``G_{-1}`` ``(..., n, n)``, the gain of the transition from the initial state into
        step 0 (`smooth`; None from `fixed_lag_smooth`).
    cov_root
        The square-root form's factors ``S^s_k`` ``(K, ..., n, n)``, ``cov = S S^T``
        (``form="sqrt"``; None for the covariance forms).
    """

    mean: np.ndarray
    cov: np.ndarray
    gain: np.ndarray
    initial: Gaussian
    epochs: np.ndarray
    time_s: np.ndarray | None = None
    initial_gain: np.ndarray | None = None
    cov_root: np.ndarray | None = None

    def lag_one_cov(self) -> np.ndarray:
        r"""Smoothed lag-one covariances $P^s_{k,k-1} = \operatorname{Cov}(x_k, x_{k-1} \mid z_0
        \dots z_{K-1}) = P^s_k\, G_{k-1}^T$, ``(K, ..., n, n)``, row 0 against the initial state.

        The cross term of the EM M-step (Särkkä 2013, ch. 12, the EM algorithm for linear
        state-space models; Shumway & Stoffer 1982 reach it by a backward recursion, equal
        in exact arithmetic): exact for a linear-Gaussian model, the Gaussian smoother's
        approximation for the extended and sigma-point ones. Computed from the stored gains
        and covariances, one batched product.

        Raises
        ------
        ConfigError
            The result is a fixed-lag smoother's (its windows are not one joint posterior).
        """
        if self.initial_gain is None:
            raise ConfigError(
                "lag_one_cov", "needs a fixed-interval smoother's result (smooth), not fixed_lag_smooth's"
            )
        gains = np.concatenate([self.initial_gain[None], self.gain], axis=0)
        lag: np.ndarray = self.cov @ transpose(gains)
        return lag

    def __repr__(self) -> str:
        return (
            f"SmoothedResult({self.mean.shape[0]} steps, batch {self.mean.shape[1:-1] or 'none'}, "
            f"n={self.mean.shape[-1]})"
        )


def smoother_gain(cross_cov: np.ndarray, prior_cov: np.ndarray, form: str = "solve") -> np.ndarray:
    r"""The RTS gain $G = C (P^-)^{-1}$, batched, without forming an inverse.

    Parameters
    ----------
    cross_cov
        $C = \operatorname{Cov}(x_k, x^-_{k+1})$ ``(..., n, n)``.
    prior_cov
        $P^-_{k+1}$ ``(..., n, n)``, symmetric.
    form
        ``"solve"``: $G^T$ from one batched solve of $P^- G^T = C^T$. ``"eigh"``:
        $G = C V \operatorname{diag}(1/w) V^T$ from $P^- = V \operatorname{diag}(w) V^T$, eigenvalues
        below $n \epsilon \max w$ dropped (the pseudo-inverse of a numerically singular $P^-$).
    """
    if form == "solve":
        return transpose(np.linalg.solve(prior_cov, transpose(cross_cov)))
    if form == "eigh":
        if backend.compiled() and np.all(np.isfinite(prior_cov)):
            return compiled_gain.eigh_gain(cross_cov, prior_cov)  # the same arithmetic, one compiled pass
        w, V = np.linalg.eigh(symmetrize(prior_cov))
        n = w.shape[-1]
        tol = n * np.finfo(float).eps * np.max(np.abs(w), axis=-1, keepdims=True)
        inv_w = np.where(w > tol, 1.0 / np.where(w > tol, w, 1.0), 0.0)
        gain: np.ndarray = ((cross_cov @ V) * inv_w[..., None, :]) @ transpose(V)
        return gain
    raise ConfigError(
        "smoother gain form",
        f"got {form!r}; allowed: solve, eigh (the square-root form's gain "
        "comes with its factors: smoother_sqrt.sqrt_terms)",
    )


def _psd_part(a: np.ndarray) -> np.ndarray:
    """``a`` symmetrised with its negative eigenvalues (rounding) set to zero (`project_psd`).

    One compiled positive-definiteness test first; the eigen-decomposition only for the
    batch elements that fail it (a PD element has no negative eigenvalue to clip)."""
    a = symmetrize(a)
    ok = pd_mask(a)
    if all_true(ok):
        return a
    bad = ~ok
    a = a.copy()
    a[bad] = symmetrize(project_psd(a[bad]))
    return a


def rts_step(
    filtered: Gaussian,
    prior_mean: np.ndarray,
    prior_cov: np.ndarray,
    cross_cov: np.ndarray,
    next_smoothed: Gaussian,
    gain: np.ndarray,
    form: str = "solve",
    residual_x: Residual | None = None,
) -> Gaussian:
    r"""One backward RTS step from $k+1$ to $k$ (module docstring), batched.

    Parameters
    ----------
    filtered
        $m_k, P_k$.
    prior_mean, prior_cov, cross_cov
        $m^-_{k+1}, P^-_{k+1}, C_{k+1}$ of the transition $k \to k+1$.
    next_smoothed
        $m^s_{k+1}, P^s_{k+1}$.
    gain
        $G_k$, `smoother_gain` of ``cross_cov``, ``prior_cov`` and ``form`` (it depends on
        the forward pass only: the callers solve every step's at once, or once per step
        however many windows use it).
    form
        ``"solve"`` or ``"eigh"`` (`smoother_gain`); ``"eigh"`` also writes $P^s_k$ as a
        sum of PSD terms.
    residual_x
        Angle-aware state difference ``(a, b) -> a - b`` (plain subtraction when None).

    Returns
    -------
    Gaussian
        $m^s_k, P^s_k$.
    """
    G = gain
    diff = (residual_x or np.subtract)(next_smoothed.mean, prior_mean)
    mean = filtered.mean + mat_vec(G, diff)
    if form == "eigh":
        cov = symmetrize(_psd_part(filtered.cov - G @ transpose(cross_cov)) + G @ next_smoothed.cov @ transpose(G))
    else:
        cov = symmetrize(filtered.cov + G @ (next_smoothed.cov - prior_cov) @ transpose(G))
    return Gaussian(mean, cov)


def _inputs(result: FilterResult, caller: str) -> SmootherInputs:
    if not isinstance(result, FilterResult):
        raise ConfigError(
            "result",
            f"{caller} needs the FilterResult of filter_sequence(..., store='smoother'), got {type(result).__name__}",
        )
    if result.smoother_inputs is None or result.cov is None:
        raise ConfigError(
            "result",
            f"{caller} needs the predictions and cross covariances: run filter_sequence(..., store='smoother')",
        )
    return result.smoother_inputs


def _gain_form(inputs: SmootherInputs, form: str | None) -> str:
    """``form``, or the engine's stored one when None; `ConfigError` for an unknown form, or
    ``"sqrt"`` on a result that kept no factors."""
    form = inputs.gain_form if form is None else form
    if form not in GAIN_FORMS:
        raise ConfigError("form", f"got {form!r}; allowed: {', '.join(GAIN_FORMS)}")
    if form == "sqrt" and inputs.factors is None:
        raise ConfigError(
            "form",
            "'sqrt' needs the factors a square-root engine (svd-ckf) keeps in its forward "
            f"pass; this result's engine (form {inputs.gain_form!r}) kept none: use 'solve' or 'eigh'",
        )
    return form


def _sqrt_terms(inputs: SmootherInputs, steps: slice) -> tuple[np.ndarray, np.ndarray]:
    """The gains and conditional roots (`sqrt_terms`) of the stored transitions ``steps``."""
    assert inputs.factors is not None  # _gain_form refuses "sqrt" without them
    X, Y, S = (f[steps] for f in inputs.factors)
    return sqrt_terms(X, Y, S)


def _checked_lag(lag: Any) -> int:
    """``lag`` as an int, or `ConfigError` unless an integer >= 0."""
    if isinstance(lag, bool) or not isinstance(lag, (int, np.integer)) or lag < 0:
        raise ConfigError("lag", f"must be an integer >= 0 (steps), got {lag!r}")
    return int(lag)


def smooth(result: FilterResult, *, residual_x: Residual | None = None, form: str | None = None) -> SmoothedResult:
    r"""Fixed-interval Rauch-Tung-Striebel smoothing of a stored forward pass.

    $m^s_k = E[x_k \mid z_0 \dots z_{K-1}]$ and its covariance for every step, batched over
    the result's batch dimensions (the equations are in the module docstring; Särkkä 2013,
    ch. 8 for the KF, ch. 9 for the EKF and the sigma-point filters).

    Parameters
    ----------
    result
        From ``filter_sequence(..., store="smoother")`` with any engine.
    residual_x
        Angle-aware state difference ``(a, b) -> a - b`` for angle states (the model's
        ``residual_x``); plain subtraction when None.
    form
        Override the engine's form (``"solve"``, ``"eigh"``, or ``"sqrt"`` where the forward
        pass kept the factors); None uses the one the result stored
        (``Estimator.smoother_gain``: ``"sqrt"`` for the SVD-CKF, `smoother_sqrt`).

    Returns
    -------
    SmoothedResult
        Equal to the filtered state at the last step; the smoothed initial state too.

    Raises
    ------
    ConfigError
        ``result`` was not stored for smoothing, or an unknown ``form``.
    """
    inputs = _inputs(result, "smooth")
    assert result.cov is not None  # _inputs refuses a result without it
    form = _gain_form(inputs, form)
    if form == "sqrt":
        return _smooth_sqrt(result, inputs, residual_x)
    K = result.mean.shape[0]
    # The gains depend on the forward pass only: all K (the initial state's first) in one batched call.
    gains = smoother_gain(inputs.cross_cov, inputs.prior_cov, form)
    mean = np.empty_like(result.mean)
    cov = np.empty_like(result.cov)
    mean[-1], cov[-1] = result.mean[-1], result.cov[-1]
    nxt = Gaussian(mean[-1], cov[-1])
    for k in range(K - 2, -1, -1):
        nxt = rts_step(
            Gaussian(result.mean[k], result.cov[k]),
            inputs.prior_mean[k + 1],
            inputs.prior_cov[k + 1],
            inputs.cross_cov[k + 1],
            nxt,
            gains[k + 1],
            form,
            residual_x,
        )
        mean[k], cov[k] = nxt.mean, nxt.cov
    start = _start(result, inputs)
    initial = rts_step(
        start, inputs.prior_mean[0], inputs.prior_cov[0], inputs.cross_cov[0], nxt, gains[0], form, residual_x
    )
    return SmoothedResult(
        mean=mean,
        cov=cov,
        gain=gains[1:],
        initial=initial,
        epochs=result.epochs,
        time_s=result.time_s,
        initial_gain=np.broadcast_to(gains[0], cov.shape[1:]),
    )


def _start(result: FilterResult, inputs: SmootherInputs) -> Gaussian:
    """The initial state, broadcast to the result's batch."""
    batch = result.mean.shape[1:-1]
    n = result.mean.shape[-1]
    return Gaussian(
        np.broadcast_to(inputs.initial.mean, batch + (n,)), np.broadcast_to(inputs.initial.cov, batch + (n, n))
    )


def _smooth_sqrt(result: FilterResult, inputs: SmootherInputs, residual_x: Residual | None) -> SmoothedResult:
    """`smooth` in square-root form (`smoother_sqrt`): the factors carried, ``cov = S S^T``."""
    assert result.cov is not None
    gains, cond = _sqrt_terms(inputs, slice(None))  # every transition's, the initial state's first
    K = result.mean.shape[0]
    mean = np.empty_like(result.mean)
    cov = np.empty_like(result.cov)
    root = np.empty_like(result.cov)
    mean[-1], cov[-1], root[-1] = result.mean[-1], result.cov[-1], psd_root(result.cov[-1])
    for k in range(K - 2, -1, -1):
        mean[k], root[k], cov[k] = sqrt_rts_step_cov(
            result.mean[k], inputs.prior_mean[k + 1], mean[k + 1], root[k + 1], gains[k + 1], cond[k + 1], residual_x
        )
    start = _start(result, inputs)
    m0, _, c0 = sqrt_rts_step_cov(start.mean, inputs.prior_mean[0], mean[0], root[0], gains[0], cond[0], residual_x)
    return SmoothedResult(
        mean=mean,
        cov=cov,
        gain=gains[1:],
        initial=Gaussian(m0, c0),
        epochs=result.epochs,
        time_s=result.time_s,
        initial_gain=np.broadcast_to(gains[0], cov.shape[1:]),
        cov_root=root,
    )


def fixed_lag_smooth(
    result: FilterResult, lag: int, *, residual_x: Residual | None = None, form: str | None = None
) -> SmoothedResult:
    r"""Fixed-lag smoothing of a stored forward pass: $E[x_j \mid z_0 \dots z_{\min(j+L, K-1)}]$.

    What a streaming fixed-lag smoother (`FixedLagSmoother`) outputs for step ``j`` once
    step ``j + L`` has been filtered, and at the end of the stream (the last L steps) the
    fixed-interval smoother of the final window. Each window is an RTS backward pass from
    the filtered state at its end (module docstring); all windows run at once, batched,
    so the cost is L backward steps whatever K.

    Parameters
    ----------
    result
        From ``filter_sequence(..., store="smoother")``.
    lag
        L >= 0 steps (0 returns the filtered states; L >= K-1 the fixed-interval smoother).

    Returns
    -------
    SmoothedResult
        ``gain`` holds ``G_0 .. G_{K-2}``, which depend on the forward pass only, so they are
        the fixed-interval smoother's (zeros where L = 0); ``initial`` is the initial state
        as given (not smoothed).
    """
    inputs = _inputs(result, "fixed_lag_smooth")
    assert result.cov is not None  # _inputs refuses a result without it
    lag = _checked_lag(lag)
    form = _gain_form(inputs, form)
    K = result.mean.shape[0]
    steps = min(lag, K - 1)  # backward steps of the longest window
    # G_i (transition i -> i+1) depends on the forward pass only: each once, not once per window.
    cond = None
    if steps == 0:
        gain = np.zeros((max(K - 1, 0),) + result.cov.shape[1:])
    elif form == "sqrt":
        gain, cond = _sqrt_terms(inputs, slice(1, None))
    else:
        gain = smoother_gain(inputs.cross_cov[1:], inputs.prior_cov[1:], form)
    j = np.arange(K)
    end = np.minimum(j + lag, K - 1)  # the last step each window sees
    mean, cov = result.mean[end].copy(), result.cov[end].copy()
    root = psd_root(cov) if cond is not None else None
    shape = (K,) + (1,) * (result.mean.ndim - 1)
    for d in range(1, steps + 1):
        i = end - d  # step smoothed now in each window
        active = i >= j
        ic = np.maximum(i, 0)
        a = active.reshape(shape)
        if root is not None and cond is not None:
            out_mean, out_root, out_cov = sqrt_rts_step_cov(
                result.mean[ic], inputs.prior_mean[ic + 1], mean, root, gain[ic], cond[ic], residual_x
            )
            root = np.where(a[..., None], out_root, root)
            mean = np.where(a, out_mean, mean)
            cov = np.where(a[..., None], out_cov, cov)
            continue
        out = rts_step(
            Gaussian(result.mean[ic], result.cov[ic]),
            inputs.prior_mean[ic + 1],
            inputs.prior_cov[ic + 1],
            inputs.cross_cov[ic + 1],
            Gaussian(mean, cov),
            gain[ic],
            form,
            residual_x,
        )
        mean = np.where(a, out.mean, mean)
        cov = np.where(a[..., None], out.cov, cov)
    return SmoothedResult(
        mean=mean, cov=cov, gain=gain, initial=inputs.initial, epochs=result.epochs, time_s=result.time_s
    )


@dataclass(frozen=True)
class LagEstimate:
    """A fixed-lag smoother's output: the state of step ``step`` given every measurement so far."""

    step: int
    state: Gaussian


@dataclass
class _Transition:
    """One step of a streaming window: its posterior and the prediction into it."""

    posterior: Gaussian
    prior_mean: np.ndarray
    prior_cov: np.ndarray
    cross_cov: np.ndarray
    factors: tuple[np.ndarray, np.ndarray, np.ndarray] | None
    form: str

    @cached_property
    def terms(self) -> tuple[np.ndarray, np.ndarray | None]:
        """The gain of the transition into this step (`smoother_gain`) and, in the square-root
        form, the conditional root (`smoother_sqrt.sqrt_terms`): solved once, however many
        windows use them."""
        if self.form == "sqrt":
            assert self.factors is not None  # a "sqrt" engine keeps them
            return sqrt_terms(*self.factors)
        return smoother_gain(self.cross_cov, self.prior_cov, self.form), None


class FixedLagSmoother:
    r"""Streaming fixed-lag RTS smoother: after filtering step k, the estimate of step k-L.

    Runs a `FilterStep` (so the recovery policies and noise adapters behave as in
    `filter_sequence`) and keeps the last L+1 filtered states with their predictions and
    cross covariances; each step runs the RTS backward pass over that window (module
    docstring), L batched backward steps. Its outputs equal `fixed_lag_smooth` on the same
    sequence, and the fixed-interval smoother's where L spans the sequence.

    Parameters
    ----------
    estimator
        Any ``estimator`` plugin.
    lag
        L >= 0 steps.
    adapter, on_failure, missing
        As for `filter_sequence`.
    residual_x
        Angle-aware state difference for the backward pass.

    Examples
    --------
    >>> import numpy as np
    >>> from gnssframework import registry
    >>> from gnssframework.estimation import Gaussian, LinearModel
    >>> model = LinearModel(np.eye(1), np.eye(1), [[0.1]], [[1.0]])
    >>> fls = FixedLagSmoother(registry.create("estimator", "kf"), lag=2)
    >>> fls.start(Gaussian(np.zeros(1), np.eye(1)), model)
    >>> [fls.step(np.array([z]), model) for z in (1.0, 2.0)]
    [None, None]
    >>> fls.step(np.array([3.0]), model).step
    0
    >>> [e.step for e in fls.flush()]
    [1, 2]
    """

    def __init__(
        self,
        estimator: Estimator,
        lag: int,
        adapter: NoiseAdapter | None = None,
        *,
        on_failure: OnFailure = "raise",
        missing: OnMissing = "raise",
        residual_x: Residual | None = None,
    ) -> None:
        check_argument(estimator, "estimator", "FixedLagSmoother")
        self.lag = _checked_lag(lag)
        self.estimator = estimator
        self.residual_x = residual_x
        self.form = estimator.smoother_gain
        self._step = FilterStep(estimator, adapter, on_failure=on_failure, missing=missing)
        self._window: deque[Any] = deque(maxlen=self.lag + 1)
        self._state: Gaussian | None = None
        self._k = 0

    def start(self, initial: Gaussian, model: Model) -> None:
        """Begin a sequence from ``initial`` (the state the first step predicts from)."""
        self._state = self._step.start(initial, model)
        self._window.clear()
        self._k = 0

    def step(self, z: np.ndarray, model: Model) -> LagEstimate | None:
        """Filter ``z`` ``(..., m)``; return the estimate of step ``k - lag`` (None while k < lag)."""
        if self._state is None:
            raise ConfigError("FixedLagSmoother", "call start(initial, model) before step")
        r = self._step(self._state, z, model)
        self._window.append(_Transition(r.posterior, *transition_terms(self.estimator, self._state, r), self.form))
        self._state = r.posterior
        self._k += 1
        if len(self._window) <= self.lag:
            return None
        return LagEstimate(self._k - 1 - self.lag, self._backward()[0])

    def flush(self) -> list[LagEstimate]:
        """The estimates not yet given (the last ``lag`` steps), each given every measurement."""
        states = self._backward() if self._window else []
        first = self._k - len(self._window)
        start = 1 if len(self._window) > self.lag else 0  # the oldest was given by step()
        return [LagEstimate(first + i, states[i]) for i in range(start, len(states))]

    def _backward(self) -> list[Gaussian]:
        """RTS over the window, oldest first."""
        window = list(self._window)
        nxt = window[-1].posterior
        out = [nxt]
        root = psd_root(nxt.cov) if self.form == "sqrt" else None
        for i in range(len(window) - 2, -1, -1):
            t = window[i + 1]
            gain, cond = t.terms
            if root is not None and cond is not None:
                mean, root, cov = sqrt_rts_step_cov(
                    window[i].posterior.mean, t.prior_mean, nxt.mean, root, gain, cond, self.residual_x
                )
                nxt = Gaussian(mean, cov)
            else:
                nxt = rts_step(
                    window[i].posterior, t.prior_mean, t.prior_cov, t.cross_cov, nxt, gain, self.form, self.residual_x
                )
            out.append(nxt)
        return out[::-1]
