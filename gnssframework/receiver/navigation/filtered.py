"""Positions from a registry ``nav_filter`` run on the observables' pseudoranges and Dopplers.

The weighted least squares of `fixes.solve_epochs` solves every epoch alone; a navigation
filter (``ekf-pv`` first: its state ``[x, y, z, vx, vy, vz, b, d]`` in ECEF metres, clock
bias and drift in metres) carries position and velocity from epoch to epoch. It is fed as
a vector loop feeds it (`gnssframework.receiver.tracking.vector`), with the channel errors
zero and the replica range and rate replaced by the measurements themselves, corrected as
the least squares corrects them (`gnssframework.navigation.pvt`):

- satellite time to GPS time with the SV clock (polynomial, relativity, T_GD; IS-GPS-200
  20.3.3.3.3.1-2), the satellite's position and velocity at transmit time rotated by
  ``-ω_e τ`` into the ECEF frame of the receive time (20.3.3.4.3.3.2);
- Klobuchar and, switchable, the troposphere at the filter's last position, so that
  ``ρ_c = ρ + c Δt_SV - I - T = |s - r| + b`` and ``-λ D + c Δṫ_SV = (v_s - v)·e + d``,
  the ``h(x)`` of ``ekf-pv`` (Zou et al. 2018, eqs. 35-36);
- variances ``(σ / sin E)²``, the least squares' weights, as the filter's R.

The filter starts from the first least-squares fix (position, velocity, clock) with a
covariance from that fix's dilution of precision, then steps at every epoch of the
observables' grid. Which satellites it takes is ``exclusion``:

- ``"innovation"`` (default): every satellite with a healthy ephemeris above the mask,
  screened by the filter's own innovation test (`innovation_exclusion`): the normalised
  innovation squared ``ν^T S^-1 ν`` of the epoch's ranges and rates against the filter's
  prediction (``S = H P⁻ H^T + R``) is chi-square with ``2 n`` degrees of freedom when the
  model holds (Bar-Shalom, Li & Kirubarajan 2001, sec. 5.4.2); above its ``1 - p`` quantile
  (``p = innovation_false_alarm``) the satellite whose removal lowers the statistic most
  is left out, and the test is repeated while more than four satellites remain;
- ``"least-squares"``: the satellites the least squares used at that epoch (its
  residual-based exclusion carries over), or all healthy ones at an epoch it did not solve;
- ``"none"``: every healthy satellite, untested.

An epoch without any satellite ends the run; the filter restarts at the next
least-squares fix.

With ``integrity_risk`` every row also gets protection levels from the filter's own
covariance (`integrity.covariance_protection_levels` of its position covariance rotated
to east-north-up: fault-free bounds, as honest as the filter's covariance) and the
outcome of the innovation test (``ok``, ``excluded``; ``unavailable`` for a filter that
publishes no covariance): the columns `fixes.INTEGRITY_COLUMNS`. This is the one
integrity mechanism of every nav filter: the test, the exclusion and the levels are the
harness's, from the filter's ``transition`` and covariance, not each plugin's.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pymap3d

from ... import names, registry
from ...errors import ConfigError
from ...interfaces import NavFilter, RunContext, refuse_fixed_channel_set
from ...navigation.ephemeris import (
    OMEGA_EARTH_RAD_S,
    Ephemerides,
    ionosphere_scale,
    satellite_state,
    single_frequency_clock_s,
)
from ...navigation.lnav import IonoUtc
from ...navigation.pvt import chi2_ppf, dop, klobuchar_delay_s, troposphere_delay_m
from ...signal.gps_l1ca import GPS_L1CA
from ...signal.spec import SPEED_OF_LIGHT_M_S, SignalSpec
from .filtered_smoothing import check_smoothable, smooth_runs
from .fixes import PositionTable, full_week
from .fixes import _ephemeris_for as ephemeris_for
from .observables import Observables

__all__ = [
    "EpochMeasurements",
    "MEASUREMENT_INPUTS",
    "NAV_STATE_OUTPUTS",
    "EXCLUSIONS",
    "check_nav_filter",
    "corrected_measurements",
    "innovation_exclusion",
    "run_nav_filter",
    "filter_epochs",
]

#: The satellite selections of `filter_epochs` (see the module text).
EXCLUSIONS = ("innovation", "least-squares", "none")

#: What this harness gives a nav filter at each epoch: the vector loop's harness inputs
#: and a channel filter's outputs (zero errors with the measurement variances).
MEASUREMENT_INPUTS = (
    names.SAT_POS_M,
    names.SAT_VEL_M_S,
    names.NEXT_SAT_POS_M,
    names.NEXT_SAT_VEL_M_S,
    names.REPLICA_RANGE_M,
    names.REPLICA_RATE_M_S,
    names.CODE_ERROR_CHIPS,
    names.CODE_ERROR_VAR_CHIPS2,
    names.FREQ_ERROR_HZ,
    names.FREQ_ERROR_VAR_HZ2,
)
#: What it reads back: ECEF position and velocity, clock bias and drift.
NAV_STATE_OUTPUTS = (names.POSITION_M, names.VELOCITY_M_S, names.CLOCK_M)


@dataclass(frozen=True)
class EpochMeasurements:
    """One epoch's corrected measurements of ``S`` satellites.

    ``sat_pos_m``, ``sat_vel_m_s`` ``(S, 3)`` in the ECEF frame of the receive time;
    ``range_m`` ``(S,)`` the pseudorange plus the SV clock, minus ionosphere and troposphere
    (``|s - r| + b``); ``rate_m_s`` ``(S,)`` ``-λ D`` plus the SV clock drift
    (``(v_s - v)·e + d``); ``range_var_m2``, ``rate_var_m2_s2`` ``(S,)`` their variances.
    """

    sat_pos_m: np.ndarray
    sat_vel_m_s: np.ndarray
    range_m: np.ndarray
    rate_m_s: np.ndarray
    range_var_m2: np.ndarray
    rate_var_m2_s2: np.ndarray


def check_nav_filter(name: str, field: str = "nav_filter") -> None:
    """Refuse a registered nav_filter that cannot run on pseudoranges and Dopplers: one
    that needs an input this harness does not give, or gives no position, velocity and
    clock.

    Raises
    ------
    ConfigError
        Naming ``field`` and the registered filters that fit.
    """
    try:
        cls = registry.get("nav_filter", name)
    except ConfigError as exc:
        raise ConfigError(field, exc.detail) from None
    fits = [n for n in registry.names("nav_filter") if not _misfit(registry.get("nav_filter", n))]
    why = _misfit(cls)
    if why:
        raise ConfigError(
            field,
            f"nav_filter {name!r} cannot run on pseudoranges and Dopplers: {why}; those that "
            f"can: {', '.join(fits) or '(none registered)'}",
        )


def _misfit(cls: type) -> str:
    unmet = [n for n in getattr(cls, "requires", ()) if n not in MEASUREMENT_INPUTS]
    if unmet:
        return f"it needs {', '.join(unmet)}"
    missing = [n for n in NAV_STATE_OUTPUTS if n not in getattr(cls, "provides", ())]
    return f"it does not provide {', '.join(missing)}" if missing else ""


def _rotate_z(v: np.ndarray, theta_rad: np.ndarray) -> np.ndarray:
    """Rows of ``v`` rotated by ``-theta`` about the z axis (a frame ``theta / ω_e`` later)."""
    c, s = np.cos(theta_rad), np.sin(theta_rad)
    return np.stack([c * v[:, 0] + s * v[:, 1], -s * v[:, 0] + c * v[:, 1], v[:, 2]], axis=-1)


def corrected_measurements(
    pseudorange_m: np.ndarray,
    transmit_s: np.ndarray,
    doppler_hz: np.ndarray,
    ephemeris: Ephemerides,
    receiver_ecef_m: np.ndarray,
    *,
    iono: IonoUtc | None = None,
    troposphere: bool = False,
    sigma_m: float = 5.0,
    sigma_rate_m_s: float = 0.5,
    elevation_mask_deg: float = 5.0,
    wavelength_m: float | None = None,
    signal: SignalSpec = GPS_L1CA,
) -> tuple[EpochMeasurements, np.ndarray]:
    """Correct one epoch's measurements at the receiver position ``receiver_ecef_m`` (see the
    module text).

    Parameters
    ----------
    pseudorange_m, transmit_s, doppler_hz
        ``(S,)`` as `Observables` holds them (transmit time: satellite time of week).
    ephemeris
        ``S`` records in the same order.
    receiver_ecef_m
        ``(3,)`` where the light time, elevations and delays are evaluated.
    sigma_m, sigma_rate_m_s
        Zenith standard deviations of the pseudorange and the range rate.
    wavelength_m
        Carrier wavelength of the Dopplers (default ``signal.wavelength_m``).
    signal
        The signal measured (`SignalSpec`; GPS L1 C/A by default).

    Returns
    -------
    The measurements of the satellites above ``elevation_mask_deg`` with a Doppler, and
    the boolean ``(S,)`` mask of those satellites.
    """
    if wavelength_m is None:
        wavelength_m = signal.wavelength_m
    pr, tx, d = (np.asarray(a, float) for a in (pseudorange_m, transmit_s, doppler_hz))
    r = np.asarray(receiver_ecef_m, float)
    carrier_hz = SPEED_OF_LIGHT_M_S / signal.wavelength_m
    clock = single_frequency_clock_s(ephemeris, satellite_state(ephemeris, tx), carrier_hz)
    state = satellite_state(ephemeris, tx - clock)  # t = t_SV - Δt_SV (20.3.3.3.3.1)
    tau = np.linalg.norm(state.position_m - r, axis=1) / SPEED_OF_LIGHT_M_S
    sat_pos = _rotate_z(state.position_m, OMEGA_EARTH_RAD_S * tau)
    sat_vel = _rotate_z(state.velocity_mps, OMEGA_EARTH_RAD_S * tau)
    lat, lon, h = (float(v) for v in pymap3d.ecef2geodetic(*r))
    az, el, _ = pymap3d.ecef2aer(sat_pos[:, 0], sat_pos[:, 1], sat_pos[:, 2], lat, lon, h)
    az, el = np.asarray(az, float), np.asarray(el, float)
    delay = np.zeros(pr.size)
    if iono is not None:  # at the time pvt.solve_position evaluates it
        delay += (
            ionosphere_scale(carrier_hz)
            * SPEED_OF_LIGHT_M_S
            * klobuchar_delay_s(iono.alpha, iono.beta, lat, lon, az, el, float(np.median(tx)) + 0.075)
        )
    if troposphere:
        delay += troposphere_delay_m(lat, h, el)
    keep = (el >= elevation_mask_deg) & np.isfinite(pr) & np.isfinite(d)
    inv_sin2 = 1.0 / np.sin(np.radians(np.maximum(el, 1.0))) ** 2
    meas = EpochMeasurements(
        sat_pos[keep],
        sat_vel[keep],
        (pr + SPEED_OF_LIGHT_M_S * single_frequency_clock_s(ephemeris, state, carrier_hz) - delay)[keep],
        (-wavelength_m * d + SPEED_OF_LIGHT_M_S * state.clock_drift_s_s)[keep],
        (sigma_m**2 * inv_sin2)[keep],
        (sigma_rate_m_s**2 * inv_sin2)[keep],
    )
    return meas, keep


def _inputs(m: EpochMeasurements, signal: SignalSpec = GPS_L1CA) -> dict[str, np.ndarray]:
    """The nav filter's step inputs for one run: channel outputs ``(1, S)``, satellites ``(S, 3)``
    (variances in chips and Hz of ``signal``, whose chip length and wavelength the filter uses)."""
    chip_length_m, wavelength_m = signal.chip_length_m, signal.wavelength_m
    zero = np.zeros((1, m.range_m.size))
    return {
        names.SAT_POS_M: m.sat_pos_m,
        names.SAT_VEL_M_S: m.sat_vel_m_s,
        names.NEXT_SAT_POS_M: m.sat_pos_m,
        names.NEXT_SAT_VEL_M_S: m.sat_vel_m_s,
        names.REPLICA_RANGE_M: m.range_m[None],
        names.REPLICA_RATE_M_S: m.rate_m_s[None],
        names.CODE_ERROR_CHIPS: zero,
        names.CODE_ERROR_VAR_CHIPS2: m.range_var_m2[None] / chip_length_m**2,
        names.FREQ_ERROR_HZ: zero,
        names.FREQ_ERROR_VAR_HZ2: m.rate_var_m2_s2[None] / wavelength_m**2,
    }


def start_nav_filter(nav: NavFilter, interval_s: float, initial_state: np.ndarray, initial_cov: np.ndarray) -> None:
    """Reset ``nav`` for one run at ``interval_s`` between epochs from the 8-state estimate
    ``initial_state`` ``(8,)`` (at the first epoch it will be given) and ``initial_cov``."""
    context = RunContext(
        coherent_time_s=interval_s,
        epoch_interval_s=interval_s,
        initial_state=np.asarray(initial_state, float)[None],
        initial_cov=np.asarray(initial_cov, float),
    )
    nav.reset((1,), context)


def step_nav_filter(nav: NavFilter, measurements: EpochMeasurements, signal: SignalSpec = GPS_L1CA) -> np.ndarray:
    """One epoch: the filter's ``[x, y, z, vx, vy, vz, b, d]`` after it (measurement variances
    in chips and Hz of ``signal``)."""
    return _step(nav, measurements, signal)[0]


def _step(
    nav: NavFilter, measurements: EpochMeasurements, signal: SignalSpec = GPS_L1CA
) -> tuple[np.ndarray, np.ndarray | None]:
    """One epoch: the 8-state after it and its 8x8 covariance (None if the filter gives none)."""
    out = nav.checked_step(_inputs(measurements, signal))
    x = np.concatenate(
        [
            np.reshape(out[names.POSITION_M], 3),
            np.reshape(out[names.VELOCITY_M_S], 3),
            np.reshape(out[names.CLOCK_M], 2),
        ]
    )
    cov = out.get(names.COV)
    return x, None if cov is None else np.reshape(cov, np.shape(cov)[-2:])[:8, :8]


def _subset(m: EpochMeasurements, keep: np.ndarray) -> EpochMeasurements:
    return EpochMeasurements(
        m.sat_pos_m[keep],
        m.sat_vel_m_s[keep],
        m.range_m[keep],
        m.rate_m_s[keep],
        m.range_var_m2[keep],
        m.rate_var_m2_s2[keep],
    )


def innovation_exclusion(
    predicted_state: np.ndarray,
    predicted_cov: np.ndarray,
    measurements: EpochMeasurements,
    false_alarm: float = 1e-3,
    min_satellites: int = 4,
) -> tuple[np.ndarray, float]:
    """The satellites that pass the filter's innovation test (see the module text).

    Parameters
    ----------
    predicted_state, predicted_cov
        The filter's 8-state prediction ``[r, v, b, d]`` ``(8,)`` at this epoch and its
        covariance ``(8, 8)``.
    measurements
        The epoch's ``S`` satellites.
    false_alarm
        Probability ``p`` that the statistic of a fault-free epoch exceeds the threshold
        ``chi2.ppf(1 - p, 2 n)``.
    min_satellites
        No satellite is left out once this many remain.

    Returns
    -------
    The boolean ``(S,)`` mask of the satellites kept and the statistic ``ν^T S^-1 ν`` of
    those satellites.
    """
    x, P, m = np.asarray(predicted_state, float), np.asarray(predicted_cov, float), measurements
    los = m.sat_pos_m - x[:3]
    dist = np.linalg.norm(los, axis=1)
    e = los / dist[:, None]
    n = dist.size
    # Ranges then rates, as ekf-pv orders them (Zou et al. 2018, eqs. 35-36).
    nu = np.r_[m.range_m - (dist + x[6]), m.rate_m_s - (np.sum((m.sat_vel_m_s - x[3:6]) * e, axis=1) + x[7])]
    H = np.zeros((2 * n, 8))
    H[:n, :3], H[:n, 6] = -e, 1.0
    H[n:, 3:6], H[n:, 7] = -e, 1.0
    S = H @ P @ H.T + np.diag(np.r_[m.range_var_m2, m.rate_var_m2_s2])

    def statistic(sats: np.ndarray) -> float:
        rows = np.r_[sats, sats + n]
        return float(nu[rows] @ np.linalg.solve(S[np.ix_(rows, rows)], nu[rows]))

    keep = np.ones(n, dtype=bool)
    stat = statistic(np.flatnonzero(keep))
    while keep.sum() > min_satellites and stat > chi2_ppf(1.0 - false_alarm, 2 * int(keep.sum())):
        kept = np.flatnonzero(keep)
        without = [statistic(kept[kept != i]) for i in kept]
        keep[kept[int(np.argmin(without))]] = False
        stat = float(min(without))
    return keep, stat


def _predict(nav: NavFilter, x: np.ndarray, P: np.ndarray, interval_s: float) -> tuple[np.ndarray, np.ndarray]:
    """The filter's prediction of its 8 published states one interval ahead, from its own
    ``transition(T)`` (their block: exact for ``ekf-pv``, whose state they are)."""
    F, Q = (np.asarray(a, float)[:8, :8] for a in nav.transition(interval_s))
    return F @ x, F @ P @ F.T + Q


def run_nav_filter(
    nav: NavFilter,
    interval_s: float,
    initial_state: np.ndarray,
    initial_cov: np.ndarray,
    epochs: list[EpochMeasurements],
) -> np.ndarray:
    """Run ``nav`` over consecutive epochs ``interval_s`` apart; returns the states ``(E, 8)``."""
    start_nav_filter(nav, interval_s, initial_state, initial_cov)
    return np.array([step_nav_filter(nav, m) for m in epochs]).reshape(-1, 8)


def _enu(lat_deg: float, lon_deg: float) -> np.ndarray:
    """Rows: east, north, up unit vectors in ECEF."""
    la, lo = np.radians(lat_deg), np.radians(lon_deg)
    return np.array(
        [
            [-np.sin(lo), np.cos(lo), 0.0],
            [-np.sin(la) * np.cos(lo), -np.sin(la) * np.sin(lo), np.cos(la)],
            [np.cos(la) * np.cos(lo), np.cos(la) * np.sin(lo), np.sin(la)],
        ]
    )


def filter_epochs(
    obs: Observables,
    wls: PositionTable,
    nav_filter: str = "ekf-pv",
    params: dict[str, Any] | None = None,
    rinex: Ephemerides | None = None,
    *,
    ionosphere: bool = True,
    troposphere: bool = False,
    iono: IonoUtc | None = None,
    sigma_m: float = 5.0,
    sigma_rate_m_s: float = 0.5,
    elevation_mask_deg: float = 5.0,
    reference_week: int | None = None,
    exclusion: str = "innovation",
    innovation_false_alarm: float = 1e-3,
    signal: SignalSpec = GPS_L1CA,
    integrity_risk: float | None = None,
    smooth: bool = False,
) -> PositionTable:
    """The registered ``nav_filter`` (with ``params``) on every epoch of ``obs`` from the
    first fix of ``wls`` on (see the module text); the same columns as ``wls``, with
    ``excluded_prn`` the first satellite the innovation test left out at each epoch (0: none).
    ``signal`` names the satellites in ``rinex`` (`SignalSpec.rinex_satellite`).

    ``wls`` is `fixes.solve_epochs` of the same observables and settings; ``exclusion``
    one of `EXCLUSIONS`; ``innovation_false_alarm`` the test's probability ``p``;
    ``integrity_risk`` (None: none) adds the protection levels (see the module text).
    ``smooth``: the rows are the forward-backward (RTS) estimates of each run of the filter
    (`filtered_smoothing`), the levels of their covariances; the satellites and exclusions
    are the forward pass's.

    Raises
    ------
    ConfigError
        For an unknown or unfit filter name (field ``--nav-filter``), bad parameters, an
        unknown ``exclusion`` or a ``p`` outside (0, 1).
    """
    if exclusion not in EXCLUSIONS:
        raise ConfigError("exclusion", f"got {exclusion!r}; allowed: {', '.join(EXCLUSIONS)}")
    if not 0.0 < innovation_false_alarm < 1.0:
        raise ConfigError("innovation_false_alarm", f"must be a probability in (0, 1), got {innovation_false_alarm}")
    if len(wls) == 0:
        return wls
    check_nav_filter(nav_filter)
    nav = registry.create("nav_filter", nav_filter, **(params or {}))
    refuse_fixed_channel_set(nav, "nav_filter.params")
    gate = exclusion == "innovation"
    if gate and not hasattr(nav, "transition"):
        raise ConfigError(
            "exclusion",
            f"the innovation test needs the filter's transition(T); nav_filter "
            f"{nav_filter!r} has none: use exclusion 'least-squares' or 'none'",
        )
    klobuchar = (iono or obs.iono_utc) if ionosphere else None
    interval_s = float(np.median(np.diff(obs.rx_time_s))) if obs.rx_time_s.size > 1 else 1.0
    if smooth:
        F_s, Q_s = check_smoothable(nav, nav_filter, interval_s)
    covs: list[np.ndarray | None] = []
    run_starts: list[int] = []
    wls_row = {int(np.argmin(np.abs(obs.sample_time_s - t))): k for k, t in enumerate(wls.sample_time_s)}
    rows, states, used, dops, excluded, levels = [], [], [], [], [], []
    running = False
    for e in range(obs.rx_time_s.size):
        k = wls_row.get(e)
        if k is not None and exclusion == "least-squares":
            prns = np.array(wls.used_prns[k])
        else:
            prns = obs.prn[np.isfinite(obs.pseudorange_m[e])]
        j = np.flatnonzero(np.isin(obs.prn, prns))
        records = ephemeris_for(obs.prn[j], obs, rinex, float(obs.rx_time_s[e]), float(obs.sample_time_s[e]), signal)
        j = np.array([jj for jj, r in zip(j, records) if r is not None], dtype=int)
        if not running and k is None:
            continue
        if j.size == 0:
            running = False
            continue
        if not running:  # (re)start from this epoch's fix; no prediction before the first step
            x0, P0 = _prior(wls, k, sigma_m, sigma_rate_m_s)
            start_nav_filter(nav, interval_s, x0, P0)
            running, here, predicted = True, x0[:3], (x0, P0)
            run_starts.append(len(states))
        meas, keep = corrected_measurements(
            obs.pseudorange_m[e, j],
            obs.transmit_s[e, j],
            obs.doppler_hz[e, j],
            Ephemerides.concatenate([r for r in records if r is not None]),
            here,
            iono=klobuchar,
            troposphere=troposphere,
            sigma_m=sigma_m,
            sigma_rate_m_s=sigma_rate_m_s,
            elevation_mask_deg=elevation_mask_deg,
            signal=signal,
        )
        if not keep.any():
            running = False
            continue
        out_prn = 0
        if gate and predicted[1] is not None:
            passed, _ = innovation_exclusion(*predicted, meas, innovation_false_alarm)
            if not passed.all():
                out_prn = int(obs.prn[j[keep]][np.flatnonzero(~passed)[0]])
                meas = _subset(meas, passed)
                keep[np.flatnonzero(keep)[~passed]] = False
        x, P = _step(nav, meas, signal)
        predicted = _predict(nav, x, P, interval_s) if gate and P is not None else (x, None)
        here = x[:3]
        rows.append(e)
        states.append(x)
        covs.append(P)
        used.append(tuple(int(p) for p in obs.prn[j[keep]]))
        excluded.append(out_prn)
        dops.append(_dops(meas.sat_pos_m, x[:3]))
    if smooth and states:
        if any(P is None for P in covs):
            raise ConfigError("smooth", f"nav_filter {nav_filter!r} publishes no covariance: nothing to smooth")
        states_a, covs_a = smooth_runs(np.array(states), np.array(covs), run_starts, F_s, Q_s)
        states, covs = list(states_a), list(covs_a)
    if integrity_risk is not None:
        levels = [_levels(x, P, integrity_risk) for x, P in zip(states, covs)]
    table = _table(
        obs,
        np.array(rows, dtype=int),
        np.array(states).reshape(-1, 8),
        used,
        np.array(dops).reshape(-1, 2),
        full_week(obs.week, reference_week, obs.week_bits)
        if reference_week is not None or obs.week is not None
        else int(wls.columns["gps_week"][0]),
        np.array(excluded, dtype=int),
    )
    if integrity_risk is not None:
        pl = np.array(levels, float).reshape(-1, 2)
        status = np.where(np.isnan(pl[:, 0]), "unavailable", np.where(table.excluded_prn > 0, "excluded", "ok"))
        table.columns.update(hpl_m=pl[:, 0], vpl_m=pl[:, 1], raim=status.astype("<U11"))
    return table


def _levels(x: np.ndarray, P: np.ndarray | None, integrity_risk: float) -> tuple[float, float]:
    """HPL, VPL of the filter's position covariance (ECEF ``P[:3, :3]``) in east-north-up
    at ``x`` (NaN without a covariance)."""
    if P is None:
        return np.nan, np.nan
    from ...navigation.integrity import covariance_protection_levels

    lat, lon, _ = pymap3d.ecef2geodetic(*x[:3])
    R = _enu(float(lat), float(lon))
    hpl, vpl = covariance_protection_levels(R @ P[:3, :3] @ R.T, integrity_risk)
    return float(hpl), float(vpl)


def _prior(wls: PositionTable, k: int, sigma_m: float, sigma_rate_m_s: float) -> tuple[np.ndarray, np.ndarray]:
    """The fix ``k`` as an 8-state estimate, with variances ``(σ DOP)²``."""
    c = wls.columns
    R = _enu(float(c["lat_deg"][k]), float(c["lon_deg"][k]))
    vel_enu = np.array([c["vel_e_mps"][k], c["vel_n_mps"][k], c["vel_u_mps"][k]], float)
    vel = R.T @ np.nan_to_num(vel_enu)
    d = wls.clock_drift_mps
    drift = float(d[k]) if d is not None and np.isfinite(d[k]) else 0.0
    x0 = np.r_[wls.ecef_m[k], vel, float(c["clock_bias_m"][k]), drift]
    pdop = float(np.hypot(c["hdop"][k], c["vdop"][k]))
    var_pos, var_vel = (sigma_m * pdop) ** 2 / 3, (sigma_rate_m_s * pdop) ** 2 / 3
    return x0, np.diag([var_pos] * 3 + [var_vel] * 3 + [(sigma_m * pdop) ** 2, (sigma_rate_m_s * pdop) ** 2])


def _table(
    obs: Observables,
    rows: np.ndarray,
    states: np.ndarray,
    used: list[tuple[int, ...]],
    dops: np.ndarray,
    week: int,
    excluded: np.ndarray,
) -> PositionTable:
    n = rows.size
    lat, lon, h = (
        np.asarray(v, float).reshape(-1) for v in pymap3d.ecef2geodetic(states[:, 0], states[:, 1], states[:, 2])
    )
    vel = np.array([_enu(lat[i], lon[i]) @ states[i, 3:6] for i in range(n)]).reshape(-1, 3)
    hdop, vdop = dops[:, 0], dops[:, 1]
    bias = states[:, 6]
    columns = {
        "gps_week": np.full(n, week),
        "tow_s": obs.rx_time_s[rows] - bias / SPEED_OF_LIGHT_M_S,
        "lat_deg": lat,
        "lon_deg": lon,
        "height_m": h,
        "vel_e_mps": vel[:, 0],
        "vel_n_mps": vel[:, 1],
        "vel_u_mps": vel[:, 2],
        "clock_bias_m": bias,
        "n_sats": np.array([len(u) for u in used], dtype=int),
        "hdop": hdop,
        "vdop": vdop,
    }
    return PositionTable(columns, states[:, :3].copy(), obs.sample_time_s[rows], used, excluded, states[:, 7].copy())


def _dops(sat_pos_m: np.ndarray, r: np.ndarray) -> tuple[float, float]:
    """HDOP and VDOP of satellites ``(S, 3)`` seen from ``r`` (NaN with fewer than four)."""
    if sat_pos_m.shape[0] < 4:
        return np.nan, np.nan
    lat, lon, _ = pymap3d.ecef2geodetic(*r)
    los = sat_pos_m - r
    _, _, hdop, vdop = dop((los / np.linalg.norm(los, axis=1)[:, None]) @ _enu(float(lat), float(lon)).T)
    return hdop, vdop
