"""RINEX 3.04 observation file of a receiver's observables (GPS L1 C/A, or the signal given).

One epoch record per receive epoch of :class:`~gnssframework.receiver.navigation.observables.Observables`
with the satellites that have a pseudorange, and per satellite ``C1C`` (pseudorange, m),
``L1C`` (carrier phase, cycles), ``D1C`` (Doppler, Hz) and ``S1C`` (C/N0, dB-Hz), in the
fixed-width fields of RINEX 3.04 (section 5 and tables A1-A3): the header labels in
columns 61-80, epoch lines ``> yyyy mm dd hh mm ss.sssssss flag n``, observations as
F14.3 with the loss-of-lock and strength digits. The loss-of-lock indicator (section 5.3)
is the observables' ``lli`` on the carrier phase (bit 0: lock lost since the previous
epoch, cycle slip possible; bit 1: half-cycle ambiguity), blank when zero; the signal
strength digit (section 5.7) follows C1C, L1C and D1C. Epochs are the receiver clock's (GPS
time biased by the receiver clock error), as RINEX defines them. Another signal's file
takes its system letter, satellite names and observation codes from its `SignalSpec`
(``J01 C1C ...`` for QZSS L1 C/A; ``E11 C1B L1B D1B S1B`` for Galileo E1-B, the I/NAV
data component, RINEX 3.04 table A6) and its time system from `TIME_SYSTEMS`. A mixed file
(``M``, a `multi_receive.SignalSet`: GPS L1 C/A with Galileo E1-B) has one ``SYS / # / OBS
TYPES`` line per system and its epochs in GPS time (the fixes' reference clock).
"""

from __future__ import annotations

from datetime import datetime
from pathlib import Path

import numpy as np

from ...errors import ConfigError
from ...navigation.weeks import gps_calendar
from ...signal.gps_l1ca import GPS_L1CA
from ...signal.spec import SignalSpec
from .observables import Observables

__all__ = ["write_rinex_obs", "OBS_TYPES", "TIME_SYSTEMS"]

#: Observation types written for GPS L1 C/A, in this order (another signal's:
#: `SignalSpec.rinex_obs_types`).
OBS_TYPES = ("C1C", "L1C", "D1C", "S1C")
#: The time system written in TIME OF FIRST OBS (RINEX 3.04 table A2): Galileo System Time
#: (``GAL``) for Galileo, whose epochs the receiver dates from the I/NAV GST (`inav_stream`);
#: GPS time otherwise (QZSS L1 C/A is dated in GPS time: QZSST is aligned to it). GST is
#: steered to GPS time and RINEX counts its weeks continuously with GPS's, so the calendar
#: of an epoch is computed the same way.
TIME_SYSTEMS = {"E": "GAL"}


def _line(content: str, label: str) -> str:
    return f"{content:<60.60}{label:<20}\n"


def _calendar(week: int, tow_s: float) -> tuple[datetime, float]:
    """Calendar time (whole seconds) and the fraction of a second of a GPS week and tow."""
    whole = np.floor(tow_s)
    return gps_calendar(week, float(whole)), float(tow_s - whole)


def _strength(cn0_dbhz: float) -> int:
    """RINEX signal strength digit 1-9 from C/N0 (RINEX 3.04 5.7: 9 for >= 54 dB-Hz, 1 below 12)."""
    return int(np.clip(np.floor(cn0_dbhz / 6.0), 1, 9))


