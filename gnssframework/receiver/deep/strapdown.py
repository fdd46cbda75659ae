"""The strapdown INS of `gnssframework.inertial` in the deep-integration loop.

`StrapdownIns` is the `ins_navigator.StrapdownSolution` the `InsNavigator` needs: it
mechanises the IMU's (erroneous) increments with `gnssframework.inertial.mechanisation`,
accumulates the 15-state error model's transition and process noise between updates
(`gnssframework.inertial` error-state model), gives the ECEF acceleration for NCO aiding
(Groves 2013, eq. 5.35, from the last velocity increment) and applies closed-loop
corrections. The ``deep-integration`` scenario's runners of the INS candidates are in
`gnssframework.experiments.scenarios.deep_integration_runs`.
"""

from __future__ import annotations

import numpy as np

from ...errors import ConfigError

__all__ = ["StrapdownIns"]


class StrapdownIns:
    """`ins_navigator.StrapdownSolution` on `gnssframework.inertial`: mechanisation, error model, corrections.

    Parameters
    ----------
    state0
        Initial (erroneous) `inertial.mechanisation.NavState`, batch ``(runs,)``.
    dtheta_rad, dv_mps
        Measured IMU increments ``(N, runs, 3)``.
    imu_interval_s
        IMU interval.
    grade
        `inertial.imu.ImuGrade` whose noise the error model propagates.
    calibration
        Carry the IMU's scale factors and misalignments as 18 more error states
        (`inertial.calibration`): the transition and noise handed out are then ``(runs, 33,
        33)``, a correction ``(runs, 33)`` also updates the estimated ``M`` of each triad, and
        the increments are compensated with ``(I + M_hat)^-1``.

    Notes
    -----
    The error state is `inertial.error_model`'s: its transition over each IMU interval is
    the second-order series (``error_state_transition(method="second-order")``; Van Loan
    per 5 ms step and run costs too much), accumulated until the integration update. The
    transitions of all IMU intervals since the last update are evaluated in one vectorised
    call when the filter takes them (`take_error_model`), at the states and specific forces
    each interval had, and multiplied up in order: the same arithmetic as one call per
    interval, without its per-interval Python overhead.
    Closed-loop corrections go through `inertial.error_model.correct_state`, which keeps
    the bias estimates that `compensate_increments` removes from later increments.
    With ``calibration`` the calibration states' coupling ``Gamma`` of each interval is
    accumulated beside the transition (``S <- Phi_k S + Gamma_k``, the top-right block of the
    augmented product) and the augmented matrices are assembled when the filter takes them.
    """

    def __init__(self, state0, dtheta_rad, dv_mps, imu_interval_s: float, grade, calibration: bool = False) -> None:
        from ...inertial import calibration as cal
        from ...inertial import error_model, mechanisation

        self.mech = mechanisation
        self.em = error_model
        self.cal = cal if calibration else None
        self.state = state0
        self.dtheta = np.asarray(dtheta_rad, float)
        self.dv = np.asarray(dv_mps, float)
        self.dt = imu_interval_s
        self.grade = grade
        runs = state0.position_ecef_m.shape[0]
        self.runs = runs
        self.k = 0
        self.prev = (None, None)
        self.gyro_bias = np.zeros((runs, 3))  # bias estimates removed from the increments
        self.accel_bias = np.zeros((runs, 3))
        self.f_b = np.zeros((runs, 3))
        self.w_b = np.zeros((runs, 3))
        self.gyro_cal = np.zeros((runs, 3, 3))  # estimated M of each triad (calibration only)
        self.accel_cal = np.zeros((runs, 3, 3))
        self._reset_model()

    @property
    def error_states(self) -> int:
        """Size of the error state this INS propagates and corrects: 15, or 33 with calibration."""
        return 15 if self.cal is None else 15 + self.cal.N_CALIBRATION_STATES

    def _reset_model(self) -> None:
        self.Phi = np.broadcast_to(np.eye(15), (self.runs, 15, 15)).copy()
        self.Qd = np.zeros((self.runs, 15, 15))
        self.S = None if self.cal is None else np.zeros((self.runs, 15, self.cal.N_CALIBRATION_STATES))
        self._pending: list[tuple] = []  # (state, specific force, rate) of each interval not yet in Phi, Qd

    def _accumulate(self) -> None:
        """Transition and noise of the pending IMU intervals (one batched evaluation), multiplied up in order."""
        if not self._pending:
            return
        states, forces, rates = zip(*self._pending)
        self._pending = []
        stacked = self.mech.NavState(
            np.stack([x.q_b_e for x in states]),
            np.stack([x.velocity_ecef_mps for x in states]),
            np.stack([x.position_ecef_m for x in states]),
        )
        Phi_all, Qd_all = self.em.error_state_transition(
            stacked, np.stack(forces), self.dt, self.grade, method="second-order"
        )
        Gamma_all = None
        if self.cal is not None:
            G = self.cal.calibration_coupling(stacked.q_b_e, np.stack(rates), np.stack(forces))
            Gamma_all = self.cal.calibration_transition(Phi_all, G, self.dt)
        for k, (Phi, Qd) in enumerate(zip(Phi_all, Qd_all)):
            self.Phi = Phi @ self.Phi
            self.Qd = Phi @ self.Qd @ np.swapaxes(Phi, -1, -2) + Qd
            if Gamma_all is not None:
                self.S = Phi @ self.S + Gamma_all[k]

    def advance(self, t_s: float) -> None:
        """Mechanise to ``t_s`` and accumulate the error model's transition and noise."""
        n = int(round(t_s / self.dt))
        if n > self.dtheta.shape[0]:
            raise ConfigError(
                "StrapdownIns", f"no IMU increments beyond {self.dtheta.shape[0] * self.dt} s (asked {t_s} s)"
            )
        while self.k < n:
            dth, dv = self.em.compensate_increments(
                self.dtheta[self.k], self.dv[self.k], self.gyro_bias, self.accel_bias, self.dt
            )
            if self.cal is not None:
                dth = self.cal.compensate_calibration(dth, self.gyro_cal)
                dv = self.cal.compensate_calibration(dv, self.accel_cal)
                self.w_b = dth / self.dt
            self.f_b = dv / self.dt
            self._pending.append((self.state, self.f_b, self.w_b))
            # Increments (from simulate_imu) and state are checked once; a non-finite INS output
            # is caught, named, at the harness's next re-aiding (deep._check_finite).
            self.state = self.mech.strapdown_step_trusted(self.state, dth, dv, self.dt, *self.prev)
            self.prev = (dth, dv)
            self.k += 1

    def kinematics(self):
        """Position, velocity and the ECEF acceleration from the last specific force (Groves 2013, eq. 5.35)."""
        s = self.state
        return (s.position_ecef_m, s.velocity_ecef_mps, self.mech.kinematic_acceleration_ecef(s, self.f_b))

    def take_error_model(self):
        """Transition and process noise since the last take, ``(runs, n, n)`` for ``n`` =
        `error_states` (with calibration: ``[[Phi, S], [0, I]]`` and ``Qd`` padded with zeros)."""
        self._accumulate()
        Phi, Qd, S = self.Phi, self.Qd, self.S
        self._reset_model()
        if S is None:
            return Phi, Qd
        n = self.error_states
        Phi_a = np.broadcast_to(np.eye(n), (self.runs, n, n)).copy()
        Phi_a[:, :15, :15], Phi_a[:, :15, 15:] = Phi, S
        Qd_a = np.zeros((self.runs, n, n))
        Qd_a[:, :15, :15] = Qd
        return Phi_a, Qd_a

    def correct(self, dx: np.ndarray) -> None:
        """Closed-loop correction with an error estimate ``(runs, error_states)``."""
        dx = np.asarray(dx, float)
        if dx.shape[-1] != self.error_states:
            raise ConfigError(
                "StrapdownIns", f"a correction needs {self.error_states} error states, got {dx.shape[-1]}"
            )
        self.state, self.gyro_bias, self.accel_bias = self.em.correct_state(
            self.state, dx[..., :15], self.gyro_bias, self.accel_bias
        )
        if self.cal is not None:
            m = dx[..., 15:]
            self.gyro_cal = self.gyro_cal + m[..., self.cal.GYRO_CALIBRATION].reshape(-1, 3, 3)
            self.accel_cal = self.accel_cal + m[..., self.cal.ACCEL_CALIBRATION].reshape(-1, 3, 3)
