"""Built-in navigation filter ``ekf-pv`` (the vector-tracking EKF of Zou et al. 2018)."""

from __future__ import annotations

import math
from typing import Any
from collections.abc import Mapping

import numpy as np
from pydantic import Field, NonNegativeFloat, PositiveFloat

from gnssframework.errors import ConfigError
from gnssframework import backend
from gnssframework.estimation import (
    CompiledFunctions,
    FilterStep,
    Gaussian,
    LinearModel,
    NonlinearModel,
    StepResult,
    linear_f,
    register_warm_up,
)
from gnssframework.interfaces import BatchPositionFilter, NavFilter, RunContext
from gnssframework.navigation.geometry import line_of_sight
from gnssframework.plugin import PluginParams
from gnssframework.plugin_ref import PluginRef, handles_nonlinear
from gnssframework.receiver.tracking.vector import predicted_range
from gnssframework.signal.gps_l1ca import GPS_L1CA
from gnssframework.signal.spec import SPEED_OF_LIGHT_M_S, SignalSpec
from gnssframework.simulation.clock import PRESETS

from .range_bias import (
    RangeBiasBudget,
    RangeBiasParams,
    budget_assumptions,
    check_channels,
    elevation_deg,
    least_squares_prior,
    up_vector,
)

__all__ = [
    "EkfPositionVelocity",
    "PositionConstantAcceleration",
    "cv_clock_model",
    "range_rate_row",
    "range_rate_jacobian",
    "pv_measurements",
    "pv_nco_command",
]


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


# -- ekf-pv's compiled twins (the NumPy lines of EkfPositionVelocity are the reference) --


@backend.jit
def range_rate_row(params, X, k, Z, kz):
    """Pseudorange and rate of the state ``X[k]`` = ``[x, y, z, vx, vy, vz, b, d]`` to
    ``ch`` satellites (Zou et al. 2018, eqs. 35-36) into ``Z[kz]``: ``params`` ``(ch, 6)``,
    satellite ECEF position and velocity per row. As
    `gnssframework.receiver.tracking.vector.predicted_range`: rho = |s - r| + b, rate = (v_s - v) . e + d."""
    n_ch = params.shape[0]
    for c in range(n_ch):
        lx = params[c, 0] - X[k, 0]
        ly = params[c, 1] - X[k, 1]
        lz = params[c, 2] - X[k, 2]
        dist = math.sqrt(lx * lx + ly * ly + lz * lz)
        Z[kz, c] = dist + X[k, 6]
        Z[kz, n_ch + c] = (
            (params[c, 3] - X[k, 3]) * (lx / dist)
            + (params[c, 4] - X[k, 4]) * (ly / dist)
            + (params[c, 5] - X[k, 5]) * (lz / dist)
        ) + X[k, 7]


@backend.jit
def range_rate_jacobian(params, X, k, J):
    """``dh/dx`` of `range_rate_row` at ``X[k]`` as ``ekf-pv``'s NumPy model gives it:
    ``-e`` in the position (range) and velocity (rate) columns, 1 for the clock bias and
    drift; the rate's dependence on the position through ``e`` is neglected, as there."""
    n_ch = params.shape[0]
    J[:, :] = 0.0
    for c in range(n_ch):
        lx = params[c, 0] - X[k, 0]
        ly = params[c, 1] - X[k, 1]
        lz = params[c, 2] - X[k, 2]
        dist = math.sqrt(lx * lx + ly * ly + lz * lz)
        e0 = lx / dist
        e1 = ly / dist
        e2 = lz / dist
        J[c, 0] = -e0
        J[c, 1] = -e1
        J[c, 2] = -e2
        J[c, 6] = 1.0
        J[n_ch + c, 3] = -e0
        J[n_ch + c, 4] = -e1
        J[n_ch + c, 5] = -e2
        J[n_ch + c, 7] = 1.0


# The vector loop's navigation filter: its drivers compile in the kernels' warm-up (8
# states, 8 channels), satellites 2e7 m out so every point is well away from them.
register_warm_up(
    CompiledFunctions(linear_f, np.eye(8), range_rate_row, np.tile([2e7, 0, 0, 0, 0, 0], (8, 1)), range_rate_jacobian),
    8,
    16,
)


