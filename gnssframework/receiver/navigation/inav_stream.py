"""Galileo I/NAV from a tracked E1-B channel: its prompts, symbol by symbol, to pages and GST.

An E1-B symbol is one 4 ms code period (Galileo OS SIS ICD 4.3.2, 250 symbol/s), and
every row of a channel's record (`gnssframework.receiver.channels.ChannelRecord`) starts
on a code epoch of its replica: a row integrated over one code period (``coherent_ms`` 1,
whatever the stage) is one soft symbol, with no bit synchronisation. A run of such rows
without a gap (consecutive rows one code period apart, half a period of slack) is one
stream for :func:`~gnssframework.navigation.inav.decode_inav`; a channel that loses lock
starts a new run.

The GST a page carries (word type 0 or 5: WN, TOW) is the satellite time at the start of
that page's even part (ICD 5.1.2), the first symbol of the row the decoder names; the row
``k`` rows later started transmitting ``k x 4 ms`` after it, and its replica was
``code_phase_chips / chip rate`` further on (a chip is 1/1.023 MHz of satellite time), so

    t_tx(row) = TOW + (row - start) x 4 ms + code_phase_chips / 1.023e6 s

(`InavTiming.transmit_s`: satellite time of week, before the clock correction, as
`observables.channel_timing` gives it for LNAV). Rows of runs without a decoded GST are
not dated.

F/NAV on E5a-I (`carries_fnav`) is read the same way: a symbol is twenty 1 ms rows under
the CS20_1 overlay, wiped off and summed (`overlay_symbols.overlay_symbols_of_run`), the
pages are decoded by :func:`~gnssframework.navigation.fnav.decode_fnav`, and a page's GST is
the satellite time at its first sync symbol, on the row that symbol starts on; rows are
then dated every 1 ms from it.

BeiDou D1 on B1I (`carries_d1`) the same again: a bit is twenty 1 ms rows under NH20,
subframes by :func:`~gnssframework.navigation.d1nav.decode_d1`, a subframe's SOW is the BDT
at its first bit, taken to GPS time (+14 s, week + 1356) before the rows are dated.
D2 on a GEO satellite's B1I (`carries_d2`) is read as SBAS L1's symbols are: after bit
synchronisation each row is one whole 2 ms bit (``coherent_ms`` 2), its in-phase prompt the
soft bit; a run of such rows goes to :func:`~gnssframework.navigation.d2nav.decode_d2`, and
the rows are dated every 2 ms from a subframe's start (its frame's SOW + 0.6 s a subframe).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ...errors import ConfigError
from ...navigation import d1nav, d2nav, fnav
from ...navigation.ephemeris import Ephemerides
from ...navigation.inav import PAGE_SYMBOLS, InavMessage, decode_inav
from ...navigation.bds_iono import BdsKlobuchar
from ...navigation.inav_params import InavIonoTime, merge_iono_time
from ...navigation.lnav import LnavMessage
from ...signal.spec import SignalSpec
from ..channels.signal_settings import coherent_periods
from .overlay_symbols import overlay_symbols_of_run

if TYPE_CHECKING:
    from ..channels import ChannelRecord, TrackingResult
    from .observables import ChannelTiming

__all__ = [
    "carries_inav",
    "carries_fnav",
    "carries_d1",
    "carries_d2",
    "carries_lnav",
    "require_lnav",
    "symbol_runs",
    "InavTiming",
    "channel_inav",
    "INAV_COLUMNS",
    "inav_summary",
    "inav_channel_timing",
    "write_inav_report",
    "coherent_periods",
]

_WEEK_S = 604_800.0
_PULL_IN = 0  # index of "pull-in" in receiver.channels.STAGES
#: Columns of the ``track`` command's ``inav.csv``: one row per E1-B channel.
INAV_COLUMNS = (
    "prn",
    "symbols",
    "pages",
    "word_types",
    "crc_failures",
    "iodnav",
    "gst_wn",
    "gst_tow_s",
    "gst_time_s",
    "inverted",
    "ephemeris",
)


def carries_inav(signal: SignalSpec) -> bool:
    """Whether ``signal``'s tracked component is Galileo E1-B (I/NAV, one symbol a 4 ms code period)."""
    sym = signal.components[0].symbol_period_s
    return signal.system == "E" and sym is not None and abs(sym - 0.004) < 1e-9 and signal.code_periods_per_symbol == 1


