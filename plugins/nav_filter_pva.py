"""Built-in navigation filter ``ekf-pva``: ``ekf-pv`` with acceleration states (white-jerk model)."""

from __future__ import annotations

import dataclasses
from typing import Any
from collections.abc import Mapping

import numpy as np
from pydantic import Field

from gnssframework.errors import ConfigError
from gnssframework.interfaces import RunContext
from gnssframework.plugin import PluginParams
from gnssframework.plugin_ref import PluginRef, handles_nonlinear
from gnssframework.receiver.tracking.vector import predicted_range

from .nav_filters import EkfPositionVelocity, cv_clock_model
from .range_bias import RangeBiasParams

__all__ = ["EkfPositionVelocityAcceleration", "ca_clock_model"]

#: State order: ekf-pv's eight states first, so its range/rate model reads them unchanged.
POSITION, VELOCITY, CLOCK, ACCELERATION = slice(0, 3), slice(3, 6), slice(6, 8), slice(8, 11)


def ca_clock_model(T: float, jerk_psd: float, clock: str) -> tuple[np.ndarray, np.ndarray]:
    """F and Q of ``[x, y, z, vx, vy, vz, b, d, ax, ay, az]``: constant acceleration driven
    by white jerk (PSD ``jerk_psd``, m²/s⁵, the same on every axis) and the clock of the
    named preset (metres).

    Per axis, the exact discretisation of the white-jerk model (Bar-Shalom, Li and
    Kirubarajan 2001, section 6.2.3):

    $$
    F = \\begin{bmatrix} 1 & T & T^2/2 \\\\ 0 & 1 & T \\\\ 0 & 0 & 1 \\end{bmatrix},\\qquad
    Q = q \\begin{bmatrix} T^5/20 & T^4/8 & T^3/6 \\\\ T^4/8 & T^3/3 & T^2/2 \\\\
    T^3/6 & T^2/2 & T \\end{bmatrix}
    $$
    """
    F = np.eye(11)
    F[:8, :8], Q8 = cv_clock_model(T, 1.0, clock)
    F[POSITION, ACCELERATION] = T**2 / 2 * np.eye(3)
    F[VELOCITY, ACCELERATION] = T * np.eye(3)
    Q = np.zeros((11, 11))
    Q[CLOCK, CLOCK] = Q8[CLOCK, CLOCK]
    per_axis = jerk_psd * np.array(
        [[T**5 / 20, T**4 / 8, T**3 / 6], [T**4 / 8, T**3 / 3, T**2 / 2], [T**3 / 6, T**2 / 2, T]]
    )
    blocks = (POSITION, VELOCITY, ACCELERATION)
    for i, rows in enumerate(blocks):
        for j, cols in enumerate(blocks):
            Q[rows, cols] = per_axis[i, j] * np.eye(3)
    return F, Q


class _EkfPvaOwnParams(PluginParams):
    estimator: PluginRef("estimator", check=handles_nonlinear) = Field(
        "ekf", description="estimator plugin that runs the filter (ekf, ukf, ckf, svd-ckf)"
    )
    jerk_psd: float = Field(1e4, gt=0, description="white-jerk PSD of the constant-acceleration model, m²/s⁵")
    initial_accel_std_m_s2: float = Field(
        1.0,
        gt=0,
        description="initial acceleration standard deviation per axis "
        "(m/s²) when the run's initial state holds only ekf-pv's 8 states",
    )
    clock: str = Field("tcxo", description="clock preset for the clock process noise: tcxo or ocxo")
    min_code_var_chips2: float = Field(1e-6, gt=0, description="floor of the code-error variance fed in as R")
    min_freq_var_hz2: float = Field(1e-4, gt=0, description="floor of the frequency-error variance fed in as R")


class EkfPvaParams(RangeBiasParams, _EkfPvaOwnParams):
    """ekf-pva's parameters: its own, then the range-error budget (`plugins.range_bias`)."""


class EkfPositionVelocityAcceleration(EkfPositionVelocity):
    """11-state position/velocity/acceleration/clock filter for vector tracking.

    ``ekf-pv`` (Zou et al. 2018, eqs. 32-38: the same measurements, R and estimator) with
    three acceleration states appended after the clock and a constant-acceleration
    transition driven by white jerk (`ca_clock_model`), so a sustained manoeuvre is a
    state the filter estimates rather than noise it must absorb. ``accel_psd`` is unused.
    A run's 8-state initial estimate gets zero acceleration with variance
    ``initial_accel_std_m_s2²``. Outputs are ekf-pv's: position, velocity and clock, and
    the 8x8 marginal covariance of those states; the NCO command is the range and rate
    predicted half an interval ahead along the acceleration.
    """

    name = "ekf-pva"
    description = "11-state position/velocity/acceleration/clock EKF for vector tracking (white-jerk model)"
    Params = EkfPvaParams
    params: EkfPvaParams  # self.params, as validated

    def assumptions(self, context):
        return {"line-of-sight jerk PSD": (self.params.jerk_psd, "m²/s⁵"), **self._budget_assumptions()}

    def reset(self, batch_shape: tuple[int, ...], context: RunContext) -> None:
        x0 = np.asarray(context.require("initial_state", f"nav_filter {self.name!r}"), float)
        P0 = np.asarray(context.require("initial_cov", f"nav_filter {self.name!r}"), float)
        if x0.shape[-1] == 8 and P0.shape[-2:] == (8, 8):  # ekf-pv's initial state: no acceleration known
            x0 = np.concatenate([x0, np.zeros(x0.shape[:-1] + (3,))], axis=-1)
            P = np.zeros(P0.shape[:-2] + (11, 11))
            P[..., :8, :8] = P0
            P[..., ACCELERATION, ACCELERATION] = self.params.initial_accel_std_m_s2**2 * np.eye(3)
            P0 = P
        elif x0.shape[-1] != 11 or P0.shape[-2:] != (11, 11):
            raise ConfigError(
                f"nav_filter {self.name!r}.initial_state",
                f"needs 8 or 11 states with a matching covariance; got state {x0.shape} and covariance {P0.shape}",
            )
        super().reset(batch_shape, dataclasses.replace(context, initial_state=x0, initial_cov=P0))

    def transition(self, T: float) -> tuple[np.ndarray, np.ndarray]:
        """F and Q over one interval ``T`` (s): constant acceleration (`ca_clock_model`)."""
        return ca_clock_model(T, self.params.jerk_psd, self.params.clock)

    def _nco_command(self, x: np.ndarray, sat_pos: np.ndarray, sat_vel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """NCO command for the next interval: range and rate at its start (t + T/2) along the acceleration."""
        h = self.T / 2
        ahead = x[..., :8].copy()
        ahead[..., POSITION] += x[..., VELOCITY] * h + x[..., ACCELERATION] * h**2 / 2
        ahead[..., VELOCITY] += x[..., ACCELERATION] * h
        ahead[..., 6] += x[..., 7] * h
        rho, rate, _ = predicted_range(ahead, sat_pos, sat_vel)
        return rho, rate

    def step(self, inputs: Mapping[str, np.ndarray]) -> dict[str, Any]:
        out = super().step(inputs)
        out["cov"] = out["cov"][..., :8, :8]  # the marginal of ekf-pv's states, as the vector loop records
        return out
