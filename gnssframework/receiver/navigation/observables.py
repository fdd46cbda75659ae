"""Observables of tracked channels: transmit time, pseudorange, Doppler and carrier phase.

Every row of a channel's record (`gnssframework.receiver.channels.ChannelRecord`) starts
on a code epoch of its replica, at sample ``time_s * fs``, with the replica ``code_phase_chips``
past that epoch. Once LNAV is decoded (`lnav.find_subframes` on its bits,
`bit_stream.bit_runs`), the epoch's transmit time is known: the HOW's TOW gives the start of
the subframe, and the row is ``20 ms x (bits since) + 1 ms x (code periods into its bit)``
later; the code phase adds ``code_phase_chips / 1.023 MHz`` (a chip is 1/1.023 MHz of
satellite time, IS-GPS-200 3.3.1.1). This is the satellite's own time (``t_SV``, before its
clock correction), as a receiver measures it (IS-GPS-200 20.3.3.3.3.1).

At common receive epochs (a grid of the receiver clock, rate a parameter) each channel's
transmit time is interpolated linearly between its rows (10-20 ms apart: the curvature of
a range over 20 ms is below a millimetre), and

    pseudorange = c (t_rx - t_SV),

with the receiver clock ``t_rx`` = sample time + an offset chosen so the first epoch's
pseudoranges are near 75 ms (the receiver clock bias, estimated by the position solution,
absorbs the rest). Doppler is the channel's carrier NCO frequency relative to the IF, and the carrier
phase the NCO's accumulated Doppler phase with the sign of RINEX (phase grows with range),
plus half a cycle where the preamble came inverted (the Costas loop locked 180 degrees
off: IS-GPS-200 sends the preamble upright).

A channel that loses lock and locks again starts a new run of bits. The new run is dated
from the channel's last dated row while no subframe of its own has arrived (for gaps up to
`MAX_BRIDGE_S`): its satellite time has advanced by the elapsed receive time times
``1 + D / f_L1`` (the Doppler ``D`` of that row; receiver clock drift included), and its
first bit edge is the nearest whole 20 ms of satellite time (LNAV bits start on them), so
the bridge holds while the prediction is within 10 ms; its rows are used once the run has
held for 50 bits (1 s), as a false lock seldom does. Until the run's own preamble is
found the carrier's polarity is unknown. The observables flag both, per RINEX 3.04
(section 5.3): bit 0 of ``lli`` on the first epoch of every run after a channel's first
(lost lock: cycle slip possible), bit 1 on epochs whose carrier has a half-cycle ambiguity.

An assisted vector start (`vector_tracking.Assistance`) decodes no LNAV before its channels
close: `assisted_timing` dates a vector channel's rows from the replica's transmit time the
tracker resolved (from the approximate position and start time) instead. A replica's
transmit time modulo 1 ms is its code phase (a C/A period is 1 ms of satellite time), so a
row's time is its code phase plus the whole milliseconds nearest the tracker's time carried
back to it; the receiver clock is then the start time plus recording time
(`observables`' ``rx_offset_s``). Once a subframe arrives on those rows, its TOW checks the
dating (``tow_offset_s``): the start time's error, in whole bits (a misresolved millisecond
is refused earlier, by the assisted fix's residuals).

The chip rate, the carrier frequency (code and satellite-time Doppler) and the code period
are read from the channels' `SignalSpec` (GPS L1 C/A by default); the bit structure is
LNAV's, which QZSS L1 C/A shares.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ...errors import ConfigError
from ...signal.gps_l1ca import GPS_L1CA
from ...signal.navdata import data_bit_period_s
from ...signal.spec import SignalSpec
from .bit_stream import bit_ms, bit_runs
from ...navigation.ephemeris import Ephemerides
from ...navigation.bds_iono import BdsKlobuchar
from ...navigation.inav_params import InavIonoTime, merge_iono_time
from ...navigation.lnav import BITS_PER_SUBFRAME, IonoUtc, LnavMessage, decode_lnav, find_subframes

if TYPE_CHECKING:
    from ..channels import ChannelRecord

__all__ = [
    "ChannelTiming",
    "Observables",
    "channel_timing",
    "assisted_timing",
    "observables",
    "SPEED_OF_LIGHT_MPS",
    "MAX_BRIDGE_S",
    "LLI_LOST_LOCK",
    "LLI_HALF_CYCLE",
    "TOW_TOLERANCE_S",
]

#: Speed of light, m/s (IS-GPS-200 20.3.4.3).
SPEED_OF_LIGHT_MPS = 299_792_458.0
_WEEK_S = 604_800.0
_EXTENDED = 2  # index of "extended" in receiver.channels.STAGES: bit-aligned integrations
_VECTOR = 4  # index of "vector" in receiver.channels.STAGES: closed by the navigation filter
#: Largest difference (s) between a decoded TOW and an assisted transmit time taken as agreement
#: (both put the subframe's start on a whole 20 ms: any disagreement is a whole bit or more).
TOW_TOLERANCE_S = 1e-3
_MAX_GAP_S = 0.025  # rows further apart are not interpolated between
#: Longest gap (s) across which a run is dated from the previous one: receiver clock drift
#: and Doppler error together stay under 1e-5, so the prediction's error is well under 10 ms.
MAX_BRIDGE_S = 300.0
_BRIDGE_S = 1.0  # a bridged run is dated from its second second on (its lock has held for 1 s)
#: RINEX 3.04 loss-of-lock indicator bits (section 5.3).
LLI_LOST_LOCK, LLI_HALF_CYCLE = 1, 2


@dataclass(frozen=True)
class ChannelTiming:
    """One channel's rows with a known transmit time.

    ``time_s`` (recording time, s from the first sample), ``transmit_s`` (satellite time of
    week, s), ``doppler_hz``, ``carrier_cycles`` (accumulated Doppler phase, cycles), ``cn0_dbhz``;
    ``half_cycle`` per row, True where the carrier is locked 180 degrees off (the preamble of
    the row's run came inverted); ``arc_start`` per row, True on the first row of each run;
    ``polarity_known`` per row, False before the run's own preamble has arrived (a run
    dated from the previous one); ``message`` the decoded
    LNAV; ``ephemerides`` each decoded ephemeris with the recording time at which its last
    subframe had arrived.
    """

    prn: int
    time_s: np.ndarray
    transmit_s: np.ndarray
    doppler_hz: np.ndarray
    carrier_cycles: np.ndarray
    cn0_dbhz: np.ndarray
    half_cycle: np.ndarray
    message: LnavMessage
    ephemerides: list[tuple[float, Ephemerides]]
    arc_start: np.ndarray | None = None
    polarity_known: np.ndarray | None = None
    #: `assisted_timing` only: the decoded TOW minus the assisted time at the start of the first
    #: subframe found on the rows (None: none found).
    tow_offset_s: float | None = None
    #: Galileo E1-B only (`inav_stream.inav_channel_timing`): the NeQuick, GST-UTC and GGTO decoded.
    inav_iono_time: InavIonoTime | None = None
    #: BeiDou B1I only: D1's Klobuchar coefficients (`bds_iono.BdsKlobuchar`).
    bds_iono: BdsKlobuchar | None = None


def _bit_time(run, time_s: np.ndarray, bit: int, bit_s: float) -> float:
    """Recording time at which bit ``bit`` (``bit_s`` long) of a run starts (its end, past the last bit)."""
    rows = run.rows[run.bit_of_row == bit]
    if rows.size:
        return float(time_s[rows[0]])
    per_bit = np.count_nonzero(run.bit_of_row == run.bit_of_row[-1])  # rows of one bit
    return float(time_s[run.rows[-1]]) + bit_s / per_bit


def channel_timing(record: ChannelRecord, causal: bool = True, signal: SignalSpec = GPS_L1CA) -> ChannelTiming | None:
    """The rows of a `ChannelRecord` whose transmit time the decoded LNAV gives, or None
    when no subframe was decoded (too short, or never bit-aligned).

    ``causal``: only the rows after the first decoded subframe has arrived (as a receiver
    running in real time has them); False also dates the rows before it, from the same TOW.
    ``signal``: the tracked signal (an LNAV-format one: GPS or QZSS L1 C/A).
    """
    col = record.column
    if not record.rows:
        return None
    time_s, code_chips = col("time_s"), col("code_phase_chips")
    stage = col("stage")
    continued = _continued_vector_rows(stage)
    bit_s = data_bit_period_s(signal)
    bridge_bits = round(_BRIDGE_S / bit_s)
    runs = bit_runs(
        time_s,
        col("prompt_i"),
        col("coherent_ms"),
        (stage == _EXTENDED) | continued,
        min_bits=bridge_bits + 1,
        signal=signal,
    )
    doppler = col("doppler_hz")
    rows, tx, inverted, known, messages, ephemerides = [], [], [], [], [], []
    for run in runs:
        subframes = find_subframes(run.symbols)
        edge_tow = _bridge(rows, tx, time_s, doppler, run.rows[0], code_chips[run.rows[0]], signal)
        if subframes:
            first = subframes[0]
            own = first.tow_s - first.start * bit_s  # satellite time of the run's first bit edge
            arrived = first.start + BITS_PER_SUBFRAME if causal else 0
            # The run's own TOW rules; the bridge dates its rows before the subframe arrives.
            agree = edge_tow is not None and abs((own - edge_tow + _WEEK_S / 2) % _WEEK_S - _WEEK_S / 2) < bit_s / 2
            edge_tow, keep = own, run.bit_of_row >= (0 if agree else arrived)
            polarity = run.bit_of_row[keep] >= arrived
            is_inverted = first.inverted
        elif edge_tow is not None:
            keep = run.bit_of_row >= bridge_bits
            polarity, is_inverted = np.zeros(int(keep.sum()), dtype=bool), False
        else:
            continue
        bit_tow = edge_tow + np.arange(run.symbols.size) * bit_s
        tx.append(
            (
                bit_tow[run.bit_of_row]
                + run.ms_in_bit * signal.code_period_s
                + code_chips[run.rows] / signal.chip_rate_hz
            )[keep]
            % _WEEK_S
        )
        rows.append(run.rows[keep])
        inverted.append(np.full(int(keep.sum()), is_inverted))
        known.append(polarity)
        if subframes:
            message = decode_lnav(run.symbols, record.prn)
            messages.append(message)
            ephemerides += [(_bit_time(run, time_s, bit, bit_s), rec) for bit, rec in message.ephemerides]
    r = np.concatenate(rows) if rows else np.zeros(0, int)
    if r.size == 0:
        return None
    starts = np.zeros(r.size, dtype=bool)
    starts[np.cumsum([0] + [p.size for p in rows[:-1]])] = True
    # No carrier phase is tracked after the hand-over (a vector FLL): its NCO phase is no carrier phase.
    carrier = np.where(continued[r], np.nan, col("carrier_phase_cycles")[r])
    return ChannelTiming(
        record.prn,
        time_s[r],
        np.concatenate(tx),
        doppler[r],
        carrier,
        col("cn0_dbhz")[r],
        np.concatenate(inverted),
        _merge(record.prn, messages),
        ephemerides,
        starts,
        np.concatenate(known),
    )


def _continued_vector_rows(stage: np.ndarray) -> np.ndarray:
    """``(N,)`` True on the ``vector`` rows of a stretch that begins right after an
    ``extended`` row: a channel handed over from its bit-aligned scalar loop, whose rows go
    on bit by bit (same interval, same code epochs). A stretch that starts afresh (a
    channel joined after re-acquisition, or closed from a 1 ms stage) may start mid-bit:
    it is not continued."""
    vector = stage == _VECTOR
    start = np.flatnonzero(vector & ~np.r_[False, vector[:-1]])  # first row of each vector stretch
    good = start[(start > 0) & (stage[np.maximum(start - 1, 0)] == _EXTENDED)]
    stretch = np.cumsum(np.r_[False, vector[:-1]] != vector)  # a label per stretch of equal kind
    return vector & np.isin(stretch, stretch[good])


def _bridge(
    rows: list[np.ndarray],
    tx: list[np.ndarray],
    time_s: np.ndarray,
    doppler_hz: np.ndarray,
    first_row: int,
    code_chips: float,
    signal: SignalSpec = GPS_L1CA,
) -> float | None:
    """Satellite time of a new run's first bit edge predicted from the channel's last dated
    row (see the module text), or None without one within `MAX_BRIDGE_S`."""
    last = next((k for k in range(len(rows) - 1, -1, -1) if rows[k].size), None)
    if last is None:
        return None
    last_row, last_tx = int(rows[last][-1]), float(tx[last][-1])
    elapsed_s = float(time_s[first_row] - time_s[last_row])
    if not 0.0 < elapsed_s <= MAX_BRIDGE_S:
        return None
    predicted = (
        last_tx + elapsed_s * (1.0 + doppler_hz[last_row] / signal.carrier_freq_hz) - code_chips / signal.chip_rate_hz
    )
    bit_s = data_bit_period_s(signal)
    return float(np.round(predicted / bit_s) * bit_s)


def assisted_timing(
    record: ChannelRecord, end_time_s: float, end_transmit_s: float, signal: SignalSpec = GPS_L1CA
) -> ChannelTiming | None:
    r"""The vector-tracked rows of a channel closed by an assisted start, dated from the
    replica's transmit time ``end_transmit_s`` (s of week) at recording time ``end_time_s``
    after its last row (see the module text); None without two such rows.

    The rows are the record's last unbroken stretch of the ``vector`` stage. Row ``k``'s
    transmit time is :math:`t_k = T\,\mathrm{round}((\tilde t_k - p_k / f_c) / T) + p_k / f_c`
    with :math:`p_k` its code phase (chips), :math:`f_c` the chip rate, :math:`T` the code
    period (1 ms for L1 C/A; all three ``signal``'s) and
    :math:`\tilde t_k = t_{end} - (\tau_{end} - \tau_k)(1 + D_k / f_{L1})` the end's time
    carried back at the row's Doppler (satellite time runs at :math:`1 + D/f_{L1}` of
    receive time, IS-GPS-200 3.3.1.1; the error over a minute is microseconds). Carrier
    phase carries the half-cycle flag (no preamble has fixed its polarity).
    """
    if not record.rows:
        return None
    stage = record.column("stage")
    other = np.flatnonzero(stage != _VECTOR)
    rows = np.arange(other[-1] + 1 if other.size else 0, stage.size)  # empty when the last row is not vector
    if rows.size < 2:
        return None
    time_s, chips = record.column("time_s")[rows], record.column("code_phase_chips")[rows]
    doppler = record.column("doppler_hz")[rows]
    sub_ms_s = chips / signal.chip_rate_hz
    approx = end_transmit_s - (end_time_s - time_s) * (1.0 + doppler / signal.carrier_freq_hz)
    period_s = signal.code_period_s
    tx = np.round((approx - sub_ms_s) * (1.0 / period_s)) * period_s + sub_ms_s
    n = rows.size
    starts = np.zeros(n, dtype=bool)
    starts[0] = True
    return ChannelTiming(
        record.prn,
        time_s,
        tx % _WEEK_S,
        doppler,
        record.column("carrier_phase_cycles")[rows],
        record.column("cn0_dbhz")[rows],
        np.zeros(n, dtype=bool),
        LnavMessage(record.prn, [], None, None, None),
        [],
        starts,
        np.zeros(n, dtype=bool),
        _tow_offset(tx, record.column("prompt_i")[rows], record.column("coherent_ms")[rows], signal),
    )


def _tow_offset(
    tx_s: np.ndarray, prompt_i: np.ndarray, coherent_ms: np.ndarray, signal: SignalSpec = GPS_L1CA
) -> float | None:
    """The decoded TOW minus the assisted time at the start of the first subframe found in
    the rows' bits (rows summed into ``signal``'s data bits, 20 ms on L1 C/A, by their transmit
    times; a bit not wholly covered is a zero symbol, which fails parity), or None."""
    bit_s = data_bit_period_s(signal)
    # Each row's bit: from its transmit time at mid-interval, clear of the bit edges it starts on.
    bit = np.floor((tx_s + 0.5 * coherent_ms * 1e-3) / bit_s).astype(np.int64)
    first = int(bit[0])
    k = bit - first
    symbols = np.bincount(k, weights=prompt_i)
    covered = np.bincount(k, weights=coherent_ms.astype(float))
    symbols[covered != bit_ms(signal)] = 0.0
    subframes = find_subframes(symbols)
    if not subframes:
        return None
    sub = subframes[0]
    offset = sub.tow_s - (first + sub.start) * bit_s
    return float((offset + _WEEK_S / 2) % _WEEK_S - _WEEK_S / 2)


def _merge(prn: int, messages: list[LnavMessage]) -> LnavMessage:
    """One message of a channel's runs: their subframes, the last ephemeris, page 18 and week."""

    def last(name: str):
        return next((getattr(m, name) for m in reversed(messages) if getattr(m, name) is not None), None)

    bits = next((m.week_bits for m in reversed(messages) if m.week is not None), 10)
    return LnavMessage(
        prn,
        [s for m in messages for s in m.subframes],
        last("ephemeris"),
        last("iono_utc"),
        last("week"),
        week_bits=bits,
    )