def _twenty_periods_a_symbol(signal: SignalSpec, system: str) -> bool:
    """Whether ``signal`` is of ``system`` and its tracked component sends one symbol every
    twenty 1 ms code periods under a 20-chip overlay (E5a-I's CS20_1, B1I's NH20)."""
    sym = signal.components[0].symbol_period_s
    return (
        signal.system == system
        and sym is not None
        and abs(sym - 0.02) < 1e-9
        and abs(signal.code_period_s - 1e-3) < 1e-12
        and signal.overlay_length(0) == signal.code_periods_per_symbol == 20
    )


def carries_fnav(signal: SignalSpec) -> bool:
    """Whether ``signal``'s tracked component is Galileo E5a-I (F/NAV, one symbol twenty 1 ms
    code periods under a 20-chip overlay)."""
    return _twenty_periods_a_symbol(signal, "E")


def carries_d1(signal: SignalSpec) -> bool:
    """Whether ``signal``'s tracked component is BeiDou B1I of a D1 satellite (one bit twenty
    1 ms code periods under NH20)."""
    return _twenty_periods_a_symbol(signal, "C")


def carries_d2(signal: SignalSpec) -> bool:
    """Whether ``signal``'s tracked component is BeiDou B1I of a GEO satellite (D2: one bit
    two 1 ms code periods, no overlay)."""
    sym = signal.components[0].symbol_period_s
    return (
        signal.system == "C"
        and sym is not None
        and abs(sym - 0.002) < 1e-9
        and abs(signal.code_period_s - 1e-3) < 1e-12
        and signal.code_periods_per_symbol == 2
        and not signal.overlay_length(0)
    )


def carries_lnav(signal: SignalSpec) -> bool:
    """Whether ``signal`` is an L1 C/A signal of the GPS LNAV format (GPS, QZSS): 1 ms
    code periods, 20 ms bits."""
    return (
        signal.system in ("G", "J")
        and signal.code_periods_per_symbol == 20
        and abs(signal.code_period_s - 1e-3) < 1e-12
    )


def require_lnav(signal: SignalSpec) -> None:
    """Refuse, in one line, a signal the receiver's dating and positioning would read as LNAV wrongly."""
    if not carries_lnav(signal):
        hint = (
            f"; its I/NAV is decoded by `track --signal {signal.name}` and positioned by `receive --signal "
            f"{signal.name}`"
            if carries_inav(signal)
            else ""
        )
        raise ConfigError(
            "signal", f"{signal.name}: LNAV dating and positioning take GPS LNAV (gps-l1ca, qzss-l1ca) only{hint}"
        )


def symbol_runs(
    time_s: np.ndarray, coherent: np.ndarray, code_period_s: float, min_symbols: int = 1
) -> list[np.ndarray]:
    """Row indices of the gap-free runs of one-code-period rows: consecutive in the record,
    ``coherent`` 1, each starting one code period after the previous (half a period of
    slack); runs shorter than ``min_symbols`` left out."""
    time_s, coherent = np.asarray(time_s, float), np.asarray(coherent, int)
    if time_s.shape != coherent.shape or time_s.ndim != 1:
        raise ConfigError(
            "symbol_runs", f"columns of one record must be 1-D and of one length, got {time_s.shape}, {coherent.shape}"
        )
    rows = np.flatnonzero(coherent == 1)
    if rows.size == 0:
        return []
    breaks = (np.diff(rows) != 1) | (np.abs(np.diff(time_s[rows]) - code_period_s) > 0.5 * code_period_s)
    return [r for r in np.split(rows, np.flatnonzero(breaks) + 1) if r.size >= min_symbols]


