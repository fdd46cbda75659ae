"""SBAS L1 messages from a tracked ``sbas-l1`` channel: its prompts, symbol by symbol, to
250-bit messages (:mod:`~gnssframework.navigation.sbas_message`).

An SBAS L1 symbol is 2 ms, two code periods (RTCA DO-229 Appendix A: 500 symbols/s). After bit
synchronisation the tracker integrates whole symbols (``coherent_ms`` 2 code periods, the
default `inav_stream.coherent_periods` gives ``sbas-l1``), each row starting on a symbol
edge: such a row's in-phase prompt is one soft symbol. A run of such rows without a gap
(consecutive rows one symbol apart, half a symbol of slack; `inav_stream.symbol_runs`) is
one stream for :func:`~gnssframework.navigation.sbas_message.find_messages`; the pull-in's
one-period rows (before the bit edge is known) and a channel that loses lock end a run.

A message's time is the recording time (``time_s``) of the row holding its first bit's
first symbol: when the replica's symbol that carries it began. ``sbas.csv``'s ``content``
column says in one line what each message holds (`sbas_content.describe`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ...errors import ConfigError
from ...navigation.sbas_content import decode_content, describe
from ...navigation.sbas_message import MESSAGE_SYMBOLS, SbasMessage, find_messages
from ...signal.spec import SignalSpec
from .inav_stream import symbol_runs

if TYPE_CHECKING:
    from ..channels import ChannelRecord, TrackingResult

__all__ = [
    "carries_sbas",
    "SbasChannel",
    "channel_sbas",
    "SBAS_COLUMNS",
    "sbas_rows",
    "write_sbas_csv",
    "write_sbas_report",
]

#: Columns of the ``track`` command's ``sbas.csv``: one row per message read.
SBAS_COLUMNS = ("prn", "time_s", "row", "preamble", "message_type", "crc_ok", "inverted", "message_hex", "content")


def carries_sbas(signal: SignalSpec) -> bool:
    """Whether ``signal`` is SBAS L1: system ``S``, 2 ms symbols of two 1 ms code periods."""
    sym = signal.components[0].symbol_period_s
    return (
        signal.system == "S"
        and sym is not None
        and abs(sym - 0.002) < 1e-12
        and signal.code_periods_per_symbol == 2
        and abs(signal.code_period_s - 1e-3) < 1e-12
    )


@dataclass(frozen=True)
class SbasChannel:
    """What one ``sbas-l1`` channel's symbols gave: ``messages`` (every message of each
    run's grid, CRC good or not) with ``rows`` (the record row of each one's first symbol)
    and ``times_s`` (that row's ``time_s``); ``failures`` one line per message whose CRC or
    preamble failed; ``symbols`` the one-symbol rows the runs held."""

    prn: int
    messages: list[SbasMessage]
    rows: np.ndarray
    times_s: np.ndarray
    failures: list[str]
    symbols: int

    @property
    def good(self) -> list[SbasMessage]:
        return [m for m in self.messages if m.crc_ok]


def channel_sbas(record: ChannelRecord, signal: SignalSpec) -> SbasChannel:
    """Read the SBAS messages of one channel tracking ``sbas-l1``, run by run (module text).

    Raises
    ------
    ConfigError
        ``signal`` is not SBAS L1, or no run of the channel holds one message's symbols
        (500, 1 s): one line naming the PRN and the symbols it had.
    """
    if not carries_sbas(signal):
        raise ConfigError("signal", f"{signal.name} carries no SBAS L1 message (sbas-l1 does)")
    per_symbol = signal.code_periods_per_symbol
    period = float(signal.symbol_period_s or 0.002)  # carries_sbas: 2 ms
    runs: list[np.ndarray] = []
    if record.rows:
        col = record.column
        one_symbol = (col("coherent_ms") == per_symbol).astype(int)
        runs = symbol_runs(col("time_s"), one_symbol, period)
    symbols = sum(r.size for r in runs)
    longest = max((r.size for r in runs), default=0)
    if longest < MESSAGE_SYMBOLS:
        raise ConfigError(
            "symbols",
            f"SBAS PRN {record.prn}: its longest gap-free run of 2 ms symbols is {longest} "
            f"({symbols} in all); a message needs {MESSAGE_SYMBOLS} (1 s of rows of one whole symbol each, "
            "--coherent-ms-track 2, the default): no message can be read",
        )
    time_s, prompt = record.column("time_s"), record.column("prompt_i")
    messages: list[SbasMessage] = []
    rows, failures = [], []
    for run in runs:
        if run.size < MESSAGE_SYMBOLS:
            continue
        found, bad = find_messages(prompt[run])
        messages += found
        rows += [int(run[m.start]) for m in found]
        failures += [f"PRN {record.prn}: {line} of a run from {time_s[run[0]]:.3f} s" for line in bad]
    r = np.array(rows, dtype=int)
    return SbasChannel(record.prn, messages, r, time_s[r] if r.size else np.zeros(0), failures, symbols)


def sbas_rows(channel: SbasChannel) -> list[dict]:
    """The rows of ``sbas.csv`` (`SBAS_COLUMNS`) of one channel: one per message read."""
    return [
        {
            "prn": channel.prn,
            "time_s": f"{t:.9f}",
            "row": int(r),
            "preamble": f"0x{m.preamble:02X}",
            "message_type": m.message_type,
            "crc_ok": int(m.crc_ok),
            "inverted": int(m.inverted),
            "message_hex": m.hex,
            "content": describe(decode_content(m.bits)) if m.crc_ok else "",
        }
        for m, r, t in zip(channel.messages, channel.rows, channel.times_s)
    ]


def write_sbas_csv(out_dir: str | Path, channels: list[SbasChannel]) -> Path:
    """``out_dir/sbas.csv`` (`SBAS_COLUMNS`, one row per message) of ``channels``."""
    from ...io.files import write_rows_csv

    return write_rows_csv(Path(out_dir) / "sbas.csv", SBAS_COLUMNS, (row for c in channels for row in sbas_rows(c)))


def write_sbas_report(
    out_dir: str | Path, tracking: TrackingResult, signal: SignalSpec
) -> tuple[Path, list[SbasChannel], list[str]]:
    """Read every channel of ``tracking`` (a `TrackingResult` of ``sbas-l1``) and write
    ``out_dir/sbas.csv`` (`write_sbas_csv`); the path, each channel read, and one line per
    channel that could not be (too few symbols: `channel_sbas`)."""
    channels, notes = [], []
    for _, ch in sorted(tracking.channels.items()):
        try:
            channels.append(channel_sbas(ch, signal))
        except ConfigError as exc:
            notes.append(exc.detail)
    return write_sbas_csv(out_dir, channels), channels, notes
