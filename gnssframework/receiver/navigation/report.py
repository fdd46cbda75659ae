"""``report.md`` of a ``receive`` run and its figures.

The report holds the time to first fix (recording time of the first solution), a table of
the satellites (epochs used, median C/N0 while locked, locked fraction, elevation and
azimuth at the first fix, where the ephemeris came from), the horizontal and vertical RMS
errors against a known position when one is given, and four figures in ``plots/``: the sky
plot (each used satellite's azimuth and elevation over the run, from its ephemeris seen
from the solutions), C/N0 and lock over time per PRN, the position track (east/north about
the truth, else about the mean) and, with a truth, the east/north/up errors over time.
When a navigation filter gave the positions, the least-squares fixes' errors are given
beside its own.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pymap3d

from ...navigation.ephemeris import Ephemerides, satellite_state
from ...signal.gps_l1ca import GPS_L1CA
from ...signal.spec import SignalSpec
from ..channels.report import locked_channels
from .fixes import ELEVATION_MASK_DEG, PositionTable, full_week
from .fixes import _ephemeris_for as ephemeris_for
from .decoded import navigation_message
from .receive import ReceiveResult, position_errors

__all__ = [
    "sky_tracks",
    "write_receive_report",
    "write_no_position_report",
    "no_position_reason",
    "why_unused",
    "decoded_lnav",
]

#: Satellites a position needs (three coordinates and the receiver clock).
_NEEDED = 4


def sky_tracks(
    result: ReceiveResult, table: PositionTable, rinex: Ephemerides | None = None, signal: SignalSpec = GPS_L1CA
) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """Per PRN used in ``table``, azimuth and elevation (degrees) ``(F,)`` at each solution
    (NaN where it has no ephemeris yet), from its ephemeris seen from the solution."""
    obs = result.observables
    out = {}
    lat, lon, h = (table.columns[k] for k in ("lat_deg", "lon_deg", "height_m"))
    for prn in sorted({p for u in table.used_prns for p in u}):
        az, el = np.full(len(table), np.nan), np.full(len(table), np.nan)
        for k in range(len(table)):
            t = float(table.columns["tow_s"][k])
            rec = ephemeris_for(np.array([prn]), obs, rinex, t, float(table.sample_time_s[k]), signal)[0]
            if rec is None:
                continue
            pos = satellite_state(rec, np.array([t - 0.075])).position_m[0]
            a, e, _ = pymap3d.ecef2aer(*pos, lat[k], lon[k], h[k])
            az[k], el[k] = float(a), float(e)
        out[prn] = (az, el)
    return out


def _fmt(value: float, digits: int = 1) -> str:
    return f"{value:.{digits}f}" if np.isfinite(value) else "-"


def write_receive_report(
    out_dir: str | Path,
    result: ReceiveResult,
    table: PositionTable,
    truth_lat_lon_h: tuple[float, float, float] | None = None,
    rinex: Ephemerides | None = None,
    filters: str = "",
    signal: SignalSpec = GPS_L1CA,
) -> list[Path]:
    """Write ``report.md`` and ``plots/*.png`` into ``out_dir`` (see the module text);
    returns their paths. ``filters`` is a line saying which filters ran; ``signal`` names
    the satellites of ``rinex`` (`SignalSpec.rinex_satellite`)."""
    out = Path(out_dir)
    plots = out / "plots"
    plots.mkdir(parents=True, exist_ok=True)
    sky = sky_tracks(result, table, rinex, signal)
    err = position_errors(table, truth_lat_lon_h) if truth_lat_lon_h is not None else None
    wls = result.least_squares
    figures = _figures(plots, result, table, sky, err, truth_lat_lon_h)
    c = table.columns
    used_count: dict[int, int] = {}
    for u in table.used_prns:
        for p in u:
            used_count[p] = used_count.get(p, 0) + 1
    lines = ["# Receiver run", ""]
    if filters:
        lines += [filters, ""]
    lines += [
        f"- solutions: {len(table)}, GPS week {int(c['gps_week'][0])}, tow {c['tow_s'][0]:.3f} s to "
        f"{c['tow_s'][-1]:.3f} s",
        f"- time to first fix: {table.sample_time_s[0]:.2f} s into the recording "
        f"(tracked {result.tracking.duration_s:.2f} s)",
        f"- satellites per solution: {int(c['n_sats'].min())}-{int(c['n_sats'].max())}; median HDOP "
        f"{_fmt(float(np.nanmedian(c['hdop'])), 2)}, VDOP {_fmt(float(np.nanmedian(c['vdop'])), 2)}",
    ]
    if err is not None:
        h_rms = float(np.sqrt(np.mean(np.sum(err[:, :2] ** 2, axis=1))))
        v_rms = float(np.sqrt(np.mean(err[:, 2] ** 2)))
        lines.append(
            f"- against the truth {truth_lat_lon_h[0]:.7f}, {truth_lat_lon_h[1]:.7f}, "
            f"{truth_lat_lon_h[2]:.2f} m: horizontal RMS {h_rms:.2f} m, vertical RMS {v_rms:.2f} m"
        )
        if wls is not None and wls is not table and len(wls):  # a nav filter ran: the least squares beside it
            e_wls = position_errors(wls, truth_lat_lon_h)
            lines.append(
                f"- the least-squares fixes of the same run ({len(wls)}): horizontal RMS "
                f"{np.sqrt(np.mean(np.sum(e_wls[:, :2] ** 2, axis=1))):.2f} m, vertical RMS "
                f"{np.sqrt(np.mean(e_wls[:, 2] ** 2)):.2f} m"
            )
    lines += [
        "",
        "## Satellites",
        "",
        "| PRN | epochs used | C/N0 locked (dB-Hz) | locked | elevation (deg) | azimuth (deg) | ephemeris "
        "| why not used |",
        "|---:|---:|---:|---:|---:|---:|---|---|",
    ]
    obs = result.observables
    for prn, ch in sorted(result.tracking.channels.items()):
        lock = ch.column("lock").astype(bool) if ch.rows else np.zeros(0, bool)
        cn0 = float(np.median(ch.column("cn0_dbhz")[lock])) if lock.any() else np.nan
        az, el = sky.get(prn, (np.array([np.nan]), np.array([np.nan])))
        first = np.flatnonzero(np.isfinite(el))
        decoded = obs.ephemeris.get(prn) if obs is not None else None
        source = (f"decoded at {decoded[0][0]:.1f} s" if decoded else "") + (
            " + RINEX" if rinex is not None and prn in used_count and not decoded else ""
        )
        locked = 100 * lock.mean() if lock.size else 0.0
        lines.append(
            f"| {prn} | {used_count.get(prn, 0)} | {_fmt(cn0)} | {locked:.0f} % "
            f"| {_fmt(el[first[0]] if first.size else np.nan)} | "
            f"{_fmt(az[first[0]] if first.size else np.nan)} | {source.strip(' +') or '-'} | "
            f"{why_unused(prn, ch, result, table, rinex, signal) if not used_count.get(prn) else '-'} |"
        )
    lines += ["", "## Figures", ""] + [f"![{p.stem.replace('_', ' ')}](plots/{p.name})" for p in figures] + [""]
    report = out / "report.md"
    report.write_text("\n".join(lines))
    return [report, *figures]


def why_unused(
    prn: int,
    ch,
    result: ReceiveResult,
    table: PositionTable | None,
    rinex: Ephemerides | None = None,
    signal: SignalSpec = GPS_L1CA,
) -> str:
    """Why a tracked satellite is in no solution of ``table``: the first of never locked, no
    LNAV bits or subframe (no transmit time), no pseudorange, no healthy ephemeris, excluded
    by the residual test, below the elevation mask, left out of the vector loop's updates
    (C/N0 below its ``min_cn0_dbhz``), or pseudoranges only at epochs without a solution."""
    lock = ch.column("lock").astype(bool) if ch.rows else np.zeros(0, bool)
    if not lock.any():
        return "never locked"
    obs = result.observables
    if obs is None or prn not in obs.prn:
        return navigation_message(signal).no_transmit_time(ch)
    j = int(np.flatnonzero(obs.prn == prn)[0])
    valid = np.flatnonzero(np.isfinite(obs.pseudorange_m[:, j]))
    if valid.size == 0:
        return "no pseudorange at any epoch"
    records = [
        ephemeris_for(np.array([prn]), obs, rinex, float(obs.rx_time_s[e]), float(obs.sample_time_s[e]), signal)[0]
        for e in (valid[0], valid[-1])
    ]
    if all(r is None for r in records):
        return "no healthy ephemeris (none decoded" + (
            ", none in --ephemeris)" if rinex is not None else ", no --ephemeris file)"
        )
    if table is None or len(table) == 0:
        return "no epoch had four usable satellites"
    excluded = int(np.count_nonzero(table.excluded_prn == prn))
    if excluded:
        return f"excluded by the residual test ({excluded} epochs)"
    rec = next(r for r in records if r is not None)
    t = float(table.columns["tow_s"][0])
    pos = satellite_state(rec, np.array([t - 0.075])).position_m[0]
    _, el, _ = pymap3d.ecef2aer(*pos, *(float(table.columns[k][0]) for k in ("lat_deg", "lon_deg", "height_m")))
    if float(el) < ELEVATION_MASK_DEG:
        return f"below the {ELEVATION_MASK_DEG:g} deg elevation mask ({float(el):.1f} deg)"
    if result.vector is not None and prn in result.vector.prns:
        return "left out of the vector loop's updates (C/N0 below its min_cn0_dbhz)"
    return "its pseudoranges fall only at epochs without a solution"


def decoded_lnav(result: ReceiveResult, signal: SignalSpec = GPS_L1CA) -> dict[int, dict]:
    """Per tracked PRN what its navigation message gave (`decoded.navigation_message` of
    ``signal``: LNAV, or I/NAV on Galileo E1-B): ``subframes``, ``first_tow_s``,
    ``ephemeris``, ``iono`` and ``week`` (`decoded.NavMessage`)."""
    message = navigation_message(signal)
    return {prn: message.decoded(ch, signal) for prn, ch in sorted(result.tracking.channels.items())}


def no_position_reason(
    result: ReceiveResult,
    nav_info=None,
    assist=None,
    reference_week: int | None = None,
    signal: SignalSpec = GPS_L1CA,
) -> str:
    """Why a run gave no position, most basic first: too few satellites found, an assisted
    start that did not hand over, no LNAV subframe, an ephemeris (``nav_info``, a
    `rinex_nav_header.NavFileInfo`) that does not cover the recording, too few usable
    satellites at every epoch."""
    found = sorted(result.tracking.channels)
    listed = f" (PRN {', '.join(map(str, found))})" if found else ""
    if len(found) < _NEEDED:
        start = "an assisted start" if assist is not None else "a position"
        plural = "s" if len(found) != 1 else ""
        return f"only {len(found)} satellite{plural} found{listed}: {start} needs {_NEEDED}"
    vector = result.vector
    if assist is not None and (vector is None or vector.handover_s is None):
        events = [text for _, text in vector.events] if vector is not None else []
        return f"the assisted start did not hand over with {len(found)} satellites found" + (
            f" (last: {events[-1]})" if events else ""
        )
    obs = result.observables
    if obs is None:
        locked = sum(1 for ch in result.tracking.channels.values() if ch.rows and ch.column("lock").any())
        return navigation_message(signal).none_decoded(locked, len(found))
    week = full_week(obs.week, reference_week, obs.week_bits)
    valid = np.flatnonzero(np.isfinite(obs.pseudorange_m).any(axis=1))
    # The recording's time: its first epoch with a pseudorange, else (no epoch formed, e.g. no
    # ephemeris for any satellite) the first time of week a channel's message gave.
    decoded_tows = [d["first_tow_s"] for d in decoded_lnav(result, signal).values() if d["first_tow_s"] is not None]
    tow = float(obs.rx_time_s[valid[0]]) if valid.size else min(decoded_tows, default=None)
    if nav_info is not None and week >= 0 and tow is not None:
        if not nav_info.covers(week, tow):
            return (
                f"the ephemeris does not cover the recording (its records span {nav_info.dates()}; the "
                f"recording is at GPS week {week}, tow {tow:.0f} s)"
            )
    dated = [int(p) for j, p in enumerate(obs.prn) if np.isfinite(obs.pseudorange_m[:, j]).any()]
    return (
        f"fewer than {_NEEDED} satellites with a pseudorange and a decoded or --ephemeris ephemeris at every "
        f"epoch ({len(dated)} with a transmit time" + (f": PRN {', '.join(map(str, dated))})" if dated else ")")
    )


def write_no_position_report(
    out_dir: str | Path,
    result: ReceiveResult,
    reason: str,
    rinex: Ephemerides | None = None,
    signal: SignalSpec = GPS_L1CA,
) -> list[Path]:
    """``report.md`` of a run without a position: the reason, per tracked satellite its
    lock, what its navigation message gave (`decoded_lnav`) and why it was not used, the vector loop's
    events, and the C/N0 figure; returns the paths written."""
    out = Path(out_dir)
    (out / "plots").mkdir(parents=True, exist_ok=True)
    decoded = decoded_lnav(result, signal)
    header = "| PRN | C/N0 locked (dB-Hz) | locked | " + " | ".join(navigation_message(signal).columns) + " "
    lines = [
        "# Receiver run: no position",
        "",
        f"- reason: {reason}",
        f"- tracked {len(result.tracking.channels)} satellites for {result.tracking.duration_s:.2f} s",
        "",
        "## Satellites",
        "",
        header + "| why not used |",
        "|---:|---:|---:|---:|---:|---|---|---:|---|",
    ]
    for prn, ch in sorted(result.tracking.channels.items()):
        lock = ch.column("lock").astype(bool) if ch.rows else np.zeros(0, bool)
        cn0 = float(np.median(ch.column("cn0_dbhz")[lock])) if lock.any() else np.nan
        d = decoded[prn]
        tow = "-" if d["first_tow_s"] is None else f"{d['first_tow_s']:.0f}"
        lines.append(
            f"| {prn} | {_fmt(cn0)} | {100 * lock.mean() if lock.size else 0.0:.0f} % | {d['subframes']} | "
            f"{tow} | "
            f"{'yes' if d['ephemeris'] else 'no'} | {'-' if d['iono'] is None else 'yes' if d['iono'] else 'no'} | "
            f"{'-' if d['week'] is None else d['week']} | {why_unused(prn, ch, result, None, rinex, signal)} |"
        )
    if result.vector is not None and result.vector.events:
        lines += ["", "## Vector tracking", ""] + [f"- {t:.2f} s: {text}" for t, text in result.vector.events]
    figure = _cn0_figure(out / "plots" / "cn0_lock.png", result)
    lines += ["", "## Figures", "", f"![cn0 lock](plots/{figure.name})", ""]
    report = out / "report.md"
    report.write_text("\n".join(lines))
    return [report, figure]


def _cn0_figure(path: Path, result: ReceiveResult) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    # A never-locked channel's C/N0 estimate (e.g. -97 dB-Hz) is noise and would squash the others' scale.
    locked = locked_channels(result.tracking)
    fig, axes = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    for prn, ch in locked:
        t = ch.column("time_s")
        axes[0].plot(t, ch.column("cn0_dbhz"), label=f"PRN {prn}")
        lock = ch.column("lock").astype(bool)
        axes[1].plot(t[lock], np.full(int(lock.sum()), prn), "|", ms=6)
    never = sorted(set(result.tracking.channels) - {prn for prn, _ in locked})
    axes[0].set_ylabel("C/N0 (dB-Hz)")
    axes[0].set_title(
        "C/N0 of the channels that locked"
        + (f" (never locked, not shown: PRN {', '.join(map(str, never))})" if never else ""),
        fontsize=9,
    )
    if axes[0].lines:
        axes[0].legend(fontsize=7, ncol=4)
    axes[1].set_ylabel("PRN locked")
    axes[1].set_xlabel("recording time (s)")
    return _save(fig, path, plt)


def _figures(
    folder: Path,
    result: ReceiveResult,
    table: PositionTable,
    sky: dict,
    err: np.ndarray | None,
    truth: tuple[float, float, float] | None,
) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    written = []
    fig = plt.figure(figsize=(5, 5))
    ax = fig.add_subplot(projection="polar")
    ax.set_theta_zero_location("N")
    ax.set_theta_direction(-1)
    for prn, (az, el) in sky.items():
        ok = np.isfinite(el)
        if ok.any():
            ax.plot(np.radians(az[ok]), 90.0 - el[ok], ".-", ms=2)
            ax.annotate(str(prn), (np.radians(az[ok][-1]), 90.0 - el[ok][-1]))
    ax.set_rlim(0, 90)
    ax.set_yticks([0, 30, 60, 90], ["90", "60", "30", "0"])
    ax.set_title("sky plot (elevation, deg)")
    written.append(_save(fig, folder / "sky.png", plt))

    written.append(_cn0_figure(folder / "cn0_lock.png", result))

    if truth is not None:
        ref = truth
    else:
        ref = tuple(float(v) for v in pymap3d.ecef2geodetic(*table.ecef_m.mean(axis=0)))
    e, n, _ = pymap3d.ecef2enu(table.ecef_m[:, 0], table.ecef_m[:, 1], table.ecef_m[:, 2], *ref)
    fig, ax = plt.subplots(figsize=(5, 5))
    ax.plot(e, n, ".-", ms=3)
    ax.plot([0.0], [0.0], "k+", ms=12, label="truth" if truth is not None else "mean")
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.axis("equal")
    ax.legend()
    ax.set_title("position track")
    written.append(_save(fig, folder / "track.png", plt))

    if err is not None:
        fig, ax = plt.subplots(figsize=(8, 4))
        for i, label in enumerate(("east", "north", "up")):
            ax.plot(table.sample_time_s, err[:, i], label=label)
        ax.set_xlabel("recording time (s)")
        ax.set_ylabel("error (m)")
        ax.legend()
        written.append(_save(fig, folder / "enu_errors.png", plt))
    return written


def _save(fig, path: Path, plt) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path