@dataclass(frozen=True)
class InavTiming:
    """What one E1-B channel's I/NAV (or E5a-I channel's F/NAV, or B1I channel's D1) gave.

    ``messages``: `InavMessage` (`fnav.FnavMessage`) per run (`symbol_runs`); ``rows`` and ``transmit_s`` the
    record rows dated from a decoded GST and their transmit times (satellite time of week,
    s); ``gst``: the last ``(recording time s of the dated symbol, WN, TOW s)``;
    ``ephemeris`` the last complete one (None without); ``half_cycle`` per dated row, True
    where its run's pages came inverted (the Costas loop 180 degrees off: the sync pattern
    is sent upright); ``arc_start`` True on the first dated row of each run;
    ``ephemerides`` each run's complete ephemeris with the recording time of the run's
    last row (when it is surely in hand); ``iono_time`` the NeQuick, GST-UTC and GGTO of
    the last runs that decoded word types 5, 6 and 10 (each part from the last run with it);
    ``bds_iono`` the Klobuchar coefficients of the last D1 subframe 1 or D2 page 2
    (`d1nav.D1Message.iono`, `d2nav.D2Message.iono`).
    """

    prn: int
    messages: list[InavMessage | fnav.FnavMessage | d1nav.D1Message | d2nav.D2Message]
    rows: np.ndarray
    transmit_s: np.ndarray
    gst: tuple[float, int | None, float] | None
    ephemeris: Ephemerides | None
    half_cycle: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    arc_start: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    ephemerides: list[tuple[float, Ephemerides]] = field(default_factory=list)
    iono_time: InavIonoTime | None = None
    bds_iono: BdsKlobuchar | None = None

    @property
    def pages(self) -> int:
        return sum(len(m.pages) for m in self.messages)

    @property
    def failures(self) -> list[str]:
        return [f for m in self.messages for f in m.failures]


#: The messages that carry BeiDou's Klobuchar coefficients.
_BEIDOU = (d1nav.D1Message, d2nav.D2Message)


