"""The strapdown INS of `gnssframework.inertial` in the deep-integration loop, and the scenario's runners.

`StrapdownIns` is the `deep_ins.StrapdownSolution` the `InsNavigator` needs: it
mechanises the IMU's (erroneous) increments with `gnssframework.inertial.mechanisation`,
accumulates the 15-state error model's transition and process noise between updates
(`gnssframework.inertial` error-state model), gives the ECEF acceleration for NCO aiding
(Groves 2013, eq. 5.35, from the last velocity increment) and applies closed-loop
corrections. `run_deep` and `run_loose` are the ``deep-integration`` scenario's runners
of the INS candidates.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import random_streams as draw
from ..errors import ConfigError
from ..interfaces import RunContext
from .deep import DeepTruth, run_aided_tracking
from .deep_ins import InsNavigator, loose_update
from .deep_loose import (correlated_error_inflation, line_of_sight_accel, pv_fix, scalar_measurement_variances,
                         scalar_measurements, scalar_tracking, trailing_rate_measurement)
from .deep_navigators import ClockFilter

__all__ = ["Flight", "make_flight", "StrapdownIns", "run_deep", "run_loose"]


class Flight:
    """Truth of the flight: kinematics at any time and the exact IMU increments."""

    def __init__(self, model: Any) -> None:
        self.model = model

    def kinematics(self, t_s) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """ECEF position, velocity, acceleration, each ``np.shape(t_s) + (3,)``."""
        t = np.asarray(t_s, float)
        tr = self.model.evaluate(t.reshape(-1))
        shape = t.shape + (3,)
        return (tr.position_ecef_m.reshape(shape), tr.velocity_ecef_mps.reshape(shape),
                tr.acceleration_ecef_mps2.reshape(shape))

    def body_to_ned(self, t_s) -> np.ndarray:
        """Body-to-local-level (NED at the true position) DCM ``(T, 3, 3)``."""
        tr = self.model.evaluate(np.atleast_1d(np.asarray(t_s, float)))
        return _body_to_ned(tr.q_b_e, tr.position_ecef_m)

    def truth(self, t_s):
        return self.model.evaluate(np.atleast_1d(np.asarray(t_s, float)))


def _body_to_ned(q_b_e: np.ndarray, position_ecef_m: np.ndarray) -> np.ndarray:
    """C_b^n = C_e^n C_b^e with the NED frame at each position (geodetic latitude, pymap3d)."""
    import pymap3d

    from ..inertial.frames import ned_to_ecef_matrix
    from ..inertial.quaternion import quat_to_dcm

    r = np.broadcast_to(position_ecef_m, q_b_e.shape[:-1] + (3,))
    lat, lon, _ = pymap3d.ecef2geodetic(r[..., 0], r[..., 1], r[..., 2])
    return np.swapaxes(ned_to_ecef_matrix(lat, lon), -1, -2) @ quat_to_dcm(q_b_e)


def make_flight(profile: str, lat_deg: float, lon_deg: float, height_m: float, duration_s: float, *,
                pulse: dict | None = None) -> Flight:
    """Reference 002's pull-up (`inertial.trajectory.paper_profile`, moved to the given start), straight
    flight, or a ``jerk-pulse``: straight flight at (50, 50, 50) m/s ENU with one smooth acceleration
    pulse ``pulse`` = {accel_g, jerk_g_s, start_s, hold_s, direction_enu}, whose rise takes
    ``1.875 * accel / jerk`` so that its peak jerk is ``jerk_g_s`` (`inertial.trajectory`)."""
    from ..inertial.earth import STANDARD_GRAVITY_MPS2
    from ..inertial.trajectory import AccelerationPulse, TrajectoryModel, constant_velocity_profile, paper_profile

    if profile == "pull-up":
        # The whole 50 s flight is defined; a shorter duration_s simulates its first part.
        base = paper_profile()
        prof = base.model_copy(update={"start_lat_deg": lat_deg, "start_lon_deg": lon_deg,
                                       "start_height_m": height_m,
                                       "duration_s": max(duration_s, base.duration_s)})
    elif profile == "straight":
        prof = constant_velocity_profile(lat_deg, lon_deg, height_m, (50.0, 50.0, 50.0), duration_s)
    elif profile == "jerk-pulse":
        q = pulse or {}
        u = np.asarray(q.get("direction_enu", (0.0, 0.0, 1.0)), float)
        u = u / np.linalg.norm(u)
        accel = q.get("accel_g", 20.0) * STANDARD_GRAVITY_MPS2
        rise = 1.875 * q.get("accel_g", 20.0) / q.get("jerk_g_s", 50.0)
        p = AccelerationPulse(start_s=q.get("start_s", 2.0), rise_s=rise, hold_s=q.get("hold_s", 1.0),
                              accel_enu_mps2=tuple(accel * u))
        # As for the pull-up, the whole flight is defined; a shorter duration_s simulates its first part.
        prof = constant_velocity_profile(lat_deg, lon_deg, height_m, (50.0, 50.0, 50.0), max(duration_s, p.end_s))
        prof = prof.model_copy(update={"pulses": (p,)})
    else:
        raise ConfigError("scenario.profile", f"got {profile!r}; allowed: pull-up, straight, jerk-pulse")
    return Flight(TrajectoryModel(prof))


class StrapdownIns:
    """`deep_ins.StrapdownSolution` on `gnssframework.inertial`: mechanisation, error model, corrections.

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
    """

    def __init__(self, state0, dtheta_rad, dv_mps, imu_interval_s: float, grade) -> None:
        from ..inertial import error_model, mechanisation

        self.mech = mechanisation
        self.em = error_model
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
        self._reset_model()

    def _reset_model(self) -> None:
        self.Phi = np.broadcast_to(np.eye(15), (self.runs, 15, 15)).copy()
        self.Qd = np.zeros((self.runs, 15, 15))
        self._pending: list[tuple] = []  # (state, specific force) of each interval not yet in Phi, Qd

    def _accumulate(self) -> None:
        """Transition and noise of the pending IMU intervals (one batched evaluation), multiplied up in order."""
        if not self._pending:
            return
        states, forces = zip(*self._pending)
        self._pending = []
        stacked = self.mech.NavState(np.stack([x.q_b_e for x in states]),
                                     np.stack([x.velocity_ecef_mps for x in states]),
                                     np.stack([x.position_ecef_m for x in states]))
        Phi_all, Qd_all = self.em.error_state_transition(stacked, np.stack(forces), self.dt, self.grade,
                                                         method="second-order")
        for Phi, Qd in zip(Phi_all, Qd_all):
            self.Phi = Phi @ self.Phi
            self.Qd = Phi @ self.Qd @ np.swapaxes(Phi, -1, -2) + Qd

    def advance(self, t_s: float) -> None:
        """Mechanise to ``t_s`` and accumulate the error model's transition and noise."""
        n = int(round(t_s / self.dt))
        if n > self.dtheta.shape[0]:
            raise ConfigError("StrapdownIns", f"no IMU increments beyond {self.dtheta.shape[0] * self.dt} s "
                              f"(asked {t_s} s)")
        while self.k < n:
            dth, dv = self.em.compensate_increments(self.dtheta[self.k], self.dv[self.k], self.gyro_bias,
                                                    self.accel_bias, self.dt)
            self.f_b = dv / self.dt
            self._pending.append((self.state, self.f_b))
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
        self._accumulate()
        out = (self.Phi, self.Qd)
        self._reset_model()
        return out

    def correct(self, dx: np.ndarray) -> None:
        self.state, self.gyro_bias, self.accel_bias = self.em.correct_state(self.state, dx, self.gyro_bias,
                                                                            self.accel_bias)


