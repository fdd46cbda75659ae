"""NCO aiding for deep integration: line-of-sight kinematics and the replica schedule.

Reference 002 (*Coherent deep GNSS/SINS integration on vector tracking*, eqs. 12-21,
lost in extraction) predicts each channel's code and carrier replica over the next
interval from the corrected INS position, velocity and acceleration and the satellite's
position, velocity and acceleration. The standard forms (Groves 2013, sections 9.4.1
and 16.2.2) are restored here:

$$
\\rho = \\lVert s - r \\rVert + b, \\quad
\\dot\\rho = e \\cdot (\\dot s - \\dot r) + d, \\quad
\\ddot\\rho = e \\cdot (\\ddot s - \\ddot r)
  + \\frac{\\lVert \\dot s - \\dot r \\rVert^2 - (e \\cdot (\\dot s - \\dot r))^2}{\\rho_g}
$$

with $e = (s - r)/\\rho_g$ the unit line of sight from receiver to satellite,
$\\rho_g = \\lVert s - r \\rVert$, $b$ and $d$ the receiver clock bias (m) and drift
(m/s). The second term of $\\ddot\\rho$ is the centripetal part of the line of sight's
rotation (exact derivative of the norm). The simulation's pseudorange has no light-time
or Sagnac term (`gnssframework.receiver.tracking.vector.VectorTruth.pseudorange`), so neither
has the prediction; ionosphere and troposphere are absent from the truth, so the code
and carrier ranges coincide here (002 eqs. 12 and 15 differ only in their sign).

The replica is piecewise linear: an NCO holds a range and a rate over each NCO update
interval. `nco_schedule` places the knots of that piecewise-linear replica on the
predicted polynomial $\\rho_0 + \\dot\\rho_0 \\tau + \\tfrac12 \\ddot\\rho_0 \\tau^2$
(``accel_aiding=True``) or on $\\rho_0 + \\dot\\rho_0 \\tau$ (``False``, the
``deep-no-accel`` candidate), so a line of sight with constant jerk $j$ leaves the
residual $j\\tau^3/6$ (or $\\tfrac12\\ddot\\rho_0\\tau^2 + j\\tau^3/6$) at the knots.
"""

from __future__ import annotations

import numpy as np

from ...errors import ConfigError
from ...navigation.geometry import line_of_sight, range_acceleration, range_rate

__all__ = ["line_of_sight_kinematics", "nco_schedule"]


def line_of_sight_kinematics(
    receiver_pos_m: np.ndarray,
    receiver_vel_m_s: np.ndarray,
    receiver_acc_m_s2: np.ndarray,
    sat_pos_m: np.ndarray,
    sat_vel_m_s: np.ndarray,
    sat_acc_m_s2: np.ndarray,
    clock_bias_m: np.ndarray | float = 0.0,
    clock_drift_m_s: np.ndarray | float = 0.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Pseudorange, its rate and acceleration, and the unit line of sight.

    Parameters
    ----------
    receiver_pos_m, receiver_vel_m_s, receiver_acc_m_s2
        ECEF receiver kinematics ``(runs, 3)`` (the corrected INS, or truth).
    sat_pos_m, sat_vel_m_s, sat_acc_m_s2
        ECEF satellite kinematics ``(channels, 3)`` or ``(runs, channels, 3)``
        (`gnssframework.simulation.constellation.Constellation.state`).
    clock_bias_m, clock_drift_m_s
        Receiver clock ``(runs,)`` or scalar; the clock's acceleration is taken as zero
        (a drift random walk has zero-mean acceleration).

    Returns
    -------
    range_m, range_rate_m_s, range_accel_m_s2
        ``(runs, channels)``.
    los
        ``(runs, channels, 3)`` unit vectors from receiver to satellite.
    """

    def per_channel(receiver: np.ndarray) -> np.ndarray:  # (runs, 3) against (..., channels, 3)
        return np.asarray(receiver)[..., None, :]

    rho_g, e = line_of_sight(sat_pos_m, per_channel(receiver_pos_m))
    rate_g = range_rate(sat_vel_m_s, per_channel(receiver_vel_m_s), e)
    accel = range_acceleration(
        sat_acc_m_s2, per_channel(receiver_acc_m_s2), sat_vel_m_s, per_channel(receiver_vel_m_s), e, rho_g
    )
    bias = np.asarray(clock_bias_m, float)
    drift = np.asarray(clock_drift_m_s, float)
    if bias.ndim:
        bias = bias[..., None]
    if drift.ndim:
        drift = drift[..., None]
    return rho_g + bias, rate_g + drift, accel, e


def nco_schedule(
    range_m: np.ndarray,
    range_rate_m_s: np.ndarray,
    range_accel_m_s2: np.ndarray,
    nco_interval_s: float,
    n_intervals: int,
    *,
    accel_aiding: bool = True,
) -> tuple[np.ndarray, np.ndarray]:
    """Piecewise-linear replica from one aiding instant: NCO range and rate per interval.

    Parameters
    ----------
    range_m, range_rate_m_s, range_accel_m_s2
        Predicted pseudorange kinematics at the aiding instant ``(...)``.
    nco_interval_s
        How long the NCO holds one rate (a multiple of the coherent time, in practice).
    n_intervals
        Number of NCO intervals until the next aiding instant.
    accel_aiding
        Use the range acceleration (Cai and Guo's (2017) proposal) or not.

    Returns
    -------
    nco_range_m, nco_rate_m_s
        ``(n_intervals, ...)``: the replica's range at the start of NCO interval m and
        its constant rate over it (the chord of the predicted polynomial, so every knot
        lies on the polynomial).
    """
    if not nco_interval_s > 0:
        raise ConfigError("nco_interval_s", f"must be > 0, got {nco_interval_s!r}")
    if n_intervals < 1:
        raise ConfigError("n_intervals", f"must be >= 1, got {n_intervals!r}")
    a = np.asarray(range_accel_m_s2, float) if accel_aiding else np.zeros_like(np.asarray(range_m, float))
    tau = np.arange(n_intervals + 1, dtype=float).reshape((-1,) + (1,) * np.ndim(range_m)) * nco_interval_s
    knots = np.asarray(range_m, float) + np.asarray(range_rate_m_s, float) * tau + 0.5 * a * tau**2
    return knots[:-1], np.diff(knots, axis=0) / nco_interval_s
