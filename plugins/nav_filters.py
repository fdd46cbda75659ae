"""Built-in navigation filter ``ekf-pv`` (the vector-tracking EKF of Zou et al. 2018)."""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np
from pydantic import Field, NonNegativeFloat, PositiveFloat

from gnssframework.errors import ConfigError
from gnssframework.estimation import (CompiledFunctions, FilterStep, Gaussian, LinearModel, NonlinearModel,
                                     filter_sequence, kernels, kernels_loop)
from gnssframework.interfaces import NavFilter, RunContext
from gnssframework.plugin import PluginParams
from gnssframework.plugin_ref import PluginRef, handles_nonlinear
from gnssframework.receiver.vector import predicted_range
from gnssframework.signal.constants import CA_CHIP_LENGTH_M, L1_WAVELENGTH_M, SPEED_OF_LIGHT_M_S
from gnssframework.simulation.clock import PRESETS

__all__ = ["EkfPositionVelocity", "PositionConstantAcceleration", "cv_clock_model"]


def cv_clock_model(T: float, accel_psd: float, clock: str) -> tuple[np.ndarray, np.ndarray]:
    """F and Q of ``[x, y, z, vx, vy, vz, b, d]``: constant velocity driven by white
    acceleration (PSD ``accel_psd``, m²/s³) and a clock of the named preset (metres)."""
    F = np.eye(8)
    F[0:3, 3:6] = T * np.eye(3)
    F[6, 7] = T
    Q = np.zeros((8, 8))
    q = accel_psd
    Q[0:3, 0:3] = q * T**3 / 3 * np.eye(3)
    Q[0:3, 3:6] = Q[3:6, 0:3] = q * T**2 / 2 * np.eye(3)
    Q[3:6, 3:6] = q * T * np.eye(3)
    Q[6:8, 6:8] = SPEED_OF_LIGHT_M_S**2 * PRESETS[clock].process_noise(T)
    return F, Q


class EkfPvParams(PluginParams):
    estimator: PluginRef("estimator", check=handles_nonlinear) = Field(
        "ekf", description="estimator plugin that runs the filter (ekf, ukf, ckf, svd-ckf)")
    accel_psd: float = Field(0.1, gt=0, description="white-acceleration PSD of the constant-velocity model, m²/s³")
    clock: str = Field("tcxo", description="clock preset for the clock process noise: tcxo or ocxo")
    min_code_var_chips2: float = Field(1e-6, gt=0, description="floor of the code-error variance fed in as R")
    min_freq_var_hz2: float = Field(1e-4, gt=0, description="floor of the frequency-error variance fed in as R")