@backend.jit
def _pv_measurements_body(
    rep_range, code, var_code, rep_rate, freq, var_freq, min_code, min_freq, chip_m, wave_m, z, R
):
    B, c = code.shape
    for b in range(B):
        for j in range(2 * c):
            for i in range(2 * c):
                R[b, j, i] = 0.0
        for i in range(c):
            z[b, i] = rep_range[b, i] + chip_m * code[b, i]
            z[b, c + i] = rep_rate[b, i] - wave_m * freq[b, i]
            vc, vf = var_code[b, i], var_freq[b, i]
            # np.maximum: a NaN variance stays NaN (the filter then names it).
            vc = vc if (vc > min_code or vc != vc) else min_code
            vf = vf if (vf > min_freq or vf != vf) else min_freq
            R[b, i, i] = vc * (chip_m * chip_m)
            R[b, c + i, c + i] = vf * (wave_m * wave_m)


@backend.jit
def _pv_nco_body(x, half_t, sat_pos, sat_vel, rho, rate):
    B = x.shape[0]
    c = sat_pos.shape[0]
    for b in range(B):
        r0 = x[b, 0] + x[b, 3] * half_t
        r1 = x[b, 1] + x[b, 4] * half_t
        r2 = x[b, 2] + x[b, 5] * half_t
        bias = x[b, 6] + x[b, 7] * half_t
        for i in range(c):
            l0 = sat_pos[i, 0] - r0
            l1 = sat_pos[i, 1] - r1
            l2 = sat_pos[i, 2] - r2
            dist = math.sqrt(l0 * l0 + l1 * l1 + l2 * l2)
            e0, e1, e2 = l0 / dist, l1 / dist, l2 / dist
            rate[b, i] = (
                (sat_vel[i, 0] - x[b, 3]) * e0 + (sat_vel[i, 1] - x[b, 4]) * e1 + (sat_vel[i, 2] - x[b, 5]) * e2
            ) + x[b, 7]
            rho[b, i] = dist + bias


def _as_rows(a, shape: tuple[int, ...]) -> np.ndarray:
    """``a`` broadcast to ``shape`` as a writable C-contiguous float64 array (a copy only
    where it is not one already)."""
    if type(a) is np.ndarray and a.shape == shape and a.dtype == np.float64:
        flags = a.flags
        if flags.c_contiguous and flags.writeable:
            return a
        # A strided view of the right shape (a channel filter's state column): one C-order
        # copy, not the general broadcast below (about 5 us per operand here).
        return a.copy()
    return np.array(np.broadcast_to(np.asarray(a, dtype=float), shape), dtype=float, order="C")


def pv_measurements(
    rep_range, code, var_code, rep_rate, freq, var_freq, min_code: float, min_freq: float, chip_m: float, wave_m: float
) -> tuple[np.ndarray, np.ndarray]:
    """``ekf-pv``'s measurement and its diagonal R from the channel outputs in one compiled
    pass: ``z = [range + chip_m code, rate - wave_m freq]``, ``R = diag(max(var_code,
    min_code) chip_m^2, max(var_freq, min_freq) wave_m^2)``, each ``(..., 2 ch)``."""
    shape = np.shape(code)
    c = shape[-1]
    ops = [_as_rows(a, shape).reshape(-1, c) for a in (rep_range, code, var_code, rep_rate, freq, var_freq)]
    B = ops[0].shape[0]
    z = np.empty((B, 2 * c))
    R = np.empty((B, 2 * c, 2 * c))
    _pv_measurements_body(*ops, float(min_code), float(min_freq), float(chip_m), float(wave_m), z, R)
    return z.reshape(shape[:-1] + (2 * c,)), R.reshape(shape[:-1] + (2 * c, 2 * c))


