"""RINEX 3.04 navigation file of the ephemerides a receiver decoded (``navigation.rnx``).

One record per distinct decoded ephemeris (satellite, Toc, IODE), in the layout of RINEX
3.04 section 6 and table A8 (GPS) / A14 (QZSS): a first line ``A1,I2.2`` satellite,
the Toc as ``1X,I4,5(1X,I2.2)`` and af0, af1, af2 as ``D19.12``, then seven broadcast
orbit lines of four ``D19.12`` fields after four spaces. The header carries the decoded
page 18 when there is one (IS-GPS-200 20.3.3.5.1.6-7): ``IONOSPHERIC CORR`` ``GPSA`` /
``GPSB`` (``A4,1X,4D12.4``), ``TIME SYSTEM CORR`` ``GPUT`` (a0, a1, tot, week of tot)
and ``LEAP SECONDS`` (ΔtLS).

What the decoded record does not keep is written as RINEX allows: IODC as the IODE (the
low 8 bits of IODC, which LNAV requires to equal IODE: IS-GPS-200 20.3.3.4.1), the codes
on L2 and the L2 P data flag as 0, the fit interval as 4 hours for GPS (the fit interval
flag 0 of 20.3.3.4.3.1) and as the flag 0 (2 hours) for QZSS, whose records hold the flag
(RINEX 3.04 table A14), and the transmission time of message as the GPS time of week at which
the receiver had the record (its last subframe's end, 6 s after that subframe's HOW
time). The GPS week (continuous, not modulo 1024) is the one that puts Toe (and Toc) within
half a week of that time. The system letter and satellite names come from the signal's
`SignalSpec` (``J01`` for QZSS PRN 193), so the same writer serves every LNAV-format
signal.

Galileo records decoded from I/NAV on E1-B (`inav_stream`) take the Galileo navigation
message record of RINEX 3.04 (appendix A): the Toc in GST (calendar as GPS time: GST is steered to it and RINEX counts the
Galileo week continuously with GPS's), IODnav in the first orbit line, BROADCAST ORBIT 5
``IDOT, data sources, GAL week, spare`` with the data sources 513 (bit 0: I/NAV E1-B; bit 9:
af0-af2, Toc and SISA for E5b,E1, the I/NAV clock), ORBIT 6 ``SISA (m; -1 for no accuracy
prediction), SV health, BGD E5a/E1, BGD E5b/E1`` and ORBIT 7 the transmission time (seconds
of the GAL week at which the receiver had the record) and a spare 0. The decoded record
keeps BGD(E1,E5b) (its ``TGD``, the E1 user's) but not word 5's BGD(E1,E5a): that field is
written 0. A record decoded from F/NAV on E5a-I (``FNAV`` 1) takes the data sources 258
(bit 1: F/NAV E5a-I; bit 8: the clock for E5a,E1) and its BGD(E1,E5a), BGD E5b/E1 0. The header of a Galileo file carries what the receiver decoded of word types 5, 6
and 10 (`inav_params.InavIonoTime`, each line only when its word arrived): ``IONOSPHERIC
CORR`` ``GAL `` (ai0, ai1, ai2 and a 0, ``A4,1X,4D12.4``, RINEX 3.04 table A5), ``TIME
SYSTEM CORR`` ``GAUT`` (A0, A1, t0t, WN0t) and ``GAGP`` (A0G, A1G, t0G, WN0G), both
``A4,1X,D17.10,D16.9,1X,I6,1X,I4``, and ``LEAP SECONDS`` (Delta t_LS). The weeks, sent as
their low 8 (WN0t) and 6 (WN0G) bits, are written in full: the week with those low bits
nearest the first record's (`navigation.weeks.full_week`; GST weeks are GPS weeks - 1024, so
the low bits agree).

BeiDou records decoded from D1 on B1I (`d1nav`) take the BDS record of RINEX 3.04 (table
A13): the Toc in BDT (its calendar BDT's own: BDT week 0 began with GPS week 1356, 14 s of
GPS time later), AODE in the first orbit line, BROADCAST ORBIT 5 ``IDOT, spare, BDT week,
spare``, ORBIT 6 ``SV accuracy (m), SatH1, TGD1, TGD2`` and ORBIT 7 the transmission time
(seconds of the BDT week at which the receiver had the record, its GPS time less 14 s) and
AODC, which the decoded record does not keep: written 0. The header takes D1 subframe 1's
Klobuchar coefficients as ``IONOSPHERIC CORR`` ``BDSA`` / ``BDSB`` (``A4,1X,4D12.4``, as
GPS's) where decoded. A system of another layout (SBAS, GLONASS) is refused.

The records of a run of several signals (`multi_receive.SignalSet`, system ``M``) go into
one mixed file (RINEX 3.04 6.9, ``M: MIXED`` in the first header line), each record in its
own system's layout above (the satellite's system from `SignalSet.signal_of`), with both
headers' lines: GPS's ``GPSA``/``GPSB``/``GPUT`` from page 18, Galileo's ``GAL``/
``GAUT``/``GAGP`` from word types 5, 6 and 10 and BeiDou's ``BDSA``/``BDSB`` from D1, each
where decoded, and one ``LEAP SECONDS``
(page 18's, else word 6's: both broadcast the same GPS-UTC leap seconds).
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime
from pathlib import Path

import numpy as np

from ...errors import ConfigError
from ...navigation.bds_iono import BdsKlobuchar
from ...navigation.ephemeris import Ephemerides
from ...navigation.inav_params import InavIonoTime
from ...navigation.weeks import full_week, gps_calendar
from ...navigation.lnav import WEEK_S, IonoUtc
from ...signal.gps_l1ca import GPS_L1CA
from ...signal.spec import SignalSpec

__all__ = ["NavRecord", "decoded_records", "write_rinex_nav", "RINEX_NAV_SYSTEMS"]

#: Systems whose decoded records are written: GPS and QZSS (the LNAV layout) and Galileo
#: (its I/NAV record layout; see the module text).
RINEX_NAV_SYSTEMS = {"G": "GPS", "J": "QZSS", "E": "GALILEO", "C": "BDS", "M": "MIXED"}
#: BDT week 0 is GPS week 1356, and BDT = GPS time - 14 s (BDS-SIS-ICD-B1I 3.0 5.2.4.2).
BDT_WEEK_OFFSET = 1356
BDT_OFFSET_S = 14.0
#: RINEX 3.04 Galileo data sources of an I/NAV E1-B record: bit 0 (I/NAV E1-B) and bit 9
#: (clock parameters for E5b,E1).
INAV_E1B_DATA_SOURCES = 1 + 512
#: ... and of an F/NAV E5a-I record: bit 1 (F/NAV E5a-I) and bit 8 (clock for E5a,E1).
FNAV_E5A_DATA_SOURCES = 2 + 256
#: The last field of BROADCAST ORBIT 7 per system: GPS's fit interval in hours (4: the flag
#: 0 of IS-GPS-200 20.3.3.4.3.1), QZSS's fit interval flag itself (0: 2 hours; RINEX 3.04 A14).
FIT_INTERVAL = {"G": 4.0, "J": 0.0}


@dataclass(frozen=True)
class NavRecord:
    """One decoded ephemeris to write: its satellite's PRN, the record and the full GPS
    week and time of week (s) at which the receiver had it."""

    prn: int
    record: Ephemerides
    week: int
    tow_s: float


def _d19(value: float) -> str:
    """FORTRAN ``D19.12``: `` 1.234567890123D-04``."""
    return f"{float(value):19.12E}".replace("E", "D")


def _d12(value: float) -> str:
    """FORTRAN ``D12.4``: ``  1.1176D-08``."""
    return f"{float(value):12.4E}".replace("E", "D")


def _line(content: str, label: str) -> str:
    return f"{content:<60.60}{label:<20}\n"


def _week_near(week: int, tow_s: float, t_s: float) -> int:
    """The week that puts the seconds of week ``t_s`` within half a week of ``(week, tow_s)``."""
    return int(week + np.round((tow_s - t_s) / WEEK_S))


def _calendar(week: int, tow_s: float) -> datetime:
    return gps_calendar(week, tow_s)


def decoded_records(
    ephemeris: dict[int, list[tuple[float, Ephemerides]]], sample_time_s: np.ndarray, rx_time_s: np.ndarray, week: int
) -> list[NavRecord]:
    """The distinct records (by PRN, Toc and IODE) of ``Observables.ephemeris``, each with
    the GPS time at which it was ready: the recording time it became known mapped to the
    receiver clock of the observables' epochs (``sample_time_s`` -> ``rx_time_s``, linear),
    in ``week`` (the full week of the epochs)."""
    if week < 0:
        raise ConfigError("week", "the GPS week of the epochs is unknown: the navigation file's dates need it")
    sample_time_s = np.asarray(sample_time_s, float)
    rx = np.unwrap(np.asarray(rx_time_s, float), period=WEEK_S)
    out, seen = [], set()
    for prn in sorted(ephemeris):
        for ready_s, rec in ephemeris[prn]:
            key = (prn, float(rec.toc_s[0]), int(rec.iode[0]))
            if key in seen:
                continue
            seen.add(key)
            if sample_time_s.size > 1:
                slope = (rx[-1] - rx[0]) / (sample_time_s[-1] - sample_time_s[0])
                t = rx[0] + slope * (ready_s - sample_time_s[0])
            else:
                t = rx[0] + (ready_s - sample_time_s[0])
            out.append(NavRecord(prn, rec, week + int(t // WEEK_S), float(t % WEEK_S)))
    return out


def _orbit_lines(nav: NavRecord, system: str) -> list[str]:
    rec = nav.record
    e = {k: float(v[0]) for k, v in rec.elements.items()}
    toe_week = _week_near(nav.week, nav.tow_s, e["Toe"])
    iode = float(rec.iode[0])
    accuracy = float(rec.accuracy_m[0]) if rec.accuracy_m is not None else -1.0
    if system == "E":
        # An I/NAV record's group delay is BGD(E1,E5b) (`inav_words.words_to_ephemeris`), an
        # F/NAV record's BGD(E1,E5a) (`fnav.pages_to_ephemeris`); the other is not kept.
        fnav = e.get("FNAV", 0.0) == 1.0
        sources = FNAV_E5A_DATA_SOURCES if fnav else INAV_E1B_DATA_SOURCES
        bgd_e5a, bgd_e5b = (e["TGD"], 0.0) if fnav else (0.0, e["TGD"])
        rows = (
            (iode, e["Crs"], e["DeltaN"], e["M0"]),
            (e["Cuc"], e["Eccentricity"], e["Cus"], e["sqrtA"]),
            (e["Toe"], e["Cic"], e["Omega0"], e["Cis"]),
            (e["Io"], e["Crc"], e["omega"], e["OmegaDot"]),
            (e["IDOT"], float(sources), float(toe_week), 0.0),  # data sources, GAL week, spare
            (accuracy, float(rec.health[0]), bgd_e5a, bgd_e5b),  # SISA, health, BGD E5a/E1, E5b/E1
            (nav.tow_s, 0.0),
        )
        return ["    " + "".join(_d19(v) for v in row) + "\n" for row in rows]
    if system == "C":  # BDT: its week and seconds (module text)
        bdt_week, bdt_tow = _bdt(nav.week, nav.tow_s)
        tgd2 = e.get("TGD2", 0.0)
        rows = (
            (iode, e["Crs"], e["DeltaN"], e["M0"]),
            (e["Cuc"], e["Eccentricity"], e["Cus"], e["sqrtA"]),
            (e["Toe"], e["Cic"], e["Omega0"], e["Cis"]),
            (e["Io"], e["Crc"], e["omega"], e["OmegaDot"]),
            (e["IDOT"], 0.0, float(_week_near(bdt_week, bdt_tow, e["Toe"])), 0.0),  # spare, BDT week, spare
            (accuracy, float(rec.health[0]), e["TGD"], tgd2 if np.isfinite(tgd2) else 0.0),  # SatH1, TGD1, TGD2
            (bdt_tow, 0.0),  # transmission time, AODC (not kept: 0)
        )
        return ["    " + "".join(_d19(v) for v in row) + "\n" for row in rows]
    rows = (
        (iode, e["Crs"], e["DeltaN"], e["M0"]),
        (e["Cuc"], e["Eccentricity"], e["Cus"], e["sqrtA"]),
        (e["Toe"], e["Cic"], e["Omega0"], e["Cis"]),
        (e["Io"], e["Crc"], e["omega"], e["OmegaDot"]),
        (e["IDOT"], 0.0, float(toe_week), 0.0),  # codes on L2, week, L2 P data flag
        (accuracy, float(rec.health[0]), e["TGD"], iode),  # IODC: see the module text
        (nav.tow_s, FIT_INTERVAL[system]),
    )
    return ["    " + "".join(_d19(v) for v in row) + "\n" for row in rows]


def _bdt(week: int, tow_s: float) -> tuple[int, float]:
    """BDT week and seconds of week of the GPS time ``(week, tow_s)``."""
    t = tow_s - BDT_OFFSET_S
    return week - BDT_WEEK_OFFSET + int(t // WEEK_S), float(t % WEEK_S)


def _system_of(signal: SignalSpec, prn: int) -> str:
    """The RINEX system letter of satellite ``prn`` of ``signal`` (of a `SignalSet`: its signal's)."""
    signal_of = getattr(signal, "signal_of", None)
    return signal_of(prn).system if signal_of is not None else signal.system


def _time_corr(kind: str, a0: float, a1: float, t_s: float, week: int) -> str:
    """A ``TIME SYSTEM CORR`` line: ``A4,1X,D17.10,D16.9,1X,I6,1X,I4`` (RINEX 3.04 table A5)."""
    a0_txt = f"{float(a0):17.10E}".replace("E", "D")
    a1_txt = f"{float(a1):16.9E}".replace("E", "D")
    return _line(f"{kind} {a0_txt}{a1_txt} {int(round(t_s)):6d} {int(week):4d}", "TIME SYSTEM CORR")


def _galileo_header(week: int, galileo: InavIonoTime, leap: bool = True) -> list[str]:
    """The ionospheric, time-system and (with ``leap``) leap-second lines of decoded word
    types 5, 6, 10."""
    out = []
    if galileo.ai_sfu is not None:
        out.append(_line("GAL  " + "".join(_d12(v) for v in (*galileo.ai_sfu, 0.0)), "IONOSPHERIC CORR"))
    utc, ggto = galileo.utc, galileo.ggto
    if utc is not None:
        out.append(_time_corr("GAUT", utc.a0_s, utc.a1_s_s, utc.tot_s, full_week(utc.wnt, 8, week)))
    if ggto is not None:
        out.append(_time_corr("GAGP", ggto.a0g_s, ggto.a1g_s_s, ggto.t0g_s, full_week(ggto.wn0g, 6, week)))
    if utc is not None and leap:
        out.append(_line(f"{int(utc.dt_ls_s):6d}", "LEAP SECONDS"))
    return out


def _header(
    records: list[NavRecord],
    iono: IonoUtc | None,
    signal: SignalSpec,
    galileo: InavIonoTime | None = None,
    bds_iono: BdsKlobuchar | None = None,
) -> list[str]:
    first = records[0]
    stamp = _calendar(first.week, first.tow_s).strftime("%Y%m%d %H%M%S") + " GPS"  # the data's date: same bytes
    system = f"{signal.system}: {RINEX_NAV_SYSTEMS[signal.system]}"
    out = [
        _line(f"{'3.04':>9}{'':11}{'N: GNSS NAV DATA':<20}{system:<20}", "RINEX VERSION / TYPE"),
        _line(f"{'gnssframework':<20}{'':<20}{stamp:<20}", "PGM / RUN BY / DATE"),
    ]
    if iono is not None and signal.system in ("G", "J", "M"):  # LNAV page 18 (a Galileo file has none)
        out += [
            _line("GPSA " + "".join(_d12(v) for v in iono.alpha), "IONOSPHERIC CORR"),
            _line("GPSB " + "".join(_d12(v) for v in iono.beta), "IONOSPHERIC CORR"),
        ]
        # The 8-bit week of tot placed nearest the records' week (IS-GPS-200 20.3.3.5.2.4).
        wnt = full_week(iono.wnt, 8, first.week)
        out += [
            _time_corr("GPUT", iono.a0_s, iono.a1_s_s, iono.tot_s, wnt),
            _line(f"{int(iono.dt_ls_s):6d}", "LEAP SECONDS"),
        ]
    if bds_iono is not None and signal.system in ("C", "M"):  # D1 subframe 1's (RINEX 3.04 BDSA/BDSB)
        out += [
            _line("BDSA " + "".join(_d12(v) for v in bds_iono.alpha), "IONOSPHERIC CORR"),
            _line("BDSB " + "".join(_d12(v) for v in bds_iono.beta), "IONOSPHERIC CORR"),
        ]
    if galileo is not None and signal.system in ("E", "M"):  # a mixed file: one LEAP SECONDS line
        out += _galileo_header(first.week, galileo, leap=not (signal.system == "M" and iono is not None))
    return out + [_line("", "END OF HEADER")]


def write_rinex_nav(
    path: str | Path,
    records: list[NavRecord],
    iono: IonoUtc | None = None,
    signal: SignalSpec = GPS_L1CA,
    galileo: InavIonoTime | None = None,
    bds_iono: BdsKlobuchar | None = None,
) -> Path:
    """Write ``records`` (`decoded_records`) and the page 18 ``iono`` (GPS, QZSS), the
    I/NAV words 5, 6 and 10's ``galileo`` (Galileo) or D1's Klobuchar ``bds_iono`` (BeiDou,
    ``BDSA``/``BDSB``) as a RINEX 3.04 navigation file of ``signal``'s system (see the
    module text); `rinex4_nav_out.write_rinex4_nav` writes them as RINEX 4.00 (CNAV records
    too).

    Raises
    ------
    ConfigError
        Without a record, for a system of another layout (SBAS, GLONASS), for a record of
        another system in a Galileo or BeiDou file, or for a CNAV record (no RINEX 3.04 layout).
    """
    _check_records(records, signal)
    cnav = [str(r.record.sv[0]) for r in records if float(r.record.elements.get("CNAV", np.zeros(1))[0]) == 1.0]
    if cnav:
        raise ConfigError(
            "rinex_version",
            f"{cnav[0]}: a CNAV record has no RINEX 3.04 layout (Adot, Delta n0 rate, ISC): write RINEX 4.00",
        )
    path = Path(path)
    header = _header(records, iono, signal, galileo, bds_iono)
    body = []
    for nav in sorted(records, key=lambda r: (r.prn, r.week, float(r.record.toc_s[0]))):
        body.append(_record_first_line(nav, signal))
        body += _orbit_lines(nav, _system_of(signal, nav.prn))
    path.write_text("".join(header + body))
    return path


def _check_records(records: list[NavRecord], signal: SignalSpec) -> None:
    """Refuse what no navigation file of ``signal``'s system holds (`write_rinex_nav`'s Raises)."""
    if signal.system not in RINEX_NAV_SYSTEMS:
        raise ConfigError(
            "signal",
            f"no RINEX navigation record layout for system {signal.system!r} "
            f"({signal.name}) here (systems: {', '.join(RINEX_NAV_SYSTEMS)})",
        )
    if not records:
        raise ConfigError("ephemeris", "no ephemeris was decoded: no navigation file to write")
    # The Galileo layout's fields (IODnav, BGD, data sources) are I/NAV's: a record in it must be one.
    # ... and the BeiDou layout's (AODE, TGD1, BDT) a BeiDou record's.
    for r in records:
        sv = str(r.record.sv[0])
        for letter, name in (("E", "Galileo"), ("C", "BeiDou")):
            if (_system_of(signal, r.prn) == letter) != sv.startswith(letter):
                what = (
                    f"not a {name} record"
                    if sv[:1] != letter
                    else f"a {name} record as {signal.rinex_satellite(r.prn)}"
                )
                raise ConfigError("ephemeris", f"{sv}: {what}, not written in {signal.name}'s navigation file")


def _record_first_line(nav: NavRecord, signal: SignalSpec) -> str:
    """A record's first line: satellite, Toc (BeiDou's in a BDT calendar), af0, af1, af2."""
    rec = nav.record
    if _system_of(signal, nav.prn) == "C":  # a BDT calendar: BDT week 0 at GPS week 1356
        bdt_week, bdt_tow = _bdt(nav.week, nav.tow_s)
        toc_week = _week_near(bdt_week, bdt_tow, float(rec.toc_s[0])) + BDT_WEEK_OFFSET
    else:
        toc_week = _week_near(nav.week, nav.tow_s, float(rec.toc_s[0]))
    toc = _calendar(toc_week, float(rec.toc_s[0]))
    return (
        f"{signal.rinex_satellite(nav.prn)} {toc:%Y %m %d %H %M %S}"
        + "".join(_d19(rec.elements[k][0]) for k in ("SVclockBias", "SVclockDrift", "SVclockDriftRate"))
        + "\n"
    )
