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
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ...errors import ConfigError
from ...signal.constants import CA_CHIP_RATE_HZ
from .bit_stream import BIT_MS, bit_runs
from ...navigation.ephemeris import Ephemerides
from ...navigation.lnav import BITS_PER_SUBFRAME, IonoUtc, LnavMessage, decode_lnav, find_subframes

if TYPE_CHECKING:
    from ..channels import ChannelRecord

__all__ = ["ChannelTiming", "Observables", "channel_timing", "observables", "SPEED_OF_LIGHT_MPS"]

#: Speed of light, m/s (IS-GPS-200 20.3.4.3).
SPEED_OF_LIGHT_MPS = 299_792_458.0
_WEEK_S = 604_800.0
_EXTENDED = 2  # index of "extended" in receiver.channels.STAGES: bit-aligned integrations
_MAX_GAP_S = 0.025  # rows further apart are not interpolated between


@dataclass(frozen=True)
class ChannelTiming:
    """One channel's rows with a known transmit time.

    ``time_s`` (recording time, s from the first sample), ``transmit_s`` (satellite time of
    week, s), ``doppler_hz``, ``carrier_cycles`` (accumulated Doppler phase, cycles), ``cn0_dbhz``;
    ``half_cycle`` per row, True where the carrier is locked 180 degrees off (the preamble of
    the row's run came inverted); ``message`` the decoded
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


def _bit_time(run, time_s: np.ndarray, bit: int) -> float:
    """Recording time at which bit ``bit`` of a run starts (its end, past the last bit)."""
    rows = run.rows[run.bit_of_row == bit]
    if rows.size:
        return float(time_s[rows[0]])
    per_bit = np.count_nonzero(run.bit_of_row == run.bit_of_row[-1])  # rows of one bit
    return float(time_s[run.rows[-1]]) + BIT_MS * 1e-3 / per_bit


def channel_timing(record: ChannelRecord, causal: bool = True) -> ChannelTiming | None:
    """The rows of a `ChannelRecord` whose transmit time the decoded LNAV gives, or None
    when no subframe was decoded (too short, or never bit-aligned).

    ``causal``: only the rows after the first decoded subframe has arrived (as a receiver
    running in real time has them); False also dates the rows before it, from the same TOW.
    """
    col = record.column
    if not record.rows:
        return None
    time_s, code_chips = col("time_s"), col("code_phase_chips")
    runs = bit_runs(time_s, col("prompt_i"), col("coherent_ms"), col("stage") == _EXTENDED, min_bits=300)
    rows, tx, inverted, messages, ephemerides = [], [], [], [], []
    for run in runs:
        subframes = find_subframes(run.symbols)
        if not subframes:
            continue
        first = subframes[0]
        bit_tow = first.tow_s + (np.arange(run.symbols.size) - first.start) * BIT_MS * 1e-3
        keep = run.bit_of_row >= (first.start + BITS_PER_SUBFRAME if causal else 0)
        tx.append((bit_tow[run.bit_of_row] + run.ms_in_bit * 1e-3
                   + code_chips[run.rows] / CA_CHIP_RATE_HZ)[keep] % _WEEK_S)
        rows.append(run.rows[keep])
        inverted.append(np.full(int(keep.sum()), first.inverted))
        message = decode_lnav(run.symbols, record.prn)
        messages.append(message)
        ephemerides += [(_bit_time(run, time_s, bit), rec) for bit, rec in message.ephemerides]
    r = np.concatenate(rows) if rows else np.zeros(0, int)
    if r.size == 0:
        return None
    return ChannelTiming(record.prn, time_s[r], np.concatenate(tx), col("doppler_hz")[r],
                         col("carrier_phase_cycles")[r],
                         col("cn0_dbhz")[r], np.concatenate(inverted), _merge(record.prn, messages), ephemerides)


def _merge(prn: int, messages: list[LnavMessage]) -> LnavMessage:
    """One message of a channel's runs: their subframes, the last ephemeris, page 18 and week."""

    def last(name: str):
        return next((getattr(m, name) for m in reversed(messages) if getattr(m, name) is not None), None)

    return LnavMessage(prn, [s for m in messages for s in m.subframes], last("ephemeris"), last("iono_utc"),
                       last("week"))


