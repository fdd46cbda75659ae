"""RINEX 4.00 navigation file of the ephemerides a receiver decoded (``navigation.rnx`` with
``receive --rinex-version 4``, and always for CNAV records, which RINEX 3 cannot hold).

Every record gets the line RINEX 4 puts before it (``> EPH G01 LNAV``: type, satellite,
message); the records of LNAV (GPS, QZSS), I/NAV and F/NAV (Galileo) and D1/D2 (BeiDou: D2
for a GEO satellite) keep the lines of RINEX 3.04 that `rinex_nav` writes. A CNAV record
(GPS or QZSS L2C, `cnav_records`) takes RINEX 4.00's CNAV layout (`rinex4_nav`'s table):
``Adot, Crs, Δn0, M0 / Cuc, e, Cus, √A / t_op, Cic, Ω0, Cis / i0, Crc, ω, Ω̇ / IDOT, Δṅ0,
URAI_NED0, URAI_NED1 / URAI_ED, health, T_GD, URAI_NED2 / ISC_L1CA, ISC_L2C, ISC_L5I5,
ISC_L5Q5 / t_tm, WN_op``, its epoch t_oc (= t_oe). What the decoded record does not keep is
left blank, as RINEX 4 leaves a field that is not known: the three URAI_NED indices and
ISC_L5Q5 (a receiver of L2C does not decode them into the record), and an ISC broadcast as
not available. The health is message type 10's 3-bit L1/L2/L5 word, URAI_ED the index of
the record's accuracy, t_tm the time of week the receiver had the record and WN_op the week
of t_op.

The header keeps ``LEAP SECONDS``; what RINEX 3 put in it are records here, each dated and
named by the satellite that sent it. The receiver does not keep which satellite's message
it decoded them from, nor when: they are written as sent by the first record's satellite of
their system at the time the receiver had that record. ``> ION G.. LNAV`` (page 18's α0-α3,
β0-β3), ``> STO G.. LNAV`` ``GPUT`` (A0, A1 at t_ot, UTC(USNO)), ``> ION E.. IFNV`` (ai0-ai2
and 0), ``> STO E.. IFNV`` ``GAUT`` (UTCGAL) and ``GAGP``, ``> ION C.. D1D2`` (BeiDou's
α0-α3, β0-β3). Read back by `navigation.rinex4_nav`.
"""

from __future__ import annotations

from datetime import datetime
from pathlib import Path

import numpy as np

from ...errors import ConfigError
from ...navigation.bds_iono import BdsKlobuchar
from ...navigation.ephemeris import is_bds_geo
from ...navigation.inav_params import InavIonoTime
from ...navigation.lnav import IonoUtc
from ...navigation.ura import ura_ed_m
from ...navigation.weeks import full_week
from ...signal.gps_l1ca import GPS_L1CA
from ...signal.spec import SignalSpec
from .rinex_nav import (
    BDT_WEEK_OFFSET,
    RINEX_NAV_SYSTEMS,
    NavRecord,
    _bdt,
    _calendar,
    _check_records,
    _d19,
    _header,
    _line,
    _orbit_lines,
    _record_first_line,
    _system_of,
    _week_near,
)

__all__ = ["write_rinex4_nav", "message_of"]

#: URA_ED indices (IS-GPS-200 30.3.3.1.1.4), for writing a record's accuracy as its index.
_URA_ED_INDICES = np.arange(-16, 16)
_URA_ED_M = np.array([ura_ed_m(int(k)) for k in _URA_ED_INDICES])


def _field(value: float) -> str:
    """``D19.12``, blank where the value is not known (NaN)."""
    return _d19(value) if np.isfinite(value) else " " * 19


def _lines(rows: tuple[tuple[float, ...], ...]) -> list[str]:
    return [("    " + "".join(_field(v) for v in row)).rstrip() + "\n" for row in rows]


def message_of(nav: NavRecord, system: str) -> str:
    """The RINEX 4 message name of a decoded record of ``system``."""
    e = nav.record.elements
    if system in ("G", "J"):
        return "CNAV" if float(e.get("CNAV", np.zeros(1))[0]) == 1.0 else "LNAV"
    if system == "E":
        return "FNAV" if float(e.get("FNAV", np.zeros(1))[0]) == 1.0 else "INAV"
    if system == "C":
        return "D2" if bool(is_bds_geo(nav.record.sv)[0]) else "D1"
    raise ConfigError("signal", f"no RINEX 4 navigation message for system {system!r}")


def _ura_index(accuracy_m: float) -> float:
    hit = np.flatnonzero(np.isclose(_URA_ED_M, accuracy_m, rtol=1e-9, atol=0.0))
    return float(_URA_ED_INDICES[hit[0]]) if hit.size else float("nan")


def _cnav_lines(nav: NavRecord) -> list[str]:
    rec = nav.record
    e = {k: float(v[0]) for k, v in rec.elements.items()}
    accuracy = float(rec.accuracy_m[0]) if rec.accuracy_m is not None else float("nan")
    top = e.get("Top", float("nan"))
    wn_op = float(_week_near(nav.week, nav.tow_s, top)) if np.isfinite(top) else float("nan")
    nan = float("nan")
    rows = (
        (e["Adot"], e["Crs"], e["DeltaN"], e["M0"]),
        (e["Cuc"], e["Eccentricity"], e["Cus"], e["sqrtA"]),
        (top, e["Cic"], e["Omega0"], e["Cis"]),
        (e["Io"], e["Crc"], e["omega"], e["OmegaDot"]),
        (e["IDOT"], e["DeltaN0dot"], nan, nan),  # URAI_NED0, URAI_NED1: not decoded
        (_ura_index(accuracy), e.get("HealthL1L2L5", nan), e["TGD"], nan),  # URAI_NED2: not decoded
        (e["ISC_L1CA"], e["ISC_L2C"], e["ISC_L5I5"], nan),  # ISC_L5Q5: not decoded
        (nav.tow_s, wn_op),
    )
    return _lines(rows)


