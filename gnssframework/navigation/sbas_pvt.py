r"""SBAS-corrected positions of GPS L1 C/A pseudoranges, with DO-229's protection levels
(RTCA DO-229 Appendix A, A.4.4, and Appendix J).

Each GPS satellite in the SBAS mask with a fast and a long-term correction (the long-term
one for the IODE of the record used) is corrected as A.4.4.3-A.4.4.8 say:

- its position by the long-term correction :math:`\delta r + \delta\dot r\,(t - t_0)` and
  its clock by :math:`\delta a_{f0} + \delta a_{f1} (t - t_0)` (type 25 with velocity code 1;
  code 0 has no rates), added to the broadcast ones (IS-GPS-200's, T_GD applied);
- its pseudorange by the fast correction
  :math:`PRC(t_{of}) + RRC\,(t - t_{of})`, the range-rate correction
  :math:`RRC = (PRC_{new} - PRC_{old}) / (t_{of,new} - t_{of,old})` of its last two
  corrections (zero with one, or with ``range_rate=False``);
- the ionosphere by the grid's slant delay at the pierce point and the troposphere by the
  MOPS model (`sbas_iono`), both subtracted.

A satellite whose UDREI is 14 or 15 (not monitored, do not use), whose fast correction is
older than ``max_fast_age_s``, without a long-term correction of its IODE, or whose pierce
point has no grid correction, is not used: the solution is DO-229's precision-approach one,
with no broadcast-model fallback.

The weights are :math:`w_i = 1/\sigma_i^2`,
:math:`\sigma_i^2 = \sigma^2_{flt,i} + \sigma^2_{UIRE,i} + \sigma^2_{air,i} + \sigma^2_{tropo,i}`
(J.1): :math:`\sigma^2_{flt} = (\sigma_{UDRE}\,\delta UDRE + \epsilon_{fc} + \epsilon_{rrc} + \epsilon_{ltc})^2`
(or their root sum square with type 10's RSS_UDRE = 1; A.4.5.1): with type 7,
:math:`\epsilon_{fc} = a (t - t_u + t_{lat})^2 / 2` (``a`` of the satellite's a_i, `t_lat` its
latency), a fast correction older than the a_i's precision-approach time-out ``I_fc`` not
used, and the range-rate correction 0 where a_i is 0; with type 10,
:math:`\epsilon_{rrc} = (a I_{fc}/4 + B_{rrc}/\Delta t)(t - t_{of})` after non-consecutive
IODFs (:math:`(a |\Delta t - I_{fc}/2|/2 + B_{rrc}/\Delta t)(t - t_{of})` when either IODF is 3
and :math:`\Delta t \ne I_{fc}/2`), :math:`\epsilon_{ltc} = C_{ltc,lsb} + C_{ltc,v1}
\max(0, t_0 - t, t - t_0 - I_{ltc,v1})` (velocity code 1) or :math:`C_{ltc,v0} \lfloor (t -
t_{ltc}) / I_{ltc,v0} \rfloor` (code 0, :math:`t_{ltc}` the message's time), and each IGP's
:math:`\sigma_{GIVE}` grows by :math:`\epsilon_{iono} = C_{iono,step}\lfloor\Delta t /
I_{iono}\rfloor + C_{iono,ramp}\Delta t` (RSS_iono likewise). With a type 28 of the
satellite (younger than its 240 s precision-approach time-out, Table A-25),
:math:`\delta UDRE = \sqrt{I^T C I} + \epsilon_c` (A.4.5.1.2): :math:`I = [u, 1]`, :math:`u`
the unit vector from the user to the satellite (ECEF), :math:`C` the message's relative
covariance and :math:`\epsilon_c = C_{covariance}\,2^{e - 5}` (type 10's C_covariance, 0
without one; :math:`e` the scale exponent); else, with a whole set of type 27 service
messages (every message of one IODS, within a day, A.4.4.13), the δUDRE of the
highest-priority region holding the user (the smallest δUDRE at equal priority; Table
A-16's values), or the set's outside value (its largest, should they differ) where none
does; else δUDRE is 1. :math:`\epsilon_{er}` (en-route fallback) is 0. :math:`\sigma^2_{UIRE} = F_{pp}^2\sigma^2_{UIVE}`, and
:math:`\sigma^2_{air} = \sigma^2_{noise} + \sigma^2_{multipath}` with
:math:`\sigma_{multipath} = 0.13 + 0.53\,e^{-E/10°}` m (J.2.4) and a constant
:math:`\sigma_{noise}` (``sigma_noise_m``; 0.36 m, an airborne accuracy designator A
receiver's bound).

With :math:`D = (G^T W G)^{-1}` in east, north, up and clock (rows of :math:`G`:
:math:`[-u_{ENU}, 1]`), the protection levels are (J.1)

.. math:: HPL = K_H\,\sqrt{\frac{d_E^2 + d_N^2}{2} + \sqrt{\Big(\frac{d_E^2 - d_N^2}{2}\Big)^2 + d_{EN}^2}},
   \qquad VPL = K_V\,d_U

with :math:`d_E^2 = D_{11}`, :math:`d_N^2 = D_{22}`, :math:`d_{EN} = D_{12}`,
:math:`d_U^2 = D_{33}`, :math:`K_V = 5.33` and :math:`K_H = 6.0` (precision approach) or
6.18 (en route to non-precision approach). GEO ranging and GLONASS corrections are not used.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError
from ..signal.sbas_l1 import SBAS_L1
from ..signal.spec import SPEED_OF_LIGHT_M_S as _C
from .ephemeris import Ephemerides, satellite_state, single_frequency_clock_s
from .pvt import PositionFix, solve_position_sv
from .sbas_content import SbasCorrections
from .sbas_udre import DELTA_UDRE
from .sbas_iono import (
    GIVE_VARIANCE_M2,
    UDRE_VARIANCE_M2,
    grid_vertical_delay,
    mops_troposphere,
    sbas_pierce_point,
)

__all__ = [
    "SbasFix",
    "SBAS_MODES",
    "K_V",
    "K_H",
    "protection_levels",
    "COVARIANCE_TIMEOUT_PA_S",
    "SERVICE_TIMEOUT_S",
    "delta_udre",
    "service_delta_udre",
    "sbas_satellite_corrections",
    "solve_position_sbas",
]

#: Modes of the horizontal factor: precision approach, en route to non-precision approach.
SBAS_MODES = ("pa", "npa")
#: Type 7's degradation factor a (m/s²) of each indicator a_i 0-15 (DO-229 A.4.5.1.1).
FAST_DEGRADATION_MPS2 = np.array(
    [
        0.0,
        0.00005,
        0.00009,
        0.00012,
        0.00015,
        0.0002,
        0.0003,
        0.00045,
        0.0006,
        0.0009,
        0.0015,
        0.0021,
        0.0027,
        0.0033,
        0.0046,
        0.0058,
    ]
)
#: The fast corrections' time-out (s) for precision approach of each a_i (DO-229 A.4.5.1.1).
FAST_TIMEOUT_PA_S = np.array([120, 120, 102, 90, 90, 78, 66, 54, 42, 30, 30, 18, 18, 18, 12, 12], dtype=float)
#: DO-229 J.1's factors of the vertical and horizontal protection levels.
K_V = 5.33
K_H = {"pa": 6.0, "npa": 6.18}


@dataclass(frozen=True)
class SbasFix:
    """An SBAS-corrected epoch: the least-squares ``fix`` (`pvt.PositionFix`; its
    ``used`` the satellites corrected and solved with), ``hpl_m`` and ``vpl_m`` (DO-229's
    protection levels), and per satellite ``sigma_m`` (the total σ of the weights),
    ``iono_m`` and ``troposphere_m`` (slant delays subtracted), ``fast_m`` (fast plus
    range-rate correction added) and ``reason`` (``""`` where corrected, else why not)."""

    fix: PositionFix
    hpl_m: float
    vpl_m: float
    sigma_m: np.ndarray
    iono_m: np.ndarray
    troposphere_m: np.ndarray
    fast_m: np.ndarray
    reason: tuple[str, ...]


def protection_levels(
    azimuth_deg: np.ndarray, elevation_deg: np.ndarray, sigma_m: np.ndarray, mode: str = "pa"
) -> tuple[float, float]:
    """DO-229's HPL and VPL (m; module text) of satellites at these angles with these σ."""
    if mode not in SBAS_MODES:
        raise ConfigError("mode", f"one of {', '.join(SBAS_MODES)}, got {mode!r}")
    az, el = np.radians(np.asarray(azimuth_deg, float)), np.radians(np.asarray(elevation_deg, float))
    u = np.stack([np.cos(el) * np.sin(az), np.cos(el) * np.cos(az), np.sin(el)], axis=-1)
    G = np.hstack([-u, np.ones((u.shape[0], 1))])
    D = np.linalg.inv(G.T @ (G / np.square(np.asarray(sigma_m, float))[:, None]))
    half_sum, half_diff = (D[0, 0] + D[1, 1]) / 2, (D[0, 0] - D[1, 1]) / 2
    d_major = np.sqrt(half_sum + np.sqrt(half_diff**2 + D[0, 1] ** 2))
    return float(K_H[mode] * d_major), float(K_V * np.sqrt(D[2, 2]))