@dataclass(frozen=True)
class Observables:
    """Observables at common receive epochs, ``(E, S)`` (NaN where a channel has none).

    ``rx_time_s`` ``(E,)`` the receiver clock at each epoch (GPS seconds of week, biased by
    the receiver clock error); ``sample_time_s`` ``(E,)`` the same instants in recording time;
    ``prn`` ``(S,)``; ``transmit_s`` satellite time of transmission; ``pseudorange_m``;
    ``doppler_hz``; ``carrier_cycles`` (RINEX sign, half cycle resolved); ``cn0_dbhz``.
    ``ephemeris`` holds each PRN's decoded records with the recording time from which each
    is known, ``iono_utc`` the first decoded page 18, ``week`` the decoded 10-bit week.
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


def _interp(t_new: np.ndarray, t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Linear interpolation at ``t_new`` between rows at most `_MAX_GAP_S` apart; NaN elsewhere."""
    k = np.searchsorted(t, t_new)
    ok = (k > 0) & (k < t.size)
    k = np.clip(k, 1, max(t.size - 1, 1))
    t0, t1 = t[k - 1], t[k]
    ok &= (t1 - t0) <= _MAX_GAP_S
    w = np.where(t1 > t0, (t_new - t0) / np.where(t1 > t0, t1 - t0, 1.0), 0.0)
    return np.where(ok, y[k - 1] + w * (y[k] - y[k - 1]), np.nan)


def observables(timings: list[ChannelTiming | None], rate_hz: float = 1.0) -> Observables:
    """Pseudorange, Doppler and carrier phase of every channel at common receive epochs.

    Parameters
    ----------
    timings
        `channel_timing` of each channel (None entries are skipped).
    rate_hz
        Epochs per second of the receiver clock (on its whole multiples of ``1 / rate_hz``).

    Raises
    ------
    ConfigError
        If no channel has a decoded transmit time, or ``rate_hz`` is not positive.
    """
    timings = [t for t in timings if t is not None and t.time_s.size > 1]
    if rate_hz <= 0:
        raise ConfigError("rate_hz", f"must be positive, got {rate_hz}")
    if not timings:
        raise ConfigError("observables", "no channel has a decoded transmit time (no LNAV subframe decoded: track "
                                         "at least ~8 s of a locked, bit-synchronised signal)")
    # Receiver clock: recording time + offset, the offset putting the first pseudoranges near 75 ms.
    first = [tm.transmit_s[0] - tm.time_s[0] for tm in timings]
    offset = float(np.round((np.median(first) + 0.075) * 1e3) / 1e3)
    t_lo = min(t.time_s[0] for t in timings) + offset
    t_hi = max(t.time_s[-1] for t in timings) + offset
    epochs = np.arange(np.ceil(t_lo * rate_hz), np.floor(t_hi * rate_hz) + 1) / rate_hz
    sample_t = epochs - offset
    prn = np.array([t.prn for t in timings])
    shape = (epochs.size, prn.size)
    tx, dop, cyc, cn0 = (np.full(shape, np.nan) for _ in range(4))
    for j, tm in enumerate(timings):
        # Unwrap the week so the interpolation never straddles the rollover.
        unwrapped = tm.transmit_s[0] + np.cumsum(np.r_[0.0, (np.diff(tm.transmit_s) + _WEEK_S / 2) % _WEEK_S
                                                       - _WEEK_S / 2])
        tx[:, j] = _interp(sample_t, tm.time_s, unwrapped)
        dop[:, j] = _interp(sample_t, tm.time_s, tm.doppler_hz)
        cyc[:, j] = -_interp(sample_t, tm.time_s, tm.carrier_cycles) + 0.5 * _interp(sample_t, tm.time_s,
                                                                                      tm.half_cycle.astype(float))
        cn0[:, j] = _interp(sample_t, tm.time_s, tm.cn0_dbhz)
    pr = SPEED_OF_LIGHT_MPS * ((epochs[:, None] - tx + _WEEK_S / 2) % _WEEK_S - _WEEK_S / 2)
    eph = {t.prn: t.ephemerides for t in timings if t.ephemerides}
    iono = next((t.message.iono_utc for t in timings if t.message.iono_utc is not None), None)
    week = next((t.message.week for t in timings if t.message.week is not None), None)
    return Observables(epochs % _WEEK_S, sample_t, prn, tx % _WEEK_S, pr, dop, cyc, cn0, eph, iono, week)