def _initial_cov(p) -> np.ndarray:
    """Initial covariance of the 15-state error: the scenario's initial errors and the IMU's bias levels
    (random constant plus Gauss-Markov deviation)."""
    g = p.imu
    std = np.concatenate([np.full(3, np.radians(p.initial_attitude_std_deg)), np.full(3, p.initial_velocity_std_m_s),
                          np.full(3, p.initial_position_std_m),
                          np.full(3, np.hypot(g.gyro_bias_rad_s, g.gyro_markov_sigma_rad_s)),
                          np.full(3, np.hypot(g.accel_bias_mps2, g.accel_markov_sigma_mps2))])
    return np.diag(np.maximum(std, 1e-12) ** 2)


def _setup_ins(scenario, flight: Flight, runs: int, rng: np.random.Generator):
    """Measured increments, the INS started from the truth plus drawn initial errors, and P0."""
    from ..inertial.error_model import apply_navigation_error
    from ..inertial.imu import simulate_imu

    p = scenario.params
    n = int(round(p.duration_s / p.imu_interval_s))
    dtheta, dv = flight.model.increments(p.imu_interval_s, n)
    dtheta_m, dv_m, _ = simulate_imu(dtheta[:, None, :], dv[:, None, :], p.imu_interval_s, p.imu, rng, (runs,))
    P0 = _initial_cov(p)
    err0 = draw.standard_normal(rng, (runs, 9), 0) * np.sqrt(np.diag(P0)[:9])
    truth0 = flight.model.evaluate(np.array([0.0])).nav_state(0)
    state0 = apply_navigation_error(truth0.broadcast((runs,)), err0)
    return StrapdownIns(state0, dtheta_m, dv_m, p.imu_interval_s, p.imu), P0


