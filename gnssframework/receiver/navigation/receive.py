"""From a recording to positions: acquisition, tracking, LNAV, observables, fixes.

The software receiver's navigation half, one function: :func:`receive` acquires and tracks
the recording (`gnssframework.receiver.channels.SampleTracker`), decodes every channel's
LNAV and its transmit times (`observables.channel_timing`), forms the observables at
common epochs and solves each epoch (`fixes.solve_epochs`); with a ``nav_filter`` (a
registry reference), that filter runs on the pseudoranges and Dopplers from the first
fix on (`filtered.filter_epochs`) and gives the positions. With SBAS from the signal
(`sbas_fixes.SbasOptions.from_signal`) the recording's SBAS L1 GEOs are acquired and tracked
too (`sbas_stream.channel_sbas`), their messages dated by the GPS channels' epochs
(`sbas_fixes.signal_records`) and the fixes corrected with them.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any
from collections.abc import Callable

import numpy as np
import pymap3d

from ..acquisition.report import acquire_recording
from ..acquisition.search import Acquisition, AcquisitionResult
from ..channels import SampleTracker, TrackingConfig, TrackingResult, signal_tracking_config
from ..channels.factory import StageFilters
from ..channels.groups import resolve_workers, track_in_groups
from ..frontend.recording import Recording
from ...errors import ConfigError
from ...navigation.ephemeris import Ephemerides, require_records_with_clock
from ...navigation.integrity import RaimOptions
from ...navigation.bds_iono import BdsKlobuchar
from ...navigation.lnav import IonoUtc
from ...plugin_ref import PluginSpec
from ...signal.gps_l1ca import GPS_L1CA
from ...signal.sbas_l1 import SBAS_L1
from ...signal.spec import SignalSpec
from .filtered import filter_epochs
from .decoded import LNAV, navigation_message
from .inav_stream import require_lnav
from .fixes import INTEGRITY_COLUMNS, PositionTable, full_week, solve_epochs
from .sbas_fixes import SbasOptions, merged_records, sbas_corrects, signal_records
from .sbas_stream import SbasChannel, channel_sbas
from .observables import TOW_TOLERANCE_S, ChannelTiming, Observables, assisted_timing, channel_timing, observables
from .vector_tracking import Assistance, VectorConfig, VectorSampleTracker, VectorSolution

__all__ = ["ReceiveResult", "receive", "assisted_observables", "position_errors", "concatenate_tables"]


@dataclass(frozen=True)
class ReceiveResult:
    """The tracking, the observables (None when no channel decoded a subframe) and the
    positions: the nav filter's when one was given, else the least-squares fixes (those
    are ``least_squares`` in both cases)."""

    tracking: TrackingResult
    observables: Observables | None
    positions: PositionTable | None
    least_squares: PositionTable | None = None
    #: With ``vector``: the navigation filter's states after the hand-over.
    vector: VectorSolution | None = None
    #: With SBAS from the signal: each SBAS L1 channel's messages (`sbas_stream.SbasChannel`),
    #: and one line per GEO tracked whose messages could not be read.
    sbas: list[SbasChannel] | None = None
    sbas_notes: tuple[str, ...] = ()


def receive(
    recording: Recording,
    acquisition: Acquisition,
    config: TrackingConfig,
    *,
    prns: tuple[int, ...] | None = None,
    duration_s: float | None = None,
    rate_hz: float = 1.0,
    rinex: Ephemerides | None = None,
    ionosphere: bool = True,
    troposphere: bool = False,
    reference_week: int | None = None,
    progress: Any = None,
    nav_filter: PluginSpec | None = None,
    vector: VectorConfig | None = None,
    acquisitions: list[AcquisitionResult] | None = None,
    assist: Assistance | None = None,
    iono_fallback: IonoUtc | BdsKlobuchar | None = None,
    weighting: str | None = None,
    signal: SignalSpec = GPS_L1CA,
    filters: StageFilters | None = None,
    raim: RaimOptions | None = None,
    observe: Callable[[SampleTracker], Any] | None = None,
    smooth: bool = False,
    workers: int | str | None = None,
    sbas: SbasOptions | None = None,
) -> ReceiveResult:
    """Acquire, track and position (see the module text); ``rinex`` adds ephemerides for
    satellites whose own have not been decoded yet; ``progress`` is called with the
    fraction of the recording tracked. With ``nav_filter`` the positions are that filter's
    (`filtered.filter_epochs`) from the first least-squares fix on. With ``vector`` the channels go over
    to vector tracking at the first fix (`vector_tracking.VectorSampleTracker`): the
    positions are the scalar fixes before the hand-over, then the navigation filter's.
    ``acquisitions`` (made on the first samples) replace the initial search. ``assist``
    (with ``vector`` and ``rinex``) hands over without LNAV, from an approximate position
    and start time (`vector_tracking.Assistance`); the observables are then the vector
    channels' (`assisted_observables`), and ``least_squares`` the fixes of those.
    ``iono_fallback`` (a navigation file header's Klobuchar coefficients) corrects the
    least-squares fixes, the nav filter and the vector loop's LNAV hand-over where no channel
    decoded page 18 (an assisted start takes the assistance's). ``weighting``
    that of the least-squares fixes (`pvt.solve_position`'s; ``rtklib`` for RTKLIB's SPP model).
    ``signal`` is the one searched, tracked and dated (an LNAV-format `SignalSpec`: GPS or
    QZSS L1 C/A; or Galileo E1-B, dated from its I/NAV GST, scalar tracking only, with the
    records of ``rinex`` or the decoded I/NAV ones, no Klobuchar correction unless
    ``iono_fallback``); ``filters`` the stages' channel filters built once for the task
    (`channels.factory.StageFilters` of ``config``; built by the tracker when None).
    ``smooth`` (with ``nav_filter``) makes its positions the forward-backward (RTS) estimates
    (`filtered_smoothing`). ``raim`` monitors the least-squares fixes' integrity (`pvt.solve_position`'s ``raim``)
    and gives the nav filter's rows protection levels from its covariance, its innovation
    test at ``raim.false_alarm`` (`filtered.filter_epochs`); the vector loop's rows get the
    levels of its navigation filter's covariance and its channel monitor's verdict
    (`VectorSolution.table`; the monitor is ``vector.monitor_false_alarm``'s).
    ``observe`` is given the scalar tracker before it runs (a live receiver's fixes as they
    come, `live.LiveFixes`, read its records from ``progress``). ``workers`` (a number, or
    ``"auto"``: the cores available) tracks the scalar channels in that many forked
    processes (`channels.groups.track_in_groups`: the same records); one process with
    ``vector``, ``observe`` or a live stream. ``sbas`` corrects the least-squares fixes with
    SBAS messages from a file (`sbas_fixes.SbasOptions`; GPS L1 C/A, scalar tracking, no
    ``nav_filter`` and no ``raim``): positions gain the columns `sbas_fixes.SBAS_COLUMNS`;
    with ``sbas.from_signal`` the recording's SBAS L1 GEOs are tracked under ``config``'s
    settings (their coherent time their 2 ms symbol) and their messages added
    (``ReceiveResult.sbas``)."""
    if sbas is not None and (vector is not None or nav_filter is not None or raim is not None):
        raise ConfigError(
            "sbas",
            "SBAS corrects the least-squares fixes of scalar tracking with its own protection levels: "
            "not with vector, nav_filter or raim",
        )
    if sbas is not None and not sbas_corrects(signal):
        raise ConfigError("sbas", f"SBAS L1 corrects GPS L1 C/A fixes, not {signal.name}")
    message = navigation_message(signal)  # dates the channels: LNAV subframes, the I/NAV GST
    resolve_workers(workers, 1)  # a bad value refused before any work
    if rinex is not None:  # only records that give this signal's user a clock (E5a: F/NAV's)
        rinex = require_records_with_clock(rinex, signal, "rinex", "the records given")
    if not message.hands_over and (vector is not None or assist is not None):
        raise ConfigError(
            "vector",
            f"{signal.name}: vector tracking and the assisted start hand over from LNAV; "
            f"{message.name} positions are the scalar receiver's",
        )
    if message is LNAV:
        require_lnav(signal)  # a signal carrying no message the receiver decodes is refused here
    if vector is not None and nav_filter is not None:  # the vector loop closes its own filter
        raise ConfigError(
            "nav_filter",
            "vector tracking runs its own navigation filter (VectorConfig); give nav_filter or vector, not both",
        )
    if smooth and nav_filter is None:  # checked before the tracking it would come after
        raise ConfigError("smooth", "smooths a navigation filter's positions: give nav_filter too")
    if acquisitions is None:
        acquisitions = acquire_recording(recording, acquisition, prns or None, signal=signal)  # None: all
    found = [r for r in acquisitions if r.detected]
    if vector is not None:
        tracker = VectorSampleTracker(
            recording,
            config,
            acquisition,
            vector,
            rinex=rinex,
            ionosphere=ionosphere,
            reference_week=reference_week,
            assist=assist,
            iono_fallback=iono_fallback,
            signal=signal,
            filters=filters,
        )
        tracking = tracker.run(found, duration_s, progress)
        solution = tracker.solution
        timings = [
            channel_timing(ch, signal=signal)
            if assist is not None
            else _with_rejoined(channel_timing(ch, signal=signal), ch, solution, signal)
            for ch in tracking.channels.values()
        ]  # (an assisted start's are `assisted_observables`)
        scalar = None
        if any(t is not None and t.time_s.size > 1 for t in timings):
            obs = observables(timings, rate_hz)
            scalar = solve_epochs(
                obs,
                rinex,
                ionosphere=ionosphere,
                troposphere=troposphere,
                iono=_fallback(obs, iono_fallback),
                reference_week=reference_week,
                weighting=weighting,
                signal=signal,
                **_raim_args(raim),
            )
        else:
            obs = None
        vector_rows = solution.table(vector.solution_rate_hz, None if raim is None else raim.integrity_risk)
        table = concatenate_tables(scalar, vector_rows, solution.handover_s)
        if assist is not None and solution.replica_tx:
            assisted = assisted_observables(tracking, solution, rate_hz, assist.iono, signal)
            if assisted is not None:  # the vector channels' rows, dated without LNAV
                least_squares = solve_epochs(
                    assisted,
                    rinex,
                    ionosphere=ionosphere,
                    troposphere=troposphere,
                    reference_week=assist.week if reference_week is None else reference_week,
                    weighting=weighting,
                    signal=signal,
                )
                return ReceiveResult(tracking, assisted, table, least_squares, solution)
        return ReceiveResult(tracking, obs, table, scalar, solution)
    if assist is not None:
        raise ConfigError(
            "approx_position", "an approximate position and start time start vector tracking: give vector as well"
        )
    if observe is None:  # (in one process where there is one group, `track_in_groups`)
        tracking = track_in_groups(
            recording,
            config,
            acquisition,
            found,
            duration_s,
            workers=workers,
            signal=signal,
            filters=filters,
            progress=progress,
        )
    else:
        scalar_tracker = SampleTracker(recording, config, acquisition, signal=signal, filters=filters)
        if observe is not None:
            observe(scalar_tracker)
        tracking = scalar_tracker.run(found, duration_s, progress)
    timings = [message.timing(ch, signal) for ch in tracking.channels.values()]
    if not any(t is not None and t.time_s.size > 1 for t in timings):
        return ReceiveResult(tracking, None, None)
    obs = observables(timings, rate_hz)
    iono = _fallback(obs, iono_fallback)
    sbas_channels: list[SbasChannel] | None = None
    sbas_notes: tuple[str, ...] = ()
    if sbas is not None and sbas.from_signal:
        week = full_week(obs.week, reference_week, obs.week_bits)
        sbas, sbas_channels, sbas_notes = _sbas_from_signal(
            recording, acquisition, config, sbas, obs, week, duration_s, workers
        )
    table = solve_epochs(
        obs,
        rinex,
        ionosphere=ionosphere,
        troposphere=troposphere,
        iono=iono,
        reference_week=reference_week,
        weighting=weighting,
        signal=signal,
        **_raim_args(raim),
        sbas=sbas,
    )
    if nav_filter is None:
        return ReceiveResult(tracking, obs, table, table, sbas=sbas_channels, sbas_notes=sbas_notes)
    checks = {} if raim is None else {"innovation_false_alarm": raim.false_alarm, "integrity_risk": raim.integrity_risk}
    filtered = filter_epochs(
        obs,
        table,
        nav_filter.name,
        nav_filter.params,
        rinex,
        ionosphere=ionosphere,
        troposphere=troposphere,
        iono=iono,
        reference_week=reference_week,
        signal=signal,
        smooth=smooth,
        **checks,
    )
    return ReceiveResult(tracking, obs, filtered, table)


def _sbas_from_signal(
    recording: Recording,
    acquisition: Acquisition,
    config: TrackingConfig,
    sbas: SbasOptions,
    obs: Observables,
    week: int,
    duration_s: float | None,
    workers: int | str | None,
) -> tuple[SbasOptions, list[SbasChannel], tuple[str, ...]]:
    """Acquire and track the recording's SBAS L1 GEOs (``sbas.prn``'s only, when given) under
    ``config``'s settings with SBAS L1's coherent time, read each channel's messages and add
    them, dated by ``obs`` in GPS ``week``, to ``sbas``'s records; the channels read and one
    line per GEO found whose messages could not be read."""
    prns = None if sbas.prn is None else (sbas.prn,)
    found = [r for r in acquire_recording(recording, acquisition, prns, signal=SBAS_L1) if r.detected]
    settings = {k: v for k, v in config.model_dump().items() if k != "coherent_ms"}
    geo_config = signal_tracking_config(SBAS_L1, **settings)
    channels: list[SbasChannel] = []
    notes: list[str] = []
    records = []
    if found:
        tracked = track_in_groups(
            recording, geo_config, acquisition, found, duration_s, workers=workers, signal=SBAS_L1
        )
        for _, record in sorted(tracked.channels.items()):
            try:
                channel = channel_sbas(record, SBAS_L1)
            except ConfigError as exc:
                notes.append(exc.detail)
                continue
            channels.append(channel)
            records += signal_records(channel, obs.sample_time_s, obs.rx_time_s, week)
    else:
        notes.append("no SBAS L1 GEO found in the recording" + ("" if prns is None else f" (PRN {sbas.prn})"))
    return replace(sbas, records=merged_records(sbas.records, records)), channels, tuple(notes)


def _raim_args(raim: RaimOptions | None) -> dict[str, Any]:
    """`fixes.solve_epochs`'s integrity arguments of ``raim`` (none without)."""
    if raim is None:
        return {}
    return {
        "raim": raim.method,
        "false_alarm": raim.false_alarm,
        "missed_detection": raim.missed_detection,
        "integrity_risk": raim.integrity_risk,
    }


def _with_rejoined(
    timing: ChannelTiming | None, record, solution: VectorSolution, signal: SignalSpec = GPS_L1CA
) -> ChannelTiming | None:
    """``timing`` (`channel_timing`'s) and, where the channel's last stretch of vector rows
    is not in it (a channel that rejoined the loop after re-acquisition: its first row may
    start mid-bit, so no bit run dates it), those rows dated from the replica's transmit time
    at the end of the run (`observables.assisted_timing`), without carrier phase (no PLL
    closes a vector channel). Rows whose decoded TOW disagrees with that dating are left out."""
    if record.prn not in solution.replica_tx:
        return timing
    rejoined = assisted_timing(record, *solution.replica_tx[record.prn], signal=signal)
    if rejoined is None or (timing is not None and timing.time_s[-1] >= rejoined.time_s[0]):
        return timing
    if rejoined.tow_offset_s is not None and abs(rejoined.tow_offset_s) > TOW_TOLERANCE_S:
        solution.events.append(
            (
                float(rejoined.time_s[0]),
                f"PRN {record.prn}: its decoded TOW is "
                f"{rejoined.tow_offset_s:+.3f} s from the replica's transmit time: its rows after "
                "rejoining left out of the observables",
            )
        )
        return timing
    rejoined = replace(rejoined, carrier_cycles=np.full(rejoined.time_s.size, np.nan), tow_offset_s=None)
    if timing is None:
        return rejoined
    joined = {
        f: np.concatenate([getattr(timing, f), getattr(rejoined, f)])
        for f in ("time_s", "transmit_s", "doppler_hz", "carrier_cycles", "cn0_dbhz", "half_cycle")
    }
    starts = np.concatenate(
        [
            timing.arc_start if timing.arc_start is not None else np.eye(1, timing.time_s.size, dtype=bool)[0],
            rejoined.arc_start,
        ]
    )
    known = np.concatenate(
        [
            timing.polarity_known if timing.polarity_known is not None else np.ones(timing.time_s.size, bool),
            rejoined.polarity_known,
        ]
    )
    return replace(timing, **joined, arc_start=starts, polarity_known=known)


def _fallback(obs: Observables, iono: IonoUtc | None) -> IonoUtc | None:
    """``iono`` where no channel decoded page 18 or D1's coefficients (None keeps the
    decoded ones)."""
    return iono if obs.iono_utc is None and obs.bds_iono is None else None


def assisted_observables(
    tracking: TrackingResult,
    solution: VectorSolution,
    rate_hz: float,
    iono: IonoUtc | None = None,
    signal: SignalSpec = GPS_L1CA,
) -> Observables | None:
    """Observables of the vector channels of an assisted start (`observables.assisted_timing`),
    the receiver clock at the start time (``solution.rx_offset_s``); None without a dated channel.

    A channel whose decoded TOW disagrees with its assisted transmit time (by more than
    `observables.TOW_TOLERANCE_S`: the start time was wrong) is left out, with an event in
    ``solution.events``.
    """
    timings = []
    for prn, (end_s, end_tx_s) in sorted(solution.replica_tx.items()):
        tm = assisted_timing(tracking.channels[prn], end_s, end_tx_s, signal=signal)
        if tm is None:
            continue
        if tm.tow_offset_s is not None and abs(tm.tow_offset_s) > TOW_TOLERANCE_S:
            solution.events.append(
                (
                    float(tm.time_s[-1]),
                    f"PRN {prn}: its decoded TOW is {tm.tow_offset_s:+.3f} s "
                    "from the assisted transmit time (a wrong start time?): left out of the observables",
                )
            )
            continue
        timings.append(tm)
    if not any(tm.time_s.size > 1 for tm in timings):
        return None
    return observables(timings, rate_hz, rx_offset_s=solution.rx_offset_s, iono_utc=iono)


def concatenate_tables(
    before: PositionTable | None, after: PositionTable | None, switch_s: float | None
) -> PositionTable | None:
    """The rows of ``before`` up to ``switch_s`` (recording time), then those of ``after``
    (integrity columns that one of them has and the other lacks: inf and ``unavailable`` in the
    rows that lack them)."""
    if after is None or switch_s is None:
        return before
    if before is None:
        return after
    k = before.sample_time_s < switch_s
    before_columns, after_columns = dict(before.columns), dict(after.columns)
    for c in INTEGRITY_COLUMNS:  # rows without protection levels: inf, "unavailable"
        for have, lack, rows in (
            (before_columns, after_columns, len(after)),
            (after_columns, before_columns, len(before)),
        ):
            if c in have and c not in lack:
                lack[c] = np.full(rows, "unavailable" if c == "raim" else np.inf, dtype=have[c].dtype)
    return PositionTable(
        {c: np.concatenate([before_columns[c][k], after_columns[c]]) for c in after_columns},
        np.concatenate([before.ecef_m[k], after.ecef_m]),
        np.concatenate([before.sample_time_s[k], after.sample_time_s]),
        [u for u, keep in zip(before.used_prns, k) if keep] + list(after.used_prns),
        np.concatenate([before.excluded_prn[k], after.excluded_prn]),
    )


def position_errors(table: PositionTable, truth_lat_lon_h: tuple[float, float, float]) -> np.ndarray:
    """East, north, up errors ``(F, 3)`` (m) of the fixes against a known position."""
    lat, lon, h = truth_lat_lon_h
    e, n, u = pymap3d.ecef2enu(table.ecef_m[:, 0], table.ecef_m[:, 1], table.ecef_m[:, 2], lat, lon, h)
    return np.stack([np.asarray(e), np.asarray(n), np.asarray(u)], axis=-1).reshape(-1, 3)
