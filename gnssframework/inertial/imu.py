"""IMU error model: random constant + first-order Gauss-Markov + white noise, per axis.

For each gyro and accelerometer axis the measured increment over an interval ``dt`` is::

    dtheta_meas = (1 + s_g) dtheta_true + M_g dtheta_true + (b_g + m_g[k]) dt + N_g sqrt(dt) w
    dv_meas     = (1 + s_a) dv_true     + M_a dv_true     + (b_a + m_a[k]) dt + N_a sqrt(dt) w'

with ``b`` a random constant (turn-on bias, one draw per run), ``m`` a first-order
Gauss-Markov process of steady-state deviation ``sigma_m`` and correlation time ``tau``
discretised exactly (the first-order Gauss-Markov process of Brown & Hwang, *Introduction to
Random Signals and Applied Kalman Filtering*; Groves 2nd ed. sec. 4.4)::

    m[k+1] = exp(-dt/tau) m[k] + sigma_m sqrt(1 - exp(-2 dt/tau)) w[k]

started from its stationary distribution, held constant within an interval (``dt/tau``
is 1.7e-5 at 200 Hz), ``N`` the angle / velocity random walk (white rate noise of
two-sided PSD ``N^2``), ``s`` an optional random-constant scale-factor error and ``M``
an optional random-constant cross-coupling matrix (zero diagonal, six independent
off-diagonal small angles: axis non-orthogonality and mounting misalignment, Groves,
*Principles of GNSS, Inertial, and Multisensor Integrated Navigation Systems*, 2nd ed.,
sec. 4.4.3, where scale factors and cross-couplings form ``I + M``). Every draw comes
from the ``numpy.random.Generator`` (or per-run streams) passed in.

Reading of Cai and Guo's (2017) values. The paper gives "random constant drift 0.1 deg/h,
first-order Markov with correlation time 300 s, Gaussian white noise *variance*
0.01 deg/h" for the gyros and "0.1 mg, 300 s, white noise variance 0.01 mg" for the
accelerometers. A variance in deg/h (or mg) is dimensionally wrong and a white-noise
level needs a density; we read them as an angle random walk of 0.01 deg/sqrt(h) and a
velocity random walk of 0.01 mg/sqrt(Hz) (standard deviations of the rate / specific
force densities). The Markov processes' deviation is not stated: we take it equal to
the random constant (0.1 deg/h, 0.1 mg). All are parameters of :class:`ImuGrade`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from gnssframework import random_streams as draw
from gnssframework.errors import ConfigError
from gnssframework.inertial.earth import STANDARD_GRAVITY_MPS2

__all__ = ["ImuGrade", "ImuErrors", "simulate_imu", "gauss_markov"]

_DEG_PER_H = np.pi / 180.0 / 3600.0  # rad/s
_DEG_PER_SQRT_H = np.pi / 180.0 / 60.0  # rad/sqrt(s)
_MG = 1e-3 * STANDARD_GRAVITY_MPS2  # m/s^2


class ImuGrade(BaseModel):
    """IMU error parameters (1-sigma), Cai and Guo's (2017) values as defaults.

    Units are carried by the names; the ``*_si`` properties convert to rad, m, s.
    """

    model_config = ConfigDict(frozen=True, extra="forbid")

    gyro_bias_deg_per_h: float = Field(0.1, ge=0.0, description="random-constant gyro bias")
    gyro_markov_sigma_deg_per_h: float = Field(0.1, ge=0.0, description="Gauss-Markov steady-state deviation")
    gyro_markov_tau_s: float = Field(300.0, gt=0.0, description="Gauss-Markov correlation time")
    gyro_arw_deg_per_sqrt_h: float = Field(0.01, ge=0.0, description="angle random walk")
    gyro_scale_factor_ppm: float = Field(0.0, ge=0.0, description="random-constant scale-factor error")
    accel_bias_mg: float = Field(0.1, ge=0.0, description="random-constant accelerometer bias")
    accel_markov_sigma_mg: float = Field(0.1, ge=0.0, description="Gauss-Markov steady-state deviation")
    accel_markov_tau_s: float = Field(300.0, gt=0.0, description="Gauss-Markov correlation time")
    accel_vrw_mg_per_sqrt_hz: float = Field(0.01, ge=0.0, description="velocity random walk")
    accel_scale_factor_ppm: float = Field(0.0, ge=0.0, description="random-constant scale-factor error")
    gyro_misalignment_mrad: float = Field(
        0.0,
        ge=0.0,
        le=50.0,
        description="random-constant cross-coupling of the gyro triad, 1-sigma of each of the six off-diagonal "
        "elements of its small-angle misalignment matrix M_g in mrad (axis non-orthogonality and mounting "
        "misalignment; Groves 2nd ed. sec. 4.4.3, eq. 4.18); default 0. 1 mrad = 206 arcsec",
    )
    accel_misalignment_mrad: float = Field(
        0.0, ge=0.0, le=50.0, description="the same for the accelerometer triad (M_a), in mrad; default 0"
    )

    @property
    def gyro_bias_rad_s(self) -> float:
        return self.gyro_bias_deg_per_h * _DEG_PER_H

    @property
    def gyro_markov_sigma_rad_s(self) -> float:
        return self.gyro_markov_sigma_deg_per_h * _DEG_PER_H

    @property
    def gyro_arw_rad_per_sqrt_s(self) -> float:
        """Square root of the gyro white-noise PSD (rad/s/sqrt(Hz))."""
        return self.gyro_arw_deg_per_sqrt_h * _DEG_PER_SQRT_H

    @property
    def accel_bias_mps2(self) -> float:
        return self.accel_bias_mg * _MG

    @property
    def accel_markov_sigma_mps2(self) -> float:
        return self.accel_markov_sigma_mg * _MG

    @property
    def accel_vrw_mps_per_sqrt_s(self) -> float:
        """Square root of the accelerometer white-noise PSD (m/s^2/sqrt(Hz))."""
        return self.accel_vrw_mg_per_sqrt_hz * _MG

    @classmethod
    def perfect(cls) -> ImuGrade:
        """An error-free IMU."""
        return cls(
            gyro_bias_deg_per_h=0,
            gyro_markov_sigma_deg_per_h=0,
            gyro_arw_deg_per_sqrt_h=0,
            accel_bias_mg=0,
            accel_markov_sigma_mg=0,
            accel_vrw_mg_per_sqrt_hz=0,
        )


def gauss_markov(
    rng: np.random.Generator, shape: tuple[int, ...], sigma: float, tau_s: float, dt_s: float
) -> np.ndarray:
    """First-order Gauss-Markov samples, time first ``shape = (T, ...)``, stationary start.

    Exact discretisation ``x[k+1] = phi x[k] + sigma sqrt(1 - phi^2) w[k]``,
    ``phi = exp(-dt/tau)``; the recursion runs in ``scipy.signal.lfilter`` over axis 0.
    """
    phi = np.exp(-dt_s / tau_s)
    drive = draw.standard_normal(rng, shape, 1) * (sigma * np.sqrt(1.0 - phi * phi))
    drive[0] = draw.standard_normal(rng, shape[1:], 0) * sigma
    from scipy.signal import lfilter  # here: scipy.signal's import costs every run of the CLI a second

    return lfilter([1.0], [1.0, -phi], drive, axis=0)


@dataclass(frozen=True)
class ImuErrors:
    """The error realisation behind :func:`simulate_imu`'s output (truth for evaluation).

    ``gyro_bias_rad_s`` and ``accel_bias_mps2`` are the slowly varying biases (random
    constant plus Gauss-Markov) per interval, ``(T, *batch, 3)``; scale factors
    ``(*batch, 3)`` (dimensionless).
    """

    gyro_bias_rad_s: np.ndarray
    accel_bias_mps2: np.ndarray
    gyro_scale_factor: np.ndarray
    accel_scale_factor: np.ndarray
    gyro_misalignment: np.ndarray | None = None
    accel_misalignment: np.ndarray | None = None


def simulate_imu(
    dtheta_true_rad: np.ndarray,
    dv_true_mps: np.ndarray,
    dt_s: float,
    grade: ImuGrade,
    rng: np.random.Generator,
    batch_shape: tuple[int, ...] = (),
) -> tuple[np.ndarray, np.ndarray, ImuErrors]:
    """Corrupt true increments with the IMU error model, batched over runs.

    Parameters
    ----------
    dtheta_true_rad, dv_true_mps
        True increments, ``(T, 3)`` (one trajectory for all runs) or ``(T, *batch, 3)``.
    dt_s
        IMU interval (s).
    grade
        Error parameters.
    rng
        Source of every random draw.
    batch_shape
        Run axes, e.g. ``(runs,)``.

    Returns
    -------
    dtheta_meas_rad, dv_meas_mps : (T, *batch, 3)
    errors : ImuErrors
    """
    if not dt_s > 0:
        raise ConfigError("dt_s", f"must be > 0, got {dt_s}")
    dtheta_true_rad = np.asarray(dtheta_true_rad, dtype=float)
    dv_true_mps = np.asarray(dv_true_mps, dtype=float)
    n = dtheta_true_rad.shape[0]
    if dtheta_true_rad.ndim == 2:  # one trajectory for every run: add the run axes
        dtheta_true_rad = dtheta_true_rad.reshape((n,) + (1,) * len(batch_shape) + (3,))
        dv_true_mps = dv_true_mps.reshape((n,) + (1,) * len(batch_shape) + (3,))
    shape = (n,) + tuple(batch_shape) + (3,)
    const_shape = tuple(batch_shape) + (3,)

    def sensor(true, bias, sigma_m, tau, white, sf_ppm):
        b = draw.standard_normal(rng, const_shape, 0) * bias
        m = gauss_markov(rng, shape, sigma_m, tau, dt_s) if sigma_m > 0 else np.zeros(shape)
        s = draw.standard_normal(rng, const_shape, 0) * sf_ppm * 1e-6
        w = draw.standard_normal(rng, shape, 1) * (white * np.sqrt(dt_s))
        slow = b + m
        return (1.0 + s) * true + slow * dt_s + w, slow, s

    dth, bg, sg = sensor(
        dtheta_true_rad,
        grade.gyro_bias_rad_s,
        grade.gyro_markov_sigma_rad_s,
        grade.gyro_markov_tau_s,
        grade.gyro_arw_rad_per_sqrt_s,
        grade.gyro_scale_factor_ppm,
    )
    dv, ba, sa = sensor(
        dv_true_mps,
        grade.accel_bias_mps2,
        grade.accel_markov_sigma_mps2,
        grade.accel_markov_tau_s,
        grade.accel_vrw_mps_per_sqrt_s,
        grade.accel_scale_factor_ppm,
    )
    # Cross-axis coupling, drawn after every other error so that a grade without it draws
    # the same numbers as before it existed: measured += M true, M with a zero diagonal.
    # With per-run streams from a child stream, so that switching it on shifts no later draw
    # of the run (a case with it and one without are then on common random numbers).
    cross = draw.child(rng, "imu-misalignment")
    mg = _misalignment(cross, const_shape, grade.gyro_misalignment_mrad)
    ma = _misalignment(cross, const_shape, grade.accel_misalignment_mrad)
    if mg is not None:
        dth = dth + np.einsum("...ij,...j->...i", mg, np.broadcast_to(dtheta_true_rad, shape))
    if ma is not None:
        dv = dv + np.einsum("...ij,...j->...i", ma, np.broadcast_to(dv_true_mps, shape))
    return dth, dv, ImuErrors(bg, ba, sg, sa, mg, ma)


def _misalignment(rng, const_shape: tuple[int, ...], sigma_mrad: float) -> np.ndarray | None:
    """Random-constant small-angle misalignment matrices ``(*batch, 3, 3)``: six independent
    off-diagonal elements of deviation ``sigma_mrad`` (1e-3 rad), zero diagonal (the scale
    factors are separate), or None when ``sigma_mrad`` is 0 (nothing drawn)."""
    if sigma_mrad <= 0:
        return None
    off = draw.standard_normal(rng, const_shape[:-1] + (6,), 0) * (sigma_mrad * 1e-3)
    m = np.zeros(const_shape[:-1] + (3, 3))
    rows, cols = np.nonzero(~np.eye(3, dtype=bool))
    m[..., rows, cols] = off
    return m
