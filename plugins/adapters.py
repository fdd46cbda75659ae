"""Built-in noise adapters: ``innovation``, ``sage-husa``, ``ml-q``.

All share the safeguards of ``gnssframework.estimation.adaptation`` (warm-up, PSD
projection, bounds relative to the initial covariance).
"""

from __future__ import annotations

from collections import deque
from typing import Literal

import numpy as np
from pydantic import Field

from gnssframework.estimation import AdaptationStep, AdapterRun, NoiseAdapter, SafeguardParams
from gnssframework.estimation.linalg import outer, project_psd

__all__ = ["InnovationAdapter", "SageHusaAdapter", "MaximumLikelihoodQAdapter"]


def _load_compiled_guard() -> None:
    """Load the compiled safeguard when an adapter starts under numba, not at the first
    step past its warm-up (a one-time cost per process)."""
    AdapterRun.load_compiled_guard()


class _Window:
    """Running mean of the last ``size`` arrays (O(1) per step, batch-first)."""

    def __init__(self, size: int) -> None:
        self.size = size
        self.items: deque[np.ndarray] = deque()
        self.total: np.ndarray | float = 0.0

    def push(self, item: np.ndarray) -> np.ndarray:
        self.items.append(item)
        self.total = self.total + item
        if len(self.items) > self.size:
            self.total = self.total - self.items.popleft()
        return self.total / len(self.items)


# -- innovation (Zou et al. 2018, eq. 31) --------------------------------------------


class InnovationParams(SafeguardParams):
    window: int = Field(20, ge=2, description="number L of innovations averaged")


class _WindowedRun(AdapterRun):
    """A run that averages a per-step sample over a window; subclasses give the sample."""

    def __init__(self, params, Q0, R0) -> None:
        super().__init__(params, Q0, R0)
        self.window = _Window(params.window)


class _InnovationRun(_WindowedRun):
    def __init__(self, params, Q0, R0) -> None:
        super().__init__(params, Q0, R0)
        # Under the numba backend the window and the estimate are one compiled pass
        # (bitwise these NumPy lines); the choice is made once per run.
        self.compiled = self.compiled_innovation_window(params.window)

    def estimate(self, ctx: AdaptationStep):
        v = ctx.update.innovation
        if self.compiled is not None:
            out = self.compiled.push(v, ctx.update.innovation_cov, ctx.model.R)
            if out is not None:
                return None, out
            # Operands the kernel does not take: the NumPy lines carry on with the window.
            items, total = self.compiled.as_items()
            self.window.items.extend(items)
            self.window.total = total
            self.compiled = None
        mean_vv = self.window.push(outer(v, v))
        return None, mean_vv - ctx.predicted_measurement_spread


class InnovationAdapter(NoiseAdapter):
    r"""Windowed innovation-based estimate of R (Zou et al. 2018, eq. 31).

    $$
    \hat R_k = \frac{1}{L} \sum_{j=k-L+1}^{k} v_j v_j^T
    - \Big(\sum_i W_i (Z_i - \hat z)(Z_i - \hat z)^T\Big)_k
    $$

    The bracket is the spread of the predicted measurement (``S - R``; ``H P H^T`` for
    a KF). The paper writes it with the equal cubature weights 1/m.
    """

    name = "innovation"
    description = "Windowed innovation-matching estimate of R (Zou et al. 2018, eq. 31)"
    Params = InnovationParams
    params: InnovationParams  # self.params, as validated

    def start(self, Q0, R0) -> AdapterRun:
        _load_compiled_guard()
        return _InnovationRun(self.params, Q0, R0)


# -- Sage-Husa (classic; improved of Liu et al. 2020) ---------------------------------


class SageHusaParams(SafeguardParams):
    variant: Literal["classic", "improved"] = Field("improved", description="recursion")
    estimate_q: bool = Field(True, description="adapt Q")
    estimate_r: bool = Field(True, description="adapt R")
    b: float = Field(0.97, gt=0, lt=1, description="forgetting factor of the classic variant")
    alpha_r: float = Field(0.5, ge=0, le=1, description="weight of the current R estimate (improved)")
    alpha_q: float = Field(0.5, ge=0, le=1, description="weight of the current Q estimate (improved)")


class _SageHusaRun(AdapterRun):
    params: SageHusaParams

    def estimate(self, ctx: AdaptationStep):
        p = self.params
        e = ctx.update.innovation
        K = ctx.update.gain
        # Project the one-sample estimates onto PSD *before* they are mixed in: a
        # negative sample would otherwise drag R (or Q) towards zero, P collapses, and
        # the filter locks into a large-R, tiny-P state it never leaves.
        # The classic recursion averages its samples, so only its result is projected
        # (projecting each sample would bias it upwards).
        r_inst = outer(e, e) - ctx.predicted_measurement_spread
        Ke = (K @ e[..., None])[..., 0]
        q_inst = outer(Ke, Ke) + ctx.update.state.cov - ctx.propagated_spread
        if p.variant == "improved":
            r_inst, q_inst = project_psd(r_inst), project_psd(q_inst)
        if p.variant == "classic":
            d = (1.0 - p.b) / (1.0 - p.b ** (ctx.step + 1))
            R = (1.0 - d) * self.R + d * r_inst
            Q = (1.0 - d) * self.Q + d * q_inst
        else:
            R = (1.0 - p.alpha_r) * self.R0 + p.alpha_r * r_inst
            Q = (1.0 - p.alpha_q) * self.Q0 + p.alpha_q * q_inst
        on_r = p.estimate_r and (p.variant == "classic" or p.alpha_r > 0)
        on_q = p.estimate_q and (p.variant == "classic" or p.alpha_q > 0)
        return (Q if on_q else None), (R if on_r else None)