def channel_inav(record: ChannelRecord, signal: SignalSpec) -> InavTiming:
    """Decode the I/NAV of one channel tracking E1-B (`carries_inav`), the F/NAV of one
    tracking E5a-I (`carries_fnav`) or the D1 of one tracking B1I (`carries_d1`), run by
    run, and date the rows of each run that carries a GST (BDT taken to GPS time; module
    text)."""
    is_fnav, is_d1, is_d2 = carries_fnav(signal), carries_d1(signal), carries_d2(signal)
    if not (carries_inav(signal) or is_fnav or is_d1 or is_d2):
        raise ConfigError(
            "signal",
            f"{signal.name} carries no I/NAV, F/NAV, D1 or D2 on its tracked component (galileo-e1b, "
            "galileo-e5ai, beidou-b1i and beidou-b1i-geo do)",
        )
    empty = np.zeros(0)
    if not record.rows:
        return InavTiming(record.prn, [], np.zeros(0, int), empty, None, None)
    col = record.column
    time_s, code_chips = col("time_s"), col("code_phase_chips")
    period = signal.code_period_s
    prompt_i, prompt_q = col("prompt_i"), col("prompt_q")
    page_symbols, needed = (
        (fnav.PAGE_SYMBOLS, {1, 2, 3, 4})
        if is_fnav
        else (d1nav.SUBFRAME_BITS, {1, 2, 3})
        if is_d1 or is_d2
        else (PAGE_SYMBOLS, {1, 2, 3, 4, 5})
    )
    messages: list[InavMessage | fnav.FnavMessage | d1nav.D1Message | d2nav.D2Message] = []
    rows, tx, half = [], [], []
    gst, ephemeris = None, None
    ephemerides: list[tuple[float, Ephemerides]] = []
    iono_time: InavIonoTime | None = None
    if is_d2:  # one whole 2 ms bit a row after bit synchronisation (module text)
        row_s = float(signal.symbol_period_s or 0.002)
        whole = (col("coherent_ms") == signal.code_periods_per_symbol).astype(int)
        runs = symbol_runs(time_s, whole, row_s)
    else:
        row_s = period
        runs = symbol_runs(time_s, col("coherent_ms"), period)
    for run in runs:
        # The symbols and, for each, the index in the run of the row it starts on.
        if is_d2:
            symbols, symbol_rows = prompt_i[run], np.arange(run.size)
        else:
            symbols, symbol_rows = overlay_symbols_of_run(prompt_i[run], prompt_q[run], signal, record.prn)
        msg: InavMessage | fnav.FnavMessage | d1nav.D1Message | d2nav.D2Message = (
            fnav.decode_fnav(symbols)
            if is_fnav
            else d1nav.decode_d1(symbols, record.prn)
            if is_d1
            else d2nav.decode_d2(symbols, record.prn)
            if is_d2
            else decode_inav(symbols)
        )
        messages.append(msg)
        iono_time = merge_iono_time(iono_time, msg.iono_time)
        if msg.ephemeris is not None:
            ephemeris = msg.ephemeris
            # the row after its last page
            done = symbol_rows[min(_completed_at(msg, needed) + page_symbols, symbols.size - 1)]
            ephemerides.append((float(time_s[run[done]]), msg.ephemeris))
        if msg.gst is None:
            continue
        start_symbol, wn, tow = msg.gst
        start = int(symbol_rows[start_symbol])
        gst = (float(time_s[run[start]]), wn, tow)
        k = np.arange(run.size) - start
        tx.append((tow + k * row_s + code_chips[run] / signal.chip_rate_hz) % _WEEK_S)
        rows.append(run)
        half.append(np.full(run.size, msg.pages[-1].inverted))
    starts = np.zeros(sum(r.size for r in rows), bool)
    starts[np.cumsum([0] + [r.size for r in rows[:-1]])[: len(rows)]] = True
    return InavTiming(
        record.prn,
        messages,
        np.concatenate(rows) if rows else np.zeros(0, int),
        np.concatenate(tx) if tx else empty,
        gst,
        ephemeris,
        np.concatenate(half) if half else np.zeros(0, bool),
        starts,
        ephemerides,
        iono_time,
        next((m.iono for m in reversed(messages) if isinstance(m, _BEIDOU) and m.iono is not None), None),
    )


def _completed_at(msg: InavMessage | fnav.FnavMessage | d1nav.D1Message | d2nav.D2Message, needed: set[int]) -> int:
    """Index (in its symbol stream) of the first symbol of the page that completed ``msg``'s
    ephemeris: the first page by which the ``needed`` word (page) types have all arrived,
    types 1-4 of the ephemeris's IODnav (I/NAV: words 1-5; F/NAV: pages 1-4); D1's last
    subframe 3 (its record is that of one frame's subframes 1-3)."""
    if isinstance(msg, d1nav.D1Message):
        return next((p.start for p in reversed(msg.pages) if p.word_type == 3), msg.pages[-1].start)
    if isinstance(msg, d2nav.D2Message):  # the last page 10 (its record is one page cycle's)
        return next((p.start for p in reversed(msg.subframes) if p.pnum == 10), msg.subframes[-1].start)
    iod = int(msg.ephemeris.iode[0]) if msg.ephemeris is not None else -1
    seen: set[int] = set()
    for p in msg.pages:
        if p.word_type == 5 or (p.word_type in (1, 2, 3, 4) and int(p.fields["iodnav"]) == iod):
            seen.add(p.word_type)
        if seen >= needed:
            return p.start
    return msg.pages[-1].start