def _seconds_of_day_since(tow_s: np.ndarray, t0_s: float) -> np.ndarray:
    """``tow_s``'s time of day minus ``t0_s`` (a time of day), wrapped to ±12 h."""
    return (np.asarray(tow_s, float) % 86_400.0 - t0_s + 43_200.0) % 86_400.0 - 43_200.0


def _slot_of(corrections: SbasCorrections, sv: str) -> int | None:
    """The 0-based mask number of ``sv`` (None outside the mask)."""
    if corrections.mask is None or sv not in corrections.mask.satellites:
        return None
    return corrections.mask.satellites.index(sv)


#: Type 28's time-out in precision approach (s; DO-229 Table A-25).
COVARIANCE_TIMEOUT_PA_S = 240.0


#: Type 27's time-out (s; DO-229 Table A-25: a day).
SERVICE_TIMEOUT_S = 86_400.0


def service_delta_udre(corrections: SbasCorrections, lat_deg: float, lon_deg: float, tow_s: float) -> float | None:
    """The δUDRE type 27 gives a user at ``lat_deg``, ``lon_deg`` (module text), or None
    without a whole set of service messages younger than `SERVICE_TIMEOUT_S`."""
    held = [(t, m) for t, m in corrections.service.values() if abs(tow_s - t) <= SERVICE_TIMEOUT_S]
    if not held:
        return None
    latest = max(held, key=lambda tm: tm[0])[1]
    group = {m.number: m for _, m in held if m.iods == latest.iods and m.count == latest.count}
    if set(group) != set(range(latest.count)):
        return None
    best: tuple[int, float] | None = None  # (priority, δUDRE) of the region chosen
    for m in group.values():
        for inside in m.contains(lat_deg, lon_deg):
            if inside:
                value = float(DELTA_UDRE[m.inside])
                if best is None or m.priority > best[0] or (m.priority == best[0] and value < best[1]):
                    best = (m.priority, value)
    if best is not None:
        return best[1]
    return float(max(DELTA_UDRE[m.outside] for m in group.values()))


