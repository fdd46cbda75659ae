"""Built-in navigation filter ``ins-ekf``: the 15-state error-state integration filter of deep
integration (Cai and Guo 2017) and of its loose- and tight-coupling baselines.

The filter estimates the error of a strapdown INS in the layout and sign convention of
`gnssframework.inertial.error_model`: attitude (rad), velocity (m/s), position (m), ECEF
(estimate minus truth), then the residual gyro (rad/s) and accelerometer (m/s^2) biases of
the compensated IMU output, body axes (Groves 2013, section 14.2.1). It is a closed-loop filter: every update returns the estimated error,
the caller corrects the INS with it and the filter's error estimate restarts from zero
(Groves 2013, section 14.1.1), so its mean never carries old corrections.

Each ``step`` takes the transition ``Phi`` and process noise ``Qd`` of the INS error
model over the interval since the last update (from the INS, at the INS rate) and one
of two measurements:

* ``"differenced"`` (deep integration, and tight coupling on the scalar loops'
  pseudoranges and rates, ``coupling = "tight"``): every channel's range and rate residual
  (true minus the navigator's prediction; a prefilter's new information of the
  interval) single-differenced against the reference channel, the highest C/N0, with
  the correlated covariance $D R D^T$ (Cai and Guo 2017, eqs. 9-11; Groves 2013, section
  14.3.3). The receiver clock cancels; a small clock filter beside this one keeps the
  NCOs' clock terms (`gnssframework.receiver.deep.navigators.ClockFilter`).
* ``"position-velocity"`` (loose coupling): a position and velocity fix ``(runs, 6)``
  (estimate of the GNSS solution) and its 6x6 covariance; the measurement is the INS
  minus the fix, $z = [\\delta r, \\delta v] + n$ (Groves 2013, section 14.3.1).

With a range-error budget (``sisre_std_m``, ``iono_vertical_std_m``,
``tropo_zenith_std_m``: `plugins.range_bias`) the differenced update carries it as states
appended after the 15: a SISRE bias per channel, a vertical ionospheric and a zenith
tropospheric residual, random constants or Gauss-Markov, entering channel i's range
residual as $M_i b$ and the differences as $D [M; 0]$ (`measurements.integration_measurement`).
They are not INS errors: the closed loop corrects the INS with the first 15 elements and
keeps the bias estimate (the states of `plugins.range_bias`, after Brown and Hwang 2012,
section 8.2). Their initial covariance is the budget's, independent of the INS error
(the INS starts from its own estimate, not from a fix of those ranges). A loose fix
carries them through its least-squares gain $K$ (``fix_range_gain``, `loose.fix_range_gain`):
the INS-minus-fix measurement sees $-K_{0:3} M b$ on its position rows.

With the IMU's scale factors and misalignments (``gyro_scale_factor_ppm``,
``accel_scale_factor_ppm``, ``gyro_misalignment_mrad``, ``accel_misalignment_mrad``, their
prior 1-sigma) the INS error state is 33: the 15, then the 18 elements of each triad's
residual ``M`` (`gnssframework.inertial.calibration`), random constants the closed loop
corrects like the biases. The harness's strapdown then hands out 33-state transitions
(``StrapdownIns(calibration=True)``) and takes 33-state corrections (`error_states`).

Another ``estimator`` from the registry runs the update (``kf`` by default; ``ekf``,
``ukf``, ``ckf`` give the same numbers on this linear model, which the tests check).
"""

from __future__ import annotations

from typing import Any, Literal
from collections.abc import Mapping

import numpy as np
from pydantic import Field, NonNegativeFloat

from gnssframework.errors import ConfigError, InvalidInputError
from gnssframework.estimation import FilterStep, Gaussian, LinearModel
from gnssframework.inertial.calibration import N_CALIBRATION_STATES, calibration_prior_std
from gnssframework.interfaces import ErrorStateNavFilter, IntegrationAiding, RunContext
from gnssframework.plugin import PluginParams
from gnssframework.plugin_ref import PluginRef
from gnssframework.receiver.deep.measurements import POSITION, VELOCITY, integration_measurement, reference_channel

