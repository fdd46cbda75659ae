"""Smooth reference trajectories and their exact IMU increments.

A profile is an initial state plus smooth acceleration pulses in the start point's
local ENU frame (fixed to the Earth). Each pulse rises from 0 to its peak with the
quintic "smoothstep" ``10u^3 - 15u^4 + 6u^5`` (zero slope and curvature at both
ends, so acceleration, jerk and snap are continuous; peak jerk
``1.875 * peak / rise_s``), holds, and falls back the same way. Position, velocity,
acceleration and jerk are exact piecewise polynomials (scipy ``BPoly``/``PPoly``
antiderivatives and derivatives); attitude and angular rate follow analytically.

Attitude (``attitude="velocity"``): coordinated flight. Body x (forward) is along the
Earth-referenced velocity; body y (right) is normal to the plane of the velocity and
``a + g0 u0`` (the acceleration plus standard gravity along the start point's up
``u0``), so the apparent specific force has no lateral component; body z (down)
completes the right-handed frame. ``attitude="fixed"``: the body keeps the given
roll/pitch/yaw with respect to the start point's NED frame (static or
constant-velocity tests).

The IMU increments over each interval, ``dtheta = int omega_ib^b dt`` and
``dv = int f_ib^b dt`` (what an ideal integrating IMU outputs: each sample in the
body frame of its own instant), are integrated with Gauss-Legendre quadrature on the
analytic integrands, the attitude at each node evaluated exactly.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
import pymap3d
from pydantic import BaseModel, ConfigDict, Field, model_validator
from scipy.interpolate import BPoly, PPoly
from scipy.spatial.transform import Rotation

from gnssframework.errors import ConfigError
from gnssframework.inertial.earth import STANDARD_GRAVITY_MPS2, WGS84, EarthModel
from gnssframework.inertial.frames import NED_FROM_ENU, enu_to_ecef_matrix

__all__ = [
    "MAX_START_LAT_DEG",
    "AccelerationPulse",
    "TrajectoryProfile",
    "Trajectory",
    "TrajectoryModel",
    "paper_profile",
    "static_profile",
    "constant_velocity_profile",
]


class AccelerationPulse(BaseModel):
    """One smooth acceleration pulse in the start point's ENU frame."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    start_s: float = Field(ge=0.0, description="time the pulse starts rising (s)")
    rise_s: float = Field(gt=0.0, description="rise (and fall) time (s)")
    hold_s: float = Field(ge=0.0, description="time at peak (s)")
    accel_enu_mps2: tuple[float, float, float] = Field(description="peak acceleration, ENU (m/s^2)")

    @property
    def end_s(self) -> float:
        return self.start_s + 2.0 * self.rise_s + self.hold_s


#: Largest |start latitude| of a profile: the flights are integrated in local north/east
#: axes, which degenerate at a pole.
MAX_START_LAT_DEG = 89.0


