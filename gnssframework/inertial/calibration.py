"""IMU scale-factor and misalignment errors as states of the INS error filter.

`gnssframework.inertial.imu` measures increments through ``I + M`` per triad: the scale
factors on the diagonal, the cross-couplings (axis non-orthogonality and mounting
misalignment) off it (Groves 2nd ed. sec. 4.4.3, eq. 4.18). An INS that estimates ``M``
compensates the bias-corrected increments with its inverse,

    dtheta_c = (I + M_g_hat)^-1 (dtheta - b_g_hat dt),   dv_c = (I + M_a_hat)^-1 (dv - b_a_hat dt),

and the residual error of the compensated rate and specific force is, to first order,

    omega_c - omega = dM_g omega + b_g,       f_c - f = dM_a f + b_a,

with ``dM = M - M_hat`` (measured minus estimated minus truth, the sign of the residual
biases of `gnssframework.inertial.error_model`). Its 18 elements, row-major (gyro then
accelerometer), are random constants appended after the 15 states (Groves 2nd ed. sec.
14.2.6, "additional IMU errors"); they enter the attitude and velocity rates as

    dpsi' += C_b^e W(omega_ib^b) m_g,    dv' += C_b^e W(f_ib^b) m_a,    W(u) = I_3 (x) u^T

(``W(u) m = dM u`` for ``m`` the rows of ``dM``). Over an IMU interval the augmented
transition is ``[[Phi, Gamma], [0, I]]`` with ``Gamma = (I + Phi) / 2 G dt``, equal to the
second-order series ``G dt + F G dt^2 / 2`` of ``error_model`` to its order; being
constants they add no process noise.
"""

from __future__ import annotations

import numpy as np

from gnssframework.inertial.quaternion import quat_to_dcm

__all__ = [
    "N_CALIBRATION_STATES",
    "GYRO_CALIBRATION",
    "ACCEL_CALIBRATION",
    "CALIBRATION_STATE_LABELS",
    "calibration_coupling",
    "calibration_transition",
    "compensate_calibration",
    "calibration_prior_std",
]

#: The 18 states: the gyro triad's dM_g (9, row-major), then the accelerometers' dM_a (9).
N_CALIBRATION_STATES = 18
GYRO_CALIBRATION, ACCEL_CALIBRATION = slice(0, 9), slice(9, 18)
CALIBRATION_STATE_LABELS = tuple(f"m{sensor}_{i}{j}" for sensor in "ga" for i in "xyz" for j in "xyz")


def _rows(u: np.ndarray) -> np.ndarray:
    """``W(u) = I_3 (x) u^T`` ``(..., 3, 9)``: ``W(u) m = dM u`` for ``m`` the rows of ``dM``."""
    out = np.zeros(u.shape[:-1] + (3, 9))
    for i in range(3):
        out[..., i, 3 * i : 3 * i + 3] = u
    return out


def calibration_coupling(q_b_e: np.ndarray, rate_b_rad_s: np.ndarray, force_b_mps2: np.ndarray) -> np.ndarray:
    """Continuous coupling ``G`` ``(..., 15, 18)`` of the calibration states into the 15 INS error states.

    Parameters
    ----------
    q_b_e
        Body-to-ECEF attitude quaternion ``(..., 4)``.
    rate_b_rad_s, force_b_mps2
        Body angular rate ``omega_ib^b`` and specific force ``f_ib^b`` ``(..., 3)`` (the
        compensated increments over their interval).
    """
    c = quat_to_dcm(np.asarray(q_b_e, float))
    w = np.asarray(rate_b_rad_s, float)
    f = np.asarray(force_b_mps2, float)
    batch = np.broadcast_shapes(c.shape[:-2], w.shape[:-1], f.shape[:-1])
    G = np.zeros(batch + (15, N_CALIBRATION_STATES))
    G[..., 0:3, GYRO_CALIBRATION] = c @ _rows(w)
    G[..., 3:6, ACCEL_CALIBRATION] = c @ _rows(f)
    return G


def calibration_transition(phi: np.ndarray, coupling: np.ndarray, dt_s: float) -> np.ndarray:
    """``Gamma = (I + Phi) / 2 G dt`` ``(..., 15, 18)``: the calibration states' effect on the
    INS errors over one interval of transition ``Phi`` (the second-order series' order)."""
    half = 0.5 * (np.eye(15) + phi)
    return (half @ coupling) * dt_s


def compensate_calibration(increment: np.ndarray, estimate: np.ndarray) -> np.ndarray:
    """``(I + M_hat)^-1 increment`` ``(..., 3)`` for the estimated ``M_hat`` ``(..., 3, 3)``."""
    eye = np.eye(3)
    return np.linalg.solve(eye + estimate, np.asarray(increment, float)[..., None])[..., 0]


def calibration_prior_std(
    gyro_scale_factor_ppm: float,
    accel_scale_factor_ppm: float,
    gyro_misalignment_mrad: float,
    accel_misalignment_mrad: float,
) -> np.ndarray:
    """Prior 1-sigma ``(18,)`` of the calibration states: scale factors on each triad's
    diagonal (ppm -> 1e-6), misalignments off it (mrad -> 1e-3), as `inertial.imu` draws them."""
    diag = np.eye(3, dtype=bool).ravel()
    std = np.empty(N_CALIBRATION_STATES)
    std[GYRO_CALIBRATION] = np.where(diag, gyro_scale_factor_ppm * 1e-6, gyro_misalignment_mrad * 1e-3)
    std[ACCEL_CALIBRATION] = np.where(diag, accel_scale_factor_ppm * 1e-6, accel_misalignment_mrad * 1e-3)
    return std