@dataclass(frozen=True)
class Observables:
    """Observables at common receive epochs, ``(E, S)`` (NaN where a channel has none).

    ``rx_time_s`` ``(E,)`` the receiver clock at each epoch (GPS seconds of week, biased by
    the receiver clock error); ``sample_time_s`` ``(E,)`` the same instants in recording time;
    ``prn`` ``(S,)``; ``transmit_s`` satellite time of transmission; ``pseudorange_m``;
    ``doppler_hz``; ``carrier_cycles`` (RINEX sign, half cycle resolved); ``cn0_dbhz``.
    ``ephemeris`` holds each PRN's decoded records with the recording time from which each
    is known, ``iono_utc`` the first decoded page 18, ``week`` the decoded week's low
    ``week_bits`` bits (LNAV's 10, CNAV's 13; `fixes.full_week` makes it whole).
    ``lli`` ``(E, S)`` the RINEX loss-of-lock bits of the carrier phase (`LLI_LOST_LOCK`,
    `LLI_HALF_CYCLE`; None: not known, written blank). Of an assisted start
    (`assisted_timing`), ``iono_utc`` is the assistance's and ``week`` None. ``galileo``: the
    NeQuick, GST-UTC and GGTO decoded from I/NAV (`inav_params.InavIonoTime`, each part
    from the first channel, in ``timings`` order, that has it; None without I/NAV).
    ``bds_iono``: BeiDou's Klobuchar coefficients from D1 (`bds_iono.BdsKlobuchar`, the first
    channel's that has them; None without).
    """

    rx_time_s: np.ndarray
    sample_time_s: np.ndarray
    prn: np.ndarray
    transmit_s: np.ndarray
    pseudorange_m: np.ndarray
    doppler_hz: np.ndarray
    carrier_cycles: np.ndarray
    cn0_dbhz: np.ndarray
    ephemeris: dict[int, list[tuple[float, Ephemerides]]]
    iono_utc: IonoUtc | None
    week: int | None
    lli: np.ndarray | None = None
    galileo: InavIonoTime | None = None
    week_bits: int = 10
    bds_iono: BdsKlobuchar | None = None