class EkfPositionVelocity(NavFilter):
    """8-state position/velocity/clock filter of Zou et al. (2018, eqs. 32-38).

    State, in one order throughout (the paper's printed H uses
    ``[x, y, z, vx, vy, vz, b, d]`` while its state interleaves them; we use the
    former): ECEF position and velocity, clock bias b and drift d in metres and m/s.
    Constant-velocity transition with white acceleration, clock from h-parameters.

    Each channel gives two measurements, built from the replica's mid-interval range
    $\\hat\\rho$ and rate $\\dot{\\hat\\rho}$ and the channel filter's errors:

    $$
    \\rho = \\hat\\rho + \\lambda_{chip}\\, \\delta\\tau, \\qquad
    \\dot\\rho = \\dot{\\hat\\rho} - \\lambda_{L1}\\, \\delta f, \\qquad
    R = \\mathrm{diag}(\\lambda_{chip}^2 \\sigma_\\tau^2, \\lambda_{L1}^2 \\sigma_f^2)
    $$

    with $h(x) = [\\lVert s - r\\rVert + b,\\; (v_s - v)\\cdot e + d]$ and H holding
    $-e^T$ in the position (range) and velocity (rate) columns. Writing the filter on
    the total state is algebraically the paper's error-state EKF, because its
    measurement is the residual against the same prediction. The NCO command of the
    next interval is the range and rate predicted half an interval ahead.
    """

    name = "ekf-pv"
    description = "8-state position/velocity/clock EKF for vector tracking (Zou et al. 2018)"
    Params = EkfPvParams
    requires = ("code_error_chips", "code_error_var_chips2", "freq_error_hz", "freq_error_var_hz2")
    provides = ("position_m", "velocity_m_s", "clock_m", "cov", "nco_range_m", "nco_range_rate_m_s")

    def assumptions(self, context):
        # White acceleration, the same PSD on every axis: any line of sight sees it.
        return {"line-of-sight acceleration PSD": (self.params.accel_psd, "m²/s³")}

    def __init__(self, **params: Any) -> None:
        super().__init__(**params)
        if self.params.clock not in PRESETS:
            raise ConfigError("nav_filter 'ekf-pv'.clock", f"got {self.params.clock!r}; allowed: {', '.join(PRESETS)}")
        self.engine = self.params.estimator.create()
        self.filter_step = FilterStep(self.engine, name=f"{self.name} ({self.engine.name})")

    def reset(self, batch_shape: tuple[int, ...], context: RunContext) -> None:
        who = f"nav_filter {self.name!r}"
        T = context.require("coherent_time_s", who)
        self.T = T
        self.F, self.Q = self.transition(T)
        initial = Gaussian(context.require("initial_state", who), context.require("initial_cov", who))
        self.state = self.filter_step.start(initial)
        # Measurement assembly and NCO command in one compiled call each under the numba
        # backend (chosen once per run); the NumPy lines of `_measurements`/`_nco_command`
        # are the reference.
        self._compiled = kernels.get_backend() == "numba" and kernels.available()

    def transition(self, T: float) -> tuple[np.ndarray, np.ndarray]:
        """F and Q over one interval ``T`` (s): constant velocity (`cv_clock_model`)."""
        return cv_clock_model(T, self.params.accel_psd, self.params.clock)

    def _model(self, sat_pos, sat_vel, R) -> NonlinearModel:
        F = self.F

        def f(x):
            return x @ F.T

        def h(x):
            rho, rate, _ = predicted_range(x, sat_pos, sat_vel)
            return np.concatenate([rho, rate], axis=-1)

        n_x = F.shape[0]  # 8, or more when a subclass appends states after the clock

        def h_jac(x):
            _, _, e = predicted_range(x, sat_pos, sat_vel)
            n_ch = e.shape[-2]
            H = np.zeros(e.shape[:-2] + (2 * n_ch, n_x))
            H[..., :n_ch, 0:3] = -e
            H[..., :n_ch, 6] = 1.0
            H[..., n_ch:, 3:6] = -e
            H[..., n_ch:, 7] = 1.0
            return H

        # Compiled twins of f (linear) and h (pseudorange/rate) when the satellites are
        # shared by the batch, as in the vector loop: sigma-point engines then run fused.
        compiled = None
        if np.ndim(sat_pos) == 2 and np.ndim(sat_vel) == 2:
            compiled = CompiledFunctions(kernels.F_LINEAR, F, kernels.H_RANGE_RATE,
                                         np.concatenate([sat_pos, sat_vel], axis=-1))
        return NonlinearModel(f, h, self.Q, R, f_jacobian=lambda x: np.broadcast_to(F, x.shape[:-1] + (n_x, n_x)),
                              h_jacobian=h_jac, compiled=compiled)

    def _measurements(self, inputs: Mapping[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        """z and R (Zou et al. 2018, eqs. 35-36) from the channel outputs: NumPy reference."""
        p = self.params
        var_code = np.maximum(inputs["code_error_var_chips2"], p.min_code_var_chips2) * CA_CHIP_LENGTH_M**2
        var_rate = np.maximum(inputs["freq_error_var_hz2"], p.min_freq_var_hz2) * L1_WAVELENGTH_M**2
        R = np.zeros(var_code.shape[:-1] + (2 * var_code.shape[-1],) * 2)
        idx = np.arange(2 * var_code.shape[-1])
        R[..., idx, idx] = np.concatenate([var_code, var_rate], axis=-1)
        z = np.concatenate([inputs["replica_range_m"] + CA_CHIP_LENGTH_M * inputs["code_error_chips"],
                            inputs["replica_rate_m_s"] - L1_WAVELENGTH_M * inputs["freq_error_hz"]], axis=-1)
        return z, R

    def _nco_command(self, x: np.ndarray, sat_pos: np.ndarray, sat_vel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """NCO command for the next interval: range at its start (t + T/2), rate. NumPy reference."""
        ahead = x.copy()
        ahead[..., 0:3] += x[..., 3:6] * self.T / 2
        ahead[..., 6] += x[..., 7] * self.T / 2
        rho, rate, _ = predicted_range(ahead, sat_pos, sat_vel)
        return rho, rate

    def step(self, inputs: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        p = self.params
        code = inputs["code_error_chips"]
        if self._compiled and np.ndim(code) >= 1:
            z, R = kernels_loop.pv_measurements(
                inputs["replica_range_m"], code, inputs["code_error_var_chips2"], inputs["replica_rate_m_s"],
                inputs["freq_error_hz"], inputs["freq_error_var_hz2"], p.min_code_var_chips2, p.min_freq_var_hz2,
                CA_CHIP_LENGTH_M, L1_WAVELENGTH_M)
        else:
            z, R = self._measurements(inputs)
        model = self._model(inputs["sat_pos_m"], inputs["sat_vel_m_s"], R)
        # The initial estimate is already at the first mid-interval: no prediction then.
        self.state = self.filter_step(self.state, z, model, predict=self.filter_step.step_index > 0).posterior
        x = self.state.mean
        sp, sv = inputs["next_sat_pos_m"], inputs["next_sat_vel_m_s"]
        if self._compiled and np.ndim(sp) == 2 and np.ndim(sv) == 2 and x.shape[-1] == 8:
            rho, rate = kernels_loop.pv_nco_command(x, self.T / 2, sp, sv)
        else:
            rho, rate = self._nco_command(x, sp, sv)
        return {"position_m": x[..., 0:3], "velocity_m_s": x[..., 3:6], "clock_m": x[..., 6:8],
                "cov": self.state.cov, "nco_range_m": rho, "nco_range_rate_m_s": rate}


class PositionCaParams(PluginParams):
    dt_s: float = Field(1.0, gt=0, description="epoch interval of filter(); in step() the harness's "
                        "RunContext.epoch_interval_s is used and must equal it")
    q0: list[NonNegativeFloat] = Field([1.0, 0.1, 0.01], min_length=3, max_length=3, description="diagonal of Q "
                                       "per coordinate, 3 values each >= 0: position (m²), velocity, acceleration")
    r0: float = Field(1.0, gt=0, description="measurement noise variance R0 (m²)")
    p0: list[PositiveFloat] = Field([10.0, 1.0, 0.1], min_length=3, max_length=3, description="initial variances, "
                                    "3 values each > 0: position (m²), velocity, acceleration")
    estimator: PluginRef("estimator") = Field(
        "kf", description="estimator of the streaming step(); filter() takes the candidate's estimator")


class PositionConstantAcceleration(NavFilter):
    """Position-domain filter with a constant-acceleration model per coordinate (Liu et al. 2020).

    Each coordinate (latitude and longitude in local metres) has the state
    $X = [n, \\dot n, \\ddot n]$, $\\Phi = \\begin{bmatrix}1 & t & t^2/2\\\\ 0 & 1 & t\\\\ 0 & 0 & 1\\end{bmatrix}$,
    and measurement $Z = n + V$. The coordinates run as a batch axis. The filter engine
    (``ukf`` with alpha 0.01, beta 2, kappa 0 in the paper), an optional ``colored-ar1``
    augmentation and an optional noise adapter are given by the caller, which is how a
    comparison candidate composes them.
    """

    name = "position-ca"
    description = "Constant-acceleration position filter per coordinate (Liu et al. 2020)"
    Params = PositionCaParams
    requires = ("position_m",)
    provides = ("position_m",)

    def model(self, dt_s: float | None = None):
        """The constant-acceleration model at epoch interval ``dt_s`` (default: ``params.dt_s``)."""
        p = self.params
        t = p.dt_s if dt_s is None else dt_s
        F = np.array([[1.0, t, t * t / 2], [0.0, 1.0, t], [0.0, 0.0, 1.0]])
        return LinearModel(F, np.array([[1.0, 0.0, 0.0]]), np.diag(p.q0), np.array([[p.r0]]))

    def filter(self, zs: np.ndarray, estimator, adapter=None, augmentation=None, **policies):
        """Filter positions ``(K, ..., n_coord)`` in metres; returns the `FilterResult`
        whose batch shape is ``(..., n_coord)`` (coordinate last) and state ``(..., 3)``."""
        zs = np.asarray(zs, dtype=float)
        mean0 = np.zeros(zs.shape[1:] + (3,))
        mean0[..., 0] = zs[0]
        initial = Gaussian(mean0, np.diag(self.params.p0))
        return filter_sequence(estimator, self.model(), zs[..., None], initial, adapter=adapter,
                               augmentation=augmentation, **policies)

    def reset(self, batch_shape: tuple[int, ...], context: RunContext) -> None:
        p = self.params
        self.filter_step = FilterStep(p.estimator.create(), name=f"{self.name} ({p.estimator.name})")
        self.dt_s = context.resolve("epoch_interval_s", p.dt_s, f"nav_filter {self.name!r}")
        self.state = None

    def step(self, inputs: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Streaming use without augmentation or adapter: one epoch of positions ``(..., n_coord)``."""
        z = np.asarray(inputs["position_m"], dtype=float)
        model = self.model(self.dt_s)
        if self.state is None:
            mean = np.zeros(z.shape + (3,))
            mean[..., 0] = z
            self.state = self.filter_step.start(Gaussian(mean, np.diag(self.params.p0)), model, first_step=1)
            return {"position_m": z}
        self.state = self.filter_step(self.state, z[..., None], model).posterior
        return {"position_m": self.state.mean[..., 0]}