from .range_bias import RangeBiasBudget, RangeBiasStates, budget_assumptions, check_channels, up_vector

__all__ = ["InsEkf", "N_ERROR_STATES"]

#: Size of the error state: attitude, velocity, position, gyro bias, accelerometer bias.
N_ERROR_STATES = 15


class _InsEkfOwnParams(PluginParams):
    estimator: PluginRef("estimator") = Field(
        "kf", description="estimator plugin that runs the error-state filter (kf, ekf, ukf, ckf, svd-ckf)"
    )
    accel_aiding: bool = Field(
        True,
        description="deep integration: predict the NCOs with the line-of-sight "
        "acceleration from the corrected INS (false: the deep-no-accel candidate)",
    )
    carrier_filter: PluginRef("channel_filter", provides=("carrier_freq_hz",)) | None = Field(
        None,
        description="deep integration: a carrier-phase prefilter per channel on a phase discriminator that "
        "closes only the carrier loop on top of the aided replica (e.g. kf-carrier-loop; Cai and Guo's (2017) "
        "carrier-phase filter); nothing of it reaches this filter. Unset: the carrier phase is not tracked",
    )
    clock_psd: tuple[NonNegativeFloat, NonNegativeFloat] = Field(
        (0.1, 0.1), description="white-noise PSDs of the NCO clock filter's bias (m^2/s) and drift (m^2/s^3), each >= 0"
    )
    coupling: Literal["loose", "tight"] = Field(
        "loose",
        description="with scalar tracking loops (no NCO aiding): update on position/velocity fixes (loose) or on "
        "each channel's pseudorange and rate, single-differenced (tight; Groves 2013, section 14.1.3). "
        "Deep integration (a prefilter channel_filter) ignores it",
    )


class ImuCalibrationStates(PluginParams):
    """The IMU's scale factors and misalignments as states: their prior 1-sigma (all zero: none)."""

    gyro_scale_factor_ppm: NonNegativeFloat = Field(
        0.0,
        description="prior 1-sigma of each gyro scale-factor error (ppm). With any of the four IMU calibration "
        "values > 0 the filter carries both triads' 18 scale-factor and misalignment states "
        "(gnssframework.inertial.calibration; 33 INS error states); a value of 0 holds its states at zero",
    )
    accel_scale_factor_ppm: NonNegativeFloat = Field(
        0.0, description="prior 1-sigma of each accelerometer scale-factor error (ppm)"
    )
    gyro_misalignment_mrad: NonNegativeFloat = Field(
        0.0, description="prior 1-sigma of each of the gyro triad's six cross-couplings (mrad)"
    )
    accel_misalignment_mrad: NonNegativeFloat = Field(
        0.0, description="prior 1-sigma of each of the accelerometer triad's six cross-couplings (mrad)"
    )

    def calibration_std(self) -> np.ndarray | None:
        """Prior 1-sigma of the 18 calibration states, or None when the filter carries none."""
        values = (
            self.gyro_scale_factor_ppm,
            self.accel_scale_factor_ppm,
            self.gyro_misalignment_mrad,
            self.accel_misalignment_mrad,
        )
        return calibration_prior_std(*values) if any(v > 0 for v in values) else None


class InsEkfParams(RangeBiasStates, ImuCalibrationStates, _InsEkfOwnParams):
    """ins-ekf's parameters: its own, the IMU calibration states, then the range-error budget
    (`plugins.range_bias`)."""


