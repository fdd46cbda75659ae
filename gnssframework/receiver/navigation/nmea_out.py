"""NMEA 0183 GGA, RMC, GSA and GSV sentences of a receiver's fixes (pynmea2 builds and
checksums them).

Times are UTC: GPS time minus the leap seconds (the decoded page 18's ΔtLS, IS-GPS-200
20.3.3.5.2.4). GGA's altitude field holds the WGS 84 ellipsoidal height with a geoid
separation of 0 (no geoid model is applied), so height = altitude + separation as NMEA
defines it. RMC's speed (knots) and course come from the fix's velocity.

The talker is the fix's constellation (NMEA 0183 4.11: ``GP`` GPS, ``GA`` Galileo, ``GB``
BeiDou, ``GL`` GLONASS, ``GQ`` QZSS; ``GN`` for a fix from several), from the signals'
RINEX system letters (`nmea_talker`).

With the satellites in view of each fix (`SkyView`), each fix's GGA and RMC are followed by
a GSA (mode A, 3D fix, the PRNs used, at most 12, and PDOP, HDOP, VDOP; PDOP² = HDOP² +
VDOP², the position block's trace) and by GSV sentences, four satellites each, with the
elevation (deg), azimuth (deg from true north) and SNR (the C/N0 in dB-Hz, empty where not
measured), all rounded to whole units as NMEA writes them. Satellites are numbered as NMEA
0183 4.11 does for the talker: the PRN for GPS (1-32), PRN - 192 for QZSS (1-10).

A fix of several systems (``signals``, a `multi_receive.SignalSet`: satellites keyed
``index x 1000 + PRN``) is sent as NMEA 0183 4.10/4.11 multi-GNSS receivers send it: GGA
and RMC from ``GN``, then one ``GNGSA`` per system with satellites used (that system's IDs,
the fix's DOPs, and the GNSS system ID field that 4.10 appended to GSA: 1 GPS, 3 Galileo,
5 QZSS) and GSV pages per system from its own talker (``GPGSV``, ``GAGSV``) counting that
system's satellites in view. A Galileo satellite's ID is its SVID (1-36), as NMEA 4.10/4.11
numbers them under ``GA`` (the numbering of u-blox's NMEA 4.10/4.11 modes and of the
system-ID table of https://logiqx.github.io/gps-wizard/nmea/lookups/system-id.html; the
older 301-336 of u-blox's extended NMEA 4.0 is not used).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pynmea2

from ...errors import ConfigError
from ...navigation.weeks import gps_calendar
from ...signal.gps_l1ca import GPS_L1CA
from ...signal.spec import SignalSpec
from .fixes import PositionTable

__all__ = ["nmea_sentences", "write_nmea", "nmea_talker", "SkyView", "gsa_gsv_sentences", "multi_gsa_gsv_sentences"]

#: NMEA talker of a RINEX system letter (NMEA 0183 4.11; SBAS fixes count as GPS).
_TALKERS = {"G": "GP", "S": "GP", "E": "GA", "C": "GB", "R": "GL", "J": "GQ", "I": "GI"}


def nmea_talker(*signals: SignalSpec, default: SignalSpec = GPS_L1CA) -> str:
    """The talker of a fix from ``signals`` (``"GP"`` for GPS L1 C/A alone; ``"GN"`` for
    several systems; ``default``'s, GPS's, for none).

    Raises
    ------
    ConfigError
        For a system NMEA has no talker for.
    """
    talkers = set()
    for signal in signals or (default,):
        if signal.system not in _TALKERS:
            raise ConfigError("signal", f"no NMEA talker for RINEX system {signal.system!r} ({signal.name})")
        talkers.add(_TALKERS[signal.system])
    return talkers.pop() if len(talkers) == 1 else "GN"


#: Satellite ID offset of NMEA 0183 4.11 per talker (QZSS PRN 193 is GQ satellite 1).
_NMEA_ID_OFFSET = {"GQ": 192}
#: GNSS system ID of NMEA 0183 4.10/4.11 (GSA's last field) per talker.
_SYSTEM_ID = {"GP": 1, "GL": 2, "GA": 3, "GB": 4, "GQ": 5, "GI": 6}
_KNOT_MPS = 1852.0 / 3600.0


def _angle(value_deg: float, width: int, hemispheres: str) -> tuple[str, str]:
    """NMEA (d)ddmm.mmmmm and its hemisphere letter."""
    a = abs(value_deg)
    degrees = int(a)
    minutes = (a - degrees) * 60.0
    if round(minutes, 5) >= 60.0:  # rounding up to a whole degree
        degrees, minutes = degrees + 1, 0.0
    return f"{degrees:0{width}d}{minutes:08.5f}", hemispheres[0] if value_deg >= 0 else hemispheres[1]


@dataclass(frozen=True)
class SkyView:
    """The satellites in view at one fix: PRN, elevation and azimuth (deg) and C/N0 (dB-Hz,
    NaN where not measured), each ``(N,)``."""

    prn: np.ndarray
    elevation_deg: np.ndarray
    azimuth_deg: np.ndarray
    cn0_dbhz: np.ndarray


def _whole(value: float, width: int) -> str:
    return f"{int(round(float(value))):0{width}d}" if np.isfinite(value) else ""


def _gsa(talker: str, ids: list[str], hdop: float, vdop: float, system_id: int | None = None) -> str:
    pdop = float(np.hypot(hdop, vdop))
    fields = ("A", "3", *ids, *[""] * (12 - len(ids)), f"{pdop:.2f}", f"{hdop:.2f}", f"{vdop:.2f}")
    return str(pynmea2.GSA(talker, "GSA", fields + ((str(system_id),) if system_id is not None else ())))


def gsa_gsv_sentences(
    used_prns: tuple[int, ...], hdop: float, vdop: float, sky: SkyView | None, talker: str = "GP", gsa: bool = True
) -> list[str]:
    """The GSA sentence of one fix (``used_prns``, its DOPs; none unless ``gsa``) and its GSV
    sentences (``sky``; none without it). See the module text."""
    offset = _NMEA_ID_OFFSET.get(talker, 0)
    ids = [f"{int(p) - offset:02d}" for p in sorted(used_prns)[:12]]
    out = [_gsa(talker, ids, hdop, vdop)] if gsa else []
    if sky is None or not np.size(sky.prn):
        return out
    order = np.argsort(sky.prn, kind="stable")
    n = order.size
    pages = (n + 3) // 4
    for page in range(pages):
        fields = [str(pages), str(page + 1), f"{n:02d}"]
        for j in order[4 * page : 4 * page + 4]:
            el = float(sky.elevation_deg[j])
            fields += [
                f"{int(sky.prn[j]) - offset:02d}",
                _whole(el, 2),
                _whole(round(float(sky.azimuth_deg[j])) % 360, 3) if np.isfinite(el) else "",
                _whole(np.clip(sky.cn0_dbhz[j], 0, 99), 2),
            ]
        out.append(str(pynmea2.GSV(talker, "GSV", tuple(fields))))
    return out


def multi_gsa_gsv_sentences(
    used_keys: tuple[int, ...], hdop: float, vdop: float, sky: SkyView | None, signals, gsa: bool = True
) -> list[str]:
    """The GSA sentences (``GN``, one per system with a satellite used, unless not ``gsa``)
    and the GSV sentences (each system's talker) of one fix of several ``signals`` (a
    `multi_receive.SignalSet`; ``used_keys`` and ``sky.prn`` its keys). See the module text."""
    from .multi_receive import KEY_STEP

    used = np.asarray(sorted(used_keys), int)
    gsa_out: list[str] = []
    gsv_out: list[str] = []
    for signal, indices in signals.groups:  # a system's signals together (one talker)
        talker = nmea_talker(signal)
        offset = _NMEA_ID_OFFSET.get(talker, 0)
        mine = np.sort(used[np.isin(used // KEY_STEP, indices)] % KEY_STEP)
        if gsa and mine.size:
            ids = [f"{int(p) - offset:02d}" for p in mine[:12]]
            gsa_out.append(_gsa("GN", ids, hdop, vdop, _SYSTEM_ID[talker]))
        if sky is not None:
            keys = np.asarray(sky.prn, int)
            at = np.flatnonzero(np.isin(keys // KEY_STEP, indices))
            at = at[np.argsort(keys[at] % KEY_STEP, kind="stable")]
            part = SkyView(keys[at] % KEY_STEP, sky.elevation_deg[at], sky.azimuth_deg[at], sky.cn0_dbhz[at])
            gsv_out += gsa_gsv_sentences((), hdop, vdop, part, talker, gsa=False)
    return gsa_out + gsv_out


def nmea_sentences(
    table: PositionTable,
    leap_seconds: int = 18,
    talker: str = "GP",
    sky: list[SkyView] | None = None,
    gsa: bool = False,
    signals=None,
) -> list[str]:
    """A GGA and an RMC sentence per fix of ``table``, from ``talker`` (`nmea_talker`);
    then with ``gsa`` its GSA and with ``sky`` (one `SkyView` per fix) its GSV sentences;
    of several ``signals`` (a `multi_receive.SignalSet`) those per system
    (`multi_gsa_gsv_sentences`)."""
    if sky is not None and len(sky) != len(table):
        raise ConfigError("sky", f"one SkyView per fix: {len(sky)} for {len(table)} fixes")
    out = []
    c = table.columns
    for k in range(len(table)):
        utc = gps_calendar(int(c["gps_week"][k]), float(c["tow_s"][k]) - leap_seconds)
        clock = utc.strftime("%H%M%S.") + f"{utc.microsecond // 10_000:02d}"
        lat, ns = _angle(float(c["lat_deg"][k]), 2, "NS")
        lon, ew = _angle(float(c["lon_deg"][k]), 3, "EW")
        out.append(
            str(
                pynmea2.GGA(
                    talker,
                    "GGA",
                    (
                        clock,
                        lat,
                        ns,
                        lon,
                        ew,
                        "1",
                        f"{int(c['n_sats'][k]):02d}",
                        f"{c['hdop'][k]:.2f}",
                        f"{c['height_m'][k]:.3f}",
                        "M",
                        "0.0",
                        "M",
                        "",
                        "",
                    ),
                )
            )
        )
        ve, vn = float(c["vel_e_mps"][k]), float(c["vel_n_mps"][k])
        speed = np.hypot(ve, vn) / _KNOT_MPS if np.isfinite(ve) and np.isfinite(vn) else np.nan
        course = np.degrees(np.arctan2(ve, vn)) % 360.0 if np.isfinite(speed) else np.nan
        out.append(
            str(
                pynmea2.RMC(
                    talker,
                    "RMC",
                    (
                        clock,
                        "A",
                        lat,
                        ns,
                        lon,
                        ew,
                        "" if np.isnan(speed) else f"{speed:.3f}",
                        "" if np.isnan(course) else f"{course:.2f}",
                        utc.strftime("%d%m%y"),
                        "",
                        "",
                        "A",
                    ),
                )
            )
        )
        if gsa or sky is not None:
            fix = (table.used_prns[k], float(c["hdop"][k]), float(c["vdop"][k]), None if sky is None else sky[k])
            if signals is not None:  # a GSA per system, a GSV per talker
                out += multi_gsa_gsv_sentences(*fix, signals, gsa)
            else:
                out += gsa_gsv_sentences(*fix, talker, gsa)
    return out


def write_nmea(
    path: str | Path,
    table: PositionTable,
    leap_seconds: int = 18,
    talker: str = "GP",
    sky: list[SkyView] | None = None,
    gsa: bool = False,
    signals=None,
) -> Path:
    """``nmea.txt``: the GGA and RMC sentences of every fix (with ``gsa`` its GSA, with
    ``sky`` its GSV; per system for several ``signals``), one per line."""
    path = Path(path)
    path.write_text("".join(s + "\r\n" for s in nmea_sentences(table, leap_seconds, talker, sky, gsa, signals)))
    return path