def delta_udre(
    corrections: SbasCorrections,
    sv: np.ndarray,
    los_unit: np.ndarray,
    tow_s: float,
    user_lat_lon_deg: tuple[float, float] | None = None,
) -> np.ndarray:
    """δUDRE of each satellite ``sv`` (names) seen along ``los_unit`` (``(S, 3)`` unit vectors
    from the user to the satellites, ECEF) at ``tow_s`` (A.4.5.1.2, module text): from its
    type 28 within `COVARIANCE_TIMEOUT_PA_S`; else from type 27 at the user's
    ``user_lat_lon_deg`` (`service_delta_udre`); else 1."""
    u = np.asarray(los_unit, float).reshape(-1, 3)
    regional = None if user_lat_lon_deg is None else service_delta_udre(corrections, *user_lat_lon_deg, tow_s)
    out = np.full(u.shape[0], 1.0 if regional is None else regional)
    c_cov = corrections.parameters[1].ccovariance if corrections.parameters is not None else 0.0
    for i, name in enumerate(np.asarray(sv).astype(str)):
        got = corrections.covariance.get(name)
        if got is None or abs(tow_s - got[0]) > COVARIANCE_TIMEOUT_PA_S:
            continue
        _, exponent, c = got
        i4 = np.r_[u[i], 1.0]
        out[i] = float(np.sqrt(max(i4 @ c @ i4, 0.0))) + c_cov * 2.0 ** (exponent - 5)
    return out