def _interp(t_new: np.ndarray, t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Linear interpolation at ``t_new`` between rows at most `_MAX_GAP_S` apart; NaN elsewhere."""
    k = np.searchsorted(t, t_new)
    ok = (k > 0) & (k < t.size)
    k = np.clip(k, 1, max(t.size - 1, 1))
    t0, t1 = t[k - 1], t[k]
    ok &= (t1 - t0) <= _MAX_GAP_S
    w = np.where(t1 > t0, (t_new - t0) / np.where(t1 > t0, t1 - t0, 1.0), 0.0)
    return np.where(ok, y[k - 1] + w * (y[k] - y[k - 1]), np.nan)


def observables(
    timings: list[ChannelTiming | None],
    rate_hz: float = 1.0,
    rx_offset_s: float | None = None,
    iono_utc: IonoUtc | None = None,
) -> Observables:
    """Pseudorange, Doppler and carrier phase of every channel at common receive epochs.

    Parameters
    ----------
    timings
        `channel_timing` of each channel (None entries are skipped).
    rate_hz
        Epochs per second of the receiver clock (on its whole multiples of ``1 / rate_hz``).
    rx_offset_s
        The receiver clock at the recording's first sample (GPS s of week), when known (an
        assisted start's start time); None: chosen to put the first pseudoranges near 75 ms.
    iono_utc
        Klobuchar coefficients when no channel decoded page 18 (an assistance's).

    Raises
    ------
    ConfigError
        If no channel has a decoded transmit time, or ``rate_hz`` is not positive.
    """
    timings = [t for t in timings if t is not None and t.time_s.size > 1]
    if rate_hz <= 0:
        raise ConfigError("rate_hz", f"must be positive, got {rate_hz}")
    if not timings:
        raise ConfigError(
            "observables",
            "no channel has a decoded transmit time (no LNAV subframe decoded: track "
            "at least ~8 s of a locked, bit-synchronised signal)",
        )
    # Receiver clock: recording time + offset, the offset putting the first pseudoranges near 75 ms.
    if rx_offset_s is None:
        first = [tm.transmit_s[0] - tm.time_s[0] for tm in timings]
        offset = float(np.round((np.median(first) + 0.075) * 1e3) / 1e3)
    else:
        offset = float(rx_offset_s)
    t_lo = min(t.time_s[0] for t in timings) + offset
    t_hi = max(t.time_s[-1] for t in timings) + offset
    epochs = np.arange(np.ceil(t_lo * rate_hz), np.floor(t_hi * rate_hz) + 1) / rate_hz
    sample_t = epochs - offset
    prn = np.array([t.prn for t in timings])
    shape = (epochs.size, prn.size)
    tx, dop, cyc, cn0 = (np.full(shape, np.nan) for _ in range(4))
    lli = np.zeros(shape, dtype=int)
    for j, tm in enumerate(timings):
        # Unwrap the week so the interpolation never straddles the rollover.
        unwrapped = tm.transmit_s[0] + np.cumsum(
            np.r_[0.0, (np.diff(tm.transmit_s) + _WEEK_S / 2) % _WEEK_S - _WEEK_S / 2]
        )
        tx[:, j] = _interp(sample_t, tm.time_s, unwrapped)
        dop[:, j] = _interp(sample_t, tm.time_s, tm.doppler_hz)
        cyc[:, j] = -_interp(sample_t, tm.time_s, tm.carrier_cycles) + 0.5 * _interp(
            sample_t, tm.time_s, tm.half_cycle.astype(float)
        )
        cn0[:, j] = _interp(sample_t, tm.time_s, tm.cn0_dbhz)
        lli[:, j] = _loss_of_lock(sample_t, tm, np.isfinite(tx[:, j]))
    pr = SPEED_OF_LIGHT_MPS * ((epochs[:, None] - tx + _WEEK_S / 2) % _WEEK_S - _WEEK_S / 2)
    eph = {t.prn: t.ephemerides for t in timings if t.ephemerides}
    iono = next((t.message.iono_utc for t in timings if t.message.iono_utc is not None), iono_utc)
    dated = next((t.message for t in timings if t.message.week is not None), None)
    week, week_bits = (None, 10) if dated is None else (dated.week, dated.week_bits)
    galileo = None
    for t in reversed(timings):  # the first channel's parts win
        galileo = merge_iono_time(galileo, t.inav_iono_time)
    bds = next((t.bds_iono for t in timings if t.bds_iono is not None), None)
    return Observables(
        epochs % _WEEK_S, sample_t, prn, tx % _WEEK_S, pr, dop, cyc, cn0, eph, iono, week, lli, galileo, week_bits, bds
    )


def _loss_of_lock(sample_t: np.ndarray, tm: ChannelTiming, valid: np.ndarray) -> np.ndarray:
    """RINEX LLI bits ``(E,)`` of one channel at the epochs (see the module text): lost lock
    on its first valid epoch after an epoch without it or in a later run than the last
    valid one's; half cycle where an interpolated row's polarity is not yet known."""
    out = np.zeros(sample_t.size, dtype=int)
    starts = tm.arc_start if tm.arc_start is not None else np.eye(1, tm.time_s.size, dtype=bool)[0]
    arc = np.searchsorted(tm.time_s[starts], sample_t, side="right")  # runs begun by each epoch
    e = np.flatnonzero(valid)
    if e.size > 1:
        lost = (np.diff(e) > 1) | (np.diff(arc[e]) != 0)
        out[e[1:][lost]] |= LLI_LOST_LOCK
    if tm.polarity_known is not None:
        unknown = _interp(sample_t, tm.time_s, (~tm.polarity_known).astype(float)) > 0
        out[valid & unknown] |= LLI_HALF_CYCLE
    return out
