"""Carrier-smoothed code channel filters: ``hatch`` and ``kf-smoother`` (CN105068097 patent 2015)."""

from __future__ import annotations

import dataclasses
from typing import Any
from collections.abc import Mapping

import numpy as np
from pydantic import Field

from gnssframework import names, registry
from gnssframework.estimation import FilterStep, Gaussian, LinearModel
from gnssframework.interfaces import ChannelFilter, RunContext
from gnssframework.plugin import PluginParams
from gnssframework.plugin_ref import PluginRef

__all__ = ["HatchFilter", "KalmanSmoother", "steady_state_gain", "random_walk_q_for_gain"]


def steady_state_gain(q: float, r: float) -> float:
    r"""Steady-state Kalman gain of a scalar random walk observed directly.

    The Riccati recursion $P^-_{k} = P_{k-1} + q$, $K_k = P^-_k / (P^-_k + r)$,
    $P_k = (1 - K_k) P^-_k$ has the fixed point $P^{-2} - q P^- - q r = 0$, so
    $P^- = (q + \sqrt{q^2 + 4 q r}) / 2$ and, with $K = P^-/(P^- + r) = q / P^-$,

    $$
    K = \frac{-q + \sqrt{q^2 + 4 q r}}{2 r}.
    $$

    Parameters
    ----------
    q, r
        Process noise per epoch and measurement noise (m²), both > 0.

    Returns
    -------
    float
        The gain K in (0, 1).
    """
    return float((np.sqrt(q * q + 4.0 * q * r) - q) / (2.0 * r))


def random_walk_q_for_gain(gain: float, r: float) -> float:
    r"""The random walk's q for which a fixed gain is the steady-state Kalman gain.

    Inverting :func:`steady_state_gain`: $P^- = r K / (1 - K)$ and $q = K P^-$, so
    $q = r K^2 / (1 - K)$. A Hatch filter of window $M$ ($K = 1/M$) is the steady-state
    Kalman smoother of a code-minus-carrier random walk with $q = r / (M (M - 1))$.
    """
    return float(r * gain * gain / (1.0 - gain))


def _window_assumptions(gain: float, dt: float | None) -> dict[str, tuple[Any, str]]:
    r"""The averaging of a first-order smoother $x_k = K z_k + (1 - K)\,x^-_k$ in seconds.

    Time constant $\Delta t / K$ (the Hatch window $M \Delta t$ for $K = 1/M$);
    noise-equivalent window $(2/K - 1)\,\Delta t$: white noise of variance $\sigma^2$
    leaves $\sigma^2 K / (2 - K)$, the variance of a mean over $2/K - 1$ epochs
    (the Hatch filter's $\sigma^2 / (2M - 1)$).
    """
    if dt is None:
        return {}
    return {
        "smoothing time constant": (float(dt / gain), "s"),
        "noise-equivalent window": (float((2.0 / gain - 1.0) * dt), "s"),
    }


def _slip_assumption(threshold: float) -> dict[str, tuple[Any, str]]:
    return {"slip reset threshold": (float(threshold) if threshold > 0 else "none", "m")}


def _truth_drift(context: Mapping[str, Any]) -> dict[str, tuple[Any, str]]:
    drift = context.get("code_minus_carrier_drift_psd_m2_s")
    return {} if drift is None else {"true code-minus-carrier drift PSD": (float(drift), "m²/s")}


class _SlipParams(PluginParams):
    slip_threshold_m: float = Field(
        0.0,
        ge=0,
        description="code-minus-carrier jump that declares a cycle slip and "
        "resets the smoother; 0 switches detection off",
    )


def _slip(rho, predicted, threshold: float) -> np.ndarray:
    """Innovation test: |pseudorange - smoothed prediction| above the threshold.

    The prediction carries the carrier-phase delta, so a carrier slip of N cycles shifts it
    by N wavelengths while the code does not: this is a code-minus-carrier jump test.
    """
    if threshold <= 0:
        return np.zeros(np.shape(rho), dtype=bool)
    return np.abs(rho - predicted) > threshold


def _arc_start(inputs: Mapping[str, np.ndarray], shape: tuple[int, ...]) -> np.ndarray:
    """The optional ``arc_start`` input: True where the receiver flagged a loss of lock or
    the data have a gap (:func:`gnssframework.io.observations.arc_starts`)."""
    if names.ARC_START not in inputs:
        return np.zeros(shape, dtype=bool)
    return np.broadcast_to(np.asarray(inputs[names.ARC_START], bool), shape)