class SageHusaAdapter(NoiseAdapter):
    r"""Sage-Husa adaptive estimation of R and Q.

    ``variant="classic"`` (Sage & Husa 1969), forgetting factor b,
    $d_k = (1-b)/(1-b^{k+1})$:

    $$
    R_k = (1-d_k) R_{k-1} + d_k (e_k e_k^T - H P_{k|k-1} H^T) \\
    Q_k = (1-d_k) Q_{k-1} + d_k (K_k e_k e_k^T K_k^T + P_k - \Phi P_{k-1} \Phi^T)
    $$

    ``variant="improved"`` (Liu et al. 2020, eqs. 28-29): a convex combination of the
    *initial* covariance and the current instantaneous estimate, weights ``alpha_r`` and
    ``alpha_q`` (0 switches that side off):

    $$
    R_k = (1-\alpha_1) R_0 + \alpha_1 (e_k e_k^T - H P_{k|k-1} H^T) \\
    Q_k = (1-\alpha_2) Q_0 + \alpha_2 (K_k e_k e_k^T K_k^T + P_k - \Phi P_{k-1} \Phi^T)
    $$

    For sigma-point filters $H P H^T$ is the predicted-measurement spread
    ``S - R`` and $\Phi P \Phi^T$ the propagated spread ``P[k|k-1] - Q``.
    Simultaneous Q and R estimation is not identifiable in general: set
    ``estimate_q=False`` to learn R alone.
    """

    name = "sage-husa"
    description = "Sage-Husa Q/R estimation, classic (forgetting factor) or improved (Liu et al. 2020)"
    Params = SageHusaParams
    params: SageHusaParams  # self.params, as validated

    def assumptions(self, context) -> dict[str, tuple[object, str]]:
        r"""Which adapter, what it adapts, and its memory in epochs: the improved variant
        mixes one one-sample estimate with the initial Q0/R0 (memory 1 epoch); the classic
        one weights the sample $j$ epochs back by $(1-b)\,b^j$ once $d_k \to 1-b$, an
        effective window (the weights' sum relative to the newest one's) of
        $\sum_{j \ge 0} b^j = 1/(1-b)$ epochs."""
        p = self.params
        if p.variant == "improved":
            name = f"improved Sage-Husa (alpha_r {p.alpha_r:g}, alpha_q {p.alpha_q:g})"
            memory = 1.0
            adapts_q, adapts_r = p.estimate_q and p.alpha_q > 0, p.estimate_r and p.alpha_r > 0
        else:
            name = f"classic Sage-Husa (b {p.b:g})"
            memory = 1.0 / (1.0 - p.b)
            adapts_q, adapts_r = p.estimate_q, p.estimate_r
        what = " and ".join(n for n, on in (("Q", adapts_q), ("R", adapts_r)) if on) or "nothing"
        return {"noise adapter": (f"{name}: adapts {what}", "-"), "adapter memory": (memory, "epochs")}

    def start(self, Q0, R0) -> AdapterRun:
        _load_compiled_guard()
        return _SageHusaRun(self.params, Q0, R0)


# -- maximum-likelihood Q (CN105068097 patent, 2015) ------------------------------------------


class MlQParams(SafeguardParams):
    window: int = Field(20, ge=2, description="number N of state corrections averaged")
    # A smoother's Q is a small fraction of R (carrier smoothing: Q0 = 1e-3 m^2 against
    # R = 1.25 m^2); after a cycle slip the estimate must reach the order of R for the gain
    # to approach 1, so the ceiling must allow ~1e4 Q0 (the shared default of 100 caps the
    # gain at about 0.25 and the filter then recovers no faster than without adaptation).
    q_ceiling: float = Field(
        1e4,
        ge=1,
        description="upper bound of Q, times the initial Q (large: Q0 of a "
        "smoother is ~1e-3 R and must be able to reach R after a slip)",
    )


class _MlQRun(_WindowedRun):
    def estimate(self, ctx: AdaptationStep):
        dx = (ctx.update.gain @ ctx.update.innovation[..., None])[..., 0]
        mean_dxdx = self.window.push(outer(dx, dx))
        return mean_dxdx + ctx.update.state.cov - ctx.propagated_spread, None


class MaximumLikelihoodQAdapter(NoiseAdapter):
    r"""Windowed maximum-likelihood estimate of Q (Mohamed & Schwarz, J. Geodesy 1999).

    $$
    \hat Q_k = \frac{1}{N} \sum_{j=k-N+1}^{k} \Delta x_j \Delta x_j^T
    + P_k - \Phi P_{k-1} \Phi^T, \qquad \Delta x_j = K_j v_j
    $$

    The CN105068097 patent (2015, adaptive carrier-smoothed code) uses it with R fixed; the formula is
    the standard one its text lost.

    Its ``q_ceiling`` defaults to 1e4 (the other adapters: 100). A carrier smoother's Q0
    is about 1e-3 of its R; after a cycle slip the estimate must reach the order of R
    for the gain to approach 1. With a ceiling of 100 (Q up to 0.1 m² against R =
    1.25 m², gain at most ~0.25) the carrier-smoothing example's adaptive smoother has a
    0.08 m higher RMS error with frequent slips (docs: carrier smoothing, CN105068097).
    """

    name = "ml-q"
    description = "Windowed maximum-likelihood estimate of Q (CN105068097 patent 2015)"
    Params = MlQParams
    params: MlQParams  # self.params, as validated

    def start(self, Q0, R0) -> AdapterRun:
        _load_compiled_guard()
        return _MlQRun(self.params, Q0, R0)