def _nav_record(flight: Flight, t_s: float, ins: StrapdownIns, cov: np.ndarray) -> dict[str, np.ndarray]:
    tr = flight.truth(t_s)
    s = ins.state
    err = np.concatenate([s.velocity_ecef_mps - tr.velocity_ecef_mps[0], s.position_ecef_m - tr.position_ecef_m[0]],
                         -1)
    nees = np.einsum("ri,rij,rj->r", err, np.linalg.inv(cov[:, 3:9, 3:9]), err)
    return {"position_m": s.position_ecef_m.copy(), "velocity_m_s": s.velocity_ecef_mps.copy(),
            "body_to_ned": _body_to_ned(s.q_b_e, s.position_ecef_m), "nees": nees,
            "attitude_cov_ecef": cov[:, 0:3, 0:3].copy()}


def _stack(records: list[dict[str, np.ndarray]], times: list[float], extra: dict[str, np.ndarray]) -> dict:
    out = {k: np.stack([r[k] for r in records]) for k in records[0]}
    out["time_s"] = np.asarray(times)
    out.update(extra)
    return out


def run_deep(scenario, plugins: dict[str, Any], flight: Flight, truth: DeepTruth, runs: int,
             rng: np.random.Generator) -> dict[str, np.ndarray]:
    """The ``deep`` / ``deep-no-accel`` candidates: INS-aided NCOs, prefilters, ``ins-ekf`` on differences."""
    p = scenario.params
    ekf = plugins["nav_filter"]
    ins, P0 = _setup_ins(scenario, flight, runs, rng)
    ekf.reset((runs,), RunContext(initial_cov=P0))
    c_std = np.asarray(p.initial_clock_std_m, float)
    clock = ClockFilter(truth.clock_m[0] + draw.standard_normal(rng, (runs, 2), 0) * c_std, np.diag(c_std**2),
                        tuple(ekf.params.clock_psd))
    records, times = [], []

    def record(t_s, nav):
        records.append(_nav_record(flight, t_s, nav.ins, nav.ekf.cov))
        times.append(t_s)

    nav = InsNavigator(ins, ekf, clock, on_update=record, pull_in_updates=p.pull_in_updates)
    spec = ekf.params.carrier_filter
    rec = run_aided_tracking(plugins["channel_filter"], nav, truth, rng, nco_interval_s=p.nco_interval_s,
                             update_interval_s=p.update_interval_s, accel_aiding=ekf.params.accel_aiding,
                             early_late_spacing_chips=p.early_late_spacing_chips,
                             carrier_filter=None if spec is None else spec.create())
    return _stack(records, times, {"code_error_chips": rec.code_error_chips, "freq_error_hz": rec.freq_error_hz,
                                   **rec.extra})


