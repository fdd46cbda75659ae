"""Fixes as they come: a live receiver's positions solved while it tracks, sent as NMEA.

`LiveFixes` watches the scalar tracker of `receive.receive` (its ``observe`` hook) and is
its ``progress`` callback: every ``every_s`` of signal tracked it dates the channels'
rows so far (`observables.channel_timing`, causal: only rows after a decoded subframe, as
a real-time receiver has them), forms the observables and solves the epochs not sent yet
(`fixes.solve_epochs`, the least squares the file receiver runs) up to ``settle_s``
before the slowest channel (an epoch interpolates between two rows of each channel), and
sends their GGA and RMC sentences (`nmea_out.nmea_sentences`) to its sinks
(`nmea_stream`). At the end `finish` sends the receiver's final table's epochs not sent.

A fix sent live is solved from the channels dated at that moment: a satellite whose first
subframe arrives later is in the file receiver's fix of that epoch but not in the live
one (the receiver's final outputs, positions.csv..., are the file receiver's, from every
row). With a navigation filter, the live sentences are the least-squares fixes.
Recomputing the dating of every row each ``every_s`` costs time proportional to the rows
held: fine for minutes of signal (records grow with the run, as a file run's do).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from ...navigation.ephemeris import Ephemerides
from ...navigation.lnav import IonoUtc
from ...signal.gps_l1ca import GPS_L1CA
from ...signal.spec import SignalSpec
from .fixes import PositionTable, solve_epochs
from .nmea_out import nmea_sentences, nmea_talker
from .nmea_stream import NmeaSink
from .observables import Observables, channel_timing, observables

__all__ = ["LiveFixes", "select_epochs", "table_rows"]

#: GPS leap seconds where no page 18 was decoded (since 2017).
DEFAULT_LEAP_S = 18


def select_epochs(obs: Observables, keep: np.ndarray) -> Observables:
    """The epochs ``keep`` (a boolean mask over ``obs.sample_time_s``) of ``obs``."""
    per_epoch = (
        "rx_time_s",
        "sample_time_s",
        "transmit_s",
        "pseudorange_m",
        "doppler_hz",
        "carrier_cycles",
        "cn0_dbhz",
        "lli",
    )
    return replace(obs, **{f: getattr(obs, f)[keep] for f in per_epoch if getattr(obs, f) is not None})


def table_rows(table: PositionTable, keep: np.ndarray) -> PositionTable:
    """The rows ``keep`` (a boolean mask) of ``table``."""
    return PositionTable(
        {c: v[keep] for c, v in table.columns.items()},
        table.ecef_m[keep],
        table.sample_time_s[keep],
        [u for u, k in zip(table.used_prns, keep) if k],
        table.excluded_prn[keep],
        None if table.clock_drift_mps is None else table.clock_drift_mps[keep],
    )


class LiveFixes:
    """Fixes solved and sent while tracking (module text).

    Parameters
    ----------
    sinks
        Where each new fix's GGA and RMC go (`nmea_stream.NmeaSink`).
    rate_hz, rinex, ionosphere, troposphere, reference_week, weighting, signal, iono_fallback
        As `receive.receive` takes them.
    every_s
        Signal tracked between two solutions.
    settle_s
        Epochs are solved up to this long before the slowest active channel.
    """

    def __init__(
        self,
        sinks: list[NmeaSink],
        *,
        rate_hz: float = 1.0,
        rinex: Ephemerides | None = None,
        ionosphere: bool = True,
        troposphere: bool = False,
        reference_week: int | None = None,
        weighting: str | None = None,
        signal: SignalSpec = GPS_L1CA,
        iono_fallback: IonoUtc | None = None,
        every_s: float = 1.0,
        settle_s: float = 0.1,
    ) -> None:
        self.sinks = sinks
        self.rate_hz = rate_hz
        self.solve_args: dict[str, Any] = dict(
            rinex=rinex,
            ionosphere=ionosphere,
            troposphere=troposphere,
            reference_week=reference_week,
            weighting=weighting,
            signal=signal,
        )
        self.iono_fallback = iono_fallback
        self.signal = signal
        self.every_s = every_s
        self.settle_s = settle_s
        self.tracker = None
        self.next_s = every_s
        self.sent_until_s = -np.inf  # recording time of the last epoch sent
        self.sent = 0  # fixes sent
        self.unknown_week = 0  # fixes not sent: no week known

    def observe(self, tracker) -> None:
        """`receive.receive`'s ``observe``: the tracker whose records are read."""
        self.tracker = tracker

    def __call__(self, fraction: float) -> None:
        """The tracker's progress call: solve and send when ``every_s`` more was tracked."""
        t = self.tracker
        if t is None or not t.active.any():
            return
        now_s = float(t.start_sample[t.active].min()) / t.fs
        if now_s < self.next_s:
            return
        self.next_s = now_s + self.every_s
        timings = [channel_timing(rec, signal=self.signal) for rec in t.records.values()]
        if not any(tm is not None and tm.time_s.size > 1 for tm in timings):
            return
        obs = observables(timings, self.rate_hz)
        keep = (obs.sample_time_s > self.sent_until_s) & (obs.sample_time_s <= now_s - self.settle_s)
        if not keep.any():
            return
        new = select_epochs(obs, keep)
        iono = self.iono_fallback if obs.iono_utc is None else None
        table = solve_epochs(new, iono=iono, **self.solve_args)
        self.sent_until_s = float(new.sample_time_s[-1])
        leap = obs.iono_utc.dt_ls_s if obs.iono_utc is not None else DEFAULT_LEAP_S
        self._send(table, leap)

    def _send(self, table: PositionTable | None, leap_s: int) -> None:
        if table is None or not len(table):
            return
        known = table.columns["gps_week"] >= 0
        self.unknown_week += int((~known).sum())
        if not known.any():
            return
        sentences = nmea_sentences(table_rows(table, known), leap_s, nmea_talker(self.signal))
        for sink in self.sinks:
            sink.send(sentences)
        self.sent += int(known.sum())

    def finish(self, table: PositionTable | None, obs: Observables | None) -> None:
        """Send the rows of the receiver's final ``table`` after the last epoch sent."""
        if table is None or not len(table):
            return
        leap = obs.iono_utc.dt_ls_s if obs is not None and obs.iono_utc is not None else DEFAULT_LEAP_S
        self._send(table_rows(table, table.sample_time_s > self.sent_until_s), leap)
        self.sent_until_s = max(self.sent_until_s, float(table.sample_time_s[-1]))


class LiveRun:
    """A command's live input and output: the stream recording (or a file), the NMEA sinks
    and `LiveFixes`; `finish` sends the last fixes, closes everything and returns the
    overrun line (``""`` for a file or a run that dropped nothing)."""

    def __init__(self, recording, sinks: list[NmeaSink]) -> None:
        self.recording = recording
        self.sinks = sinks
        self.fixes: LiveFixes | None = None

    def start(self, **solve) -> LiveFixes:
        """The `LiveFixes` of this run (``solve``: its keyword arguments but the sinks)."""
        self.fixes = LiveFixes(self.sinks, **solve)
        return self.fixes

    def finish(self, table: PositionTable | None = None, obs: Observables | None = None) -> str:
        try:
            if self.fixes is not None:
                self.fixes.finish(table, obs)
        finally:
            for sink in self.sinks:
                sink.close()
            close = getattr(self.recording, "close", None)
            if close is not None:
                close()
        overruns = getattr(self.recording, "overrun_summary", None)
        if overruns is None:  # a file
            return ""
        said = self.recording.realtime or self.recording.gaps or getattr(self.recording, "device_lost", False)
        return overruns() if said else ""
