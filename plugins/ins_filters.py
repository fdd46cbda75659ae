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
from gnssframework.interfaces import ErrorStateNavFilter, IntegrationAiding, RunContext
from gnssframework.plugin import PluginParams
from gnssframework.plugin_ref import PluginRef
from gnssframework.receiver.deep.measurements import POSITION, VELOCITY, integration_measurement, reference_channel

__all__ = ["InsEkf", "N_ERROR_STATES"]

#: Size of the error state: attitude, velocity, position, gyro bias, accelerometer bias.
N_ERROR_STATES = 15


class InsEkfParams(PluginParams):
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


class InsEkf(ErrorStateNavFilter):
    """15-state closed-loop error-state filter (attitude, velocity, position, gyro and accelerometer biases).

    ``reset`` needs the initial error covariance ``initial_cov`` (15x15) in the run
    context; the initial error estimate is zero (the INS's own initial estimate is the
    best guess). ``step(inputs)`` takes

    - ``transition`` ``(runs, 15, 15)`` and ``process_noise`` ``(runs, 15, 15)`` of the
      interval since the previous step, and either
    - ``residual_m`` ``(runs, ch, 2)``, ``residual_cov`` ``(runs, ch, 2, 2)``, ``los``
      ``(runs, ch, 3)``, ``cn0_dbhz`` ``(runs, ch)`` (differenced update), or
    - ``position_velocity_error`` ``(runs, 6)`` (INS minus fix, position then velocity)
      and ``position_velocity_cov`` ``(runs, 6, 6)`` (loose update),

    and returns ``error_state`` ``(runs, 15)`` (to subtract from the INS) and ``cov``
    (the posterior covariance of the INS error after that correction).
    """

    name = "ins-ekf"
    description = "15-state error-state INS integration filter, differenced or PV-fix updates (Cai and Guo 2017)"
    Params = InsEkfParams
    params: InsEkfParams  # self.params, as validated
    requires = ("residual_m", "residual_cov")
    provides = ("error_state", "cov")
    error_states = N_ERROR_STATES

    def __init__(self, **params: Any) -> None:
        super().__init__(**params)
        p = self.params
        self.engine = p.estimator.create()
        self.filter_step = FilterStep(self.engine, name=f"{self.name} ({self.engine.name})")

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
        P0 = np.broadcast_to(P0, (runs, N_ERROR_STATES, N_ERROR_STATES)).copy()
        self.state = self.filter_step.start(Gaussian(np.zeros((runs, N_ERROR_STATES)), P0))

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
        """Covariance of the INS error now (after the last correction)."""
        return self.state.cov

    def propagate(self, transition: np.ndarray, process_noise: np.ndarray) -> None:
        """Propagate the covariance without a measurement (the mean stays zero in closed loop)."""
        F = np.asarray(transition, float)
        P = F @ self.state.cov @ np.swapaxes(F, -1, -2) + process_noise
        self.state = Gaussian(self.state.mean, 0.5 * (P + np.swapaxes(P, -1, -2)))

    def _measurement(self, inputs: Mapping[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if "residual_m" in inputs:
            missing = [k for k in ("residual_cov", "los", "cn0_dbhz") if k not in inputs]
            if missing:
                raise InvalidInputError(self.name, ", ".join(missing), "needed with residual_m (differenced update)")
            return integration_measurement(
                np.asarray(inputs["residual_m"], float),
                np.asarray(inputs["residual_cov"], float),
                np.asarray(inputs["los"], float),
                reference_channel(inputs["cn0_dbhz"]),
                n_states=N_ERROR_STATES,
            )
        if "position_velocity_error" in inputs:
            z = np.asarray(inputs["position_velocity_error"], float)
            R = np.asarray(inputs["position_velocity_cov"], float)
            H = np.zeros(z.shape[:-1] + (6, N_ERROR_STATES))
            H[..., 0:3, POSITION] = np.eye(3)
            H[..., 3:6, VELOCITY] = np.eye(3)
            return z, H, R
        raise InvalidInputError(
            self.name, "inputs", "give residual_m (differenced update) or position_velocity_error (loose update)"
        )

    def step(self, inputs: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        runs = self.state.mean.shape[0]
        F = np.asarray(inputs.get("transition", np.eye(N_ERROR_STATES)), float)
        Q = np.asarray(inputs.get("process_noise", np.zeros((N_ERROR_STATES, N_ERROR_STATES))), float)
        z, H, R = self._measurement(inputs)
        model = LinearModel(
            F=np.broadcast_to(F, (runs, N_ERROR_STATES, N_ERROR_STATES)),
            H=H,
            Q=np.broadcast_to(Q, (runs, N_ERROR_STATES, N_ERROR_STATES)),
            R=R,
        )
        post = self.filter_step(self.state, z, model).posterior
        dx = post.mean
        # Closed loop: the caller removes dx from the INS; the error estimate restarts at zero.
        self.state = Gaussian(np.zeros_like(dx), post.cov)
        return {"error_state": dx, "cov": post.cov}