def _flt_variance(
    corrections: SbasCorrections, udrei: int, eps_fc: float, eps_rrc: float, eps_ltc: float, dudre: float = 1.0
) -> float:
    """σ²_flt of A.4.5.1: the UDRE's σ (times δUDRE) and the degradation terms, added
    (RSS_UDRE 0) or root-sum-squared (1)."""
    sigma = float(np.sqrt(UDRE_VARIANCE_M2[udrei])) * dudre
    rss = corrections.parameters is not None and corrections.parameters[1].rss_udre == 1
    if rss:
        return sigma**2 + eps_fc**2 + eps_rrc**2 + eps_ltc**2
    return (sigma + eps_fc + eps_rrc + eps_ltc) ** 2


def sbas_satellite_corrections(
    corrections: SbasCorrections,
    ephemeris: Ephemerides,
    tow_s: np.ndarray,
    *,
    max_fast_age_s: float = 120.0,
    range_rate: bool = True,
    dudre: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, tuple[str, ...]]:
    """Each record's long-term position (m, ECEF) and clock (s) corrections, its fast
    correction (m, with the range-rate term), σ²_flt (m², with the degradation terms of the
    module text) and why it has none (``""`` where it has both), at GPS times ``tow_s``
    (``(S,)`` seconds of week). With a type 7 its fast correction's time-out is DO-229's
    precision-approach one of the satellite's a_i (`FAST_TIMEOUT_PA_S`), else ``max_fast_age_s``.
    ``dudre``: each record's δUDRE (`delta_udre`; 1 when not given)."""
    tow = np.broadcast_to(np.asarray(tow_s, float), ephemeris.sv.shape)
    n = tow.size
    dpos, dclock, fast, var = np.zeros((n, 3)), np.zeros(n), np.zeros(n), np.full(n, np.nan)
    reasons = []
    mt7 = corrections.degradation[1] if corrections.degradation is not None else None
    mt10 = corrections.parameters[1] if corrections.parameters is not None else None
    for i, sv in enumerate(np.asarray(ephemeris.sv).astype(str)):
        got = corrections.fast.get(sv)
        long = corrections.long_term.get(sv)
        slot = _slot_of(corrections, sv)
        ai = int(mt7.ai[slot]) if mt7 is not None and slot is not None and slot < mt7.ai.size else None
        timeout = FAST_TIMEOUT_PA_S[ai] if ai is not None else max_fast_age_s
        if not sv.startswith("G"):
            reasons.append("not GPS")
        elif got is None:
            reasons.append("no fast correction")
        elif got[1] >= 14:
            reasons.append("not monitored" if got[1] == 14 else "do not use")
        elif abs(tow[i] - got[2]) > timeout:
            reasons.append("fast correction too old")
        elif long is None or long.iode != int(ephemeris.iode[i]):
            reasons.append("no long-term correction of this IODE")
        else:
            reasons.append("")
            dt = 0.0 if long.t0_s is None else float(_seconds_of_day_since(tow[i], long.t0_s))
            dpos[i] = long.dpos_m + long.dvel_mps * dt
            dclock[i] = long.daf0_s + long.daf1_s_s * dt
            prc, _, t_of = got
            old = corrections.fast_previous.get(sv)
            a = FAST_DEGRADATION_MPS2[ai] if ai is not None else 0.0
            use_rrc = range_rate and old is not None and t_of > old[2] and ai != 0
            rrc = (prc - old[0]) / (t_of - old[2]) if use_rrc and old is not None else 0.0
            age = float(tow[i] - t_of)
            fast[i] = prc + rrc * age
            latency = float(mt7.latency_s) if mt7 is not None else 0.0
            eps_fc = a * (age + latency) ** 2 / 2
            eps_rrc = eps_ltc = 0.0
            if mt10 is not None:
                if use_rrc and old is not None:
                    iodf, iodf_before = corrections.fast_iodf.get(sv, (0, None))
                    step = t_of - old[2]
                    if iodf == 3 or iodf_before == 3:
                        if step != timeout / 2:
                            eps_rrc = (a * abs(step - timeout / 2) / 2 + mt10.brrc_m / step) * age
                    elif iodf_before is not None and (iodf - iodf_before) % 3 != 1:
                        eps_rrc = (a * timeout / 4 + mt10.brrc_m / step) * age
                if long.t0_s is not None:  # velocity code 1
                    late = max(0.0, -dt, dt - mt10.iltc_v1_s)
                    eps_ltc = mt10.cltc_lsb_m + mt10.cltc_v1_mps * late
                elif mt10.iltc_v0_s > 0:
                    since = float(tow[i] - corrections.long_term_time.get(sv, float(tow[i])))
                    eps_ltc = mt10.cltc_v0_m * np.floor(max(since, 0.0) / mt10.iltc_v0_s)
            var[i] = _flt_variance(
                corrections, got[1], eps_fc, eps_rrc, eps_ltc, 1.0 if dudre is None else float(dudre[i])
            )
    return dpos, dclock, fast, var, tuple(reasons)