class TrajectoryProfile(BaseModel):
    """A reference flight: start point, initial ENU velocity, acceleration pulses."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    start_lat_deg: float = Field(ge=-MAX_START_LAT_DEG, le=MAX_START_LAT_DEG)
    start_lon_deg: float = Field(ge=-180.0, le=360.0)
    start_height_m: float = 0.0
    initial_velocity_enu_mps: tuple[float, float, float] = (0.0, 0.0, 0.0)
    duration_s: float = Field(gt=0.0)
    pulses: tuple[AccelerationPulse, ...] = ()
    attitude: Literal["velocity", "fixed"] = "velocity"
    fixed_roll_pitch_yaw_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)

    @model_validator(mode="after")
    def _check(self) -> TrajectoryProfile:
        for i, p in enumerate(self.pulses):
            if p.end_s > self.duration_s:
                raise ConfigError(
                    f"pulses[{i}].start_s", f"pulse ends at {p.end_s} s, after duration_s={self.duration_s}"
                )
        return self


def paper_profile() -> TrajectoryProfile:
    """Reference 002's flight, as this project defines it (the paper's figure was lost).

    Start 34.2300 N, 108.3576 E, 590.6 m; initial velocity (50, 50, 50) m/s read as
    ENU (heading 45 deg, climbing at 35.26 deg); 10 s of unaccelerated straight flight
    (the paper's "level" cannot hold with a 50 m/s up component); then a boost of
    20 g along the initial velocity (rise 1 s, hold 2.13 s: to about 700 m/s) and a
    pull-up of 30 g normal to the initial velocity in its vertical plane (rise 1.25 s,
    hold 0.125 s) that lifts the flight path to about 65 deg; then unaccelerated to
    50 s. Peak jerk 45 g/s (pull-up) and 37.5 g/s (boost), peak acceleration 30 g,
    top speed about 810 m/s: within the paper's 50 g/s, 30 g, 1 km/s.
    """
    g0 = STANDARD_GRAVITY_MPS2
    t0 = np.array([1.0, 1.0, 1.0]) / np.sqrt(3.0)  # along the initial velocity
    n0 = np.array([-0.5, -0.5, 1.0]) / np.sqrt(1.5)  # up-normal in the vertical plane
    boost = AccelerationPulse(start_s=10.0, rise_s=1.0, hold_s=2.13, accel_enu_mps2=tuple(20 * g0 * t0))
    pull_up = AccelerationPulse(start_s=16.0, rise_s=1.25, hold_s=0.125, accel_enu_mps2=tuple(30 * g0 * n0))
    return TrajectoryProfile(
        start_lat_deg=34.2300,
        start_lon_deg=108.3576,
        start_height_m=590.6,
        initial_velocity_enu_mps=(50.0, 50.0, 50.0),
        duration_s=50.0,
        pulses=(boost, pull_up),
    )


def static_profile(
    lat_deg: float,
    lon_deg: float,
    height_m: float,
    duration_s: float,
    roll_pitch_yaw_deg: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> TrajectoryProfile:
    """A body at rest on the rotating Earth with a fixed attitude w.r.t. the start NED frame."""
    return TrajectoryProfile(
        start_lat_deg=lat_deg,
        start_lon_deg=lon_deg,
        start_height_m=height_m,
        duration_s=duration_s,
        attitude="fixed",
        fixed_roll_pitch_yaw_deg=roll_pitch_yaw_deg,
    )


def constant_velocity_profile(
    lat_deg: float, lon_deg: float, height_m: float, velocity_enu_mps: tuple[float, float, float], duration_s: float
) -> TrajectoryProfile:
    """Straight unaccelerated flight (in the start ENU frame), body x along the velocity."""
    return TrajectoryProfile(
        start_lat_deg=lat_deg,
        start_lon_deg=lon_deg,
        start_height_m=height_m,
        initial_velocity_enu_mps=velocity_enu_mps,
        duration_s=duration_s,
    )


@dataclass(frozen=True)
class Trajectory:
    """Truth at given times (time first). Rates and forces are body-frame, ``ib``.

    Attributes
    ----------
    time_s : (T,)
    position_ecef_m, velocity_ecef_mps, acceleration_ecef_mps2, jerk_ecef_mps3 : (T, 3)
        ECEF kinematics relative to the Earth (``r_eb^e`` and its derivatives).
    q_b_e : (T, 4)
        Body-to-ECEF quaternion, scalar first.
    angular_rate_b_rad_s : (T, 3)
        ``omega_ib^b`` (what a gyro senses).
    specific_force_b_mps2 : (T, 3)
        ``f_ib^b`` (what an accelerometer senses).
    """

    time_s: np.ndarray
    position_ecef_m: np.ndarray
    velocity_ecef_mps: np.ndarray
    acceleration_ecef_mps2: np.ndarray
    jerk_ecef_mps3: np.ndarray
    q_b_e: np.ndarray
    angular_rate_b_rad_s: np.ndarray
    specific_force_b_mps2: np.ndarray

    def nav_state(self, k: int = 0):
        """The truth at sample ``k`` as a :class:`~gnssframework.inertial.mechanisation.NavState`."""
        from gnssframework.inertial.mechanisation import NavState

        return NavState(self.q_b_e[k], self.velocity_ecef_mps[k], self.position_ecef_m[k])


def _unit(w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    n = np.linalg.norm(w, axis=-1, keepdims=True)
    return w / n, n


def _unit_rate(u: np.ndarray, norm: np.ndarray, wdot: np.ndarray) -> np.ndarray:
    """d/dt of u = w/|w| given u, |w| and dw/dt."""
    return (wdot - u * np.sum(u * wdot, axis=-1, keepdims=True)) / norm


class TrajectoryModel:
    """Evaluates a :class:`TrajectoryProfile` at any time and integrates its IMU increments.

    Parameters
    ----------
    profile
        The flight.
    earth
        Earth model (rotation rate and J2 gravity enter the specific force and rates).
    """

    def __init__(self, profile: TrajectoryProfile, earth: EarthModel = WGS84) -> None:
        self.profile = profile
        self.earth = earth
        self._c_enu_e = enu_to_ecef_matrix(profile.start_lat_deg, profile.start_lon_deg)
        self._r0 = np.array(pymap3d.geodetic2ecef(profile.start_lat_deg, profile.start_lon_deg, profile.start_height_m))
        self._v0 = np.asarray(profile.initial_velocity_enu_mps, dtype=float)
        self._dirs = np.array([p.accel_enu_mps2 for p in profile.pulses]).reshape(-1, 3)
        shapes = []
        for p in profile.pulses:
            knots = (
                [p.start_s, p.start_s + p.rise_s]
                + ([p.start_s + p.rise_s + p.hold_s] if p.hold_s > 0 else [])
                + [p.end_s]
            )
            vals = [0.0, 1.0] + ([1.0] if p.hold_s > 0 else []) + [0.0]
            xi, yi = list(knots), [[v, 0.0, 0.0] for v in vals]
            if p.start_s > 0:
                xi, yi = [0.0] + xi, [[0.0, 0.0, 0.0]] + yi
            if p.end_s < profile.duration_s:
                xi, yi = xi + [profile.duration_s], yi + [[0.0, 0.0, 0.0]]
            shape = PPoly.from_bernstein_basis(BPoly.from_derivatives(xi, yi))
            # orders: -2 (position), -1 (velocity), 0 (acceleration), 1 (jerk), 2 (snap)
            shapes.append(
                {
                    -2: shape.antiderivative(2),
                    -1: shape.antiderivative(1),
                    0: shape,
                    1: shape.derivative(1),
                    2: shape.derivative(2),
                }
            )
        self._shapes = shapes
        if profile.attitude == "fixed":
            c_b_n = Rotation.from_euler("ZYX", profile.fixed_roll_pitch_yaw_deg[::-1], degrees=True).as_matrix()
            self._c_b_enu_fixed = NED_FROM_ENU @ c_b_n
        else:
            speeds = np.linalg.norm(self._local(np.linspace(0.0, profile.duration_s, 2001))[1], axis=-1)
            if speeds.min() < 1.0:
                raise ConfigError("attitude", "'velocity' attitude needs a speed >= 1 m/s throughout; use 'fixed'")

    def _local(self, t: np.ndarray) -> list[np.ndarray]:
        """ENU position, velocity, acceleration, jerk, snap at times t, each (T, 3)."""
        t = np.asarray(t, dtype=float)
        p = self._v0 * t[:, None]
        v = np.broadcast_to(self._v0, t.shape + (3,)).copy()
        out = [p, v, np.zeros_like(p), np.zeros_like(p), np.zeros_like(p)]
        for d, sh in zip(self._dirs, self._shapes):
            for i, order in enumerate((-2, -1, 0, 1, 2)):
                out[i] = out[i] + sh[order](t)[:, None] * d
        return out

    def _attitude_local(self, v: np.ndarray, a: np.ndarray, j: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """C_b^enu0 (T, 3, 3) and omega_eb^b (T, 3)."""
        if self.profile.attitude == "fixed":
            n = v.shape[0]
            return np.broadcast_to(self._c_b_enu_fixed, (n, 3, 3)), np.zeros((n, 3))
        up = np.array([0.0, 0.0, STANDARD_GRAVITY_MPS2])
        x, vn = _unit(v)
        xd = _unit_rate(x, vn, a)
        w = a + up
        nrm = np.cross(v, w)
        y, nn = _unit(nrm)
        yd = _unit_rate(y, nn, np.cross(a, w) + np.cross(v, j))
        z = np.cross(x, y)
        zd = np.cross(xd, y) + np.cross(x, yd)
        c = np.stack([x, y, z], axis=-1)
        # [omega x] = C^T dC/dt: omega_x = z.y', omega_y = x.z', omega_z = y.x'
        omega = np.stack([np.sum(z * yd, -1), np.sum(x * zd, -1), np.sum(y * xd, -1)], axis=-1)
        return c, omega

    def evaluate(self, time_s: np.ndarray) -> Trajectory:
        """Truth at the given times (s since the profile start)."""
        t = np.atleast_1d(np.asarray(time_s, dtype=float))
        p, v, a, j, _ = self._local(t)
        c = self._c_enu_e
        r_e = self._r0 + p @ c.T
        v_e, a_e, j_e = v @ c.T, a @ c.T, j @ c.T
        c_b_enu, w_eb_b = self._attitude_local(v, a, j)
        c_b_e = c @ c_b_enu
        c_e_b = np.swapaxes(c_b_e, -1, -2)
        w_ie = self.earth.rate_vector
        w_ib_b = w_eb_b + c_e_b @ w_ie
        # f = a + 2 omega_ie x v - g (Groves sec. 5.2, rearranged)
        f_e = a_e + 2.0 * np.cross(w_ie, v_e) - self.earth.gravity_ecef(r_e)
        f_b = np.einsum("tij,tj->ti", c_e_b, f_e)
        q = Rotation.from_matrix(c_b_e).as_quat(scalar_first=True)
        return Trajectory(t, r_e, v_e, a_e, j_e, q, w_ib_b, f_b)

    def increments(self, dt_s: float, n: int, start_s: float = 0.0, nodes: int = 8) -> tuple[np.ndarray, np.ndarray]:
        """Exact IMU increments over ``[start + k dt, start + (k+1) dt]``, ``k < n``.

        Gauss-Legendre quadrature with ``nodes`` points per interval on the analytic
        ``omega_ib^b(t)`` and ``f_ib^b(t)`` (exact for polynomials of degree
        ``2 nodes - 1``; the integrands are smooth within each interval when the pulse
        knots fall on interval boundaries, as for the paper profile at 200 Hz).

        Returns
        -------
        dtheta_rad, dv_mps : (n, 3)
        """
        x, w = np.polynomial.legendre.leggauss(nodes)
        t0 = start_s + dt_s * np.arange(n)
        tn = (t0[:, None] + 0.5 * dt_s * (x + 1.0)).ravel()
        tr = self.evaluate(tn)
        wts = 0.5 * dt_s * w[None, :, None]
        dtheta = np.sum(tr.angular_rate_b_rad_s.reshape(n, nodes, 3) * wts, axis=1)
        dv = np.sum(tr.specific_force_b_mps2.reshape(n, nodes, 3) * wts, axis=1)
        return dtheta, dv