def _epoch_line(when: datetime, values: tuple[float, ...]) -> str:
    return (f"    {when:%Y %m %d %H %M %S}" + "".join(_field(v) for v in values)).rstrip() + "\n"


def _values_record(head: str, when: datetime, values: tuple[float, ...]) -> list[str]:
    """A record of an epoch line with three numbers and lines of four after it."""
    out = [head, _epoch_line(when, values[:3])]
    rest = values[3:]
    out += _lines(tuple(rest[k : k + 4] for k in range(0, len(rest), 4)))
    return out


def _sto(head: str, when: datetime, code: str, utc: str, t_tm: float, a0: float, a1: float) -> list[str]:
    # 4X,I4,5(1X,I2.2), then 1X,A18 each: the offset's type, the SBAS satellite (none), UTC's name
    first = f"    {when:%Y %m %d %H %M %S} {code:<18} {'':<18} {utc:<18}".rstrip() + "\n"
    return [head, first] + _lines(((t_tm, a0, a1, 0.0),))


def _messages(
    records: list[NavRecord],
    signal: SignalSpec,
    iono: IonoUtc | None,
    galileo: InavIonoTime | None,
    bds_iono: BdsKlobuchar | None,
) -> list[str]:
    """The ION and STO records (module text)."""
    first: dict[str, NavRecord] = {}
    for nav in records:
        first.setdefault(_system_of(signal, nav.prn), nav)
    out: list[str] = []
    gps = first.get("G") or first.get("J")
    if iono is not None and gps is not None:
        sat, when = signal.rinex_satellite(gps.prn), _calendar(gps.week, gps.tow_s)
        out += _values_record(f"> ION {sat} LNAV\n", when, (*iono.alpha, *iono.beta))
        wnt = full_week(iono.wnt, 8, gps.week)
        out += _sto(
            f"> STO {sat} LNAV\n", _calendar(wnt, iono.tot_s), "GPUT", "UTC(USNO)", gps.tow_s, iono.a0_s, iono.a1_s_s
        )
    gal = first.get("E")
    if galileo is not None and gal is not None:
        sat, when = signal.rinex_satellite(gal.prn), _calendar(gal.week, gal.tow_s)
        if galileo.ai_sfu is not None:
            out += _values_record(f"> ION {sat} IFNV\n", when, (*galileo.ai_sfu, 0.0))
        if galileo.utc is not None:
            u = galileo.utc
            ref = _calendar(full_week(u.wnt, 8, gal.week), u.tot_s)
            out += _sto(f"> STO {sat} IFNV\n", ref, "GAUT", "UTCGAL", gal.tow_s, u.a0_s, u.a1_s_s)
        if galileo.ggto is not None:
            g = galileo.ggto
            ref = _calendar(full_week(g.wn0g, 6, gal.week), g.t0g_s)
            out += _sto(f"> STO {sat} IFNV\n", ref, "GAGP", "", gal.tow_s, g.a0g_s, g.a1g_s_s)
    bds = first.get("C")
    if bds_iono is not None and bds is not None:
        bdt_week, bdt_tow = _bdt(bds.week, bds.tow_s)
        when = _calendar(bdt_week + BDT_WEEK_OFFSET, bdt_tow)  # a BDT calendar, as its records'
        out += _values_record(
            f"> ION {signal.rinex_satellite(bds.prn)} D1D2\n", when, (*bds_iono.alpha, *bds_iono.beta)
        )
    return out


def write_rinex4_nav(
    path: str | Path,
    records: list[NavRecord],
    iono: IonoUtc | None = None,
    signal: SignalSpec = GPS_L1CA,
    galileo: InavIonoTime | None = None,
    bds_iono: BdsKlobuchar | None = None,
) -> Path:
    """Write ``records`` (`rinex_nav.decoded_records`) and the decoded ``iono``, ``galileo``
    and ``bds_iono`` of `rinex_nav.write_rinex_nav` as a RINEX 4.00 navigation file of
    ``signal``'s system (the module text); the program line and ``LEAP SECONDS`` are the
    RINEX 3.04 header's.

    Raises
    ------
    ConfigError
        As `rinex_nav.write_rinex_nav`, but for CNAV records, which are written.
    """
    _check_records(records, signal)
    header = _header(records, iono, signal, galileo, bds_iono)
    system = f"{signal.system}: {RINEX_NAV_SYSTEMS[signal.system]}"
    out = [_line(f"{'4.00':>9}{'':11}{'N: GNSS NAV DATA':<20}{system:<20}", "RINEX VERSION / TYPE")]
    out += [line for line in header if line[60:].strip() in ("PGM / RUN BY / DATE", "LEAP SECONDS")]
    out.append(_line("", "END OF HEADER"))
    out += _messages(records, signal, iono, galileo, bds_iono)
    for nav in sorted(records, key=lambda r: (r.prn, r.week, float(r.record.toc_s[0]))):
        letter = _system_of(signal, nav.prn)
        message = message_of(nav, letter)
        out.append(f"> EPH {signal.rinex_satellite(nav.prn)} {message}\n")
        out.append(_record_first_line(nav, signal))
        out += _cnav_lines(nav) if message == "CNAV" else _orbit_lines(nav, letter)
    path = Path(path)
    path.write_text("".join(out))
    return path
