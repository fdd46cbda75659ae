"""15-state INS error model in ECEF: system matrix, discretisation, closed-loop correction.

Error state (order and signs used everywhere in the framework)::

    dx = [dpsi (0:3), dv (3:6), dr (6:9), b_g (9:12), b_a (12:15)]

* ``dpsi`` (rad): attitude error resolved in ECEF, defined by
  ``C_b^e(estimate) = (I + [dpsi x]) C_b^e(true)``, i.e. the rotation vector of
  ``q_est (x) q_true*`` (Groves 2nd ed. sec. 5.6.1 / 14.2.1).
* ``dv = v_est - v_true`` (m/s), ``dr = r_est - r_true`` (m), ECEF.
* ``b_g`` (rad/s), ``b_a`` (m/s^2): residual gyro and accelerometer biases of the
  *compensated* IMU output (measured minus estimated bias, minus truth), body frame.

Continuous dynamics (Groves 2nd ed. sec. 14.2.3, ECEF form)::

    dpsi' = -Omega_ie dpsi + C_b^e b_g + C_b^e w_g
    dv'   = -[(C_b^e f_ib^b) x] dpsi - 2 Omega_ie dv + G dr + C_b^e b_a + C_b^e w_a
    dr'   = dv
    b'    = -b / tau + w_b             (first-order Gauss-Markov; tau = None: constant)

``G = d g / d r`` is the gravity gradient. Groves keeps only its radial part
(``2 g / r u u^T``), which is fine under frequent aiding but removes the Schuler
loop; the default ``gravity_gradient="full"`` keeps the horizontal ``-g/r`` terms so
that the free-inertial error model reproduces the Schuler oscillation.

Closed-loop correction (Groves 2nd ed. sec. 14.1.1 / 14.2.7): subtract the estimated
errors from the navigation solution, ``C <- (I - [dpsi x]) C`` (applied exactly as
the rotation ``q <- q(-dpsi) (x) q``), ``v <- v - dv``, ``r <- r - dr``; add the
estimated residual biases to the bias estimates (``b_hat <- b_hat + b``); then reset
those states of the filter to zero.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from gnssframework.errors import ConfigError
from gnssframework.inertial.earth import WGS84, EarthModel
from gnssframework.inertial.imu import ImuGrade
from gnssframework.inertial.mechanisation import NavState
from gnssframework.inertial.quaternion import (
    quat_conjugate,
    quat_from_rotvec,
    quat_multiply,
    quat_normalize,
    quat_to_dcm,
    quat_to_rotvec,
    quat_rotate,
)

__all__ = [
    "ERROR_STATE_LABELS",
    "ATTITUDE",
    "VELOCITY",
    "POSITION",
    "GYRO_BIAS",
    "ACCEL_BIAS",
    "error_state_matrices",
    "error_state_transition",
    "navigation_error",
    "apply_navigation_error",
    "correct_state",
    "compensate_increments",
]

ATTITUDE, VELOCITY, POSITION, GYRO_BIAS, ACCEL_BIAS = (
    slice(0, 3),
    slice(3, 6),
    slice(6, 9),
    slice(9, 12),
    slice(12, 15),
)
ERROR_STATE_LABELS = tuple(f"{name}_{axis}" for name in ("dpsi", "dv", "dr") for axis in "xyz") + tuple(
    f"{name}_{axis}" for name in ("bg", "ba") for axis in "xyz"
)


def _skew(v: np.ndarray) -> np.ndarray:
    out = np.zeros(v.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out


def error_state_matrices(
    state: NavState,
    specific_force_b_mps2: np.ndarray,
    grade: ImuGrade,
    *,
    earth: EarthModel = WGS84,
    bias_model: Literal["markov", "constant"] = "markov",
    gravity_gradient: Literal["full", "radial"] = "full",
) -> tuple[np.ndarray, np.ndarray]:
    """Continuous system matrix ``F`` and noise ``G Q_c G^T`` of the 15-state model.

    Parameters
    ----------
    state
        Navigation state (estimate) at which to linearise, batch ``B``.
    specific_force_b_mps2
        Body specific force ``f_ib^b`` (``(B, 3)``), e.g. last ``dv / dt``.
    grade
        IMU noise densities (white: ARW/VRW) and bias processes (Gauss-Markov sigma, tau).
    bias_model
        ``"markov"``: biases decay with the grade's ``tau`` and are driven with PSD
        ``2 sigma_m^2 / tau``; ``"constant"``: random constants (no decay, no drive).
    gravity_gradient
        ``"full"`` or ``"radial"`` (see module docstring).

    Returns
    -------
    F, Qc : (B, 15, 15)
    """
    if bias_model not in ("markov", "constant"):
        raise ConfigError("bias_model", f"got {bias_model!r}; allowed: 'markov', 'constant'")
    q = state.q_b_e
    c = quat_to_dcm(q)
    f_e = quat_rotate(q, np.asarray(specific_force_b_mps2, dtype=float))
    batch = np.broadcast_shapes(q.shape[:-1], f_e.shape[:-1], state.position_ecef_m.shape[:-1])
    c = np.broadcast_to(c, batch + (3, 3))
    om = _skew(earth.rate_vector)
    F = np.zeros(batch + (15, 15))
    F[..., ATTITUDE, ATTITUDE] = -om
    F[..., ATTITUDE, GYRO_BIAS] = c
    F[..., VELOCITY, ATTITUDE] = -_skew(np.broadcast_to(f_e, batch + (3,)))
    F[..., VELOCITY, VELOCITY] = -2.0 * om
    F[..., VELOCITY, POSITION] = earth.gravity_gradient(
        np.broadcast_to(state.position_ecef_m, batch + (3,)), gravity_gradient
    )
    F[..., VELOCITY, ACCEL_BIAS] = c
    F[..., POSITION, VELOCITY] = np.eye(3)
    Qc = np.zeros(batch + (15, 15))
    # C diag(s) C^T = s I for an isotropic density: white noise enters resolved in ECEF
    Qc[..., ATTITUDE, ATTITUDE] = grade.gyro_arw_rad_per_sqrt_s**2 * np.eye(3)
    Qc[..., VELOCITY, VELOCITY] = grade.accel_vrw_mps_per_sqrt_s**2 * np.eye(3)
    if bias_model == "markov":
        F[..., GYRO_BIAS, GYRO_BIAS] = -np.eye(3) / grade.gyro_markov_tau_s
        F[..., ACCEL_BIAS, ACCEL_BIAS] = -np.eye(3) / grade.accel_markov_tau_s
        Qc[..., GYRO_BIAS, GYRO_BIAS] = 2.0 * grade.gyro_markov_sigma_rad_s**2 / grade.gyro_markov_tau_s * np.eye(3)
        Qc[..., ACCEL_BIAS, ACCEL_BIAS] = 2.0 * grade.accel_markov_sigma_mps2**2 / grade.accel_markov_tau_s * np.eye(3)
    return F, Qc


def _expm(M: np.ndarray) -> np.ndarray:
    """Batched matrix exponential: scaling and squaring with a degree-12 Taylor polynomial.

    ``scipy.linalg.expm`` on a stack of small matrices costs about 10 ms per matrix
    (Python-level Pade per element); this is vectorised over the stack. After scaling,
    ``||M|| <= 1/2`` so the truncation error is below ``0.5^13 / 13! < 2e-14`` (relative);
    a test holds it to ``scipy.linalg.expm``.
    """
    norm = np.max(np.sum(np.abs(M), axis=-1), axis=-1)  # infinity norm per matrix
    squarings = int(max(0, np.ceil(np.log2(max(float(np.max(norm)), 1e-300) / 0.5))))
    A = M / 2.0**squarings
    eye = np.eye(M.shape[-1])
    E = eye + A / 12.0
    for k in range(11, 0, -1):  # Horner: I + A/1 (I + A/2 (I + ... (I + A/12)))
        E = eye + (A @ E) / k
    for _ in range(squarings):
        E = E @ E
    return E


def error_state_transition(
    state: NavState,
    specific_force_b_mps2: np.ndarray,
    dt_s: float,
    grade: ImuGrade,
    *,
    earth: EarthModel = WGS84,
    method: Literal["van-loan", "second-order"] = "van-loan",
    bias_model: Literal["markov", "constant"] = "markov",
    gravity_gradient: Literal["full", "radial"] = "full",
) -> tuple[np.ndarray, np.ndarray]:
    """Discrete transition ``Phi`` and process noise ``Q_d`` over ``dt_s``, batched.

    ``"van-loan"``: exact for ``F`` and ``Q_c`` constant over the interval (Van Loan,
    "Computing integrals involving the matrix exponential", IEEE TAC 23(3), 1978):
    ``expm([[-F, Qc], [0, F^T]] dt) = [[., Phi^-1 Qd], [0, Phi^T]]``.
    ``"second-order"``: ``Phi = I + F dt + (F dt)^2 / 2`` and
    ``Qd = Qc dt + (F Qc + Qc F^T) dt^2 / 2`` (the truncated series, Groves 2nd ed.
    sec. 3.2.4 and 14.2.4).

    Returns
    -------
    Phi, Qd : (B, 15, 15)
    """
    if not dt_s > 0:
        raise ConfigError("dt_s", f"must be > 0, got {dt_s}")
    F, Qc = error_state_matrices(
        state, specific_force_b_mps2, grade, earth=earth, bias_model=bias_model, gravity_gradient=gravity_gradient
    )
    if method == "second-order":
        Fd = F * dt_s
        Phi = np.eye(15) + Fd + Fd @ Fd / 2.0
        FQ = F @ Qc
        Qd = Qc * dt_s + (FQ + np.swapaxes(FQ, -1, -2)) * dt_s**2 / 2.0
        return Phi, Qd
    if method != "van-loan":
        raise ConfigError("method", f"got {method!r}; allowed: 'van-loan', 'second-order'")
    n = 15
    M = np.zeros(F.shape[:-2] + (2 * n, 2 * n))
    M[..., :n, :n] = -F
    M[..., :n, n:] = Qc
    M[..., n:, n:] = np.swapaxes(F, -1, -2)
    E = _expm(M * dt_s)
    Phi = np.swapaxes(E[..., n:, n:], -1, -2)
    Qd = Phi @ E[..., :n, n:]
    return Phi, 0.5 * (Qd + np.swapaxes(Qd, -1, -2))


def navigation_error(estimate: NavState, truth: NavState) -> np.ndarray:
    """The 9-state navigation error ``[dpsi, dv, dr]`` of ``estimate`` w.r.t. ``truth`` (``(..., 9)``)."""
    dpsi = quat_to_rotvec(quat_multiply(estimate.q_b_e, quat_conjugate(truth.q_b_e)))
    return np.concatenate(
        [dpsi, estimate.velocity_ecef_mps - truth.velocity_ecef_mps, estimate.position_ecef_m - truth.position_ecef_m],
        axis=-1,
    )


def apply_navigation_error(truth: NavState, error: np.ndarray) -> NavState:
    """A state whose :func:`navigation_error` w.r.t. ``truth`` is ``error[..., :9]`` (exact inverse)."""
    error = np.asarray(error, dtype=float)
    q = quat_multiply(quat_from_rotvec(error[..., ATTITUDE]), truth.q_b_e)
    return NavState(
        quat_normalize(q), truth.velocity_ecef_mps + error[..., VELOCITY], truth.position_ecef_m + error[..., POSITION]
    )


def correct_state(
    state: NavState, dx: np.ndarray, gyro_bias_rad_s: np.ndarray, accel_bias_mps2: np.ndarray
) -> tuple[NavState, np.ndarray, np.ndarray]:
    """Closed-loop correction with a 15-state error estimate (batched).

    Parameters
    ----------
    state
        INS solution before the correction.
    dx
        Estimated error state ``(..., 15)`` in this module's convention.
    gyro_bias_rad_s, accel_bias_mps2
        Current bias estimates subtracted from the raw IMU output (``(..., 3)``).

    Returns
    -------
    state, gyro_bias_rad_s, accel_bias_mps2
        Corrected solution and updated bias estimates. The filter's error state must
        then be reset to zero (its covariance is unchanged to first order).
    """
    dx = np.asarray(dx, dtype=float)
    q = quat_multiply(quat_from_rotvec(-dx[..., ATTITUDE]), state.q_b_e)
    corrected = NavState(
        quat_normalize(q), state.velocity_ecef_mps - dx[..., VELOCITY], state.position_ecef_m - dx[..., POSITION]
    )
    return corrected, gyro_bias_rad_s + dx[..., GYRO_BIAS], accel_bias_mps2 + dx[..., ACCEL_BIAS]


def compensate_increments(
    dtheta_rad: np.ndarray, dv_mps: np.ndarray, gyro_bias_rad_s: np.ndarray, accel_bias_mps2: np.ndarray, dt_s: float
) -> tuple[np.ndarray, np.ndarray]:
    """Raw increments minus the estimated biases times the interval."""
    return dtheta_rad - gyro_bias_rad_s * dt_s, dv_mps - accel_bias_mps2 * dt_s