class InsEkf(ErrorStateNavFilter):
    """15-state closed-loop error-state filter (attitude, velocity, position, gyro and accelerometer biases;
    33 with the IMU's scale factors and misalignments).

    ``reset`` needs the initial error covariance ``initial_cov`` (15x15) in the run
    context; the initial error estimate is zero (the INS's own initial estimate is the
    best guess). ``step(inputs)`` takes

    - ``transition`` ``(runs, n, n)`` and ``process_noise`` ``(runs, n, n)`` of the
      interval since the previous step (``n`` = `error_states`: 15, or 33 with the IMU
      calibration states), and either
    - ``residual_m`` ``(runs, ch, 2)``, ``residual_cov`` ``(runs, ch, 2, 2)``, ``los``
      ``(runs, ch, 3)``, ``cn0_dbhz`` ``(runs, ch)`` (differenced update), or
    - ``position_velocity_error`` ``(runs, 6)`` (INS minus fix, position then velocity)
      and ``position_velocity_cov`` ``(runs, 6, 6)`` (loose update),

    and returns ``error_state`` ``(runs, n)`` (to subtract from the INS) and ``cov``
    (the posterior covariance of the INS error after that correction). With a range-error
    budget an update also takes ``position_m`` ``(runs, 3)`` (the elevations that map the
    ionospheric and tropospheric states), and a loose one ``fix_range_gain``
    ``(runs, 3, ch)`` and ``los`` ``(runs, ch, 3)`` (`receiver.deep.loose.fix_range_gain`);
    the bias states are appended at the first update, for its channels, and ``cov`` stays
    the 15 INS states' marginal.
    """

    name = "ins-ekf"
    description = "15-state error-state INS integration filter, differenced or PV-fix updates (Cai and Guo 2017)"
    Params = InsEkfParams
    params: InsEkfParams  # self.params, as validated
    requires = ("residual_m", "residual_cov")
    provides = ("error_state", "cov")

    def __init__(self, **params: Any) -> None:
        super().__init__(**params)
        p = self.params
        self.engine = p.estimator.create()
        self.filter_step = FilterStep(self.engine, name=f"{self.name} ({self.engine.name})")
        self._calibration_std = p.calibration_std()
        self._n_ins = N_ERROR_STATES + (0 if self._calibration_std is None else N_CALIBRATION_STATES)

    @property
    def error_states(self) -> int:
        """15 INS error states, or 33 with the IMU calibration states."""
        return self._n_ins

    def check_context(self, context: RunContext) -> None:
        """The carrier-phase prefilter runs at the harness's T: check it there, naming its
        parameter under ``carrier_filter.params``."""
        ref = self.params.carrier_filter
        if ref is None:
            return
        inner = ref.create()
        try:
            inner.check_context(context)
        except ConfigError as exc:
            own = f"{inner.kind} {inner.name!r}"
            tail = exc.field[len(own) :] if exc.field.startswith(own) else f".{exc.field}"
            raise ConfigError(f"nav_filter {self.name!r}.carrier_filter.params{tail}", exc.detail) from None

    def reset(self, batch_shape: tuple[int, ...], context: RunContext) -> None:
        who = f"nav_filter {self.name!r}"
        P0 = np.asarray(context.require("initial_cov", who), float)
        if P0.shape[-2:] != (N_ERROR_STATES, N_ERROR_STATES):
            raise InvalidInputError(self.name, "initial_cov", f"must be (..., 15, 15), got {P0.shape}")
        runs = batch_shape[0] if batch_shape else 1
        n = self._n_ins
        P = np.zeros((runs, n, n))
        P[:, :N_ERROR_STATES, :N_ERROR_STATES] = P0
        if self._calibration_std is not None:  # a zero prior holds its state at zero (a floor keeps P factorable)
            P[:, N_ERROR_STATES:, N_ERROR_STATES:] = np.diag(np.maximum(self._calibration_std, 1e-12) ** 2)
        self.state = self.filter_step.start(Gaussian(np.zeros((runs, n)), P))
        self._bias: RangeBiasBudget | None = None  # appended at the first differenced update
        self._interval_s = 0.0  # Gauss-Markov bias states: the interval of its updates (the run context's)
        if self.params.range_bias_time_s is not None and RangeBiasBudget.wanted(self.params):
            self._interval_s = float(
                context.require("epoch_interval_s", f"{who} (range_bias_time_s: its states decay per update)")
            )

    def assumptions(self, context) -> dict[str, tuple[object, str]]:
        """The range-error budget and the IMU calibration states' priors, when they are on."""
        out: dict[str, tuple[object, str]] = dict(budget_assumptions(self.params))
        if self._calibration_std is not None:
            p = self.params
            out["IMU calibration states: gyro, accelerometer scale factor"] = (
                f"{p.gyro_scale_factor_ppm:g}, {p.accel_scale_factor_ppm:g}",
                "ppm",
            )
            out["IMU calibration states: gyro, accelerometer misalignment"] = (
                f"{p.gyro_misalignment_mrad:g}, {p.accel_misalignment_mrad:g}",
                "mrad",
            )
        return out

    def fixed_channel_set(self) -> bool:
        """True with a range-error budget: its SISRE states are appended for the first
        update's channels."""
        return RangeBiasBudget.wanted(self.params)

    def aiding(self) -> IntegrationAiding:
        """The deep-integration options this filter's parameters set."""
        p = self.params
        return IntegrationAiding(
            accel_aiding=p.accel_aiding,
            carrier_filter=p.carrier_filter,
            clock_psd=tuple(p.clock_psd),
            coupling=p.coupling,
        )

    @property
    def cov(self) -> np.ndarray:
        """Covariance of the INS error now (after the last correction): the 15 INS states'
        marginal (the range-bias states, when there are any, follow them in the state)."""
        return self.state.cov[..., :N_ERROR_STATES, :N_ERROR_STATES]

    def _augmented(self, transition: np.ndarray, process_noise: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The INS error model's ``Phi`` and ``Qd`` with the bias states' transition appended."""
        runs, m = self.state.mean.shape[0], self._n_ins
        F, Q = np.asarray(transition, float), np.asarray(process_noise, float)
        for name, value in (("transition", F), ("process_noise", Q)):
            if value.shape[-2:] != (m, m):
                which = "with the IMU calibration states" if m > N_ERROR_STATES else "the INS error states"
                raise InvalidInputError(
                    self.name,
                    name,
                    f"must be (runs, {m}, {m}) ({which}), got {value.shape} at step {self.filter_step.step_index}",
                )
        F, Q = np.broadcast_to(F, (runs, m, m)), np.broadcast_to(Q, (runs, m, m))
        if self._bias is None:
            return F, Q
        n = m + self._bias.size
        psi, q = self._bias.transition(self._interval_s)
        Fa, Qa = np.zeros((runs, n, n)), np.zeros((runs, n, n))
        Fa[:, :m, :m], Qa[:, :m, :m] = F, Q
        Fa[:, m:, m:] = np.diag(psi)
        Qa[:, m:, m:] = np.diag(q)
        return Fa, Qa

    def propagate(self, transition: np.ndarray, process_noise: np.ndarray) -> None:
        """Propagate the covariance without a measurement (the INS part of the mean stays zero
        in closed loop; a Gauss-Markov bias estimate decays)."""
        F, Q = self._augmented(transition, process_noise)
        P = F @ self.state.cov @ np.swapaxes(F, -1, -2) + Q
        mean = np.einsum("rij,rj->ri", F, self.state.mean)
        self.state = Gaussian(mean, 0.5 * (P + np.swapaxes(P, -1, -2)))

    def _start_bias(self, channels: int) -> None:
        """Append the budget's bias states for ``channels`` channels: zero mean, the budget's
        variances, independent of the INS error (`plugins.range_bias.RangeBiasBudget`)."""
        budget = RangeBiasBudget.of(self.params, channels)
        x, P = self.state.mean, self.state.cov
        runs, nb, m = x.shape[0], budget.size, self._n_ins
        n = m + nb
        xa = np.concatenate([x, np.zeros((runs, nb))], axis=-1)
        Pa = np.zeros((runs, n, n))
        Pa[:, :m, :m] = P
        Pa[:, m:, m:] = np.diag(budget.std_m() ** 2)
        self._bias = budget
        self.state = self.filter_step.start(Gaussian(xa, Pa), first_step=self.filter_step.step_index)

    def _range_rows(self, inputs: Mapping[str, np.ndarray], los: np.ndarray) -> np.ndarray | None:
        """How the bias states enter this update's ranges ``(runs, ch, n_b)`` (None without a
        budget), appending them at the first differenced update."""
        if not RangeBiasBudget.wanted(self.params):
            return None
        if "position_m" not in inputs:
            raise InvalidInputError(
                self.name, "position_m", "the INS position is needed with a range-error budget (the elevations)"
            )
        channels = los.shape[-2]
        if self._bias is None:
            self._start_bias(channels)
        assert self._bias is not None
        check_channels(self._bias, channels, f"nav_filter {self.name!r}", self.filter_step.step_index)
        position = np.asarray(inputs["position_m"], float)
        sin_e = np.einsum("rci,ri->rc", los, up_vector(position))
        return self._bias.rows(np.degrees(np.arcsin(np.clip(sin_e, -1.0, 1.0))))

    def _measurement(self, inputs: Mapping[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if "residual_m" in inputs:
            missing = [k for k in ("residual_cov", "los", "cn0_dbhz") if k not in inputs]
            if missing:
                raise InvalidInputError(self.name, ", ".join(missing), "needed with residual_m (differenced update)")
            los = np.asarray(inputs["los"], float)
            return integration_measurement(
                np.asarray(inputs["residual_m"], float),
                np.asarray(inputs["residual_cov"], float),
                los,
                reference_channel(inputs["cn0_dbhz"]),
                n_states=self._n_ins,
                range_rows=self._range_rows(inputs, los),
            )
        if "position_velocity_error" in inputs:
            rows = None
            if RangeBiasBudget.wanted(self.params):
                if "fix_range_gain" not in inputs or "los" not in inputs:
                    raise InvalidInputError(
                        self.name,
                        "fix_range_gain, los",
                        "a loose update with a range-error budget needs how the channels' ranges move the fix "
                        "(receiver.deep.loose.fix_range_gain)",
                    )
                rows = self._range_rows(inputs, np.asarray(inputs["los"], float))
            z = np.asarray(inputs["position_velocity_error"], float)
            R = np.asarray(inputs["position_velocity_cov"], float)
            H = np.zeros(z.shape[:-1] + (6, self.state.mean.shape[-1]))
            H[..., 0:3, POSITION] = np.eye(3)
            H[..., 3:6, VELOCITY] = np.eye(3)
            if rows is not None:  # INS minus fix: the fix carries K M b, so z carries -K M b
                H[..., 0:3, self._n_ins :] = -np.asarray(inputs["fix_range_gain"], float) @ rows
            return z, H, R
        raise InvalidInputError(
            self.name, "inputs", "give residual_m (differenced update) or position_velocity_error (loose update)"
        )

    def _transition(self, inputs: Mapping[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        m = self._n_ins
        return self._augmented(inputs.get("transition", np.eye(m)), inputs.get("process_noise", np.zeros((m, m))))

    def innovation(self, inputs: Mapping[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        """$z - H \\Phi \\hat x$ and $H (\\Phi P \\Phi^T + Q_d) H^T + R$ of ``inputs`` (the range-bias
        states included: their estimate is the only non-zero part of the mean), not updating."""
        z, H, R = self._measurement(inputs)
        F, Q = self._transition(inputs)
        P = F @ self.state.cov @ np.swapaxes(F, -1, -2) + Q
        x = np.einsum("rij,rj->ri", F, self.state.mean)
        return z - np.einsum("rij,rj->ri", H, x), H @ P @ np.swapaxes(H, -1, -2) + R

    def step(self, inputs: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        z, H, R = self._measurement(inputs)  # first: it may append the bias states
        F, Q = self._transition(inputs)
        post = self.filter_step(self.state, z, LinearModel(F=F, H=H, Q=Q, R=R)).posterior
        dx = post.mean[:, : self._n_ins]
        # Closed loop: the caller removes dx from the INS (and its IMU compensation); the INS
        # error estimate restarts at zero, the range-bias estimate (not an INS error) is kept.
        mean = post.mean.copy()
        mean[:, : self._n_ins] = 0.0
        self.state = Gaussian(mean, post.cov)
        return {"error_state": dx, "cov": post.cov[:, :N_ERROR_STATES, :N_ERROR_STATES]}
