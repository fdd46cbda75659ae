"""Positions at every epoch of a receiver's observables, their table and CSV.

For each epoch of :class:`~gnssframework.receiver.navigation.observables.Observables`, the
satellites with a pseudorange and a healthy ephemeris (the one decoded from their own
LNAV, else the nearest record of a RINEX navigation file) go to
:func:`~gnssframework.navigation.pvt.solve_position`. The GPS week is the decoded 10-bit
week placed in the era of the RINEX file when one is given, else in the era that began
on 2019-04-07 (weeks 2048-3071, IS-GPS-200 20.3.3.3.1.1: the week rolls over every 1024).
With ``raim`` each fix carries its integrity (`navigation.integrity`): the table and
``positions.csv`` then add the columns `INTEGRITY_COLUMNS`; fixes of several systems'
satellites the column `SYSTEM_OFFSET_COLUMN`. With ``sbas`` (messages from a file,
`sbas_fixes`) each GPS L1 C/A fix is DO-229's SBAS-corrected one where the corrections
cover the epoch: the columns `sbas_fixes.SBAS_COLUMNS`.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ...errors import ConfigError
from ...navigation.ephemeris import Ephemerides, _wrap_week, records_with_clock
from ...navigation.dual_frequency import DualFrequency
from ...navigation.weeks import full_week as nearest_week
from ...navigation.bds_iono import BdsKlobuchar
from ...navigation.lnav import IonoUtc
from .observables import SPEED_OF_LIGHT_MPS, Observables
from .sbas_fixes import SBAS_COLUMNS, SbasOptions, day_of_year, sbas_corrects
from ...navigation.pvt import PositionFix, solve_position
from ...navigation.sbas_pvt import solve_position_sbas
from ...signal.gps_l1ca import GPS_L1CA
from ...signal.spec import SignalSpec

__all__ = [
    "PositionTable",
    "solve_epochs",
    "write_positions_csv",
    "POSITION_COLUMNS",
    "INTEGRITY_COLUMNS",
    "full_week",
    "SYSTEM_OFFSET_COLUMN",
    "ELEVATION_MASK_DEG",
]

#: Columns of ``positions.csv`` (one row per solution).
POSITION_COLUMNS = (
    "gps_week",
    "tow_s",
    "lat_deg",
    "lon_deg",
    "height_m",
    "vel_e_mps",
    "vel_n_mps",
    "vel_u_mps",
    "clock_bias_m",
    "n_sats",
    "hdop",
    "vdop",
)
#: Columns added with integrity monitoring: horizontal and vertical protection levels (m;
#: inf on an alert or with too few satellites) and the outcome (`pvt.RAIM_STATUSES`).
INTEGRITY_COLUMNS = ("hpl_m", "vpl_m", "raim")
#: Column added when a fix estimated a clock per time system (several systems'
#: satellites): the second system's receiver clock minus the first's (ns; GST - GPS time
#: plus the receiver's inter-system bias in a GPS+Galileo fix, `pvt.PositionFix.system_offsets_ns`),
#: NaN in a row with one clock.
SYSTEM_OFFSET_COLUMN = "system_offset_ns"
_ERA_START_WEEK = 2048
#: Satellites below this elevation (deg) are left out of a fix.
ELEVATION_MASK_DEG = 5.0


@dataclass(frozen=True)
class PositionTable:
    """One row per epoch with a solution: the columns of `POSITION_COLUMNS` (each ``(F,)``),
    the ECEF positions ``(F, 3)``, the recording time of each epoch ``(F,)``, the PRNs used
    and the one excluded (0: none) per epoch, and the receiver clock drift ``(F,)`` (m/s,
    NaN without Dopplers; None where not solved)."""

    columns: dict[str, np.ndarray]
    ecef_m: np.ndarray
    sample_time_s: np.ndarray
    used_prns: list[tuple[int, ...]]
    excluded_prn: np.ndarray
    clock_drift_mps: np.ndarray | None = None

    def __len__(self) -> int:
        return int(self.sample_time_s.size)


def full_week(week10: int | None, reference_week: int | None = None, bits: int = 10) -> int:
    """The full GPS week of a week sent in its low ``bits`` bits (LNAV's 10, CNAV's 13): the
    one nearest ``reference_week``, else the one in the era holding week 2048 (weeks
    2048-3071 for 10 bits, 0-8191 for 13); without a decoded week, ``reference_week``
    itself (-1: unknown)."""
    if week10 is None:
        return -1 if reference_week is None else int(reference_week)
    if reference_week is not None:
        return nearest_week(week10, bits, reference_week)
    span = 1 << bits
    return _ERA_START_WEEK // span * span + week10 % span


#: Largest distance (s) of a navigation file's record from the epoch it positions: the
#: 4-hour curve fit of IS-GPS-200 (20.3.4.4), so a record is used at most 4 h from its Toe.
#: The nearest record by seconds of week alone can be of another day or week.
MAX_EPHEMERIS_AGE_S = 4 * 3600.0


def _ephemeris_for(
    prns: np.ndarray,
    obs: Observables | None,
    rinex: Ephemerides | None,
    t_s: float,
    sample_time_s: float,
    signal: SignalSpec = GPS_L1CA,
) -> list:
    """Per PRN, a healthy record (the last decoded by ``sample_time_s``, else RINEX's,
    named by ``signal``: QZSS PRN 193 is ``J01``) or None."""
    out = []
    decoded_by_prn = obs.ephemeris if obs is not None else {}  # None: no LNAV decoded (an assisted start)
    for prn in prns:
        decoded = [rec for ready_s, rec in decoded_by_prn.get(int(prn), []) if ready_s <= sample_time_s]
        rec = decoded[-1] if decoded else None
        if rec is None and rinex is not None:
            try:
                rec = rinex.select([signal.rinex_satellite(int(prn))], t_s)
            except KeyError:  # no healthy record of it in the file
                rec = None
            if rec is not None and not abs(_wrap_week(t_s - float(rec.elements["Toe"][0]))) <= MAX_EPHEMERIS_AGE_S:
                rec = None  # a record of another time of day (or week): not this recording's orbit
        out.append(rec if rec is not None and rec.health[0] == 0 else None)
    return out


def solve_epochs(
    obs: Observables,
    rinex: Ephemerides | None = None,
    *,
    ionosphere: bool = True,
    troposphere: bool = False,
    iono: IonoUtc | BdsKlobuchar | None = None,
    sigma_m: float = 5.0,
    elevation_mask_deg: float = ELEVATION_MASK_DEG,
    reference_week: int | None = None,
    elevation_weights: bool = True,
    weighting: str | None = None,
    signal: SignalSpec = GPS_L1CA,
    raim: str | None = None,
    false_alarm: float = 1e-3,
    missed_detection: float = 1e-3,
    integrity_risk: float = 1e-7,
    time_offsets_s: dict[str, float] | None = None,
    dual: DualFrequency | None = None,
    sbas: SbasOptions | None = None,
) -> PositionTable:
    """Solve every epoch of ``obs`` (see the module text).

    ``signal`` names the satellites in ``rinex`` (its `SignalSpec.rinex_satellite`); records
    that give its user no clock are not used (`ephemeris.records_with_clock`).

    ``iono`` overrides the decoded page 18 (and D1's coefficients, `Observables.bds_iono`,
    taken without a page 18); with ``ionosphere`` False no ionospheric
    correction is made; ``elevation_weights`` and ``weighting`` as `solve_position`'s
    (``rtklib``: RTKLIB's single-point error model). Epochs with fewer than four usable
    satellites give no row. ``raim``, ``false_alarm``, ``missed_detection`` and
    ``integrity_risk`` as `solve_position`'s: with ``raim`` the columns `INTEGRITY_COLUMNS`.
    ``time_offsets_s`` as `solve_position`'s (e.g. ``{"E": ggto}``, the broadcast GST - GPST:
    Galileo then takes GPS's clock and no system offset is estimated).
    ``dual``: ``obs``'s pseudoranges are this ionosphere-free combination
    (`dual_frequency.DualFrequency`, `dual_observables.ionosphere_free_observables`), solved
    with its satellite clock and no ionospheric correction.
    ``sbas``: SBAS corrections from a message file (`sbas_fixes`; GPS L1 C/A only, not with
    ``raim`` or ``dual``): the columns `SBAS_COLUMNS`.
    """
    if sbas is not None and (raim is not None or dual is not None or not sbas_corrects(signal)):
        raise ConfigError(
            "sbas",
            "SBAS L1 corrects single-frequency GPS L1 C/A fixes: not with raim, a dual-frequency combination "
            f"or {signal.name}",
        )
    replay = sbas.replay() if sbas is not None else None
    sbas_rows: list[tuple[float, float, int]] = []
    sbas_week: int | None = None
    # GPS's page 18 first (for every satellite, as RTKLIB); else BeiDou's D1 coefficients
    # by its own model (`bds_iono`).
    klobuchar = (iono or obs.iono_utc or obs.bds_iono) if ionosphere else None
    if isinstance(signal, SignalSpec):  # one signal; a multi_receive.SignalSet is not filtered here
        rinex = records_with_clock(rinex, signal.carrier_freq_hz)  # an I/NAV record gives no E5a clock
    week = full_week(obs.week, reference_week, obs.week_bits)
    rows: list[PositionFix] = []
    keep_t, used, excluded = [], [], []
    for e in range(obs.rx_time_s.size):
        ok = np.flatnonzero(np.isfinite(obs.pseudorange_m[e]))
        records = _ephemeris_for(obs.prn[ok], obs, rinex, float(obs.rx_time_s[e]), float(obs.sample_time_s[e]), signal)
        have = [j for j, r in enumerate(records) if r is not None]
        if len(have) < 4:
            continue
        idx = ok[have]
        records_used = Ephemerides.concatenate([records[j] for j in have])
        fix = solve_position(
            obs.pseudorange_m[e, idx],
            obs.transmit_s[e, idx],
            records_used,
            doppler_hz=obs.doppler_hz[e, idx],
            iono=klobuchar,
            troposphere=troposphere,
            sigma_m=sigma_m,
            elevation_mask_deg=elevation_mask_deg,
            initial_ecef_m=rows[-1].position_ecef_m if rows else None,
            elevation_weights=elevation_weights,
            weighting=weighting,
            signal=signal,
            raim=raim,
            false_alarm=false_alarm,
            missed_detection=missed_detection,
            integrity_risk=integrity_risk,
            time_offsets_s=time_offsets_s,
            dual=dual,
        )
        corrected = None
        if replay is not None:
            tow_e = float(obs.rx_time_s[e])
            if sbas_week is None:  # the observables' week, else (not decoded) the messages'
                sbas_week = week if week >= 0 else replay.week_of(tow_e)
            corrected = solve_position_sbas(
                obs.pseudorange_m[e, idx],
                obs.transmit_s[e, idx],
                records_used,
                replay.at(sbas_week, tow_e),
                day_of_year=day_of_year(sbas_week, tow_e),
                mode=sbas.mode,
                sigma_noise_m=sbas.sigma_noise_m,
                elevation_mask_deg=elevation_mask_deg,
                initial_ecef_m=fix.position_ecef_m if fix is not None else None,
            )
        if corrected is not None:
            motion = (
                {}
                if fix is None
                else {"velocity_enu_mps": fix.velocity_enu_mps, "clock_drift_mps": fix.clock_drift_mps}
            )
            fix = replace(corrected.fix, **motion)
            sbas_rows.append((corrected.hpl_m, corrected.vpl_m, int(corrected.fix.used.sum())))
        elif sbas is not None and fix is not None:  # not covered, or no message of the GEO: the broadcast fix
            sbas_rows.append((np.nan, np.nan, 0))
        if fix is None:
            continue
        rows.append(fix)
        keep_t.append(e)
        used.append(tuple(int(p) for p in obs.prn[idx][fix.used]))
        excluded.append(int(obs.prn[idx][fix.excluded]) if fix.excluded is not None else 0)
    e = np.array(keep_t, dtype=int)
    bias = np.array([f.clock_bias_m for f in rows])
    tow = obs.rx_time_s[e] - bias / SPEED_OF_LIGHT_MPS if rows else np.zeros(0)
    vel = np.array([f.velocity_enu_mps for f in rows]).reshape(-1, 3)
    columns = {
        "gps_week": np.full(len(rows), week),
        "tow_s": tow,
        "lat_deg": np.array([f.lat_deg for f in rows]),
        "lon_deg": np.array([f.lon_deg for f in rows]),
        "height_m": np.array([f.height_m for f in rows]),
        "vel_e_mps": vel[:, 0],
        "vel_n_mps": vel[:, 1],
        "vel_u_mps": vel[:, 2],
        "clock_bias_m": bias,
        "n_sats": np.array([len(u) for u in used], dtype=int),
        "hdop": np.array([f.hdop for f in rows]),
        "vdop": np.array([f.vdop for f in rows]),
    }
    offsets = [next(iter(f.system_offsets_ns.values()), np.nan) for f in rows]
    if np.isfinite(offsets).any():
        columns[SYSTEM_OFFSET_COLUMN] = np.array(offsets, float)
    if raim is not None:
        columns.update(
            hpl_m=np.array([f.hpl_m for f in rows], float),
            vpl_m=np.array([f.vpl_m for f in rows], float),
            raim=np.array([f.raim for f in rows], dtype="<U11"),
        )
    if sbas is not None:
        table = np.array(sbas_rows, float).reshape(-1, 3)
        columns.update(hpl_m=table[:, 0], vpl_m=table[:, 1], sbas_sats=table[:, 2].astype(int))
    return PositionTable(
        columns,
        np.array([f.position_ecef_m for f in rows]).reshape(-1, 3),
        obs.sample_time_s[e],
        used,
        np.array(excluded, dtype=int),
        np.array([f.clock_drift_mps for f in rows], float),
    )


def write_positions_csv(path: str | Path, table: PositionTable) -> Path:
    """``positions.csv``: a header of `POSITION_COLUMNS` (then `INTEGRITY_COLUMNS` where the
    table has them) and one row per solution."""
    path = Path(path)
    if not set(POSITION_COLUMNS) <= set(table.columns):
        raise ConfigError("table", f"lacks {sorted(set(POSITION_COLUMNS) - set(table.columns))}")
    digits = {
        "tow_s": 3,
        "lat_deg": 9,
        "lon_deg": 9,
        "height_m": 3,
        "clock_bias_m": 3,
        "hdop": 2,
        "vdop": 2,
        "hpl_m": 2,
        "vpl_m": 2,
        SYSTEM_OFFSET_COLUMN: 2,
    }
    names = (
        POSITION_COLUMNS
        + (INTEGRITY_COLUMNS if set(INTEGRITY_COLUMNS) <= set(table.columns) else ())
        + (SBAS_COLUMNS if set(SBAS_COLUMNS) <= set(table.columns) else ())
        + ((SYSTEM_OFFSET_COLUMN,) if SYSTEM_OFFSET_COLUMN in table.columns else ())
    )
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(names)
        for k in range(len(table)):
            w.writerow(
                [
                    int(table.columns[c][k])
                    if c in ("gps_week", "n_sats", "sbas_sats")
                    else str(table.columns[c][k])
                    if c == "raim"
                    else f"{table.columns[c][k]:.{digits.get(c, 3)}f}"
                    for c in names
                ]
            )
    return path
