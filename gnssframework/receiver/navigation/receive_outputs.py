"""Which files `receive` writes for other GNSS tools, and writing them.

``receive --outputs`` takes a comma-separated list of `OUTPUTS` (``default`` stands for
`DEFAULT_OUTPUTS`, the cheap ones): ``rinex-nav`` the decoded ephemerides as RINEX 3.04
or 4.00 (``navigation.rnx``, `rinex_nav`, `rinex4_nav_out`; 4.00 for CNAV records), ``gsa`` / ``gsv`` those NMEA sentences in ``nmea.txt``
(`nmea_out`), ``geojson`` / ``kml`` the track (``track.geojson``, ``track.kml``,
`track_out`), ``parquet`` the per-channel tracking (``tracking.parquet``, `columnar_out`,
needs pyarrow) and ``rtcm`` RTCM 3 MSM7 observations (``observations.rtcm3``, `rtcm_out`). The satellites in view of each fix (GSV) are those used in some fix, at the
azimuth and elevation of the report's sky plot (`report.sky_tracks`) with the C/N0 of the
observables' epoch of the fix.

A run of several signals (``signal`` a `multi_receive.SignalSet`) writes the same files:
one mixed navigation file of every system's decoded records, the Parquet table with a
``signal`` column (the PRNs each signal's own) and, per epoch, one MSM7 per system.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...errors import ConfigError
from ...navigation.ephemeris import Ephemerides
from ...signal.gps_l1ca import GPS_L1CA
from ...signal.spec import SignalSpec
from .fixes import PositionTable
from .nmea_out import SkyView
from .receive import ReceiveResult

__all__ = ["OUTPUTS", "DEFAULT_OUTPUTS", "RINEX_NAV_VERSIONS", "parse_outputs", "sky_views", "write_extra_outputs"]

#: Outputs that need an optional package: (module, the message when it is missing).
_NEEDS = {"parquet": ("pyarrow", "the parquet output needs pyarrow: pip install 'gnssframework[columnar]'")}

#: The RINEX versions navigation.rnx is written in (``--rinex-version`` 3 and 4).
RINEX_NAV_VERSIONS = ("3.04", "4.00")
#: Every output ``--outputs`` names.
OUTPUTS = ("rinex-nav", "gsa", "gsv", "geojson", "kml", "parquet", "rtcm")
#: Those written without ``--outputs``.
DEFAULT_OUTPUTS = ("rinex-nav", "gsa", "gsv", "geojson")


def parse_outputs(text: str | None) -> frozenset[str]:
    """The outputs of ``--outputs`` (None: `DEFAULT_OUTPUTS`; ``default`` inside the list too).

    Raises
    ------
    ConfigError
        For a name not in `OUTPUTS`, or one whose optional package is not installed.
    """
    if text is None:
        return frozenset(DEFAULT_OUTPUTS)
    names = {n.strip() for n in text.split(",") if n.strip()}
    if "default" in names:
        names = (names - {"default"}) | set(DEFAULT_OUTPUTS)
    unknown = sorted(names - set(OUTPUTS))
    if unknown:
        raise ConfigError("outputs", f"unknown {', '.join(unknown)} (choose from default, {', '.join(OUTPUTS)})")
    for name in sorted(names & set(_NEEDS)):  # before minutes of tracking, not after
        module, message = _NEEDS[name]
        try:
            __import__(module)
        except ImportError:
            raise ConfigError("outputs", message) from None
    return frozenset(names)


def sky_views(
    result: ReceiveResult, table: PositionTable, rinex: Ephemerides | None = None, signal: SignalSpec = GPS_L1CA
) -> list[SkyView]:
    """Per fix of ``table``, the satellites in view (see the module text; ``signal`` names
    the satellites of ``rinex``)."""
    from .report import sky_tracks

    tracks = sky_tracks(result, table, rinex, signal)
    obs = result.observables
    prns = np.array(sorted(tracks), dtype=int)
    cn0 = np.full((len(table), prns.size), np.nan)
    if obs is not None and obs.sample_time_s.size and prns.size:
        e = np.clip(np.searchsorted(obs.sample_time_s, table.sample_time_s), 0, obs.sample_time_s.size - 1)
        same = np.abs(obs.sample_time_s[e] - table.sample_time_s) < 1e-6
        column = {int(p): j for j, p in enumerate(obs.prn)}
        for i, p in enumerate(prns):
            if int(p) in column:
                cn0[same, i] = obs.cn0_dbhz[e[same], column[int(p)]]
    az = np.array([tracks[int(p)][0] for p in prns]).reshape(prns.size, len(table)).T
    el = np.array([tracks[int(p)][1] for p in prns]).reshape(prns.size, len(table)).T
    out = []
    for k in range(len(table)):
        seen = np.isfinite(el[k])
        out.append(SkyView(prns[seen], el[k, seen], az[k, seen], cn0[k, seen]))
    return out


def write_extra_outputs(
    out_dir: str | Path,
    result: ReceiveResult,
    table: PositionTable,
    outputs: frozenset[str],
    week: int,
    leap_seconds: int = 18,
    signal: SignalSpec = GPS_L1CA,
    rinex_version: str | None = None,
) -> tuple[list[Path], list[str]]:
    """The files of ``outputs`` besides ``nmea.txt`` (whose GSA/GSV its writer adds), and a
    note for each one that could not be written (no decoded ephemeris, unknown week).
    ``rinex_version`` (``"3.04"``, ``"4.00"``) is navigation.rnx's; None: 3.04, or 4.00
    where a record is from CNAV (RINEX 3.04 has no CNAV layout)."""
    if rinex_version not in (None, *RINEX_NAV_VERSIONS):
        raise ConfigError("rinex_version", f"{rinex_version!r}: one of {', '.join(RINEX_NAV_VERSIONS)}")
    out = Path(out_dir)
    written: list[Path] = []
    notes: list[str] = []
    obs = result.observables
    if "rinex-nav" in outputs:
        from .rinex4_nav_out import write_rinex4_nav
        from .rinex_nav import RINEX_NAV_SYSTEMS, decoded_records, write_rinex_nav

        from .cnav_stream import carries_cnav

        cnav = not hasattr(signal, "signals") and carries_cnav(signal)
        if obs is None or not any(obs.ephemeris.values()):
            messages = {"E": "I/NAV", "C": "D1", "M": "LNAV, I/NAV or D1"}
            name = "CNAV" if cnav else messages.get(signal.system, "LNAV")
            notes.append(f"no ephemeris decoded from {name}: no navigation.rnx")
        elif week < 0:
            notes.append("the GPS week is unknown: no navigation.rnx")
        elif signal.system not in RINEX_NAV_SYSTEMS:
            notes.append(f"no RINEX navigation layout for {signal.name}: no navigation.rnx")
        else:
            records = decoded_records(obs.ephemeris, obs.sample_time_s, obs.rx_time_s, week)
            # RINEX 3.04's GPS record is LNAV's: no place for CNAV's Adot, Delta n0 rate and ISCs.
            has_cnav = any(float(r.record.elements.get("CNAV", [0.0])[0]) == 1.0 for r in records)
            version = rinex_version or ("4.00" if has_cnav else "3.04")
            if has_cnav and version == "3.04":
                notes.append(
                    "CNAV records have no RINEX 3.04 layout (Adot, Delta n0 rate, ISC): no navigation.rnx "
                    "(--rinex-version 4 writes them)"
                )
            else:
                if has_cnav and rinex_version is None:
                    notes.append("CNAV records: navigation.rnx is written as RINEX 4.00")
                write = write_rinex4_nav if version == "4.00" else write_rinex_nav
                written.append(write(out / "navigation.rnx", records, obs.iono_utc, signal, obs.galileo, obs.bds_iono))
    if "geojson" in outputs:
        from .track_out import write_geojson

        # several signals: the satellites by RINEX name (their keys are the run's own numbering)
        named = getattr(signal, "rinex_satellite", None) if hasattr(signal, "signals") else None
        written.append(write_geojson(out / "track.geojson", table, leap_seconds, named))
    if "kml" in outputs:
        from .track_out import write_kml

        written.append(write_kml(out / "track.kml", table, leap_seconds))
    if "parquet" in outputs:
        from .columnar_out import write_tracking_parquet

        signal_of = getattr(signal, "signal_of", None)  # several signals: a signal column, the PRNs their own
        written.append(write_tracking_parquet(out / "tracking.parquet", result.tracking, signal_of))
    if "rtcm" in outputs:
        from .rtcm_out import write_rtcm

        if obs is None or week < 0:
            notes.append("no pseudoranges dated in a known week: no observations.rtcm3")
        else:
            written.append(write_rtcm(out / "observations.rtcm3", obs, week, signal=signal))
    return written, notes
