"""GPS CNAV from a tracked L2C or L5 channel: its prompts, symbol by symbol, to messages.

An L2 CM symbol is one 20 ms CM code period (IS-GPS-200 3.3.3.1.1: 25 bit/s, rate-1/2
coded to 50 symbol/s), and every row of a channel's record
(`gnssframework.receiver.channels.ChannelRecord`) starts on a code epoch of its replica:
a row integrated over one code period (``coherent_ms`` 1) is one soft symbol, with no bit
synchronisation. An L5 I5 symbol is ten 1 ms code periods under the NH10 overlay, whose
first chip starts the symbol (IS-GPS-705 3.3.2.2: 50 bit/s coded to 100 symbols/s): the
overlay's phase is found on the run's prompts, wiped off, and ten rows summed make a symbol
(`overlay_symbols.overlay_symbols_of_run`). A run of one-period rows without a gap
(`inav_stream.symbol_runs`) is one continuous stream for
:func:`~gnssframework.navigation.cnav.decode_cnav`, which finds the symbol pairing, the
polarity and the messages; a channel that loses lock starts a new run. A message lasts 12 s
on L2C and 6 s on L5: a run shorter than that holds none.

Each message is reported with the recording time of the row that starts its first symbol
(``time_s``) and the SV time of week the ICD gives that instant (``tow_s``: six times the
TOW count, less the 12 s of the message, `cnav.CnavMessage.tow_s`). The messages of types
10, 11 and 30-37 give the channel's broadcast records (`cnav_records.cnav_records`), each
known from the end of the message that completed it.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ...errors import ConfigError
from ...navigation.cnav import L5_MESSAGE_S, MESSAGE_BITS, CnavMessage, decode_cnav
from ...navigation.cnav_records import cnav_records
from ...navigation.lnav import LnavMessage
from ...signal.spec import SignalSpec
from .inav_stream import _PULL_IN, _WEEK_S, symbol_runs
from .overlay_symbols import overlay_symbols_of_run

if TYPE_CHECKING:
    from ..channels import ChannelRecord, TrackingResult
    from .observables import ChannelTiming

__all__ = [
    "carries_cnav",
    "CnavTiming",
    "channel_cnav",
    "cnav_channel_timing",
    "message_s",
    "CNAV_COLUMNS",
    "cnav_rows",
    "write_cnav_report",
]

#: Columns of the ``track`` command's ``cnav.csv``: one row per message found.
CNAV_COLUMNS = (
    "prn",
    "time_s",
    "msg_type",
    "prn_field",
    "tow_count",
    "tow_s",
    "alert",
    "crc_ok",
    "inverted",
    "bits_hex",
)


def carries_cnav(signal: SignalSpec) -> bool:
    """Whether ``signal``'s tracked component carries GPS CNAV: L2 CM (GPS or QZSS L2C, one
    symbol a 20 ms code period) or L5 I5 (one symbol ten 1 ms code periods under its 10-chip
    overlay)."""
    sym = signal.components[0].symbol_period_s
    if signal.system not in ("G", "J") or sym is None:
        return False
    l2cm = abs(sym - 0.02) < 1e-12 and abs(signal.code_period_s - 0.02) < 1e-12
    l5i5 = (
        abs(sym - 0.01) < 1e-12
        and abs(signal.code_period_s - 1e-3) < 1e-12
        and signal.overlay_length(0) == signal.code_periods_per_symbol == 10
    )
    return l2cm or l5i5


def message_s(signal: SignalSpec) -> float:
    """How long a CNAV message lasts on ``signal``: 600 symbols (12 s on L2C, 6 s on L5)."""
    return 2 * MESSAGE_BITS * float(signal.symbol_period_s or 0.0)


@dataclass(frozen=True)
class CnavTiming:
    """What one L2C channel's CNAV gave: the messages of every run in order and, for each,
    the recording time of the row its first symbol starts (s)."""

    prn: int
    messages: list[CnavMessage]
    time_s: np.ndarray

    @property
    def failures(self) -> list[CnavMessage]:
        return [m for m in self.messages if not m.crc_ok]


def channel_cnav(record: ChannelRecord, signal: SignalSpec) -> CnavTiming:
    """Decode the CNAV of one channel tracking L2 CM or L5 I5 (`carries_cnav`), run by run."""
    if not carries_cnav(signal):
        raise ConfigError(
            "signal",
            f"PRN {record.prn}: {signal.name} carries no CNAV on its tracked component (gps-l2c and gps-l5i do)",
        )
    if not record.rows:
        return CnavTiming(record.prn, [], np.zeros(0))
    time_s = record.column("time_s")
    messages, times = [], []
    for run, symbol_rows, decoded in _decoded_runs(record, signal):
        messages += decoded
        times += [float(time_s[run[symbol_rows[m.start]]]) for m in decoded]
    return CnavTiming(record.prn, messages, np.array(times))


def _decoded_runs(record: ChannelRecord, signal: SignalSpec):
    """Per gap-free run of one-period rows: its row indices, for each symbol the index in the
    run of the row it starts on (`overlay_symbols.overlay_symbols_of_run`), and the run's
    messages (`cnav.decode_cnav`)."""
    col = record.column
    prompt_i, prompt_q = col("prompt_i"), col("prompt_q")
    for run in symbol_runs(col("time_s"), col("coherent_ms"), signal.code_period_s):
        symbols, symbol_rows = overlay_symbols_of_run(prompt_i[run], prompt_q[run], signal, record.prn)
        yield run, symbol_rows, decode_cnav(symbols, prn=record.prn, message_s=message_s(signal)).messages


def _run_epoch(messages: list[CnavMessage], period_s: float) -> tuple[int, float, bool] | None:
    """``(start, tow_s, inverted)`` of a run's first CRC-checked message (``start`` its
    first symbol), or None: without one, or where two checked messages disagree on the run's
    time (their TOWs must differ by their symbols apart times the symbol period ``period_s``:
    a CRC passed by chance is one in 2^24, a wrong pairing or a slipped symbol would show
    here)."""
    good = [m for m in messages if m.crc_ok]
    if not good:
        return None
    first = good[0]
    for m in good[1:]:
        apart = ((m.tow_s - first.tow_s) % _WEEK_S) - (m.start - first.start) * period_s
        if abs(apart) > 1e-6 or m.inverted != first.inverted:
            return None
    return first.start, first.tow_s, first.inverted


def cnav_channel_timing(record: ChannelRecord, signal: SignalSpec) -> ChannelTiming | None:
    """The rows of an L2 CM or L5 I5 channel dated from its CNAV (`channel_cnav`) as the
    `observables.ChannelTiming` the observables and fixes take; None without a dated row.

    A run of one-period rows (`inav_stream.symbol_runs`) is one symbol stream; its first
    CRC-checked message gives the SV time at the start of its first symbol,
    ``tow_s`` (six times the TOW count less the message's 12 s on L2C, 6 s on L5;
    IS-GPS-200 30.3.3.1.1.2, IS-GPS-705 20.3.3.1.1.2), on row ``start``; row ``j`` of the
    run was then sent at ``tow_s + (j - start) T`` plus its code phase (every row starts on a
    code epoch of period ``T``: 20 ms on L2 CM, 1 ms on L5). A run whose checked
    messages disagree is not dated. The half-cycle flag is the stream's polarity. The
    pull-in's rows are not measurements (their code phase is converging). The channel's
    records (`cnav_records.cnav_records` of all its runs' messages, named as ``signal``
    names the satellite) come with the recording time at which the message completing each
    ended, its ionosphere and GPS-UTC parameters as the message's ``iono_utc``, and the
    type 10 week (13 bits) as its week.
    """
    from .observables import ChannelTiming

    if not record.rows:
        return None
    timing_messages: list[CnavMessage] = []
    ready_s: list[float] = []  # recording time at which each message has ended
    col = record.column
    time_s, code_chips, stage = col("time_s"), col("code_phase_chips"), col("stage")
    period, duration_s = signal.code_period_s, message_s(signal)
    rows, tx, half, starts = [], [], [], []
    for run, symbol_rows, messages in _decoded_runs(record, signal):
        timing_messages += messages
        ready_s += [float(time_s[run[symbol_rows[m.start]]]) + duration_s for m in messages]
        epoch = _run_epoch(messages, float(signal.symbol_period_s or period))
        if epoch is None:
            continue
        first_symbol, tow, inverted = epoch
        start = int(symbol_rows[first_symbol])
        keep = stage[run] != _PULL_IN
        k = (np.arange(run.size) - start)[keep]
        if k.size < 2:
            continue
        rows.append(run[keep])
        tx.append((tow + k * period + code_chips[run[keep]] / signal.chip_rate_hz) % _WEEK_S)
        half.append(np.full(k.size, inverted))
        first = np.zeros(k.size, bool)
        first[0] = True
        starts.append(first)
    if not rows:
        return None
    r = np.concatenate(rows)
    band = "L5" if abs(message_s(signal) - L5_MESSAGE_S) < 1e-9 else "L2"
    decoded = cnav_records(timing_messages, signal.rinex_satellite(record.prn), band)
    ephemerides = [(ready_s[k], rec) for k, rec in decoded.records]
    return ChannelTiming(
        record.prn,
        time_s[r],
        np.concatenate(tx),
        col("doppler_hz")[r],
        col("carrier_phase_cycles")[r],
        col("cn0_dbhz")[r],
        np.concatenate(half),
        LnavMessage(
            record.prn, [], ephemerides[-1][1] if ephemerides else None, decoded.iono, decoded.week, week_bits=13
        ),
        ephemerides,
        np.concatenate(starts),
        np.ones(r.size, bool),
    )


def cnav_rows(timing: CnavTiming) -> list[dict]:
    """The rows of ``cnav.csv`` (`CNAV_COLUMNS`) of one channel."""
    return [
        {
            "prn": timing.prn,
            "time_s": f"{t:.9f}",
            "msg_type": m.msg_type,
            "prn_field": m.prn,
            "tow_count": m.tow_count,
            "tow_s": f"{m.tow_s:.0f}",
            "alert": int(m.alert),
            "crc_ok": int(m.crc_ok),
            "inverted": int(m.inverted),
            "bits_hex": m.hex,
        }
        for m, t in zip(timing.messages, timing.time_s)
    ]


def write_cnav_report(
    out_dir: str | Path, tracking: TrackingResult, signal: SignalSpec
) -> tuple[Path, list[CnavTiming]]:
    """Decode every channel of ``tracking`` (a `TrackingResult` of L2C) and write
    ``out_dir/cnav.csv`` (`CNAV_COLUMNS`, one row per message); the path and each
    channel's `CnavTiming`."""
    from ...io.files import write_rows_csv

    timings = [channel_cnav(ch, signal) for _, ch in sorted(tracking.channels.items())]
    rows = (r for timing in timings for r in cnav_rows(timing))
    return write_rows_csv(Path(out_dir) / "cnav.csv", CNAV_COLUMNS, rows), timings
