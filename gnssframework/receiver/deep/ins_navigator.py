"""The INS navigator of deep integration: corrected strapdown INS -> NCO aiding, integration updates -> INS.

Reference 002 (Cai and Guo 2017, section 2) closes the loop of coherent deep integration
through the INS: the corrected INS position, velocity and acceleration predict every
channel's code and carrier (`aiding`), the prefilters' new information of each
integration interval updates the 15-state error-state filter (``ins-ekf``) on
single differences, and the estimated error is removed from the INS at once (closed
loop, Groves 2013, sections 14.1.1 and 16.2). The receiver clock, which the differences
cancel, is kept for the NCOs by a small clock filter beside it
(`navigators.ClockFilter`).

`InsNavigator` is that adapter. It only needs an object with the `StrapdownSolution`
methods (the INS of `gnssframework.inertial` through its adapter, or a linear
error-state stand-in in the tests), so the loop and the mechanisation are tested apart.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from ...errors import ConfigError
from ...interfaces import ErrorStateNavFilter
from .measurements import POSITION, VELOCITY
from .navigators import ClockFilter

__all__ = ["StrapdownSolution", "InsNavigator", "loose_update"]


class StrapdownSolution(Protocol):
    """What the navigator needs from a strapdown INS running on its IMU's increments."""

    def advance(self, t_s: float) -> None:
        """Mechanise forward to ``t_s`` (a multiple of the IMU interval) with the IMU's increments."""

    def kinematics(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """ECEF position, velocity and acceleration ``(runs, 3)`` now."""

    def take_error_model(self) -> tuple[np.ndarray, np.ndarray]:
        """Transition and process noise ``(runs, 15, 15)`` of the error state since the last call."""

    def correct(self, error_state: np.ndarray) -> None:
        """Remove an estimated error ``(runs, 15)`` (estimate minus truth) from the INS."""


class InsNavigator:
    """`aided_tracking.Navigator` built from a strapdown INS, an error-state filter (``ins-ekf``) and a clock filter.

    Parameters
    ----------
    ins
        The strapdown solution (`StrapdownSolution`).
    ekf
        An `~gnssframework.interfaces.ErrorStateNavFilter` (``ins-ekf``), already ``reset``
        with the initial error covariance.
    clock
        The NCOs' clock filter.
    on_update
        Optional callback ``(t_s, navigator)`` after each update (records for metrics).
    pull_in_updates
        First updates whose prefilter output is not used (the INS runs free, the
        covariance propagates): the prefilters pull in from acquisition then. The harness's
        own ``pull_in_updates`` does the same without calling ``update`` at all.
    """

    def __init__(
        self,
        ins: StrapdownSolution,
        ekf: ErrorStateNavFilter,
        clock: ClockFilter,
        on_update=None,
        pull_in_updates: int = 0,
    ) -> None:
        self.ins = ins
        self.ekf = ekf
        self.clock = clock
        self.on_update = on_update
        self.pull_in_updates = pull_in_updates
        self.updates = 0
        self.t = 0.0

    def kinematics(self, t_s: float):
        """Corrected INS position, velocity, acceleration and the clock filter's bias and drift at ``t_s``."""
        if t_s < self.t - 1e-12:
            raise ConfigError("InsNavigator", f"time runs forward only (asked {t_s} s after {self.t} s)")
        self.ins.advance(t_s)
        self.t = t_s
        p, v, a = self.ins.kinematics()
        b, d = self.clock.at(t_s)
        return p, v, a, b, d

    def update(self, t_s: float, residual_m, residual_cov, los, cn0_dbhz) -> None:
        """Differenced integration update, closed-loop INS correction, clock correction."""
        self.ins.advance(t_s)
        self.t = t_s
        self.updates += 1
        if self.updates <= self.pull_in_updates:
            self.ekf.propagate(*self.ins.take_error_model())
            self.clock.predict(t_s)
            if self.on_update is not None:
                self.on_update(t_s, self)
            return
        Phi, Qd = self.ins.take_error_model()
        out = self.ekf.step(
            {
                "transition": Phi,
                "process_noise": Qd,
                "residual_m": residual_m,
                "residual_cov": residual_cov,
                "los": los,
                "cn0_dbhz": cn0_dbhz,
            }
        )
        dx = out["error_state"]
        self.ins.correct(dx)
        self.clock.predict(t_s)
        self.clock.correct(residual_m, residual_cov, los, dx[:, POSITION], dx[:, VELOCITY])
        if self.on_update is not None:
            self.on_update(t_s, self)


#: Variance (m², (m/s)²) added to a fix the innovation gate rejects: its gain is then nil.
REJECTED_FIX_VAR = 1e12


def loose_update(
    ins: StrapdownSolution,
    ekf: ErrorStateNavFilter,
    fix_pos_m: np.ndarray,
    fix_vel_m_s: np.ndarray,
    fix_cov: np.ndarray,
    gate_probability: float = 0.0,
) -> np.ndarray:
    """One loosely coupled update: INS minus a GNSS position/velocity fix into ``ins-ekf``, then correct.

    ``fix_cov`` ``(runs, 6, 6)`` over [position, velocity]. With ``gate_probability`` > 0 a
    run's fix that fails the chi-square innovation gate (`loose.fix_gate`, against the
    filter's predicted covariance plus ``fix_cov``) is not used: its innovation is set to 0
    and its covariance raised by `REJECTED_FIX_VAR`. Returns the applied error estimate.
    """
    Phi, Qd = ins.take_error_model()
    p, v, _ = ins.kinematics()
    z = np.concatenate([p - fix_pos_m, v - fix_vel_m_s], axis=-1)
    if gate_probability > 0:
        from .loose import fix_gate

        idx = np.r_[np.arange(15)[POSITION], np.arange(15)[VELOCITY]]  # z is [position, velocity]
        P = Phi @ ekf.cov @ np.swapaxes(Phi, -1, -2) + Qd
        accepted = fix_gate(z, P[:, idx[:, None], idx] + fix_cov, gate_probability)
        z = np.where(accepted[:, None], z, 0.0)
        fix_cov = np.where(accepted[:, None, None], fix_cov, fix_cov + REJECTED_FIX_VAR * np.eye(6))
    out = ekf.step(
        {"transition": Phi, "process_noise": Qd, "position_velocity_error": z, "position_velocity_cov": fix_cov}
    )
    ins.correct(out["error_state"])
    return out["error_state"]