def run_loose(scenario, plugins: dict[str, Any], flight: Flight, truth: DeepTruth, runs: int,
              rng: np.random.Generator) -> dict[str, np.ndarray]:
    """The ``loose`` candidate: scalar loops, weighted least-squares fixes at the update rate, ``ins-ekf``."""
    p = scenario.params
    T = p.coherent_time_s
    K = truth.epochs
    t_edges = np.arange(K + 1) * T
    sat_pos, sat_vel, sat_acc = truth.sat_state(t_edges)  # (K+1, ch, 3), or (K+1, runs, ch, 3) per run
    r, v, _ = flight.kinematics(t_edges)  # (K+1, 3)
    if sat_pos.ndim == 4:  # a geometry per run: the receiver against each run's satellites
        r, v = r[:, None, None, :], v[:, None, None, :]
    else:
        r, v = r[:, None, :], v[:, None, :]
    d = sat_pos - r
    geo = np.linalg.norm(d, axis=-1)
    rate = np.sum(d / geo[..., None] * (sat_vel - v), axis=-1)
    if sat_pos.ndim == 3:  # shared satellites: add the run axis
        geo, rate = geo[:, None, :], rate[:, None, :]
    rho = geo + truth.clock_m[..., 0:1]  # (K+1, runs, ch)
    rho_rate = rate + truth.clock_m[..., 1:2]
    carrier_rho = None
    if truth.range_error_m is not None:  # errors of the truth the receiver's model lacks
        code_m, carrier_m = truth.range_error_m(t_edges)
        carrier_rho = rho + carrier_m
        rho = rho + code_m
        rho_rate = rho_rate + np.gradient(carrier_m, T, axis=0)  # the carrier's rate is what the loops read
    rho_c = rho if carrier_rho is None else carrier_rho
    channel = plugins["channel_filter"]
    track = scalar_tracking(channel, rho, truth.cn0_dbhz, T, rng,
                            early_late_spacing_chips=p.early_late_spacing_chips, carrier_range_m=carrier_rho)
    cp = channel.params
    window = int(round(p.rate_window_s / T))
    var_r, var_v = scalar_measurement_variances(truth.cn0_dbhz, T, getattr(cp, "dll_bandwidth_hz", 1.0),
                                                getattr(cp, "pll_bandwidth_hz", 15.0), window * T,
                                                p.early_late_spacing_chips)
    if p.loose_dll_correlation == "loop":  # correlated DLL errors between fixes (deep_loose.correlated_error_inflation)
        var_r = var_r * correlated_error_inflation(getattr(cp, "dll_bandwidth_hz", 1.0), p.update_interval_s)
    var_r = np.broadcast_to(var_r, rho.shape[1:])
    var_v = np.broadcast_to(var_v, rho.shape[1:])
    trailing = p.loose_rate_window == "trailing"
    ekf = plugins["nav_filter"]
    ins, P0 = _setup_ins(scenario, flight, runs, rng)
    ekf.reset((runs,), RunContext(initial_cov=P0))
    n_upd = int(round(p.update_interval_s / T))
    records, times = [], []
    for u, k_edge in enumerate(range(n_upd, K + 1, n_upd)):
        t_u = k_edge * T
        ins.advance(t_u)
        if u >= p.pull_in_updates and (k_edge >= window if trailing else k_edge + window // 2 <= K):
            m_rho, m_rate = scalar_measurements(track, rho[k_edge], rho_rate[k_edge], k_edge - 1, window)
            pos0, vel0, acc0 = ins.kinematics()
            if trailing:
                m_rate = trailing_rate_measurement(
                    track, rho_c, k_edge, window, T,
                    line_of_sight_accel(sat_pos[k_edge], sat_acc[k_edge], pos0, acc0))
            fp, fv, fcov = pv_fix(m_rho, m_rate, var_r, var_v, sat_pos[k_edge], sat_vel[k_edge], pos0, vel0)
            loose_update(ins, ekf, fp, fv, fcov, p.loose_gate_probability)
        else:
            ekf.propagate(*ins.take_error_model())
        records.append(_nav_record(flight, t_u, ins, ekf.cov))
        times.append(t_u)
    return _stack(records, times, {"code_error_chips": track.code_error_chips, "freq_error_hz": track.freq_error_hz,
                                   "phase_error_rad": track.phase_error_rad})
