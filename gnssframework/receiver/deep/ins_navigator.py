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
from ...navigation.geometry import line_of_sight, range_rate
from .loose import fix_gate
from .measurements import POSITION, VELOCITY, integration_measurement, reference_channel
from .navigators import ClockFilter

__all__ = [
    "StrapdownSolution",
    "InsNavigator",
    "exclude_channels",
    "gate_innovation",
    "left_out",
    "loose_update",
    "tight_update",
]


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
    channel_usable
        Optional ``t_s -> (runs, ch)`` bool: the channels an update at ``t_s`` may use (a
        lock detector's verdict; None: all). The others are left out of it
        (`exclude_channels`): their residuals 0, their variances raised by
        `REJECTED_FIX_VAR`, never the reference of the differences.
    """

    def __init__(
        self,
        ins: StrapdownSolution,
        ekf: ErrorStateNavFilter,
        clock: ClockFilter,
        on_update=None,
        pull_in_updates: int = 0,
        channel_usable=None,
    ) -> None:
        self.ins = ins
        self.channel_usable = channel_usable
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
        if self.channel_usable is not None:
            residual_m, residual_cov, cn0_dbhz = exclude_channels(
                self.channel_usable(t_s), residual_m, residual_cov, cn0_dbhz
            )
        out = self.ekf.step(
            {
                "transition": Phi,
                "process_noise": Qd,
                "residual_m": residual_m,
                "residual_cov": residual_cov,
                "los": los,
                "cn0_dbhz": cn0_dbhz,
                "position_m": self.ins.kinematics()[0],  # the elevations of a range-error budget
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


def exclude_channels(
    usable: np.ndarray, residual_m: np.ndarray, residual_cov: np.ndarray, cn0_dbhz: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A differenced update's inputs with the channels not ``usable`` left out.

    ``usable`` ``(runs, ch)`` bool; ``residual_m`` ``(runs, ch, 2)`` range and rate residuals,
    ``residual_cov`` ``(runs, ch, 2, 2)``, ``cn0_dbhz`` ``(runs, ch)`` or ``(ch,)``. A left-out
    channel's residuals become 0 and its variances grow by `REJECTED_FIX_VAR` (its
    difference's gain is then nil: about 1e-12 of a used one's), and its C/N0 -inf, so
    the reference of the differences (`measurements.reference_channel`, the highest C/N0)
    is a used channel. A run that keeps none (a lock detector can lose every channel) has
    every channel left out and keeps its C/N0 values: every difference of its update then
    has nil gain, and the INS coasts in it.
    """
    usable = np.asarray(usable, bool)
    residual, cov = left_out(residual_m, residual_cov, ~usable)
    none = ~usable.any(axis=-1, keepdims=True)
    cn0 = np.where(~usable & ~none, -np.inf, np.broadcast_to(np.asarray(cn0_dbhz, float), usable.shape))
    return residual, cov, cn0


def left_out(z: np.ndarray, cov: np.ndarray, out: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Measurements ``z`` ``(..., m)`` and their covariances ``(..., m, m)`` with the entries
    ``out`` (bool, broadcast to ``z.shape[:-1]``) left out of an update: z 0 and the variances
    raised by `REJECTED_FIX_VAR`, so their gain is nil (about 1e-12 of a used one's). One rule
    for a refused fix (`loose_update`), a refused run (`tight_update`'s gate) and a blocked
    channel (`exclude_channels`)."""
    out = np.asarray(out, bool)
    raised = cov + REJECTED_FIX_VAR * np.eye(z.shape[-1])
    return np.where(out[..., None], 0.0, z), np.where(out[..., None, None], raised, cov)


def gate_innovation(ekf: ErrorStateNavFilter, inputs: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """What an innovation gate tests: the filter's own `ErrorStateNavFilter.innovation`, or,
    for a filter that gives none, the measurement against the 15 INS states' predicted
    covariance $\\Phi P \\Phi^T + Q_d$ (its mean is zero between closed-loop updates)."""
    own = ekf.innovation(inputs)
    if own is not None:
        return own
    if ekf.error_states != 15:
        raise ConfigError(
            f"nav_filter {ekf.name!r}", f"{ekf.error_states} INS error states and no innovation of its own to gate on"
        )
    Phi, Qd = inputs["transition"], inputs["process_noise"]
    P = Phi @ ekf.cov @ np.swapaxes(Phi, -1, -2) + Qd
    if "residual_m" in inputs:
        z, H, R = integration_measurement(
            inputs["residual_m"], inputs["residual_cov"], inputs["los"], reference_channel(inputs["cn0_dbhz"])
        )
        return z, H @ P @ np.swapaxes(H, -1, -2) + R
    idx = np.r_[np.arange(15)[POSITION], np.arange(15)[VELOCITY]]  # z is [position, velocity]
    return inputs["position_velocity_error"], P[:, idx[:, None], idx] + inputs["position_velocity_cov"]


def loose_update(
    ins: StrapdownSolution,
    ekf: ErrorStateNavFilter,
    fix_pos_m: np.ndarray,
    fix_vel_m_s: np.ndarray,
    fix_cov: np.ndarray,
    gate_probability: float = 0.0,
    *,
    range_gain: np.ndarray | None = None,
    los: np.ndarray | None = None,
) -> np.ndarray:
    """One loosely coupled update: INS minus a GNSS position/velocity fix into ``ins-ekf``, then correct.

    ``fix_cov`` ``(runs, 6, 6)`` over [position, velocity]. With ``gate_probability`` > 0 a
    run's fix that fails the chi-square innovation gate (`loose.fix_gate` on
    `gate_innovation`: against the filter's predicted covariance plus
    ``fix_cov``, range-bias states included when the filter has them) is not used: its
    innovation is set to 0 and its covariance raised by `REJECTED_FIX_VAR`. ``range_gain``
    ``(runs, 3, ch)`` and ``los`` ``(runs, ch, 3)`` (`loose.fix_range_gain`): how each
    channel's range error moves the fix, for a filter with range-bias states. Returns the
    applied error estimate.
    """
    Phi, Qd = ins.take_error_model()
    p, v, _ = ins.kinematics()
    z = np.concatenate([p - fix_pos_m, v - fix_vel_m_s], axis=-1)
    inputs = {"transition": Phi, "process_noise": Qd, "position_velocity_error": z, "position_velocity_cov": fix_cov}
    if range_gain is not None:
        if los is None:
            raise ConfigError("loose_update", "range_gain needs the fix's lines of sight (los)")
        inputs.update(fix_range_gain=range_gain, los=los, position_m=fix_pos_m)
    if gate_probability > 0:
        innovation, S = gate_innovation(ekf, inputs)
        accepted = fix_gate(innovation, S, gate_probability)
        inputs["position_velocity_error"], inputs["position_velocity_cov"] = left_out(z, fix_cov, ~accepted)
    out = ekf.step(inputs)
    ins.correct(out["error_state"])
    return out["error_state"]


def tight_update(
    ins: StrapdownSolution,
    ekf: ErrorStateNavFilter,
    range_m: np.ndarray,
    rate_m_s: np.ndarray,
    var_range_m2: np.ndarray,
    var_rate_m2_s2: np.ndarray,
    sat_pos_m: np.ndarray,
    sat_vel_m_s: np.ndarray,
    cn0_dbhz: np.ndarray,
    gate_probability: float = 0.0,
) -> np.ndarray:
    """One tightly coupled update: each channel's pseudorange and rate minus the INS's, differenced, into ``ins-ekf``.

    Tight coupling (Groves 2013, sections 14.1.3 and 14.3.3): the scalar loops' per-channel
    measurements update the INS error state directly, with no position fix between. With
    the INS at $\\hat r, \\hat v$ and channel i's unit line of sight $e_i$ (receiver to
    satellite at $s_i, \\dot s_i$), the residual (measured minus predicted) is

    $$ z_{\\rho,i} = \\tilde\\rho_i - |s_i - \\hat r| = e_i\\cdot\\delta r - \\delta b + w_{\\rho,i}, \\qquad
       z_{\\dot\\rho,i} = \\tilde{\\dot\\rho}_i - e_i\\cdot(\\dot s_i - \\hat v) = e_i\\cdot\\delta v - \\delta d
       + w_{\\dot\\rho,i} $$

    ($\\delta x$ = estimate minus truth, $\\delta b, \\delta d$ the receiver clock's bias and
    drift: the predictions hold no clock). Single differences against the reference channel
    (the highest C/N0), $D z$, cancel the clock; their covariance is $D R D^T$ with $R$ the
    channels' diagonal variances (Groves 2013, section 14.3.3), the update that of the deep
    candidate (`InsNavigator.update`, `measurements.integration_measurement`): rows
    $D[e^T\\;0]$ on position and $D[0\\;e^T]$ on velocity of the 15-state error. Unlike
    `loose_update` it needs no fix: with fewer than four channels it still updates the
    directions their differences see.

    Parameters
    ----------
    range_m, rate_m_s, var_range_m2, var_rate_m2_s2
        ``(runs, ch)`` the scalar loops' pseudoranges (clock included) and range rates and their
        variances (`loose.scalar_measurements`, `loose.scalar_measurement_variances`).
    sat_pos_m, sat_vel_m_s
        ``(ch, 3)`` or ``(runs, ch, 3)`` satellite states at the measurement instant.
    cn0_dbhz
        ``(runs, ch)`` or ``(ch,)``: picks the reference channel.
    gate_probability
        > 0: a run's whole update (all its differences) that fails the chi-square innovation
        gate (`loose.fix_gate` on `gate_innovation`:
        $Dz$ against $DH P^- H^T D^T + D R D^T$, 2(n-1) degrees of freedom, range-bias states
        included when the filter has them) is not used, as `loose_update` refuses a fix: its residuals are set to 0 and
        its variances raised by `REJECTED_FIX_VAR`.

    Returns
    -------
    The applied error estimate ``(runs, ekf.error_states)`` (subtracted from the INS).
    """
    Phi, Qd = ins.take_error_model()
    p, v, _ = ins.kinematics()
    geo, los = line_of_sight(sat_pos_m, p[:, None, :])  # (runs, ch), (runs, ch, 3)
    residual = np.stack([range_m - geo, rate_m_s - range_rate(sat_vel_m_s, v[:, None, :], los)], axis=-1)
    cov = np.zeros(residual.shape + (2,))
    cov[..., 0, 0] = var_range_m2
    cov[..., 1, 1] = var_rate_m2_s2
    cn0 = np.broadcast_to(np.asarray(cn0_dbhz, float), residual.shape[:-1])
    inputs = {
        "transition": Phi,
        "process_noise": Qd,
        "residual_m": residual,
        "residual_cov": cov,
        "los": los,
        "cn0_dbhz": cn0,
        "position_m": p,  # the elevations of a range-error budget
    }
    if gate_probability > 0:  # the filter's innovation: its range-bias states, if any, included
        innovation, S = gate_innovation(ekf, inputs)
        accepted = fix_gate(innovation, S, gate_probability)
        inputs["residual_m"], inputs["residual_cov"] = left_out(residual, cov, ~accepted[:, None])
    out = ekf.step(inputs)
    ins.correct(out["error_state"])
    return out["error_state"]