def pv_nco_command(
    x: np.ndarray, half_t: float, sat_pos: np.ndarray, sat_vel: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Range and rate of the states ``x (..., 8)`` moved ``half_t`` ahead (position by
    velocity, bias by drift) to satellites ``(ch, 3)``: ``ekf-pv``'s NCO command, compiled."""
    lead = x.shape[:-1]
    xr = _as_rows(x, x.shape).reshape(-1, 8)
    sp, sv = _as_rows(sat_pos, np.shape(sat_pos)), _as_rows(sat_vel, np.shape(sat_vel))
    c = sp.shape[0]
    rho = np.empty((xr.shape[0], c))
    rate = np.empty((xr.shape[0], c))
    _pv_nco_body(xr, float(half_t), sp, sv, rho, rate)
    return rho.reshape(lead + (c,)), rate.reshape(lead + (c,))


class _EkfPvOwnParams(PluginParams):
    estimator: PluginRef("estimator", check=handles_nonlinear) = Field(
        "ekf", description="estimator plugin that runs the filter (ekf, ukf, ckf, svd-ckf)"
    )
    accel_psd: float = Field(0.1, gt=0, description="white-acceleration PSD of the constant-velocity model, m²/s³")
    clock: str = Field("tcxo", description="clock preset for the clock process noise: tcxo or ocxo")
    min_code_var_chips2: float = Field(1e-6, gt=0, description="floor of the code-error variance fed in as R")
    min_freq_var_hz2: float = Field(1e-4, gt=0, description="floor of the frequency-error variance fed in as R")


class EkfPvParams(RangeBiasParams, _EkfPvOwnParams):
    """ekf-pv's parameters: its own, then the range-error budget (`plugins.range_bias`)."""


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

    With a range-error budget (``sisre_std_m``, ``iono_vertical_std_m``,
    ``tropo_zenith_std_m``: `plugins.range_bias`), bias states are appended after the
    filter's own at the first step, each pseudorange row adds its mapped biases, and the
    NCO range includes them; the outputs stay the eight states and their marginal
    covariance. All zero (the default): no bias states, the filter as published.

    ``last_step`` is the last step's `StepResult` (None before the first): its
    ``update`` holds the innovation, its covariance and the cross covariance that
    `gnssframework.navigation.filter_integrity` tests.
    """

    name = "ekf-pv"
    description = "8-state position/velocity/clock EKF for vector tracking (Zou et al. 2018)"
    Params = EkfPvParams
    params: EkfPvParams  # self.params, as validated
    requires = ("code_error_chips", "code_error_var_chips2", "freq_error_hz", "freq_error_var_hz2")
    provides = ("position_m", "velocity_m_s", "clock_m", "cov", "nco_range_m", "nco_range_rate_m_s")

    def assumptions(self, context):
        # White acceleration, the same PSD on every axis: any line of sight sees it.
        return {"line-of-sight acceleration PSD": (self.params.accel_psd, "m²/s³"), **self._budget_assumptions()}

    def _budget_assumptions(self) -> dict[str, tuple[float, str]]:
        """The range-error budget as assumptions (none when it is off)."""
        return budget_assumptions(self.params)

    def fixed_channel_set(self) -> bool:
        """True with a range-error budget: its states are appended for the first step's
        channels (the scenarios' fixed sets)."""
        return RangeBiasBudget.wanted(self.params)

    def __init__(self, **params: Any) -> None:
        super().__init__(**params)
        if self.params.clock not in PRESETS:
            raise ConfigError("nav_filter 'ekf-pv'.clock", f"got {self.params.clock!r}; allowed: {', '.join(PRESETS)}")
        self.engine = self.params.estimator.create()
        self.filter_step = FilterStep(self.engine, name=f"{self.name} ({self.engine.name})")
        self._use_signal()  # GPS L1 C/A until `reset` hands it the tracked signal

    def reset(self, batch_shape: tuple[int, ...], context: RunContext) -> None:
        who = f"nav_filter {self.name!r}"
        T = context.require("coherent_time_s", who)
        self.T = T
        self.F, self.Q = self.transition(T)
        self._n_core = self.F.shape[0]  # the filter's own states; range-bias states follow them
        self._bias: RangeBiasBudget | None = None
        self._up: np.ndarray | None = None
        initial = Gaussian(context.require("initial_state", who), context.require("initial_cov", who))
        self.state = self.filter_step.start(initial)
        self.last_step: StepResult | None = None
        # Measurement assembly and NCO command in one compiled call each under the numba
        # backend (chosen once per run); the NumPy lines of `_measurements`/`_nco_command`
        # are the reference.
        self._compiled = backend.compiled()
        self._use_signal(context.spec())

    def _use_signal(self, signal: SignalSpec = GPS_L1CA) -> None:
        """The chip length and carrier wavelength that turn the channels' chips and Hz into
        metres (the tracked signal's; GPS L1 C/A's by default)."""
        self.chip_length_m, self.wavelength_m = signal.chip_length_m, signal.wavelength_m

    def transition(self, T: float) -> tuple[np.ndarray, np.ndarray]:
        """F and Q over one interval ``T`` (s): constant velocity (`cv_clock_model`)."""
        return cv_clock_model(T, self.params.accel_psd, self.params.clock)

    def _model(self, sat_pos, sat_vel, R, bias_rows: np.ndarray | None = None) -> NonlinearModel:
        """The step's model; ``bias_rows`` ``(..., ch, n_bias)`` adds the range-bias states
        (after the filter's own ``n_core``) to each pseudorange."""
        F = self.F
        n_core = self._n_core

        def f(x):
            return x @ F.T

        def h(x):
            rho, rate, _ = predicted_range(x, sat_pos, sat_vel)
            if bias_rows is not None:
                rho = rho + np.einsum("...cn,...n->...c", bias_rows, x[..., n_core:])
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
            if bias_rows is not None:
                H[..., :n_ch, n_core:] = bias_rows
            return H

        # Compiled twins of f (linear) and h (pseudorange/rate) when the satellites are
        # shared by the batch, as in the vector loop: sigma-point engines then run fused.
        compiled = None
        if bias_rows is None and np.ndim(sat_pos) == 2 and np.ndim(sat_vel) == 2:
            compiled = CompiledFunctions(
                linear_f, F, range_rate_row, np.concatenate([sat_pos, sat_vel], axis=-1), range_rate_jacobian
            )
        return NonlinearModel(
            f,
            h,
            self.Q,
            R,
            f_jacobian=lambda x: np.broadcast_to(F, x.shape[:-1] + (n_x, n_x)),
            h_jacobian=h_jac,
            compiled=compiled,
        )

    def _measurements(self, inputs: Mapping[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        """z and R (Zou et al. 2018, eqs. 35-36) from the channel outputs: NumPy reference."""
        p = self.params
        chip_m, lam = self.chip_length_m, self.wavelength_m
        var_code = np.maximum(inputs["code_error_var_chips2"], p.min_code_var_chips2) * chip_m**2
        var_rate = np.maximum(inputs["freq_error_var_hz2"], p.min_freq_var_hz2) * lam**2
        R = np.zeros(var_code.shape[:-1] + (2 * var_code.shape[-1],) * 2)
        idx = np.arange(2 * var_code.shape[-1])
        R[..., idx, idx] = np.concatenate([var_code, var_rate], axis=-1)
        z = np.concatenate(
            [
                inputs["replica_range_m"] + chip_m * inputs["code_error_chips"],
                inputs["replica_rate_m_s"] - lam * inputs["freq_error_hz"],
            ],
            axis=-1,
        )
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
            z, R = pv_measurements(
                inputs["replica_range_m"],
                code,
                inputs["code_error_var_chips2"],
                inputs["replica_rate_m_s"],
                inputs["freq_error_hz"],
                inputs["freq_error_var_hz2"],
                p.min_code_var_chips2,
                p.min_freq_var_hz2,
                self.chip_length_m,
                self.wavelength_m,
            )
        else:
            z, R = self._measurements(inputs)
        rows = self._bias_rows(inputs)
        model = self._model(inputs["sat_pos_m"], inputs["sat_vel_m_s"], R, rows)
        # The initial estimate is already at the first mid-interval: no prediction then.
        # The whole step is kept for integrity monitoring (`navigation.filter_integrity`).
        self.last_step = self.filter_step(self.state, z, model, predict=self.filter_step.step_index > 0)
        self.state = self.last_step.posterior
        x = self.state.mean
        core = x[..., : self._n_core]
        sp, sv = inputs["next_sat_pos_m"], inputs["next_sat_vel_m_s"]
        if self._compiled and np.ndim(sp) == 2 and np.ndim(sv) == 2 and core.shape[-1] == 8:
            rho, rate = pv_nco_command(core, self.T / 2, sp, sv)
        else:
            rho, rate = self._nco_command(core, sp, sv)
        if rows is not None:  # the replica follows the biased range the filter predicts
            rho = rho + np.einsum("...cn,...n->...c", rows, x[..., self._n_core :])
        return {
            "position_m": x[..., 0:3],
            "velocity_m_s": x[..., 3:6],
            "clock_m": x[..., 6:8],
            "cov": self.state.cov[..., :8, :8],
            "nco_range_m": rho,
            "nco_range_rate_m_s": rate,
        }

    def _bias_rows(self, inputs: Mapping[str, np.ndarray]) -> np.ndarray | None:
        """The mapping of the range-bias states into this step's pseudoranges, appending
        the states at the first step (None without a budget)."""
        p = self.params
        if not RangeBiasBudget.wanted(p):
            return None
        channels = int(np.shape(inputs["code_error_chips"])[-1])
        sat_pos = inputs["sat_pos_m"]
        if self._bias is None:
            self._start_bias(channels, sat_pos)
        assert self._bias is not None and self._up is not None
        check_channels(self._bias, channels, f"nav_filter {self.name!r}", self.filter_step.step_index)
        return self._bias.rows(elevation_deg(sat_pos, self.state.mean[..., 0:3], self._up))

    def _start_bias(self, channels: int, sat_pos: np.ndarray) -> None:
        """Append the budget's bias states (zero mean, their prior variances) to the state,
        F and Q: random constants or Gauss-Markov (`plugins.range_bias.RangeBiasBudget`);
        with ``initial_fix_from_ranges``, the prior of `plugins.range_bias.least_squares_prior`."""
        budget = RangeBiasBudget.of(self.params, channels)
        x, P, n = self.state.mean, self.state.cov, self._n_core
        nb = budget.size
        lead = x.shape[:-1]
        xa = np.concatenate([x, np.zeros(lead + (nb,))], axis=-1)
        up = up_vector(x[..., 0:3])
        P_bias = np.diag(budget.std_m() ** 2)
        if self.params.initial_fix_from_ranges:
            _, los = line_of_sight(sat_pos, x[..., None, 0:3])
            rows = budget.rows(elevation_deg(sat_pos, x[..., 0:3], up))
            Pa = least_squares_prior(np.broadcast_to(P, lead + (n, n)), P_bias, rows, los, n)
        else:
            Pa = np.zeros(lead + (n + nb, n + nb))
            Pa[..., :n, :n] = P
            Pa[..., n:, n:] = P_bias
        psi, q = budget.transition(self.T)
        F, Q = np.zeros((n + nb, n + nb)), np.zeros((n + nb, n + nb))
        F[:n, :n], Q[:n, :n] = self.F, self.Q
        F[n:, n:], Q[n:, n:] = np.diag(psi), np.diag(q)
        self.F, self.Q = F, Q
        self._bias, self._up = budget, up
        self.state = self.filter_step.start(Gaussian(xa, Pa), first_step=self.filter_step.step_index)


class PositionCaParams(PluginParams):
    dt_s: float = Field(
        1.0,
        gt=0,
        description="epoch interval of filter(); in step() the harness's "
        "RunContext.epoch_interval_s is used and must equal it",
    )
    q0: list[NonNegativeFloat] = Field(
        [1.0, 0.1, 0.01],
        min_length=3,
        max_length=3,
        description="diagonal of Q per coordinate, 3 values each >= 0: position (m²), velocity, acceleration",
    )
    r0: float = Field(1.0, gt=0, description="measurement noise variance R0 (m²)")
    p0: list[PositiveFloat] = Field(
        [10.0, 1.0, 0.1],
        min_length=3,
        max_length=3,
        description="initial variances, 3 values each > 0: position (m²), velocity, acceleration",
    )
    estimator: PluginRef("estimator") = Field(
        "kf", description="estimator of the streaming step(); filter() takes the candidate's estimator"
    )


class PositionConstantAcceleration(BatchPositionFilter):
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
    params: PositionCaParams  # self.params, as validated
    requires = ("position_m",)
    provides = ("position_m",)

    def assumptions(self, context: Mapping[str, Any]) -> dict[str, tuple[Any, str]]:
        r"""Q0 per epoch and coordinate, each derivative's variance added at every step
        (a diagonal Q0: no continuous-time PSD behind it), and R0 against the case's true
        measurement-noise variance $\sigma_c^2 + \sigma_w^2$ (``context``'s
        ``measurement_variance_m2``; the ratio is left out when the scenario does not
        know it). With a ``colored-ar1`` augmentation R0 is the variance of the AR(1)
        driving noise; its row gives the factor $1/(1-\psi^2)$ to the stationary variance."""
        q = self.params.q0
        out = {
            "position process-noise variance per epoch": (float(q[0]), "m²"),
            "velocity process-noise variance per epoch": (float(q[1]), "m²/s²"),
            "acceleration process-noise variance per epoch": (float(q[2]), "m²/s⁴"),
        }
        truth = context.get("measurement_variance_m2")
        if truth:
            out["R0 / true measurement variance (white + colored)"] = (self.params.r0 / truth, "-")
        return out

    def model(self, dt_s: float | None = None) -> LinearModel:
        """The constant-acceleration model at epoch interval ``dt_s`` (default: ``params.dt_s``)."""
        p = self.params
        t = p.dt_s if dt_s is None else dt_s
        F = np.array([[1.0, t, t * t / 2], [0.0, 1.0, t], [0.0, 0.0, 1.0]])
        return LinearModel(F, np.array([[1.0, 0.0, 0.0]]), np.diag(p.q0), np.array([[p.r0]]))

    def initial(self, first: np.ndarray) -> Gaussian:
        """The prior: position at the first measurement ``(..., n_coord)``, variances ``p0``."""
        mean0 = np.zeros(np.shape(first) + (3,))
        mean0[..., 0] = first
        return Gaussian(mean0, np.diag(self.params.p0))

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
            self.state = self.filter_step.start(self.initial(z), model, first_step=1)
            return {"position_m": z}
        self.state = self.filter_step(self.state, z[..., None], model).posterior
        return {"position_m": self.state.mean[..., 0]}
