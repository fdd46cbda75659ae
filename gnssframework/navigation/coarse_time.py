r"""Coarse-time navigation: a position fix whose transmit times share an unknown offset.

A receiver that knows its time only roughly (an assisted start, a snapshot) resolves each
code phase's whole periods from an approximate position and time, so the transmit times
it gets are right *relative to one another* but all off by one common error
:math:`\delta`. The pseudoranges are not harmed (the common part goes into the receiver
clock); the satellite positions are, since each is computed :math:`\delta` away from its
true transmit time. To first order the range to satellite :math:`i` then errs by
:math:`\dot\rho_i \delta`, with :math:`\dot\rho_i = u_i \cdot v_i` the satellite's range
rate seen from the receiver (up to ~800 m/s: 1.6 km at 2 s). The fix takes
:math:`\delta` as a fifth state (van Diggelen, *A-GPS: Assisted GPS, GNSS and SBAS*, 2009,
ch. 4, "coarse-time navigation"):

.. math::

    \rho_i = \lVert s_i(t_i + \delta) - r \rVert + b - c\,\Delta t_{SV,i}(t_i + \delta)
             + \text{atmosphere}, \qquad
    H_i = \begin{bmatrix} -u_i^T & 1 & u_i \cdot v_i - c\,\Delta\dot t_{SV,i} \end{bmatrix}.

It needs five satellites, and :math:`\delta` is observable only through how the range
rates differ between satellites: its standard deviation is
:math:`\sigma_\delta = (\dot\rho_\perp^T W \dot\rho_\perp)^{-1/2}`, where
:math:`\dot\rho_\perp` is the range-rate column less its weighted projection on the
position and clock columns. With 100 m pseudoranges (code phases at the end of a pull-in)
that is of the order of 0.1 s; with metre-level ones, milliseconds.

Here each Gauss-Newton step solves the four-state fix (`pvt.solve_position`, so the
satellite clock, Earth rotation, Klobuchar and troposphere models are the same) at the
current :math:`\delta`, and the range-rate column's regression on its residuals gives the
step of :math:`\delta` (the Frisch-Waugh-Lovell theorem: identical to the five-state
least squares).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError
from ..signal.gps_l1ca import GPS_L1CA
from ..signal.spec import SPEED_OF_LIGHT_M_S as _C
from ..signal.spec import SignalSpec
from .ephemeris import Ephemerides, satellite_state
from .lnav import IonoUtc
from .pvt import PositionFix, solve_position

__all__ = ["CoarseTimeFix", "off_geometry", "solve_coarse_time"]

#: A sigma that no residual reaches: the four-state fixes inside the iteration run without
#: their residual test (a time error makes every residual large; excluding a satellite
#: for it would be wrong). The weights' relative sizes, all the fix uses, do not change.
_NO_TEST_SIGMA_M = 1e12


@dataclass(frozen=True)
class CoarseTimeFix:
    """A fix with its time offset (`solve_coarse_time`).

    ``fix`` the four-state `PositionFix` at the corrected transmit times
    (``transmit_s + time_offset_s``), with its residual test at the ``sigma_m`` given;
    ``time_offset_s`` the common offset :math:`\\delta` to add to every transmit time (and
    to the receiver's time: true time minus the time assumed); ``time_offset_sigma_s`` its
    standard deviation at ``sigma_m``; ``range_rate_mps`` ``(S,)`` each satellite's
    :math:`\\dot\\rho_i` (NaN where not used); ``iterations`` the Gauss-Newton steps taken.
    """

    fix: PositionFix
    time_offset_s: float
    time_offset_sigma_s: float
    range_rate_mps: np.ndarray
    iterations: int


def _range_rates(
    ephemeris: Ephemerides, transmit_s: np.ndarray, receiver_ecef_m: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """:math:`u_i \\cdot v_i - c\\,\\Delta\\dot t_{SV,i}` at the transmit times, and the unit
    vectors :math:`u_i` ``(S, 3)`` (the Earth's rotation over the flight time, 1e-6 of the
    rate, is left out of this column)."""
    t = np.where(np.isfinite(transmit_s), transmit_s, 0.0)
    st = satellite_state(ephemeris, t - satellite_state(ephemeris, t).clock_l1_s)
    los = st.position_m - receiver_ecef_m
    u = los / np.linalg.norm(los, axis=1)[:, None]
    return np.sum(u * st.velocity_mps, axis=1) - _C * st.clock_drift_s_s, u


def _weights(fix: PositionFix, sigma_m: float, elevation_weights: bool) -> np.ndarray:
    """`pvt.solve_position`'s weights: ``sin²(E)/σ²`` (elevations of at least 1°) or ``1/σ²``."""
    if not elevation_weights:
        return np.full(fix.used.size, 1.0 / sigma_m**2)
    return np.sin(np.radians(np.maximum(fix.elevation_deg, 1.0))) ** 2 / sigma_m**2


def off_geometry(y: np.ndarray, w: np.ndarray, u: np.ndarray) -> np.ndarray:
    """``y`` (``(n,)`` or ``(n, k)``: columns over ``n`` satellites) less its weighted least-squares
    projection on the position and clock columns ``[-u, 1]`` (lines of sight ``u``, weights
    ``w``): what of ``y`` the four-state fix cannot absorb (the Frisch-Waugh-Lovell step; Van
    Diggelen, *A-GPS*, 2009, ch. 4, for the coarse-time column)."""
    H = np.hstack([-u, np.ones((u.shape[0], 1))])
    Hw = H * w[:, None]
    return y - H @ np.linalg.solve(Hw.T @ H, Hw.T @ y)


def solve_coarse_time(
    pseudorange_m: np.ndarray,
    transmit_s: np.ndarray,
    ephemeris: Ephemerides,
    *,
    initial_ecef_m: np.ndarray | None = None,
    sigma_m: float = 5.0,
    iono: IonoUtc | None = None,
    troposphere: bool = False,
    elevation_mask_deg: float = 5.0,
    elevation_weights: bool = True,
    false_alarm: float = 1e-3,
    signal: SignalSpec = GPS_L1CA,
    max_iterations: int = 10,
    tolerance_s: float = 1e-7,
) -> CoarseTimeFix | None:
    """Position, clock and the common transmit-time offset :math:`\\delta` of one epoch
    (module text; van Diggelen 2009, ch. 4).

    Parameters
    ----------
    pseudorange_m, transmit_s
        ``(S,)`` as `pvt.solve_position`'s, the transmit times all off by the same unknown
        :math:`\\delta` (seconds to a few tens of seconds: beyond that the range rates'
        change over :math:`\\delta` makes the steps slow).
    ephemeris
        ``S`` records in the same order.
    initial_ecef_m
        The approximate position (default the Earth's centre).
    sigma_m, iono, troposphere, elevation_mask_deg, elevation_weights, false_alarm, signal
        As `pvt.solve_position`'s; ``sigma_m`` also scales ``time_offset_sigma_s``.
    max_iterations, tolerance_s
        Gauss-Newton steps at most, and the step of :math:`\\delta` that ends them.

    Returns
    -------
    CoarseTimeFix, or None with fewer than five usable satellites (four states and the
    offset) or when the steps do not settle.
    """
    pr = np.asarray(pseudorange_m, float)
    tx = np.asarray(transmit_s, float)
    if pr.shape != tx.shape or pr.ndim != 1 or ephemeris.sv.size != pr.size:
        raise ConfigError(
            "solve_coarse_time",
            f"pseudoranges {pr.shape}, transmit times {tx.shape} and "
            f"{ephemeris.sv.size} ephemeris records must all be (S,)",
        )
    if not sigma_m > 0:
        raise ConfigError("sigma_m", f"must be positive, got {sigma_m}")
    if len(set(np.asarray(ephemeris.sv).astype("U1"))) > 1:
        raise ConfigError("solve_coarse_time", "one system's satellites only (one receiver clock)")

    def four_state(delta: float, x0, sigma: float, alarm: float = 1e-3) -> PositionFix | None:
        return solve_position(
            pr,
            tx + delta,
            ephemeris,
            iono=iono,
            troposphere=troposphere,
            sigma_m=sigma,
            elevation_mask_deg=elevation_mask_deg,
            false_alarm=alarm,
            initial_ecef_m=x0,
            elevation_weights=elevation_weights,
            signal=signal,
        )

    delta, x0, steps, d = 0.0, initial_ecef_m, 0, np.inf
    used, rate, info = np.zeros(pr.size, bool), np.full(pr.size, np.nan), 0.0
    while abs(d) >= tolerance_s:
        if steps == max_iterations:
            return None  # the steps did not settle
        steps += 1
        fix = four_state(delta, x0, _NO_TEST_SIGMA_M)
        if fix is None or fix.used.sum() < 5:
            return None
        use = used = fix.used
        rate, u = _range_rates(ephemeris, tx + delta, fix.position_ecef_m)
        w = _weights(fix, sigma_m, elevation_weights)[use]
        perp = off_geometry(rate[use], w, u[use])
        info = float(np.sum(w * perp**2))
        if not info > 0:
            return None
        d = float(np.sum(w * perp * fix.residuals_m[use])) / info
        delta, x0 = delta + d, fix.position_ecef_m
    final = four_state(delta, x0, sigma_m, false_alarm)
    if final is None:
        return None
    return CoarseTimeFix(final, delta, 1.0 / np.sqrt(info), np.where(used, rate, np.nan), steps)