def _iono_grid(corrections: SbasCorrections, tow_s: float) -> dict[tuple[float, float], tuple[float, float]]:
    """Monitored IGPs (latitude, longitude in [-180, 180)) to their delay and σ²_ionogrid at
    ``tow_s``: σ²_GIVE with type 10's ε_iono (``C_iono_step ⌊Δt / I_iono⌋ + C_iono_ramp Δt``,
    Δt the age of the IGP's delay), added to σ_GIVE (RSS_iono 0) or root-sum-squared (1)."""
    mt10 = corrections.parameters[1] if corrections.parameters is not None else None
    grid = {}
    for (_, lat, lon), (delay, givei, t) in corrections.iono.items():
        if np.isfinite(delay) and givei < 15:
            var = float(GIVE_VARIANCE_M2[givei])
            if mt10 is not None:
                age = max(tow_s - t, 0.0)
                steps = np.floor(age / mt10.iiono_s) if mt10.iiono_s > 0 else 0.0
                eps = mt10.ciono_step_m * steps + mt10.ciono_ramp_mps * age
                var = var + eps**2 if mt10.rss_iono == 1 else (np.sqrt(var) + eps) ** 2
            grid[(lat, (lon + 180.0) % 360.0 - 180.0)] = (delay, var)
    return grid


