r"""Hand-over from the scalar channels to the navigation filter (vector tracking on samples).

After LNAV (`try_handover`): once at least four channels run bit-aligned (``extended``)
with a transmit time from their LNAV and an ephemeris (decoded, or from a RINEX file), a
first fix (`fixes.solve_epochs`) starts the navigation filter and those channels are
closed by it. With an `Assistance` (`try_assisted_handover`): each replica's transmit time
is resolved from the approximate position and start time, and every acquired channel is
closed from its pull-in on, without LNAV.

The functions take the `vector_tracking.VectorSampleCloser` ``v`` (annotated, not imported: it
imports them) whose state they set: its `VectorNavigator` (``v.nav``, None before the
hand-over) and its solution.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ...errors import ConfigError
from ...navigation.coarse_time import CoarseTimeFix, solve_coarse_time
from ...navigation.ephemeris import Ephemerides, satellite_state
from ...navigation.pvt import solve_position
from ..channels.channel import SampleChannel, stage_context
from ..tracking.jitter import code_thermal_std_chips
from .fixes import full_week, solve_epochs
from .observables import SPEED_OF_LIGHT_MPS, channel_timing, observables
from .vector_config import Assistance
from .vector_navigator import VectorNavigator, rotate, stack
from .vector_reacquire import join
from .vector_time import TimeOffsetEstimator

__all__ = ["try_handover", "try_assisted_handover", "hand_over", "start_vector", "shifted_start", "VECTOR"]

_C = SPEED_OF_LIGHT_MPS
#: Code periods every channel runs (its pull-in) before an assisted hand-over.
_ASSIST_SETTLE_MS = 100
#: An assisted fix further than this from the approximate position (m) is refused (a wrong millisecond).
_ASSIST_RADIUS_M = 300e3
#: ... or one with a residual above this (m): pull-in code phases are within a chip (300 m), a wrong
#: millisecond is 300 km.
_ASSIST_MAX_RESIDUAL_M = 1000.0
#: A GPS week (s).
_WEEK_S = 604_800.0
#: Resolve-and-fix rounds of an assisted hand-over.
_ASSIST_ITERATIONS = 4
#: A start time whose coarse-time offset is this many of its standard deviations from zero
#: is refused (`_start_time_error`): 4 sigma, a false refusal once in 16,000 tries.
_ASSIST_TIME_SIGMAS = 4.0
#: ... and within this many seconds (s): a time error is the explanation looked for up to
#: here (the coarse-time model's steps stay linear to tens of seconds).
_ASSIST_TIME_RANGE_S = 10.0


class _VectorClosure:
    """Marks a channel closed by the navigation filter (a channel's ``closure``)."""


#: The ``closure`` of a vector channel.
VECTOR = _VectorClosure()


def try_handover(v: VectorSampleCloser) -> None:
    """Hand over the locked ``extended`` channels with LNAV timing and an ephemeris, at a
    first fix with at least four of them."""
    t = v.tracker
    sp = t.signal
    ready = [c for c in t.channels.values() if c.stage == "extended" and c.locked]
    timings = {c.prn: channel_timing(c.record, signal=sp) for c in ready}
    timings = {p: tm for p, tm in timings.items() if tm is not None and tm.time_s.size > 1}
    if len(timings) < 4:
        return
    try:
        obs = observables(list(timings.values()), rate_hz=10.0)
    except ConfigError:
        return
    table = solve_epochs(
        obs,
        v.rinex,
        ionosphere=v.ionosphere,
        reference_week=v.reference_week,
        iono=None if obs.iono_utc is not None else v.iono_fallback,
        signal=sp,
    )
    if len(table) == 0:
        return
    records = {p: _ephemeris(v, p, obs, float(table.sample_time_s[-1])) for p in timings}
    prns = tuple(sorted(p for p, r in records.items() if r is not None))
    if len(prns) < 4:
        return
    slots = np.array([t.slot(p) for p in prns])
    tx_anchor = np.zeros(len(t.active))
    chip_anchor = np.zeros(len(t.active))
    for p, i in zip(prns, slots):
        tx_anchor[i] = _transmit_now(t, timings[p], t.channels[p].record, i)
        chip_anchor[i] = t.ms_index[i] * sp.code_length_chips + t.code_phase[i]
    e = len(table) - 1
    t_fix = float(table.sample_time_s[e])
    bias = float(table.columns["clock_bias_m"][e])
    rx_offset = float(table.columns["tow_s"][e] + bias / _C - t_fix)
    v.nav = VectorNavigator(
        t,
        v.vector,
        v.solution,
        slots,
        stack([records[p] for p in prns]),
        (obs.iono_utc or v.iono_fallback) if v.ionosphere else None,
        rx_offset,
        tx_anchor,
        chip_anchor,
    )
    hand_over(
        v,
        prns,
        table.ecef_m[e],
        bias,
        t_fix,
        full_week(obs.week, v.reference_week, obs.week_bits),
        f"first fix with {len(table.used_prns[e])} satellites",
    )


def _transmit_now(t, timing, record, i: int) -> float:
    """A channel's transmit time at its replica's current start (slot ``i``): from its last
    LNAV-dated row, plus the chips generated since (no code-phase jumps in the extended
    stage)."""
    sp = t.signal
    j = int(np.searchsorted(record.column("time_s"), timing.time_s[-1]))
    chips = sp.code_length_chips * record.column("coherent_ms")[j:].sum() + t.code_phase[i] - record.rows[j][4]
    return float(timing.transmit_s[-1] + chips / sp.chip_rate_hz)


def admit_locked(v: VectorSampleCloser) -> None:
    """Once the loop runs, a scalar channel outside it that is now locked in the extended
    stage, dated by its own LNAV and with a healthy ephemeris (decoded, or the RINEX file's)
    joins it (`vector_reacquire.join`, at its exact transmit time): a channel out of lock at
    the hand-over is not left out for the rest of the run."""
    t = v.tracker
    sp = t.signal
    in_loop = set(v.nav.slots.tolist())
    for c in t.channels.values():
        if c.slot in in_loop or c.stage != "extended" or not c.locked or not t.active[c.slot]:
            continue
        timing = channel_timing(c.record, signal=sp)
        if timing is None or timing.time_s.size < 2:
            continue
        try:
            obs = observables([timing], rate_hz=10.0)
        except ConfigError:
            continue
        record = _ephemeris(v, c.prn, obs, float(t.start_sample[c.slot]) / t.fs)
        if record is None:
            continue
        tx_now = _transmit_now(t, timing, c.record, c.slot)
        join(v, c, record, tx_now - t.code_phase[c.slot] / sp.chip_rate_hz)
        v.solution.events.append(
            (float(t.start_sample[c.slot]) / t.fs, f"PRN {c.prn} joined the loop (locked, LNAV-dated)")
        )


def _assisted_transmit_times(
    v: VectorSampleCloser, chans: list[SampleChannel], now_s: float, r0: np.ndarray
) -> tuple[list[SampleChannel], Ephemerides, np.ndarray] | None:
    r"""The channels of ``chans`` with a healthy RINEX record, their records and each
    replica's transmit time (s of week, satellite time) at its current start sample,
    from the `Assistance`'s start time and position ``r0`` (None with fewer than four
    such channels).

    A replica at a code epoch has sent a whole number of code periods plus ``code_phase``
    chips; the predicted transmit time
    :math:`t_{rx} - \lVert s - r_0\rVert / c + \Delta t_{SV}` from the approximate
    position :math:`r_0` and the start time picks the period (the coarse-time
    resolution of van Diggelen, *A-GPS*, 2009, ch. 4). The receiver clock's offset
    modulo a code period is common to every channel: it is taken out first (the circular
    mean of the fractional residuals), so only the geometry's error must stay under half a
    period (~150 km of range on L1 C/A).
    """
    t = v.tracker
    sp = t.signal
    a = v.assist
    records = {}
    for c in chans:
        try:
            records[c.prn] = v.rinex.select([sp.rinex_satellite(c.prn)], a.start_tow_s + now_s)
        except KeyError:  # no healthy record of it in the file
            continue
    chans = [c for c in chans if c.prn in records]
    if len(chans) < 4:
        return None
    slots = np.array([c.slot for c in chans])
    eph = stack([records[c.prn] for c in chans])
    t_rx = a.start_tow_s + t.start_sample[slots] / t.fs
    tx = t_rx - 0.075
    for _ in range(3):  # the flight time, iterated (it changes by < 1 us after two)
        st = satellite_state(eph, tx)
        pos = rotate(st.position_m, t_rx - tx)
        tx = t_rx - np.linalg.norm(pos - r0, axis=-1) / _C + st.clock_l1_s
    sub_period = t.code_phase[slots] / sp.chip_rate_hz
    per_s = 1.0 / sp.code_period_s
    residual = (tx - sub_period) * per_s  # code periods
    common = np.angle(np.mean(np.exp(2j * np.pi * residual))) / (2 * np.pi)
    return chans, eph, np.round(residual - common) * sp.code_period_s + sub_period


def try_assisted_handover(v: VectorSampleCloser, now_s: float) -> None:
    """Close every active channel from its assisted transmit time
    (`_assisted_transmit_times`), whatever its scalar stage: the navigation filter
    starts from a least-squares fix on these pseudoranges, once every active channel
    has run `_ASSIST_SETTLE_MS` (its pull-in has narrowed the acquisition's Doppler).

    No lock, bit sync or LNAV is needed: the bit edges follow from the transmit times
    (LNAV bits start where the satellite's time is a whole multiple of 20 ms,
    IS-GPS-200 20.3.2), and a channel in 1 ms pull-in or tracking goes over at its
    next boundary of a ``coherent_ms`` interval within a bit (`VectorSampleCloser.advance`)."""
    t = v.tracker
    sp = t.signal
    active = sorted((c for c in t.channels.values() if t.active[c.slot] and c.stage != "lost"), key=lambda c: c.prn)
    if len(active) < 4 or any(t.ms_index[c.slot] < _ASSIST_SETTLE_MS for c in active):
        return
    a = v.assist
    fix, r0, previous = None, a.position_ecef_m, None
    # Resolve, fix, resolve again from the fix: a consistent resolution is one the fix
    # reproduces (a misresolved period moves the fix, and the next resolution).
    for _ in range(_ASSIST_ITERATIONS):
        found = _assisted_transmit_times(v, active, now_s, r0)
        if found is None:
            return
        chans, eph, tx_start = found
        if previous is not None and np.array_equal(previous, tx_start):
            break
        slots = np.array([c.slot for c in chans])
        t_s = t.start_sample[slots] / t.fs
        # Pseudoranges at a common receive epoch (the latest channel's start).
        t_fix = float(t_s.max())
        tx_fix = tx_start + (t_fix - t_s) * t.code_rate[slots] / sp.chip_rate_hz
        pr = _C * (a.start_tow_s + t_fix - tx_fix)
        # The residual test at the pull-in code phases' noise, not at a tracked code's.
        fix = solve_position(
            pr,
            tx_fix,
            eph,
            iono=a.iono if v.ionosphere else None,
            elevation_mask_deg=0.0,
            initial_ecef_m=a.position_ecef_m,
            sigma_m=v.vector.assisted_pseudorange_sigma_m,
            signal=sp,
        )
        if fix is None:
            break
        previous, r0 = tx_start, fix.position_ecef_m
    else:
        fix = None  # the resolution did not settle
    # A start time seconds off shows as residuals or an excluded satellite too: the time
    # is named first, with its estimate. The first time, the start time is corrected by
    # the estimate and the hand-over tried again at once (the loop refines what is left:
    # `vector_time`); a second time it is refused for good: a later try with fewer
    # satellites (four: the offset is not observable) would hand over on it unchecked.
    found = None if fix is None else _start_time_error(v, pr, tx_fix, eph, fix, pull_in_code_sigma_m(v, chans))
    if found is not None:
        if v.time_corrected:
            v.solution.events.append((now_s, _refusal(found, pr.size)))
            v.next_assist = float("inf")
            return
        shift = round(found.time_offset_s, 3)  # whole milliseconds: the code phases give the rest
        v.assist = shifted_start(a, shift)
        v.time_corrected = True
        v.solution.events.append(
            (
                now_s,
                f"start time corrected by {shift:+.3f} s at the pull-in (coarse-time fix on {pr.size} "
                f"satellites: {found.time_offset_s:+.3f} ± {found.time_offset_sigma_s:.3f} s); the loop "
                "checks what is left",
            )
        )
        v.next_assist = now_s
        return
    if (
        fix is None
        or not np.all(fix.used)
        or np.nanmax(np.abs(fix.residuals_m)) > _ASSIST_MAX_RESIDUAL_M
        or np.linalg.norm(fix.position_ecef_m - a.position_ecef_m) > _ASSIST_RADIUS_M
    ):
        v.solution.events.append(
            (
                now_s,
                "assisted fix failed (no solution, a satellite excluded, residuals "
                "or distance to the approximate position too large): no hand-over",
            )
        )
        v.next_assist = now_s + v.vector.try_every_s
        return
    prns = tuple(c.prn for c in chans)
    per_s = 1.0 / sp.code_period_s
    for c, tx_s in zip(chans, tx_start):
        if c.stage != "extended":  # (an extended channel is bit-aligned already)
            whole = int(np.round((tx_s - t.code_phase[c.slot] / sp.chip_rate_hz) * per_s))
            # The tracker labels the coming code period ms_index + 1 (`ScalarSampleCloser.advance`).
            c.bit_edge = (int(t.ms_index[c.slot]) + 1 - whole) % c.periods_per_symbol
    tx_anchor = np.zeros(len(t.active))
    chip_anchor = np.zeros(len(t.active))
    tx_anchor[slots] = tx_start
    chip_anchor[slots] = t.ms_index[slots] * sp.code_length_chips + t.code_phase[slots]
    v.nav = VectorNavigator(
        t, v.vector, v.solution, slots, eph, a.iono if v.ionosphere else None, a.start_tow_s, tx_anchor, chip_anchor
    )
    if v.vector.time_window_s > 0:  # the start time checked in the loop (`vector_time`)
        v.nav.time = TimeOffsetEstimator(v.vector.time_window_s)
    vc = v.vector
    # A locked loop's Doppler (averaged over its last bit), else the acquisition's: a
    # 1 ms pull-in loop that has not locked may have wandered tens of Hz from it.
    doppler = np.array(
        [
            np.mean(c.record.column("doppler_hz")[-c.periods_per_symbol :]) if c.locked else v.acq_doppler[c.slot]
            for c in chans
        ]
    )
    hand_over(
        v,
        prns,
        fix.position_ecef_m,
        fix.clock_bias_m,
        t_fix,
        a.week,
        f"assisted fix with {int(np.sum(fix.used))} satellites (approximate position and start "
        "time, RINEX ephemerides)",
        vc.assisted_pseudorange_sigma_m,
        vc.assisted_range_rate_sigma_mps,
        doppler,
    )


def shifted_start(a: Assistance, shift_s: float) -> Assistance:
    """``a`` with its start time ``shift_s`` later, across a week's end into the next (or
    previous) GPS week."""
    week, tow = divmod(a.start_tow_s + shift_s, _WEEK_S)
    return replace(a, week=a.week + int(week), start_tow_s=float(tow))


def _refusal(found: CoarseTimeFix, satellites: int) -> str:
    return (
        f"assisted start refused: the start time is off by {found.time_offset_s:+.3f} s "
        f"(± {found.time_offset_sigma_s:.3f} s, coarse-time fix on {satellites} satellites) after "
        "its correction; an assisted start needs it to ~1 s: correct --start-time, or drop the "
        "assistance to hand over after LNAV"
    )


def pull_in_code_sigma_m(v: VectorSampleCloser, chans: list[SampleChannel]) -> float:
    """The standard deviation (m) of the pull-in code phases of ``chans`` at an assisted
    hand-over, the largest over the channels: the acquisition's code phase, a whole sample
    within one of the true delay (noise picks the neighbour of a delay between two samples:
    uniform over two, :math:`\\Delta/\\sqrt{3}` chips for :math:`\\Delta` chips a sample),
    decayed by the DLL of bandwidth :math:`B_L` over the channel's pull-in so far
    (:math:`e^{-4 B_L t}`, a first-order loop's), and the DLL's thermal jitter
    :math:`\\sqrt{2 B_L T \\sigma_D^2}` (`jitter.code_thermal_std_chips`) from its discriminator's
    noise variance at the acquisition's C/N0 estimate (biased low: the sigma errs large).
    A channel filter without ``dll_bandwidth_hz`` and ``code_discriminator`` parameters
    (a plugin of another kind) gives ``assisted_pseudorange_sigma_m`` instead.

    Measured (docs/receiver/navigation.md, "A wrong start time is corrected"): on the
    project's generator at 28-40 dB-Hz, 2.6 MHz, five satellites and start times drawn per
    run, the coarse-time offsets of a right start time scatter within this sigma's (with
    half a sample, not one, they did not at 32 dB-Hz: 1.4 times it)."""
    t = v.tracker
    sp = t.signal
    T = sp.code_period_s
    acquired_chips = sp.chip_rate_hz / t.fs / np.sqrt(3.0)
    worst = 0.0
    for c in chans:
        if c.stage not in ("pull-in", "track", "extended"):
            return v.vector.assisted_pseudorange_sigma_m
        loop = t.filters.factory(c.stage).prototype  # (a batch's channels hold no filter of their own)
        thermal = float(code_thermal_std_chips(loop, v.acq_cn0[c.slot], T, t.config.early_late_spacing_chips))
        if not np.isfinite(thermal):  # no DLL parameters to take it from
            return v.vector.assisted_pseudorange_sigma_m
        left = acquired_chips * np.exp(-4.0 * loop.params.dll_bandwidth_hz * float(t.ms_index[c.slot]) * T)
        worst = max(worst, float(np.hypot(thermal, left)))
    return worst * _C / sp.chip_rate_hz


def _start_time_error(
    v: VectorSampleCloser, pr: np.ndarray, tx: np.ndarray, eph: Ephemerides, fix, sigma_m: float
) -> CoarseTimeFix | None:
    """The coarse-time fix that finds the `Assistance`'s start time off, or None: the coarse-time fix
    (`coarse_time.solve_coarse_time`) of the assisted pseudoranges estimates the common
    error of their transmit times, which the millisecond resolution cannot see (it takes
    whole periods of it into every channel alike). A start time off by a second moves
    every satellite by kilometres along its orbit and the fix by about as much; the
    estimate's sigma is that of the pull-in code phases, ``sigma_m`` (`pull_in_code_sigma_m`).
    Needs five satellites (with four, the offset is not observable: no check); with
    five, the coarse-time fix has no residual to test, so a misresolved millisecond could
    read as an offset: only one within `_ASSIST_TIME_RANGE_S` whose fix is near the
    approximate position is named."""
    if pr.size < 5:
        return None
    found = solve_coarse_time(
        pr,
        tx,
        eph,
        initial_ecef_m=fix.position_ecef_m,
        sigma_m=sigma_m,
        iono=v.assist.iono if v.ionosphere else None,
        elevation_mask_deg=0.0,
        signal=v.tracker.signal,
    )
    if found is None or abs(found.time_offset_s) <= _ASSIST_TIME_SIGMAS * found.time_offset_sigma_s:
        return None
    # Named only where a time error explains the pseudoranges: an offset within the range
    # looked for, and a coarse-time fix that passes the hand-over's own tests (a misresolved
    # millisecond, 300 km of range, also fits some offset: then the fix fails as before).
    ct = found.fix
    if (
        abs(found.time_offset_s) > _ASSIST_TIME_RANGE_S
        or not np.all(ct.used)
        or np.nanmax(np.abs(ct.residuals_m)) > _ASSIST_MAX_RESIDUAL_M
        or np.linalg.norm(ct.position_ecef_m - v.assist.position_ecef_m) > _ASSIST_RADIUS_M
    ):
        return None
    return found


def hand_over(
    v: VectorSampleCloser,
    prns: tuple[int, ...],
    r: np.ndarray,
    bias: float,
    t_fix: float,
    week: int,
    why: str,
    range_sigma_m: float | None = None,
    rate_sigma_mps: float | None = None,
    doppler_hz: np.ndarray | None = None,
) -> None:
    """Start the navigation filter (``v.nav``, created with its channels, ephemerides and
    transmit-time anchors) at fix ``r``, ``bias`` (recording time ``t_fix``) and close
    channels ``prns``; the sigmas of the fix default to the config's."""
    t, nav, vc = v.tracker, v.nav, v.vector
    slots = nav.slots
    # Velocity and clock drift from the channels' Dopplers (the PLL's, the best there is).
    vel, d, G = nav.velocity(slots, r, doppler_hz)
    x0 = np.r_[r, vel, bias, d]
    # The first fix's covariance from its geometry (G = [-e, 1]), position and clock
    # from the pseudoranges, velocity and drift from the Dopplers.
    info = np.linalg.inv(G.T @ G)
    cov0 = np.zeros((8, 8))
    pc, vd = np.r_[0:3, 6], np.r_[3:6, 7]
    cov0[np.ix_(pc, pc)] = (range_sigma_m or vc.pseudorange_sigma_m) ** 2 * info
    cov0[np.ix_(vd, vd)] = (rate_sigma_mps or vc.range_rate_sigma_mps) ** 2 * info
    nav.start_at(x0, cov0, t_fix)
    s = v.solution
    s.prns, s.handover_s, s.rx_offset_s, s.week = prns, t_fix, nav.rx_offset, week
    s.events.append((t_fix, f"{why}: vector tracking of PRN {', '.join(map(str, prns))}"))
    for p in prns:
        c = t.channels[p]
        if c.stage == "extended":
            start_vector(v, c)
        else:  # 1 ms stages: over at the next interval boundary within a bit (`VectorSampleCloser.advance`)
            c.vector_pending = True  # its scalar loop stops steering (`VectorSampleCloser.step`)
            t.leave_batch(c)
            c.join_tries = 3
    if doppler_hz is not None:  # an assisted start: a 1 ms pull-in loop may have wandered
        nav.t_nav = t_fix  # every channel's NCOs from the first state at once
        nav.command(slots, x0)


def _ephemeris(v: VectorSampleCloser, prn: int, obs, sample_time_s: float) -> Ephemerides | None:
    decoded = [rec for ready, rec in obs.ephemeris.get(prn, []) if ready <= sample_time_s]
    rec = decoded[-1] if decoded else None
    if rec is None and v.rinex is not None:
        try:
            rec = v.rinex.select([v.tracker.signal.rinex_satellite(prn)], float(obs.rx_time_s[-1]))
        except KeyError:
            rec = None
    return rec if rec is not None and rec.health[0] == 0 else None


def start_vector(v: VectorSampleCloser, c: SampleChannel) -> None:
    """Channel ``c`` (bit-aligned) is closed by the navigation filter from now on: its
    error-output channel filter, stepped alone, hands its errors to `VectorNavigator.measure`."""
    t = v.tracker
    t.leave_batch(c)
    cfg = t.config
    T = c.coherent_ms * c.spec.code_period_s
    c.stage = "vector"
    c.filter = v.channel_filter.new()  # a copy of the configuration built once
    c.cn0_ref = max(c.cn0_dbhz, 20.0)
    c.filter.reset((1,), stage_context(cfg, T, c.cn0_ref, float(t.doppler[c.slot]), c.spec))
    c.closure = VECTOR
    c.batch = None
    c.join_tries = 3  # steps alone: its outputs go to the navigation filter, one channel at a time
    c.stage_ms = 0
    c.unlocked_ms = 0
    c.low_cn0_ms = 0
    t.shift_chips[c.slot] = t.shift_hz[c.slot] = 0.0  # its filter is new: no NCO move before it
    t.voting[c.slot] = False
    c.record.events.append((float(t.start_sample[c.slot]) / t.fs, "vector tracking"))
