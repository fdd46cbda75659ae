r"""Single-point position, velocity and time from GPS L1 C/A pseudoranges and Dopplers, or from
GPS, QZSS, Galileo and BeiDou ones together.

One epoch at a time, batch over the satellites:

- the satellite's state at its transmit time: the signal carries the satellite time
  ``t_SV``; ``t = t_SV - Δt_SV`` with the SV clock of IS-GPS-200 20.3.3.3.3.1 (polynomial and
  relativistic term) minus T_GD for the L1 C/A user (20.3.3.3.3.2), position from the
  ephemeris (`ephemeris.satellite_state`, Table 20-IV);
- the Earth's rotation during the flight time ``τ``: the satellite position is rotated by
  ``-ω_e τ`` about the z axis into the ECEF frame of the receive time (IS-GPS-200 20.3.3.4.3.3.2);
- the ionosphere by the Klobuchar model of the broadcast alpha/beta (20.3.3.5.2.5), and a
  troposphere (Saastamoinen's zenith delays with a standard atmosphere over 1/sin(E)),
  each switchable: gps-sdr-sim applies Klobuchar and no troposphere;
- weighted least squares (Gauss-Newton) on position and one receiver clock bias per time
  system (below), weights
  ``sin^2(E) / σ^2`` once the elevations are known; DOP from the unweighted geometry in
  the local east-north-up frame;
- residual-based exclusion of one satellite: when the weighted sum of squared residuals
  exceeds the chi-square bound of ``n - 4`` degrees of freedom at ``false_alarm``, the
  solution leaving out the satellite whose removal minimises it is taken, if that one
  passes (with six satellites or more);
- or, with ``raim`` (`integrity.raim`), fault detection and exclusion by its residual or
  solution-separation test and horizontal and vertical protection levels per epoch;
- velocity and clock drift from the Dopplers (range rate ``-λ D``) on the same geometry.

Several systems: the receiver clock is one state per time system, ``b_s`` (m), and the
model of a pseudorange of system ``s`` is

.. math:: \rho_i = |r_i - x| + b_{s(i)} + I_i + T_i - c\,\Delta t_{SV,i},
   \qquad H_i = [-u_i^T,\ e_{s(i)}^T]

(``e_s`` the unit row of the system's clock column: Hofmann-Wellenhof, Lichtenegger & Wasle,
*GNSS* (2008) 6.1.2 and 6.4; RTKLIB 2.4.3 ``pntpos.c`` ``rescode``, which takes the GPS clock
plus per-system offsets, the same model reparametrised). One clock per system rather than GPS
clock plus offsets so that a system without satellites simply has no column (``systems="EC"``
needs no GPS); the fix reports each other system's clock minus the reference clock (GPS's
when it is used) as ``system_offsets_ns``: the inter-system time offset (GPST minus the
system's time: Galileo's GGTO, BDT's residual after the 14 s of `ephemeris`) plus the
receiver's inter-system hardware bias. QZSS takes GPS's clock: QZSST is aligned to GPST
(IS-QZSS-PNT-005; RTKLIB does the same). A known offset (``time_offsets_s``, e.g. the broadcast
GGTO) corrects its system's pseudoranges instead and the system joins GPS's clock. A system
with fewer than two usable satellites is left out: one satellite only fixes its own clock
(its residual is zero, it carries no position information) and would make the residual
test's subsets singular. The residual test and `integrity.raim` count ``n - 3 - k``
degrees of freedom with ``k`` clock states, and DOPs come from ``(H^T H)^{-1}`` with all
``k`` clock columns (GDOP over every state).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pymap3d
from scipy import special  # not scipy.stats: its import costs a second of every run's start-up

from ..errors import ConfigError
from ..signal.gps_l1ca import GPS_L1CA
from ..signal.spec import SignalSpec
from ..signal.spec import SPEED_OF_LIGHT_M_S as SPEED_OF_LIGHT_MPS
from .dual_frequency import DualFrequency
from .ephemeris import (
    OMEGA_EARTH_RAD_S,
    SYSTEMS,
    Ephemerides,
    SatelliteState,
    ionosphere_scale,
    satellite_state,
    single_frequency_clock_s,
)
from .bds_iono import BdsKlobuchar
from .lnav import PI_IS_GPS, IonoUtc

__all__ = [
    "PositionFix",
    "RAIM_STATUSES",
    "klobuchar_delay_s",
    "broadcast_iono_delay_s",
    "iono_reference",
    "troposphere_delay_m",
    "dop",
    "solve_position",
    "solve_position_sv",
    "rtklib_variance_m2",
    "WEIGHTINGS",
    "CLOCK_OF_SYSTEM",
]

#: The receiver clock state each system's pseudoranges take: QZSS shares GPS's (QZSST is
#: aligned to GPST, IS-QZSS-PNT-005; RTKLIB 2.4.3 ``pntpos.c`` does the same).
CLOCK_OF_SYSTEM = {"G": "G", "J": "G", "E": "E", "C": "C"}
_CLOCK_ORDER = "GEC"

#: ``solve_position``'s weightings: ``elevation`` sin²(E)/σ², ``uniform`` 1/σ², ``rtklib``
#: 1/`rtklib_variance_m2` (RTKLIB's single-point error model).
WEIGHTINGS = ("elevation", "uniform", "rtklib")
#: RTKLIB 2.4.3's URA values (m) of the broadcast URA index 0-14 (IS-GPS-200 20.3.3.3.1.3).
_RTKLIB_URA_M = np.array(
    [2.4, 3.4, 4.85, 6.85, 9.65, 13.65, 24.0, 48.0, 96.0, 192.0, 384.0, 768.0, 1536.0, 3072.0, 6144.0]
)

_C = SPEED_OF_LIGHT_MPS


def chi2_ppf(q: float, dof: int) -> float:
    """Chi-square quantile, ``scipy.stats.chi2.ppf(q, dof)`` to the bit: ``2 P^{-1}(dof/2, q)``
    with ``P`` the regularised lower incomplete gamma function; NaN for ``dof < 1`` as scipy.stats."""
    return float(2 * special.gammaincinv(dof / 2, q)) if dof > 0 else float("nan")


@dataclass(frozen=True)
class PositionFix:
    """One epoch's solution.

    ``position_ecef_m`` (3,), geodetic ``lat_deg``, ``lon_deg``, ``height_m`` (WGS 84),
    ``clock_bias_m`` (receiver clock error times c), ``velocity_enu_mps`` (3,) and
    ``clock_drift_mps`` (NaN without Dopplers), ``gdop``/``pdop``/``hdop``/``vdop``, per
    satellite ``used`` (S,) and ``residuals_m`` (S,, NaN where not used), ``excluded`` the
    index of the satellite left out by the residual test (None if none), and
    ``elevation_deg``/``azimuth_deg`` (S,). With ``raim`` (`solve_position`): ``raim`` the
    outcome, one of `RAIM_STATUSES` (``""`` without), ``test_statistic`` the solution's
    weighted sum of squared residuals, ``fault_detected`` whether the test of the
    all-satellite solution fired, ``hpl_m``/``vpl_m`` the protection levels of the solution
    given (inf on an alert or with too few satellites, NaN without ``raim``).
    Several systems: ``clock_bias_m`` is the reference clock's (GPS's when used, else the
    first of Galileo, BeiDou with satellites), ``clock_systems`` the letters of the clock
    states of the solution (`CLOCK_OF_SYSTEM`; ``"G"`` for GPS alone) and
    ``system_offsets_ns`` each other clock minus the reference one (ns).
    """

    position_ecef_m: np.ndarray
    lat_deg: float
    lon_deg: float
    height_m: float
    clock_bias_m: float
    velocity_enu_mps: np.ndarray
    clock_drift_mps: float
    gdop: float
    pdop: float
    hdop: float
    vdop: float
    used: np.ndarray
    residuals_m: np.ndarray
    excluded: int | None
    elevation_deg: np.ndarray
    azimuth_deg: np.ndarray
    raim: str = ""
    test_statistic: float = float("nan")
    fault_detected: bool = False
    hpl_m: float = float("nan")
    vpl_m: float = float("nan")
    clock_systems: str = "G"
    system_offsets_ns: dict[str, float] = field(default_factory=dict)


#: ``PositionFix.raim``: no fault detected; one satellite excluded (and the remaining ones
#: pass); a fault detected and not excluded (protection levels inf); too few satellites
#: for a protection level (``n < m + 2``; inf).
RAIM_STATUSES = ("ok", "excluded", "alert", "unavailable")


def klobuchar_delay_s(
    alpha: np.ndarray,
    beta: np.ndarray,
    lat_deg: float,
    lon_deg: float,
    azimuth_deg: np.ndarray,
    elevation_deg: np.ndarray,
    gps_tow_s: float,
) -> np.ndarray:
    """L1 ionospheric delay (s) of the Klobuchar model (IS-GPS-200 20.3.3.5.2.5, Figure 20-4).

    ``alpha`` and ``beta`` as broadcast (s/semicircle^n); angles in degrees, converted to
    semicircles as the ICD's algorithm takes them.
    """
    E = np.asarray(elevation_deg, float) / 180.0
    A = np.radians(azimuth_deg)
    phi_u, lam_u = lat_deg / 180.0, lon_deg / 180.0
    psi = 0.0137 / (E + 0.11) - 0.022  # Earth's central angle to the pierce point
    phi_i = np.clip(phi_u + psi * np.cos(A), -0.416, 0.416)
    lam_i = lam_u + psi * np.sin(A) / np.cos(phi_i * PI_IS_GPS)
    phi_m = phi_i + 0.064 * np.cos((lam_i - 1.617) * PI_IS_GPS)  # geomagnetic latitude
    t = (4.32e4 * lam_i + gps_tow_s) % 86_400.0  # local time at the pierce point
    F = 1.0 + 16.0 * (0.53 - E) ** 3  # obliquity factor
    powers = phi_m[..., None] ** np.arange(4)
    amp = np.maximum(powers @ np.asarray(alpha, float), 0.0)
    per = np.maximum(powers @ np.asarray(beta, float), 72_000.0)
    x = 2 * PI_IS_GPS * (t - 50_400.0) / per
    day = F * (5e-9 + amp * (1 - x**2 / 2 + x**4 / 24))
    return np.where(np.abs(x) < 1.57, day, F * 5e-9)


def broadcast_iono_delay_s(
    iono: IonoUtc | BdsKlobuchar,
    lat_deg: float,
    lon_deg: float,
    azimuth_deg: np.ndarray,
    elevation_deg: np.ndarray,
    gps_tow_s: float,
) -> np.ndarray:
    """The broadcast model's ionospheric delay (s) at its own reference carrier
    (`iono_reference`): GPS's page 18 by IS-GPS-200's algorithm (`klobuchar_delay_s`, L1),
    BeiDou's coefficients by the BDS ICD's (`bds_iono.bds_klobuchar_delay_s`, B1I)."""
    if isinstance(iono, BdsKlobuchar):
        return iono.delay_s(lat_deg, lon_deg, azimuth_deg, elevation_deg, gps_tow_s)
    return klobuchar_delay_s(iono.alpha, iono.beta, lat_deg, lon_deg, azimuth_deg, elevation_deg, gps_tow_s)


def iono_reference(iono: IonoUtc | BdsKlobuchar | None, gps: SignalSpec = GPS_L1CA) -> SignalSpec:
    """The signal whose delay ``iono``'s model gives: B1I for BeiDou's, ``gps`` (L1 C/A, page
    18's, IS-GPS-200 20.3.3.5.2.5) otherwise."""
    return iono.reference if isinstance(iono, BdsKlobuchar) else gps


def troposphere_delay_m(
    lat_deg: float, height_m: float, elevation_deg: np.ndarray, humidity: float = 0.7
) -> np.ndarray:
    """Tropospheric delay (m): Saastamoinen's hydrostatic and wet zenith delays (1972) with
    a standard atmosphere (1013.25 hPa, 15 degC at sea level, lapse 6.5 K/km, relative
    ``humidity``), mapped by 1/sin(E)."""
    h = float(np.clip(height_m, 0.0, 10_000.0))
    pressure_hpa = 1013.25 * (1 - 2.2557e-5 * h) ** 5.2568
    temp_k = 15.0 - 6.5e-3 * h + 273.16
    vapour_hpa = 6.108 * humidity * np.exp((17.15 * temp_k - 4684.0) / (temp_k - 38.45))
    zenith_dry = 0.0022768 * pressure_hpa / (1 - 0.00266 * np.cos(2 * np.radians(lat_deg)) - 0.00028 * h / 1e3)
    zenith_wet = 0.002277 * (1255.0 / temp_k + 0.05) * vapour_hpa
    sin_e = np.sin(np.radians(np.maximum(np.asarray(elevation_deg, float), 1.0)))
    return (zenith_dry + zenith_wet) / sin_e


def dop(unit_enu: np.ndarray, clocks: np.ndarray | None = None) -> tuple[float, float, float, float]:
    """GDOP, PDOP, HDOP, VDOP of line-of-sight unit vectors ``(S, 3)`` (east, north, up from
    the receiver to each satellite): the square roots of the diagonal of ``(HᵀH)⁻¹`` with
    rows ``H = [-u, 1]``, or ``H = [-u, clocks]`` with ``clocks`` ``(S, k)`` the one-hot
    clock columns of several time systems (GDOP then sums all ``3 + k`` variances)."""
    ones = np.ones((len(unit_enu), 1)) if clocks is None else np.asarray(clocks, float)
    H = np.hstack([-np.asarray(unit_enu, float), ones])
    Q = np.linalg.inv(H.T @ H)
    d = np.diag(Q)
    return (float(np.sqrt(d.sum())), float(np.sqrt(d[:3].sum())), float(np.sqrt(d[:2].sum())), float(np.sqrt(d[2])))


def _rotate_earth(pos: np.ndarray, tau_s: np.ndarray) -> np.ndarray:
    """Satellite ECEF positions at transmit time expressed in the ECEF frame ``tau_s`` later."""
    theta = OMEGA_EARTH_RAD_S * tau_s
    c, s = np.cos(theta), np.sin(theta)
    return np.stack([c * pos[:, 0] + s * pos[:, 1], -s * pos[:, 0] + c * pos[:, 1], pos[:, 2]], axis=-1)


def _enu_rotation(lat_deg: float, lon_deg: float) -> np.ndarray:
    """Rows: east, north, up unit vectors in ECEF."""
    la, lo = np.radians(lat_deg), np.radians(lon_deg)
    return np.array(
        [
            [-np.sin(lo), np.cos(lo), 0.0],
            [-np.sin(la) * np.cos(lo), -np.sin(la) * np.sin(lo), np.cos(la)],
            [np.cos(la) * np.cos(lo), np.cos(la) * np.sin(lo), np.sin(la)],
        ]
    )


def rtklib_variance_m2(
    elevation_deg: np.ndarray, iono_m: np.ndarray | None, troposphere: bool, ura_m: np.ndarray | None
) -> np.ndarray:
    r"""Pseudorange variance (m²) of RTKLIB 2.4.3's single-point solution (``pntpos.c``:
    ``varerr``, ``rescode``, ``ionocorr``, ``tropcorr``, ``var_uraeph``), per satellite:

    .. math:: \sigma^2 = 0.3^2 (1 + 1/\sin E) + 0.3^2 + \sigma_{URA}^2 + \sigma_{ion}^2 + \sigma_{trop}^2

    (its default error ratio 100 times 0.003 m, and the 0.3 m code bias); the URA the first
    table value at or above the broadcast accuracy ``ura_m`` (2.4 m where unknown);
    :math:`\sigma_{ion} = 0.5 I` with the Klobuchar delay ``iono_m`` applied, else 5 m;
    :math:`\sigma_{trop} = 0.3 / (\sin E + 0.1)` with Saastamoinen applied, else 3 m.
    """
    sin_e = np.sin(np.radians(np.maximum(np.asarray(elevation_deg, float), 1.0)))
    var = 0.3**2 * (1.0 + 1.0 / sin_e) + 0.3**2
    var = var + (np.square(0.5 * np.asarray(iono_m, float)) if iono_m is not None else 5.0**2)
    var = var + ((0.3 / (sin_e + 0.1)) ** 2 if troposphere else 3.0**2)
    ura = np.full(sin_e.shape, np.nan) if ura_m is None else np.asarray(ura_m, float)
    index = np.minimum(
        np.searchsorted(_RTKLIB_URA_M, np.where(np.isfinite(ura) & (ura > 0), ura, 0.0)), _RTKLIB_URA_M.size - 1
    )
    return var + _RTKLIB_URA_M[index] ** 2


def _clock_columns(use: np.ndarray, clock_index: np.ndarray | None, k: int) -> tuple[np.ndarray, np.ndarray]:
    """The satellites used and the clock states estimated: with several clocks, a clock's
    satellites only where it has two or more (one alone fixes its own clock only)."""
    if clock_index is None or k == 1:
        return use, np.arange(1)
    count = np.bincount(clock_index[use], minlength=k)
    use = use & (count[clock_index] >= 2)
    return use, np.flatnonzero(np.bincount(clock_index[use], minlength=k) > 0)


def _least_squares(
    pr,
    sat_pos,
    clock_m,
    keep,
    sigma_m,
    iono,
    troposphere,
    tow_s,
    x0,
    mask_deg,
    weighting="elevation",
    ura_m=None,
    clock_index=None,
    iono_scale=1.0,
):
    """Gauss-Newton on (x, y, z, b_1..b_k) with the satellites ``keep``, weighted as
    ``weighting`` (one of `WEIGHTINGS`); ``clock_index`` ``(S,)`` the clock state of each
    satellite (None: one clock). Returns the state, the weighted residuals' chi-square,
    residuals, unit vectors, elevations, azimuths, the satellites used, the rotated
    satellite positions, the weights, the clock columns ``(S, k_used)`` of the design
    matrix and the indices of the clocks estimated."""
    x = x0.copy()
    S = pr.size
    k = x.size - 3
    onehot = np.ones((S, 1)) if clock_index is None else (clock_index[:, None] == np.arange(k)).astype(float)
    el = np.full(S, 90.0)
    az = np.zeros(S)
    corr = np.zeros(S)
    use, cols = _clock_columns(keep.copy(), clock_index, k)
    for _ in range(20):
        near_surface = np.linalg.norm(x[:3]) > 6.0e6
        tau = np.where(near_surface, np.linalg.norm(sat_pos - x[:3], axis=1) / _C, 0.075)
        rot = _rotate_earth(sat_pos, tau)
        los = rot - x[:3]
        geo = np.linalg.norm(los, axis=1)
        u = los / geo[:, None]
        if near_surface:
            lat, lon, h = pymap3d.ecef2geodetic(*x[:3])
            az, el, _ = pymap3d.ecef2aer(rot[:, 0], rot[:, 1], rot[:, 2], lat, lon, h)
            az, el = np.asarray(az, float), np.asarray(el, float)
            corr = np.zeros(S)
            iono_m = None
            if iono is not None:
                iono_m = iono_scale * _C * broadcast_iono_delay_s(iono, lat, lon, az, el, tow_s)
                corr = corr + iono_m
            if troposphere:
                corr = corr + troposphere_delay_m(lat, h, el)
            use, cols = _clock_columns(keep & (el >= mask_deg), clock_index, k)
            if weighting == "rtklib":
                w = 1.0 / rtklib_variance_m2(el, iono_m, troposphere, ura_m)
            else:
                elevation = weighting == "elevation"
                w = (np.sin(np.radians(np.maximum(el, 1.0))) ** 2 if elevation else np.ones(S)) / sigma_m**2
        else:
            w = np.full(S, 1.0 / sigma_m**2) if np.ndim(sigma_m) == 0 else 1.0 / np.square(sigma_m)
        if use.sum() < 3 + cols.size or cols.size == 0:
            return None
        clk = x[3] if k == 1 else onehot @ x[3:]
        dz = pr - (geo + clk + corr - clock_m)
        H = np.hstack([-u, onehot[:, cols]])
        Hw = H[use] * w[use, None]
        dx = np.linalg.solve(Hw.T @ H[use], Hw.T @ dz[use])
        if k == 1:
            x = x + dx
        else:
            x[:3] += dx[:3]
            x[3 + cols] += dx[3:]
        if np.linalg.norm(dx) < 1e-4:
            break
    clk = x[3] if k == 1 else onehot @ x[3:]
    res = pr - (geo + clk + corr - clock_m)
    stat = float(np.sum(w[use] * res[use] ** 2))
    return x, stat, np.where(use, res, np.nan), u, el, az, use, rot, w, onehot[:, cols], cols


def _dof(sol) -> int:
    """Degrees of freedom of a solution: satellites used less 3 and its clock states."""
    return int(sol[6].sum()) - 3 - sol[9].shape[1]


def _clock_index(letters: np.ndarray, time_offsets_s: dict[str, float], keep: np.ndarray) -> tuple[np.ndarray, str]:
    """Each satellite's clock state and the letters of the clocks of the satellites ``keep``
    (`CLOCK_OF_SYSTEM`; a system with a known offset takes GPS's clock; a satellite left out
    takes the first clock, unused)."""
    clock = np.array(["G" if str(s) in time_offsets_s else CLOCK_OF_SYSTEM.get(str(s), "") for s in letters])
    present = "".join(c for c in _CLOCK_ORDER if np.any((clock == c) & keep))
    return np.array([present.index(c) if c and c in present else 0 for c in clock], dtype=int), present


def _check_systems(systems: str | None, time_offsets_s: dict[str, float] | None) -> None:
    for letter in (systems or "") + "".join(time_offsets_s or {}):
        if letter not in SYSTEMS:
            raise ConfigError("systems", f"RINEX letters of {', '.join(SYSTEMS)} (e.g. 'GEC'), got {letter!r}")
    for letter, offset in (time_offsets_s or {}).items():
        if letter in "GJ" or not np.isfinite(offset):
            raise ConfigError(
                "time_offsets_s", f"a finite offset of a system with its own time (E, C), got {letter!r}: {offset}"
            )


def solve_position(
    pseudorange_m: np.ndarray,
    transmit_s: np.ndarray,
    ephemeris: Ephemerides,
    *,
    doppler_hz: np.ndarray | None = None,
    iono: IonoUtc | BdsKlobuchar | None = None,
    troposphere: bool = False,
    sigma_m: float = 5.0,
    elevation_mask_deg: float = 5.0,
    false_alarm: float = 1e-3,
    initial_ecef_m: np.ndarray | None = None,
    elevation_weights: bool = True,
    wavelength_m: float | None = None,
    signal: SignalSpec = GPS_L1CA,
    weighting: str | None = None,
    raim: str | None = None,
    missed_detection: float = 1e-3,
    integrity_risk: float = 1e-7,
    systems: str | None = None,
    time_offsets_s: dict[str, float] | None = None,
    dual: DualFrequency | None = None,
) -> PositionFix | None:
    """Position, velocity and clock of one epoch.

    Parameters
    ----------
    pseudorange_m, transmit_s
        ``(S,)`` pseudoranges and the satellite times of transmission (GPS seconds of week,
        before the SV clock correction), NaN where a satellite has none.
    ephemeris
        ``S`` records in the same order (:meth:`Ephemerides.select`); of GPS, QZSS, Galileo
        and BeiDou satellites together, one receiver clock per time system is estimated
        (module text).
    doppler_hz
        ``(S,)`` Dopplers for the velocity (optional; one clock drift, of a single system).
    wavelength_m
        Carrier wavelength of the Dopplers (default ``signal.wavelength_m``).
    signal
        The signal measured (`SignalSpec`; GPS L1 C/A by default): its wavelength is the
        default ``wavelength_m``. A set of signals on different carriers (anything with
        ``carrier_freq_hz_of(letters)``, `multi_receive.SignalSet`) gives each satellite its
        own system's carrier: its Doppler's wavelength, its single-frequency clock and its
        ionospheric scale (``wavelength_m`` must then be None).
    iono
        Broadcast Klobuchar coefficients (None: no ionospheric correction): GPS's page 18
        (`lnav.IonoUtc`, IS-GPS-200's model, L1's delay) or BeiDou's (`bds_iono.BdsKlobuchar`,
        the BDS ICD's model, B1I's delay); each satellite's delay scaled from that signal's
        carrier to its own (`broadcast_iono_delay_s`).
    troposphere
        Apply `troposphere_delay_m`.
    sigma_m
        Pseudorange standard deviation at the zenith (weights and the residual test).
    elevation_mask_deg
        Satellites below are not used (once the position is known).
    false_alarm
        Probability of the residual test rejecting a fault-free solution.
    initial_ecef_m
        Starting point (default the Earth's centre).
    elevation_weights
        Weights ``sin²(E) / σ²`` (default); False: ``1 / σ²`` for every satellite (the
        weighting of a comparison with a solver that weights nearly equally, as RTKLIB's
        single-point solution with broadcast URA does).
    weighting
        One of `WEIGHTINGS`, overriding ``elevation_weights``: ``rtklib`` weights by
        `rtklib_variance_m2` (with the records' ``accuracy_m`` as URA), as RTKLIB's SPP
        does, for solutions that agree with it on the same observations (``sigma_m`` is then
        unused: the residual test takes RTKLIB's variances).
    raim
        None (default): the residual exclusion above. One of `integrity.RAIM_METHODS`
        (``chi2`` the residual test with slope protection levels, ``ss`` solution separation
        with its own): `integrity.raim` at ``false_alarm``, ``missed_detection`` and
        ``integrity_risk`` decides the exclusion (the satellite it names is left out and
        the solution solved again) and gives the fix's protection levels.
    missed_detection, integrity_risk
        ``P_md`` and the fault-free integrity risk of the protection levels (with ``raim``).
    systems
        RINEX letters of the systems to use (``"GEC"``, ``"E"``; default every system of
        ``ephemeris``): the other satellites are left out.
    time_offsets_s
        Known system time minus GPS time (s) per system letter, e.g. ``{"E": ggto}`` with
        Galileo's broadcast GGTO ``A0G + A1G (t - t0G)`` (Galileo OS SIS ICD 5.1.8): that
        system's pseudoranges are corrected by ``+c offset`` and it takes GPS's clock instead
        of its own (its receiver hardware bias is then taken as GPS's).
    dual
        The pseudoranges are the ionosphere-free combination of these two signals
        (`dual_frequency.DualFrequency`): the satellite clock is the combination's, no
        ionospheric correction is made (``iono`` is not used), and the Dopplers are those of
        ``signal`` (give its ``first``).

    Returns
    -------
    PositionFix, or None with fewer than four usable satellites (three plus one per clock
    state).
    """
    pr = np.asarray(pseudorange_m, float)
    tx = np.asarray(transmit_s, float)
    if pr.shape != tx.shape or pr.ndim != 1 or ephemeris.sv.size != pr.size:
        raise ConfigError(
            "solve_position",
            f"pseudoranges {pr.shape}, transmit times {tx.shape} and "
            f"{ephemeris.sv.size} ephemeris records must all be (S,)",
        )
    if sigma_m <= 0:
        raise ConfigError("sigma_m", f"must be positive, got {sigma_m}")
    if weighting is not None and weighting not in WEIGHTINGS:
        raise ConfigError("weighting", f"one of {', '.join(WEIGHTINGS)}, got {weighting!r}")
    _check_systems(systems, time_offsets_s)
    if weighting is None:
        weighting = "elevation" if elevation_weights else "uniform"
    ura_m = ephemeris.accuracy_m
    keep = np.isfinite(pr) & np.isfinite(tx)
    letters = np.asarray(ephemeris.sv).astype("U1")
    if systems is not None:
        keep &= np.isin(letters, list(systems))
    if keep.sum() < 4:
        return None
    t = np.where(keep, tx, 0.0)
    # Each satellite's carrier: the signal's, or per system for a set of signals on
    # different carriers (`multi_receive.SignalSet.carrier_freq_hz_of`).
    carriers_of = getattr(signal, "carrier_freq_hz_of", None)
    carriers = carriers_of(letters) if carriers_of is not None else None
    if carriers is None or np.all(carriers == carriers[0]):
        carrier_hz = _C / signal.wavelength_m if carriers is None else float(carriers[0])
        iono_scale: float | np.ndarray = ionosphere_scale(carrier_hz, iono_reference(iono))
        lam_sv: float | np.ndarray = _C / carrier_hz if wavelength_m is None else wavelength_m
    else:
        if wavelength_m is not None:
            raise ConfigError("wavelength_m", f"{signal.name}: one wavelength given for signals on different carriers")
        iono_scale = np.array([ionosphere_scale(float(c), iono_reference(iono)) for c in carriers])
        lam_sv = _C / carriers

    def sv_clock_s(st: SatelliteState) -> np.ndarray:
        if dual is not None:
            return dual.clock_s(ephemeris, st)
        if carriers is None or np.all(carriers == carriers[0]):
            return single_frequency_clock_s(ephemeris, st, carrier_hz)
        out = np.full(letters.shape, np.nan)
        for c in np.unique(carriers):  # each system's own signal
            mine = carriers == c
            out = np.where(mine, single_frequency_clock_s(ephemeris, st, float(c)), out)
        return out

    if dual is not None:  # no first-order ionosphere left to correct
        iono, iono_scale = None, 0.0
    clock = sv_clock_s(satellite_state(ephemeris, t))
    state = satellite_state(ephemeris, t - clock)  # t = t_SV - Δt_SV (20.3.3.3.3.1)
    clock_m = _C * sv_clock_s(state)
    tow = float(np.nanmedian(tx)) + 0.075
    prz = np.where(keep, pr, 0.0)
    offsets = time_offsets_s or {}
    if offsets:
        prz = prz + _C * np.array([offsets.get(str(s), 0.0) for s in letters])
    fix = _solve(
        prz,
        state.position_m,
        clock_m,
        keep,
        letters,
        offsets,
        initial_ecef_m,
        (sigma_m, iono, troposphere, tow, iono_scale),
        (elevation_mask_deg, weighting, ura_m),
        (raim, false_alarm, missed_detection, integrity_risk),
    )
    if fix is None:
        return None
    sol, excluded, checks, clocks = fix
    vel, drift = np.full(3, np.nan), np.nan
    x, _, _, u, _, _, use, rot, _, _, _ = sol
    if doppler_hz is not None:
        d = np.asarray(doppler_hz, float)
        ok = use & np.isfinite(d)
        if ok.sum() >= 4:
            lat, lon, _ = pymap3d.ecef2geodetic(*x[:3])
            R = _enu_rotation(float(lat), float(lon))
            # Range rate -λ D = u·(v_sat - v_rx) + ḃ - c Δṫ_SV (satellite velocity rotated as its position).
            v_sat = _rotate_earth(state.velocity_mps, np.linalg.norm(rot - x[:3], axis=1) / _C)
            y = -lam_sv * d - np.sum(u * v_sat, axis=1) + _C * state.clock_drift_s_s
            H = np.hstack([-u, np.ones((u.shape[0], 1))])
            sol_v, *_ = np.linalg.lstsq(H[ok], y[ok], rcond=None)
            vel, drift = R @ sol_v[:3], float(sol_v[3])
    return _position_fix(sol, excluded, checks, clocks, vel, drift)


def solve_position_sv(
    pseudorange_m: np.ndarray,
    sv_position_ecef_m: np.ndarray,
    sv_clock_m: np.ndarray,
    system: np.ndarray | list[str],
    *,
    sigma_m: float | np.ndarray = 5.0,
    weighting: str = "uniform",
    elevation_mask_deg: float = 0.0,
    false_alarm: float = 1e-3,
    initial_ecef_m: np.ndarray | None = None,
    raim: str | None = None,
    missed_detection: float = 1e-3,
    integrity_risk: float = 1e-7,
    systems: str | None = None,
    time_offsets_s: dict[str, float] | None = None,
) -> PositionFix | None:
    """Position and clocks of one epoch from satellite states given with the ranges (as
    smartphone logs carry them), by the least squares of `solve_position`.

    Parameters
    ----------
    pseudorange_m
        ``(S,)`` pseudoranges corrected for everything but the satellite clock and the
        receiver's (ionosphere, troposphere subtracted), NaN where absent.
    sv_position_ecef_m
        ``(S, 3)`` satellite positions at transmit time in the ECEF frame of that time (the
        Earth's rotation over the flight time is applied here).
    sv_clock_m
        ``(S,)`` satellite clock offsets times c, added to the pseudoranges.
    system
        ``(S,)`` RINEX letter of each satellite's system (G, J, E, C).
    sigma_m
        Pseudorange standard deviations, scalar or ``(S,)``.
    weighting
        ``uniform`` (default, ``1/σ²``) or ``elevation`` (``sin²(E)/σ²``).
    elevation_mask_deg, false_alarm, initial_ecef_m, raim, missed_detection, integrity_risk, systems, time_offsets_s
        As `solve_position`'s.

    Returns
    -------
    PositionFix (velocity and drift NaN), or None with too few usable satellites.
    """
    pr = np.asarray(pseudorange_m, float)
    pos = np.asarray(sv_position_ecef_m, float)
    clock_m = np.asarray(sv_clock_m, float)
    letters = np.asarray(system).astype("U1")
    if pr.ndim != 1 or pos.shape != pr.shape + (3,) or clock_m.shape != pr.shape or letters.shape != pr.shape:
        raise ConfigError(
            "solve_position_sv",
            f"pseudoranges {pr.shape}, satellite positions {pos.shape}, clocks "
            f"{clock_m.shape} and systems {letters.shape} must be (S,), (S, 3), "
            "(S,), (S,)",
        )
    sigma = np.asarray(sigma_m, float)
    if not np.all(sigma > 0):
        raise ConfigError("sigma_m", f"must be positive, got {sigma_m}")
    if weighting not in ("uniform", "elevation"):
        raise ConfigError("weighting", f"uniform or elevation, got {weighting!r}")
    _check_systems(systems, time_offsets_s)
    chosen = letters if systems is None else letters[np.isin(letters, list(systems))]
    _check_systems("".join(np.unique(chosen).tolist()), None)
    keep = np.isfinite(pr) & np.all(np.isfinite(pos), axis=1) & np.isfinite(clock_m) & np.isfinite(sigma)
    if systems is not None:
        keep &= np.isin(letters, list(systems))
    if keep.sum() < 4:
        return None
    offsets = time_offsets_s or {}
    prz = np.where(keep, pr, 0.0) + _C * np.array([offsets.get(str(s), 0.0) for s in letters])
    sigma = np.where(keep, np.broadcast_to(sigma, pr.shape), 1.0) if sigma.ndim else float(sigma)
    far = np.array([0.0, 0.0, 2.6e7])  # a stand-in for an unused satellite without a position (no 0/0)
    fix = _solve(
        prz,
        np.where(keep[:, None], pos, far),
        np.where(keep, clock_m, 0.0),
        keep,
        letters,
        offsets,
        initial_ecef_m,
        (sigma, None, False, 0.0, 1.0),
        (elevation_mask_deg, weighting, None),
        (raim, false_alarm, missed_detection, integrity_risk),
    )
    if fix is None:
        return None
    return _position_fix(*fix, np.full(3, np.nan), float("nan"))


def _solve(prz, sat_pos, clock_m, keep, letters, offsets, initial_ecef_m, model, options, integrity):
    """Least squares, then the residual exclusion or `integrity.raim`: the solution, the
    index excluded (None), the integrity fields and the clocks' letters."""
    raim, false_alarm, missed_detection, integrity_risk = integrity
    sigma_m, iono, troposphere, tow, iono_scale = model
    elevation_mask_deg, weighting, ura_m = options
    clock_index, clocks = _clock_index(letters, offsets, keep)
    one = len(clocks) == 1
    k = len(clocks)
    x0 = np.zeros(3 + k) if initial_ecef_m is None else np.r_[np.asarray(initial_ecef_m, float), np.zeros(k)]
    args = (prz, sat_pos, clock_m)
    index = None if one else clock_index
    sol = _least_squares(
        *args, keep, sigma_m, iono, troposphere, tow, x0, elevation_mask_deg, weighting, ura_m, index, iono_scale
    )
    if sol is None:
        return None
    excluded = None
    dof = _dof(sol)
    checks: dict = {}
    if raim is not None:
        sol, excluded, checks = _raim_solution(
            sol,
            args,
            keep,
            model,
            (elevation_mask_deg, weighting, ura_m, index),
            raim,
            false_alarm,
            missed_detection,
            integrity_risk,
        )
    elif dof >= 2 and sol[1] > chi2_ppf(1 - false_alarm, dof):
        trials = {}
        for j in np.flatnonzero(sol[6]):
            k_ = keep.copy()
            k_[j] = False
            trial = _least_squares(
                *args,
                k_,
                sigma_m,
                iono,
                troposphere,
                tow,
                sol[0],
                elevation_mask_deg,
                weighting,
                ura_m,
                index,
                iono_scale,
            )
            if trial is not None:
                trials[int(j)] = trial
        if trials:
            j, best = min(trials.items(), key=lambda kv: kv[1][1])
            if best[1] <= chi2_ppf(1 - false_alarm, _dof(best)):
                sol, excluded = best, j
    return sol, excluded, checks, clocks


def _position_fix(sol, excluded, checks, clocks, vel, drift) -> PositionFix:
    """The `PositionFix` of a solution; DOPs with its clock columns."""
    x, _, res, u, el, az, use, _, _, columns, cols = sol
    lat, lon, h = (float(v) for v in pymap3d.ecef2geodetic(*x[:3]))
    R = _enu_rotation(lat, lon)
    if len(clocks) == 1:
        gdop, pdop, hdop, vdop = dop(u[use] @ R.T)
        return PositionFix(
            x[:3],
            lat,
            lon,
            h,
            float(x[3]),
            vel,
            drift,
            gdop,
            pdop,
            hdop,
            vdop,
            use,
            res,
            excluded,
            el,
            az,
            **checks,
            clock_systems=clocks,
            system_offsets_ns={},
        )
    gdop, pdop, hdop, vdop = dop(u[use] @ R.T, columns[use])
    estimated = [clocks[i] for i in cols]  # a clock whose satellites were all left out has no state
    ref = estimated[0]
    offsets = {c: float((x[3 + clocks.index(c)] - x[3 + clocks.index(ref)]) / _C * 1e9) for c in estimated[1:]}
    return PositionFix(
        x[:3],
        lat,
        lon,
        h,
        float(x[3 + clocks.index(ref)]),
        vel,
        drift,
        gdop,
        pdop,
        hdop,
        vdop,
        use,
        res,
        excluded,
        el,
        az,
        **checks,
        clock_systems="".join(estimated),
        system_offsets_ns=offsets,
    )


def _integrity_of(sol, method: str, false_alarm: float, missed_detection: float, integrity_risk: float):
    """`integrity.raim` of one least-squares solution (its geometry in east-north-up at the
    solution, its weights and post-fit residuals)."""
    from .integrity import raim

    x, _, res, u, _, _, use, _, w, columns, _ = sol
    lat, lon, _ = pymap3d.ecef2geodetic(*x[:3])
    with np.errstate(divide="ignore"):
        sigma = 1.0 / np.sqrt(w)
    # The design matrix [-u, clock columns] (`integrity.enu_geometry` for one clock): n - 3 - k dof.
    geometry = np.concatenate([-(u @ _enu_rotation(float(lat), float(lon)).T), columns], axis=-1)
    return raim(
        geometry,
        sigma,
        res,
        use,
        false_alarm=false_alarm,
        missed_detection=missed_detection,
        integrity_risk=integrity_risk,
        method=method,
    )


def _raim_solution(sol, args, keep, model, options, method, false_alarm, missed_detection, integrity_risk):
    """The solution after `integrity.raim`'s exclusion, the index excluded (None) and the
    `PositionFix` integrity fields."""
    from .integrity import RAIM_METHODS

    if method not in RAIM_METHODS:
        raise ConfigError("raim", f"one of {', '.join(RAIM_METHODS)}, got {method!r}")
    first = _integrity_of(sol, method, false_alarm, missed_detection, integrity_risk)
    result, excluded, status = first, None, "ok"
    if bool(first.detected):
        status = "alert"
        j = int(first.excluded)
        if j >= 0:
            k = keep.copy()
            k[j] = False
            trial = _least_squares(*args, k, *model[:4], sol[0], *options, iono_scale=model[4])
            if trial is not None:
                again = _integrity_of(trial, method, false_alarm, missed_detection, integrity_risk)
                if not bool(again.detected):
                    sol, excluded, result, status = trial, j, again, "excluded"
    hpl, vpl = float(result.hpl_m), float(result.vpl_m)
    if status == "alert":
        hpl = vpl = float("inf")
    elif not np.isfinite(hpl):
        status = "unavailable"
    return (
        sol,
        excluded,
        {
            "raim": status,
            "test_statistic": float(result.wsse),
            "fault_detected": bool(first.detected),
            "hpl_m": hpl,
            "vpl_m": vpl,
        },
    )