def inav_channel_timing(record: ChannelRecord, signal: SignalSpec) -> ChannelTiming | None:
    """The rows of an E1-B channel dated from its I/NAV GST (`channel_inav`) as the
    `observables.ChannelTiming` the observables and fixes take (no LNAV message: the GPS
    week's low 10 bits from the GST week, no Klobuchar coefficients; the ephemerides decoded
    per run; the NeQuick, GST-UTC and GGTO of word types 5, 6 and 10 as ``inav_iono_time``);
    None without a GST."""
    from .observables import ChannelTiming

    timing = channel_inav(record, signal)
    col = record.column
    # The pull-in's rows decode (their symbols are as good once the carrier is in) but
    # their code phase is still converging: only the rows from lock on are measurements.
    keep = col("stage")[timing.rows] != _PULL_IN
    if np.count_nonzero(keep) < 2:
        return None
    run = np.cumsum(timing.arc_start)[keep]
    arc_start = np.r_[True, np.diff(run) != 0]
    r = timing.rows[keep]
    # GST week 0 is GPS week 1024 (OS SIS ICD 5.1.2; GST steered to GPS time), and GST sends
    # 12 bits of its week: the GPS week's low 12 bits (`fixes.full_week` makes it whole).
    # D1's and D2's GST is already GPS time (`D1Message.gst`: BDT week + 1356), of 13 bits.
    week = None if timing.gst is None else timing.gst[1]  # None: an F/NAV page type 4 alone (no WN)
    bits = 13 if carries_d1(signal) or carries_d2(signal) else 12
    week12 = None if week is None else week % 8192 if bits == 13 else (week + 1024) % 4096
    return ChannelTiming(
        record.prn,
        col("time_s")[r],
        timing.transmit_s[keep],
        col("doppler_hz")[r],
        col("carrier_phase_cycles")[r],
        col("cn0_dbhz")[r],
        timing.half_cycle[keep],
        LnavMessage(record.prn, [], None, None, week12, week_bits=bits),
        timing.ephemerides,
        arc_start,
        np.ones(r.size, bool),
        inav_iono_time=timing.iono_time,
        bds_iono=timing.bds_iono,
    )


def inav_summary(timing: InavTiming, symbols: int) -> dict:
    """One row of ``inav.csv`` (`INAV_COLUMNS`) for a channel of ``symbols`` one-period rows."""
    pages = [p for m in timing.messages for p in m.pages]
    iods = sorted(
        {int(p.fields.get("iodnav", p.fields.get("aode", 0))) for p in pages if {"iodnav", "aode"} & set(p.fields)}
    )
    gst = timing.gst
    return {
        "prn": timing.prn,
        "symbols": symbols,
        "pages": len(pages),
        "word_types": " ".join(str(p.word_type) for p in pages),
        "crc_failures": len(timing.failures),
        "iodnav": " ".join(str(i) for i in iods),
        "gst_wn": "" if gst is None or gst[1] is None else gst[1],
        "gst_tow_s": "" if gst is None else f"{gst[2]:.3f}".rstrip("0").rstrip("."),  # D2: 0.6 s steps
        "gst_time_s": "" if gst is None else f"{gst[0]:.9f}",
        "inverted": " ".join(sorted({str(int(p.inverted)) for p in pages})),
        "ephemeris": int(timing.ephemeris is not None),
    }


def write_inav_report(out_dir: str | Path, tracking: TrackingResult, signal: SignalSpec) -> tuple[Path, list[dict]]:
    """Decode every channel of ``tracking`` (a `TrackingResult` of E1-B, or of E5a-I) and
    write ``out_dir/inav.csv`` (``fnav.csv`` for E5a-I; `INAV_COLUMNS`, one row per channel,
    ``word_types`` the page types of F/NAV); the path and the rows."""
    from ...io.files import write_rows_csv

    rows = []
    for _, ch in sorted(tracking.channels.items()):
        per_row = signal.code_periods_per_symbol if carries_d2(signal) else 1  # D2: 2 ms bits a row
        n = int(np.count_nonzero(ch.column("coherent_ms") == per_row)) if ch.rows else 0
        rows.append(inav_summary(channel_inav(ch, signal), n))
    name = "fnav" if carries_fnav(signal) else "d1" if carries_d1(signal) else "d2" if carries_d2(signal) else "inav"
    return write_rows_csv(Path(out_dir) / f"{name}.csv", INAV_COLUMNS, rows), rows