class HatchParams(_SlipParams):
    window: int = Field(100, ge=2, description="smoothing window tau (epochs)")


class HatchFilter(ChannelFilter):
    """Hatch filter (Hatch 1982; the form of the CN105068097 patent, 2015).

    $$
    \\rho_s[k] = \\frac{1}{n}\\rho[k] + \\frac{n-1}{n}\\big(\\rho_s[k-1] + \\varphi[k] - \\varphi[k-1]\\big),
    \\qquad n = \\min(k + 1, \\tau)
    $$

    with $\\varphi$ the carrier phase in metres. The window grows from 1 to $\\tau$ after
    a start or a reset (the usual implementation; the patent writes the steady state,
    $n = \\tau$). With ``slip_threshold_m`` > 0, a code-minus-carrier jump larger than
    the threshold resets the window (beyond the paper).

    An optional input ``arc_start`` (bool) restarts the window where a new carrier arc
    begins: a receiver's loss-of-lock flag or a gap in the data. ``slip_detected``
    reports the filter's own detections only, to be read beside the receiver's flags.
    """

    name = "hatch"
    description = "Hatch carrier-smoothed code filter, growing window, optional slip reset"
    Params = HatchParams
    params: HatchParams  # self.params, as validated
    requires = ("pseudorange_m", "carrier_m")
    provides = ("smoothed_m", "slip_detected")

    def assumptions(self, context: Mapping[str, Any]) -> dict[str, tuple[Any, str]]:
        """Steady state (window $M$, gain $1/M$): time constant $M\\,\\Delta t$,
        noise-equivalent window $(2M - 1)\\,\\Delta t$, and the code-minus-carrier drift for
        which this gain is the Kalman gain given the truth's code noise variance $\\sigma^2$,
        $\\sigma^2 / (M (M - 1)) / \\Delta t$ (`random_walk_q_for_gain`). It takes no R."""
        gain, dt = 1.0 / self.params.window, context.get("epoch_interval_s")
        out = _window_assumptions(gain, dt)
        var = context.get("code_noise_variance_m2")
        if var is not None and dt is not None:
            out["assumed code-minus-carrier drift PSD"] = (random_walk_q_for_gain(gain, var) / dt, "m²/s")
        out.update(_truth_drift(context))
        out["Q adapter"] = ("none", "")
        out.update(_slip_assumption(self.params.slip_threshold_m))
        return out

    def reset(self, batch_shape: tuple[int, ...], context: RunContext) -> None:
        self.smoothed = None
        self.n = np.zeros(batch_shape)

    def step(self, inputs: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        rho, phi = np.asarray(inputs["pseudorange_m"], float), np.asarray(inputs["carrier_m"], float)
        if self.smoothed is None:
            self.smoothed, self.phi, self.n = rho.copy(), phi, np.ones_like(rho)
            return {"smoothed_m": self.smoothed, "slip_detected": np.zeros(rho.shape, bool)}
        predicted = self.smoothed + (phi - self.phi)
        slip = _slip(rho, predicted, self.params.slip_threshold_m)
        restart = slip | _arc_start(inputs, rho.shape)
        self.n = np.where(restart, 1.0, np.minimum(self.n + 1, self.params.window))
        predicted = np.where(restart, rho, predicted)  # an undefined carrier delta across the restart
        self.smoothed = rho / self.n + (self.n - 1) / self.n * predicted
        self.phi = phi
        return {"smoothed_m": self.smoothed, "slip_detected": slip}


class KalmanSmootherParams(_SlipParams):
    q: float = Field(1e-3, gt=0, description="process noise Q (m²) of the carrier-propagated range")
    r: float = Field(1.0, gt=0, description="pseudorange noise R (m²)")
    adapter: PluginRef("noise_adapter") | None = Field(
        None, description="noise adapter for Q, e.g. 'ml-q' (CN105068097 patent 2015)"
    )
    adapter_params: dict[str, Any] = Field(default_factory=dict, description="parameters of the adapter")


class KalmanSmoother(ChannelFilter):
    """The Hatch filter as a Kalman filter (CN105068097 patent 2015), optionally with adaptive Q.

    State: the pseudorange. Prediction with the carrier-phase delta as a known input,
    update with the pseudorange:

    $$
    x[k|k-1] = x[k-1] + \\varphi[k] - \\varphi[k-1], \\quad P[k|k-1] = P[k-1] + Q, \\quad
    z = \\rho[k], \\; H = 1, \\; R
    $$

    With ``adapter="ml-q"`` the maximum-likelihood estimator re-estimates Q from a window of
    state corrections (R stays fixed, as in the patent). A cycle slip makes the carrier
    delta wrong by N wavelengths, the corrections grow, and the adapted Q raises the gain
    until the error has decayed. ``slip_threshold_m`` resets the filter on a detected
    slip instead.

    An optional input ``arc_start`` (bool) restarts the filter from the code where a new
    carrier arc begins (a receiver's loss-of-lock flag or a gap in the data);
    ``slip_detected`` reports the filter's own detections only.
    """

    name = "kf-smoother"
    description = "Carrier-smoothed code as a Kalman filter, optional ml-q adaptive Q and slip reset"
    Params = KalmanSmootherParams
    params: KalmanSmootherParams  # self.params, as validated
    requires = ("pseudorange_m", "carrier_m")
    provides = ("smoothed_m", "slip_detected")

    def __init__(self, **params: Any) -> None:
        super().__init__(**params)
        p = self.params
        self.engine = registry.create("estimator", "kf")
        # adapter_params (the flat form) win over the reference's own params.
        self.adapter = (
            dataclasses.replace(p.adapter, params={**p.adapter.params, **p.adapter_params}).create()
            if p.adapter
            else None
        )
        self.filter_step = FilterStep(self.engine, self.adapter, name=f"{self.name} (kf)")

    def assumptions(self, context: Mapping[str, Any]) -> dict[str, tuple[Any, str]]:
        """At Q0 (an adapter moves Q): the steady-state gain K of `steady_state_gain`, its
        time constant $\\Delta t / K$ and noise-equivalent window $(2/K - 1)\\,\\Delta t$;
        the code-minus-carrier drift PSD $q / \\Delta t$ against the truth's; R against the
        truth's code noise variance (white noise plus the multipath's stationary variance)."""
        p, dt = self.params, context.get("epoch_interval_s")
        out = _window_assumptions(steady_state_gain(p.q, p.r), dt)
        if dt is not None:
            out["assumed code-minus-carrier drift PSD"] = (float(p.q / dt), "m²/s")
        out.update(_truth_drift(context))
        var = context.get("code_noise_variance_m2")
        if var:
            out["pseudorange R / code noise variance"] = (float(p.r / var), "-")
        out["Q adapter"] = (self._adapter_label(), "")
        out.update(_slip_assumption(p.slip_threshold_m))
        return out

    def _adapter_label(self) -> str:
        if self.adapter is None:
            return "none"
        ap = self.adapter.params
        parts = [
            f"{label} {getattr(ap, field):g}{unit}"
            for field, label, unit in (
                ("window", "window", ""),
                ("warmup", "warm-up", ""),
                ("q_ceiling", "Q ceiling", " Q0"),
            )
            if hasattr(ap, field)
        ]
        return f"{self.adapter.name} ({', '.join(parts)})" if parts else self.adapter.name

    def reset(self, batch_shape: tuple[int, ...], context: RunContext) -> None:
        p = self.params
        self.base = LinearModel(np.eye(1), np.eye(1), np.array([[p.q]]), np.array([[p.r]]))
        self.state = None

    def step(self, inputs: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        rho, phi = np.asarray(inputs["pseudorange_m"], float), np.asarray(inputs["carrier_m"], float)
        if self.state is None:
            # The first epoch only initialises (from the code): filter steps start at epoch 1.
            self.state = self.filter_step.start(
                Gaussian(rho[..., None], np.broadcast_to(self.base.R, rho.shape + (1, 1))), self.base, first_step=1
            )
            self.phi = phi
            return {"smoothed_m": rho.copy(), "slip_detected": np.zeros(rho.shape, bool)}
        model = LinearModel(self.base.F, self.base.H, self.base.Q, self.base.R, u=(phi - self.phi)[..., None])
        prior = self.filter_step.predict(self.state, model)
        slip = _slip(rho, prior.mean[..., 0], self.params.slip_threshold_m)
        restart = slip | _arc_start(inputs, rho.shape)
        post = self.filter_step.update(prior, rho[..., None], model, previous=self.state).posterior
        if restart.any():  # restart from the code alone
            mean = np.where(restart[..., None], rho[..., None], post.mean)
            cov = np.where(restart[..., None, None], self.base.R, post.cov)
            post = Gaussian(mean, cov)
        self.state, self.phi = post, phi
        return {"smoothed_m": post.mean[..., 0], "slip_detected": slip}
