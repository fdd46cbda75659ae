"""Strapdown inertial navigation in ECEF from angle and velocity increments.

State: body-to-ECEF quaternion ``q_b^e``, ECEF velocity ``v_eb^e`` and ECEF position
``r_eb^e``, each batched over leading axes (Monte Carlo runs). One call of
:func:`strapdown_step` advances every batch element by one IMU interval; the only
Python loop (in :func:`integrate`) is over time.

References
----------
Groves, *Principles of GNSS, Inertial and Multisensor Integrated Navigation Systems*,
2nd ed., sec. 5.2 (ECEF-frame navigation equations: attitude, specific-force
transformation, velocity and position updates) and sec. 5.5 (precise attitude and
specific-force transformation from increments, coning and sculling). Equation numbers
are not quoted: they could not be checked against the book here. Savage, "Strapdown inertial navigation integration algorithm design,
parts 1-2", J. Guid. Control Dyn. 21(1-2), 1998 (two-sample coning and sculling).
Titterton & Weston, *Strapdown Inertial Navigation Technology*, 2nd ed., sec. 11.2.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from gnssframework.errors import ConfigError
from gnssframework.backend import resolve_backend
from gnssframework.inertial._kernels import HAVE_NUMBA, integrate_kernel
from gnssframework.inertial.earth import WGS84, EarthModel
from gnssframework.inertial.quaternion import (
    cross,
    quat_from_rotvec,
    quat_multiply,
    quat_normalize,
    quat_rotate,
)

__all__ = [
    "NavState",
    "MechanisationOptions",
    "strapdown_step",
    "strapdown_step_trusted",
    "integrate",
    "NavSeries",
    "kinematic_acceleration_ecef",
]

RotationTerm = Literal["exact", "first-order", "none"]


@dataclass(frozen=True)
class NavState:
    """Navigation state, batched over leading axes.

    Attributes
    ----------
    q_b_e
        Body-to-ECEF attitude quaternion, scalar first, shape ``(..., 4)``.
    velocity_ecef_mps
        ``v_eb^e``, shape ``(..., 3)``.
    position_ecef_m
        ``r_eb^e``, shape ``(..., 3)``.
    """

    q_b_e: np.ndarray
    velocity_ecef_mps: np.ndarray
    position_ecef_m: np.ndarray

    def __post_init__(self) -> None:
        q = np.asarray(self.q_b_e, dtype=float)
        v = np.asarray(self.velocity_ecef_mps, dtype=float)
        r = np.asarray(self.position_ecef_m, dtype=float)
        if q.shape[-1:] != (4,) or v.shape[-1:] != (3,) or r.shape[-1:] != (3,):
            raise ConfigError("NavState", f"need q (...,4), v (...,3), r (...,3); got {q.shape}, {v.shape}, {r.shape}")
        object.__setattr__(self, "q_b_e", q)
        object.__setattr__(self, "velocity_ecef_mps", v)
        object.__setattr__(self, "position_ecef_m", r)

    def broadcast(self, batch_shape: tuple[int, ...]) -> NavState:
        """The same state repeated over a batch of runs (copies, so runs can diverge)."""
        return NavState(
            np.broadcast_to(self.q_b_e, batch_shape + (4,)).copy(),
            np.broadcast_to(self.velocity_ecef_mps, batch_shape + (3,)).copy(),
            np.broadcast_to(self.position_ecef_m, batch_shape + (3,)).copy(),
        )


@dataclass(frozen=True)
class MechanisationOptions:
    """Switches of the increment-processing algorithm.

    Attributes
    ----------
    coning
        Two-sample coning correction ``(1/12) dtheta_{k-1} x dtheta_k`` (Savage part 1,
        two-sample form with the previous interval; Groves sec. 5.5).
    sculling
        Two-sample sculling correction ``(1/12)(dtheta_{k-1} x dv_k + dv_{k-1} x dtheta_k)``
        (Savage part 2; Groves sec. 5.5).
    rotation_term
        Velocity-rotation compensation: ``"exact"`` applies the average
        attitude ``I + (1-cos a)/a^2 [alpha x] + (1 - sin a / a)/a^2 [alpha x]^2`` to the
        velocity increment (exact for constant rate and force), ``"first-order"`` the
        classical ``1/2 alpha x dv`` (Savage part 2), ``"none"`` drops it (for the
        test that shows it matters).
    earth
        Earth model (rotation rate, J2 gravity).
    backend
        :func:`integrate`'s loop: ``"numba"`` (compiled) or ``"numpy"`` (the reference,
        :func:`strapdown_step` per time step); a test holds them equal to rounding.
        ``None`` (the default) follows the process-wide choice
        (`gnssframework.backend.get_backend`: ``GNSSFRAMEWORK_BACKEND``, else numba).
    """

    coning: bool = True
    sculling: bool = True
    rotation_term: RotationTerm = "exact"
    earth: EarthModel = WGS84
    backend: Literal["numba", "numpy"] | None = None

    def __post_init__(self) -> None:
        if self.rotation_term not in ("exact", "first-order", "none"):
            raise ConfigError("rotation_term", f"got {self.rotation_term!r}; allowed: 'exact', 'first-order', 'none'")
        if self.backend is not None and (
            self.backend not in ("numba", "numpy") or (self.backend == "numba" and not HAVE_NUMBA)
        ):
            raise ConfigError(
                "backend", f"got {self.backend!r}; allowed: None, 'numpy'" + (", 'numba'" if HAVE_NUMBA else "")
            )

    @property
    def use_compiled(self) -> bool:
        """Whether `integrate` runs the compiled loop: ``backend`` if set, else the
        process-wide choice (`gnssframework.backend.get_backend`, ``GNSSFRAMEWORK_BACKEND``)."""
        return resolve_backend(self.backend, "backend") == "numba"


def _z_rotation_quat(angle_rad: float) -> np.ndarray:
    return np.array([np.cos(0.5 * angle_rad), 0.0, 0.0, np.sin(0.5 * angle_rad)])


def body_increments(
    dtheta_rad: np.ndarray,
    dv_mps: np.ndarray,
    prev_dtheta_rad: np.ndarray | None,
    prev_dv_mps: np.ndarray | None,
    options: MechanisationOptions,
) -> tuple[np.ndarray, np.ndarray]:
    """Attitude rotation vector and velocity increment of one interval, in the start body frame.

    Parameters
    ----------
    dtheta_rad, dv_mps
        Raw gyro and accelerometer increments ``int omega_ib^b dt`` and ``int f_ib^b dt``
        of the interval, ``(..., 3)``.
    prev_dtheta_rad, prev_dv_mps
        The previous interval's raw increments (``None`` on the first step: no correction).

    Returns
    -------
    alpha, dv_body
        Rotation vector ``alpha_ib^b`` (body at end relative to body at start) and the specific-force velocity increment resolved in the start
        body frame (Groves sec. 5.5).
    """
    dtheta_rad = np.asarray(dtheta_rad, dtype=float)
    dv_mps = np.asarray(dv_mps, dtype=float)
    if prev_dtheta_rad is not None:
        prev_dtheta_rad = np.asarray(prev_dtheta_rad, dtype=float)
        prev_dv_mps = np.asarray(prev_dv_mps, dtype=float)
    alpha = dtheta_rad
    dv = dv_mps
    if prev_dtheta_rad is not None and options.coning:
        alpha = dtheta_rad + cross(prev_dtheta_rad, dtheta_rad) / 12.0
    if prev_dtheta_rad is not None and options.sculling:
        dv = dv_mps + (cross(prev_dtheta_rad, dv_mps) + cross(prev_dv_mps, dtheta_rad)) / 12.0
    if options.rotation_term == "first-order":
        dv = dv + 0.5 * cross(alpha, dv_mps)
    elif options.rotation_term == "exact":
        a2 = np.sum(alpha * alpha, axis=-1, keepdims=True)
        small = a2 < 1e-6
        safe2 = np.where(small, 1.0, a2)
        a = np.sqrt(safe2)
        # series of (1 - cos a)/a^2 and (1 - sin a/a)/a^2 to keep full precision near 0
        k1 = np.where(small, 0.5 - a2 / 24.0 + a2 * a2 / 720.0, (1.0 - np.cos(a)) / safe2)
        k2 = np.where(small, 1.0 / 6.0 - a2 / 120.0 + a2 * a2 / 5040.0, (1.0 - np.sin(a) / a) / safe2)
        ax = cross(alpha, dv_mps)
        dv = dv + k1 * ax + k2 * cross(alpha, ax)
    return alpha, dv


def strapdown_step(
    state: NavState,
    dtheta_rad: np.ndarray,
    dv_mps: np.ndarray,
    dt_s: float,
    prev_dtheta_rad: np.ndarray | None = None,
    prev_dv_mps: np.ndarray | None = None,
    options: MechanisationOptions = MechanisationOptions(),
) -> NavState:
    """Advance the ECEF navigation state by one IMU interval.

    Attitude (Groves sec. 5.2/5.5, ECEF form with the Earth rotation over the interval)::

        q_b^e(+) = q_z(-omega_ie dt) (x) q_b^e(-) (x) q(alpha)

    Velocity (Groves sec. 5.2 and 5.5): the body velocity increment is resolved
    with the start attitude and rotated by half the Earth rotation of the interval;
    gravity (J2, at the predicted mid-interval position) and the Coriolis term (at the
    predicted mid-interval velocity) are integrated with the midpoint rule::

        v(+) = v(-) + R_z(-omega_ie dt/2) C_b^e(-) dv_body + (g(r_mid) - 2 omega_ie x v_mid) dt

    Position (Groves sec. 5.2): trapezoid ``r(+) = r(-) + (v(-) + v(+)) dt / 2``.

    Parameters
    ----------
    state
        Navigation state at the start of the interval.
    dtheta_rad, dv_mps
        Raw angle and velocity increments of the interval, ``(..., 3)`` broadcastable
        against the state's batch.
    dt_s
        Interval length (s).
    prev_dtheta_rad, prev_dv_mps
        Previous interval's raw increments for coning and sculling (``None``: first step).
    options
        Algorithm switches, Earth model and backend (``"numba"`` runs the compiled
        kernel for this one step; ``"numpy"`` is the reference below).
    """
    if options.use_compiled:
        dtheta_rad = np.asarray(dtheta_rad, dtype=float)
        dv_mps = np.asarray(dv_mps, dtype=float)
        series = integrate(state, dtheta_rad[None], dv_mps[None], dt_s, options, prev_dtheta_rad, prev_dv_mps)
        return series.at(1)
    return _strapdown_step_numpy(state, dtheta_rad, dv_mps, dt_s, prev_dtheta_rad, prev_dv_mps, options)


def strapdown_step_trusted(
    state: NavState,
    dtheta_rad: np.ndarray,
    dv_mps: np.ndarray,
    dt_s: float,
    prev_dtheta_rad: np.ndarray | None = None,
    prev_dv_mps: np.ndarray | None = None,
    options: MechanisationOptions = MechanisationOptions(),
) -> NavState:
    """`strapdown_step` for a caller that has validated its inputs once (a harness stepping
    an INS every IMU interval): the compiled kernel without `integrate`'s per-call checks.

    The state and increments must be finite, of one batch shape ``(B, 4)`` / ``(B, 3)``
    (a flat batch), ``dt_s > 0``. The arithmetic is `strapdown_step`'s (the same kernel,
    the same bits); with the ``"numpy"`` backend it is `strapdown_step` itself.
    """
    if not options.use_compiled:
        return strapdown_step(state, dtheta_rad, dv_mps, dt_s, prev_dtheta_rad, prev_dv_mps, options)
    has_prev = prev_dtheta_rad is not None
    zero = np.zeros_like(state.velocity_ecef_mps) if not has_prev else None
    qs, vs, rs = integrate_kernel(
        np.ascontiguousarray(state.q_b_e),
        np.ascontiguousarray(state.velocity_ecef_mps),
        np.ascontiguousarray(state.position_ecef_m),
        np.ascontiguousarray(dtheta_rad)[None],
        np.ascontiguousarray(dv_mps)[None],
        zero if zero is not None else np.ascontiguousarray(prev_dtheta_rad),
        zero if zero is not None else np.ascontiguousarray(prev_dv_mps),
        has_prev,
        dt_s,
        options.coning,
        options.sculling,
        options.rotation_term,
        options.earth,
    )
    return NavState(qs[1], vs[1], rs[1])


def _strapdown_step_numpy(state, dtheta_rad, dv_mps, dt_s, prev_dtheta_rad, prev_dv_mps, options):
    earth = options.earth
    alpha, dv_body = body_increments(dtheta_rad, dv_mps, prev_dtheta_rad, prev_dv_mps, options)
    omega = earth.rate_rad_s
    w_ie = earth.rate_vector
    q0, v0, r0 = state.q_b_e, state.velocity_ecef_mps, state.position_ecef_m

    dv_sf = quat_rotate(quat_multiply(_z_rotation_quat(-0.5 * omega * dt_s), q0), dv_body)
    # predictor for the mid-interval velocity and position (second-order midpoint rule)
    v_mid = v0 + 0.5 * (dv_sf + (earth.gravity_ecef(r0) - 2.0 * cross(w_ie, v0)) * dt_s)
    r_mid = r0 + 0.25 * dt_s * (v0 + v_mid)
    v1 = v0 + dv_sf + (earth.gravity_ecef(r_mid) - 2.0 * cross(w_ie, v_mid)) * dt_s
    r1 = r0 + 0.5 * dt_s * (v0 + v1)
    q1 = quat_multiply(_z_rotation_quat(-omega * dt_s), quat_multiply(q0, quat_from_rotvec(alpha)))
    return NavState(quat_normalize(q1), v1, r1)


@dataclass(frozen=True)
class NavSeries:
    """Recorded navigation states, time first: ``q_b_e`` ``(T+1, ..., 4)`` etc.

    Index 0 is the initial state; index k the state after k increments.
    """

    q_b_e: np.ndarray
    velocity_ecef_mps: np.ndarray
    position_ecef_m: np.ndarray

    def at(self, k: int) -> NavState:
        """The state after ``k`` increments."""
        return NavState(self.q_b_e[k], self.velocity_ecef_mps[k], self.position_ecef_m[k])


def integrate(
    state0: NavState,
    dtheta_rad: np.ndarray,
    dv_mps: np.ndarray,
    dt_s: float,
    options: MechanisationOptions = MechanisationOptions(),
    prev_dtheta_rad: np.ndarray | None = None,
    prev_dv_mps: np.ndarray | None = None,
) -> NavSeries:
    """Run :func:`strapdown_step` over a time series of increments.

    Parameters
    ----------
    state0
        Initial state, batch shape ``B`` (e.g. ``(runs,)``).
    dtheta_rad, dv_mps
        Raw increments, time first: ``(T, ..., 3)`` with the trailing batch axes
        broadcastable against ``B`` (a single true series ``(T, 3)`` drives all runs).
    dt_s
        IMU interval (s).
    prev_dtheta_rad, prev_dv_mps
        Increments of the interval before the first one (for the first coning and
        sculling corrections); ``None`` skips the corrections on the first step.

    Returns
    -------
    NavSeries
        ``T + 1`` states, the initial one first.
    """
    dtheta_rad = np.asarray(dtheta_rad, dtype=float)
    dv_mps = np.asarray(dv_mps, dtype=float)
    if dtheta_rad.shape != dv_mps.shape or dtheta_rad.shape[-1] != 3:
        raise ConfigError("increments", f"dtheta {dtheta_rad.shape} and dv {dv_mps.shape} must match, (T, ..., 3)")
    if not np.all(np.isfinite(dtheta_rad)) or not np.all(np.isfinite(dv_mps)):
        raise ConfigError("increments", "non-finite angle or velocity increment")
    if not dt_s > 0:
        raise ConfigError("dt_s", f"must be > 0, got {dt_s}")
    for name, x in (
        ("q_b_e", state0.q_b_e),
        ("velocity_ecef_mps", state0.velocity_ecef_mps),
        ("position_ecef_m", state0.position_ecef_m),
    ):
        if not np.all(np.isfinite(x)):
            bad = np.argwhere(~np.isfinite(x))[0][:-1]
            raise ConfigError(f"state0.{name}", f"non-finite at batch element {tuple(int(i) for i in bad)}")
    n = dtheta_rad.shape[0]
    batch = np.broadcast_shapes(state0.q_b_e.shape[:-1], dtheta_rad.shape[1:-1])
    state = state0.broadcast(batch)
    if options.use_compiled:
        nb = int(np.prod(batch, dtype=int))

        def flat(x, lead=()):
            return np.ascontiguousarray(np.broadcast_to(x, lead + batch + (x.shape[-1],))).reshape(
                lead + (nb, x.shape[-1])
            )

        has_prev = prev_dtheta_rad is not None
        pth = np.zeros(3) if prev_dtheta_rad is None else np.asarray(prev_dtheta_rad, dtype=float)
        pdv = np.zeros(3) if prev_dv_mps is None else np.asarray(prev_dv_mps, dtype=float)
        qs, vs, rs = integrate_kernel(
            flat(state.q_b_e),
            flat(state.velocity_ecef_mps),
            flat(state.position_ecef_m),
            flat(dtheta_rad, (n,)),
            flat(dv_mps, (n,)),
            flat(pth),
            flat(pdv),
            has_prev,
            dt_s,
            options.coning,
            options.sculling,
            options.rotation_term,
            options.earth,
        )
        return NavSeries(
            qs.reshape((n + 1,) + batch + (4,)),
            vs.reshape((n + 1,) + batch + (3,)),
            rs.reshape((n + 1,) + batch + (3,)),
        )
    qs = np.empty((n + 1,) + batch + (4,))
    vs = np.empty((n + 1,) + batch + (3,))
    rs = np.empty((n + 1,) + batch + (3,))
    qs[0], vs[0], rs[0] = state.q_b_e, state.velocity_ecef_mps, state.position_ecef_m
    pth, pdv = prev_dtheta_rad, prev_dv_mps
    for k in range(n):
        state = _strapdown_step_numpy(state, dtheta_rad[k], dv_mps[k], dt_s, pth, pdv, options)
        pth, pdv = dtheta_rad[k], dv_mps[k]
        qs[k + 1], vs[k + 1], rs[k + 1] = state.q_b_e, state.velocity_ecef_mps, state.position_ecef_m
    return NavSeries(qs, vs, rs)


def kinematic_acceleration_ecef(
    state: NavState, specific_force_b_mps2: np.ndarray, earth: EarthModel = WGS84
) -> np.ndarray:
    """ECEF acceleration ``a_eb^e = C_b^e f_ib^b + g^e - 2 Omega_ie v_eb^e`` (Groves sec. 5.2).

    Used by NCO aiding (range acceleration along the line of sight); the specific force
    is e.g. the last velocity increment divided by the interval.
    """
    f_e = quat_rotate(state.q_b_e, specific_force_b_mps2)
    return f_e + earth.gravity_ecef(state.position_ecef_m) - 2.0 * cross(earth.rate_vector, state.velocity_ecef_mps)