def solve_position_sbas(
    pseudorange_m: np.ndarray,
    transmit_s: np.ndarray,
    ephemeris: Ephemerides,
    corrections: SbasCorrections,
    *,
    day_of_year: float,
    mode: str = "pa",
    sigma_noise_m: float = 0.36,
    elevation_mask_deg: float = 5.0,
    max_fast_age_s: float = 120.0,
    range_rate: bool = True,
    initial_ecef_m: np.ndarray | None = None,
) -> SbasFix | None:
    """One epoch's SBAS-corrected position and protection levels (module text).

    Parameters
    ----------
    pseudorange_m, transmit_s, ephemeris
        As `pvt.solve_position`'s: ``(S,)`` GPS L1 C/A pseudoranges and satellite times of
        transmission (GPS seconds of week), and the ``S`` records of the satellites.
    corrections
        The SBAS messages received so far (`sbas_content.SbasCorrections`), their times in
        the same GPS seconds of week.
    day_of_year
        Of the epoch (1-366), for the MOPS troposphere's season.
    mode
        One of `SBAS_MODES`: the horizontal protection level's factor.
    sigma_noise_m
        The receiver's code noise σ (m) in σ²_air.
    elevation_mask_deg, initial_ecef_m
        As `pvt.solve_position`'s.
    max_fast_age_s, range_rate
        A fast correction older than this is not used; apply the range-rate correction.

    Returns
    -------
    SbasFix, or None with fewer than four corrected satellites.
    """
    if mode not in SBAS_MODES:
        raise ConfigError("mode", f"one of {', '.join(SBAS_MODES)}, got {mode!r}")
    if not sigma_noise_m > 0:
        raise ConfigError("sigma_noise_m", f"must be positive, got {sigma_noise_m}")
    if not 1 <= day_of_year <= 366:
        raise ConfigError("day_of_year", f"1 to 366, got {day_of_year}")
    pr, tx = np.asarray(pseudorange_m, float), np.asarray(transmit_s, float)
    if pr.shape != tx.shape or pr.ndim != 1 or ephemeris.sv.size != pr.size:
        raise ConfigError(
            "solve_position_sbas",
            f"pseudoranges {pr.shape}, transmit times {tx.shape} and "
            f"{ephemeris.sv.size} ephemeris records must all be (S,)",
        )
    t = np.where(np.isfinite(tx), tx, 0.0)
    carrier_hz = SBAS_L1.carrier_freq_hz  # the L1 C/A user's clock: SBAS L1 corrects that signal
    clock = single_frequency_clock_s(ephemeris, satellite_state(ephemeris, t), carrier_hz)
    state = satellite_state(ephemeris, t - clock)
    dpos, dclock, fast, var_flt, reasons = sbas_satellite_corrections(
        corrections, ephemeris, t - clock, max_fast_age_s=max_fast_age_s, range_rate=range_rate
    )
    reasons = tuple("no pseudorange" if not np.isfinite(p) else r for p, r in zip(pr, reasons))
    corrected = np.array([r == "" for r in reasons])
    sv_pos = state.position_m + dpos
    clock_m = _C * (single_frequency_clock_s(ephemeris, state, carrier_hz) + dclock)
    pr_fast = np.where(corrected, pr + fast, np.nan)
    letters = np.asarray(ephemeris.sv).astype("U1")
    sigma0 = np.where(corrected, np.sqrt(np.nan_to_num(var_flt) + sigma_noise_m**2), 1.0)
    first = solve_position_sv(
        pr_fast, sv_pos, clock_m, letters, sigma_m=sigma0, false_alarm=0.0, initial_ecef_m=initial_ecef_m
    )
    if first is None:
        return None
    fix, iono, tropo, sigma, reasons_now = first, np.zeros(pr.size), np.zeros(pr.size), sigma0, list(reasons)
    for _ in range(2):  # the pierce points and elevations of the fix, then once more
        lat, lon, h = fix.lat_deg, fix.lon_deg, fix.height_m
        if corrections.covariance or corrections.service:  # δUDRE along the lines of sight from the fix
            los = sv_pos - fix.position_ecef_m
            los_unit = los / np.linalg.norm(los, axis=1, keepdims=True)
            now = float(np.nanmedian(t - clock))
            dudre = delta_udre(corrections, np.asarray(ephemeris.sv), los_unit, now, (float(lat), float(lon)))
            var_flt = sbas_satellite_corrections(
                corrections, ephemeris, t - clock, max_fast_age_s=max_fast_age_s, range_rate=range_rate, dudre=dudre
            )[3]
        el, az = fix.elevation_deg, fix.azimuth_deg
        lat_pp, lon_pp, slant = sbas_pierce_point(lat, lon, az, el)
        vertical, var_uive = grid_vertical_delay(lat_pp, lon_pp, _iono_grid(corrections, float(np.nanmedian(tx))))
        iono, var_uire = slant * vertical, slant**2 * var_uive
        tropo, var_tropo = mops_troposphere(lat, h, el, day_of_year)
        multipath = 0.13 + 0.53 * np.exp(-el / 10.0)
        var = np.nan_to_num(var_flt) + var_uire + sigma_noise_m**2 + multipath**2 + var_tropo
        reasons_now = [
            r if r or np.isfinite(iono[i]) else "no ionospheric grid correction" for i, r in enumerate(reasons)
        ]
        use = np.array([r == "" for r in reasons_now])
        sigma = np.where(use, np.sqrt(np.where(use, var, 1.0)), 1.0)
        again = solve_position_sv(
            np.where(use, pr_fast - iono - tropo, np.nan),
            sv_pos,
            clock_m,
            letters,
            sigma_m=sigma,
            elevation_mask_deg=elevation_mask_deg,
            false_alarm=0.0,
            initial_ecef_m=fix.position_ecef_m,
        )
        if again is None:
            return None
        fix = again
    used = fix.used
    hpl, vpl = protection_levels(fix.azimuth_deg[used], fix.elevation_deg[used], sigma[used], mode)
    final = tuple(r if r or used[i] else "below the elevation mask" for i, r in enumerate(reasons_now))
    return SbasFix(
        fix,
        hpl,
        vpl,
        np.where(used, sigma, np.nan),
        np.where(used, iono, np.nan),
        np.where(used, tropo, np.nan),
        np.where(used, fast, np.nan),
        final,
    )
