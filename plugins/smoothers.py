"""Carrier-smoothed code channel filters: ``hatch`` and ``kf-smoother`` (CN105068097 patent 2015)."""

from __future__ import annotations

import dataclasses
from typing import Any, Mapping

import numpy as np
from pydantic import Field

from gnssframework import names, registry
from gnssframework.estimation import FilterStep, Gaussian, LinearModel
from gnssframework.interfaces import ChannelFilter, RunContext
from gnssframework.plugin import PluginParams
from gnssframework.plugin_ref import PluginRef

__all__ = ["HatchFilter", "KalmanSmoother"]


class _SlipParams(PluginParams):
    slip_threshold_m: float = Field(0.0, ge=0, description="code-minus-carrier jump that declares a cycle slip and "
                                    "resets the smoother; 0 switches detection off")


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
    requires = ("pseudorange_m", "carrier_m")
    provides = ("smoothed_m", "slip_detected")

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
        None, description="noise adapter for Q, e.g. 'ml-q' (CN105068097 patent 2015)")
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
    requires = ("pseudorange_m", "carrier_m")
    provides = ("smoothed_m", "slip_detected")

    def __init__(self, **params: Any) -> None:
        super().__init__(**params)
        p = self.params
        self.engine = registry.create("estimator", "kf")
        # adapter_params (the flat form) win over the reference's own params.
        self.adapter = (dataclasses.replace(p.adapter, params={**p.adapter.params, **p.adapter_params}).create()
                        if p.adapter else None)
        self.filter_step = FilterStep(self.engine, self.adapter, name=f"{self.name} (kf)")

    def reset(self, batch_shape: tuple[int, ...], context: RunContext) -> None:
        p = self.params
        self.base = LinearModel(np.eye(1), np.eye(1), np.array([[p.q]]), np.array([[p.r]]))
        self.state = None

    def step(self, inputs: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        rho, phi = np.asarray(inputs["pseudorange_m"], float), np.asarray(inputs["carrier_m"], float)
        if self.state is None:
            # The first epoch only initialises (from the code): filter steps start at epoch 1.
            self.state = self.filter_step.start(
                Gaussian(rho[..., None], np.broadcast_to(self.base.R, rho.shape + (1, 1))), self.base, first_step=1)
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