def write_rinex_obs(
    path: str | Path,
    obs: Observables,
    week: int,
    approx_ecef_m: np.ndarray | None = None,
    marker: str = "GNSSFRAMEWORK",
    signal: SignalSpec = GPS_L1CA,
) -> Path:
    """Write ``obs`` as a RINEX 3.04 observation file of one signal (GPS L1 C/A by default).

    Parameters
    ----------
    week
        Full GPS week of the epochs (``fixes.full_week``).
    approx_ecef_m
        APPROX POSITION XYZ (zeros when unknown).
    signal
        The observed signal: system letter, satellite names, observation codes.
    """
    if week < 0:
        raise ConfigError("week", "the GPS week of the epochs is unknown (no subframe 1 decoded and no reference)")
    path = Path(path)
    # A signal set (`multi_receive.SignalSet`, system "M") lists each system's types on its own
    # line, once for a system of two signals (one observable: `SignalSet.groups`).
    groups = getattr(signal, "groups", None)
    members = (signal,) if groups is None else tuple(first for first, _ in groups)
    rows = [e for e in range(obs.rx_time_s.size) if np.isfinite(obs.pseudorange_m[e]).any()]
    if not rows:
        raise ConfigError("observables", "no epoch holds a pseudorange: nothing to write")
    xyz = np.zeros(3) if approx_ecef_m is None else np.asarray(approx_ecef_m, float)
    first, frac = _calendar(week, float(obs.rx_time_s[rows[0]]))
    # The file's date is its first epoch's, not the wall clock's: the same input gives the same bytes.
    stamp = first.strftime("%Y%m%d %H%M%S") + " GPS"
    header = [
        _line(f"{'3.04':>9}{'':11}{'OBSERVATION DATA':<20}{signal.system:<20}", "RINEX VERSION / TYPE"),
        _line(f"{'gnssframework':<20}{'':<20}{stamp:<20}", "PGM / RUN BY / DATE"),
        _line(marker, "MARKER NAME"),
        _line(f"{'':<20}{'':<40}", "OBSERVER / AGENCY"),
        _line(f"{'0':<20}{'gnssframework SDR':<20}{'':<20}", "REC # / TYPE / VERS"),
        _line(f"{'0':<20}{'unknown':<20}", "ANT # / TYPE"),
        _line("".join(f"{v:14.4f}" for v in xyz), "APPROX POSITION XYZ"),
        _line("".join(f"{v:14.4f}" for v in (0.0, 0.0, 0.0)), "ANTENNA: DELTA H/E/N"),
        *(
            _line(
                f"{m.system}{len(m.rinex_obs_types):5d}" + "".join(f" {t}" for t in m.rinex_obs_types),
                "SYS / # / OBS TYPES",
            )
            for m in members
        ),
        _line(
            f"{first.year:6d}{first.month:6d}{first.day:6d}{first.hour:6d}{first.minute:6d}"
            f"{first.second + frac:13.7f}{'':5}{TIME_SYSTEMS.get(signal.system, 'GPS')}",
            "TIME OF FIRST OBS",
        ),
        _line("", "END OF HEADER"),
    ]
    body = []
    for e in rows:
        t, frac = _calendar(week, float(obs.rx_time_s[e]))
        sats = np.flatnonzero(np.isfinite(obs.pseudorange_m[e]))
        body.append(
            f"> {t.year:4d} {t.month:02d} {t.day:02d} {t.hour:02d} {t.minute:02d}"
            f"{t.second + frac:11.7f}  0{sats.size:3d}\n"
        )
        for j in sats:
            ssi = str(_strength(float(obs.cn0_dbhz[e, j]))) if np.isfinite(obs.cn0_dbhz[e, j]) else " "
            lli = int(obs.lli[e, j]) if obs.lli is not None else 0
            values = (obs.pseudorange_m[e, j], obs.carrier_cycles[e, j], obs.doppler_hz[e, j], obs.cn0_dbhz[e, j])
            flags = (" " + ssi, (str(lli) if lli else " ") + ssi, " " + ssi, "  ")  # LLI on the phase only
            fields = "".join(f"{v:14.3f}{f}" if np.isfinite(v) else " " * 16 for v, f in zip(values, flags))
            body.append(f"{signal.rinex_satellite(obs.prn[j])}{fields}".rstrip() + "\n")
    path.write_text("".join(header + body))
    return path
