"""Loop closers: what a `SampleTracker` calls to close its channels' loops.

The tracker owns the samples, the NCO arrays, the compiled correlation and interval
bookkeeping, the lock detectors and the filter batches; a loop closer decides what the
channel filters' outputs do to the NCOs and how a channel goes through its stages. The
tracker calls its closer at seven points of a run, and nowhere else:

===================  ==================================================================
``bind(tracker)``    a run starts (the tracker's arrays and channel table are fresh)
``added(c, acq)``    channel ``c`` was (re)started from acquisition ``acq``
``step(...)``        a filter (one channel, or a batch) has its wiped interval sums
``advance(c, t0)``   channel ``c``'s interval is recorded: run its state machine
``after_interval``   channels ``idx`` have all completed an interval
``reacquire``        the re-acquisition clock has ticked
``finish(result)``   the run is over
===================  ==================================================================

`ScalarSampleCloser` closes every channel alone: a filter's NCO commands steer its NCOs
(the loop engine's `gnssframework.receiver.engine.closers.ScalarCloser`, the closer of the
analytic harness, on the slots' NCOs: `nco.SlotNCOs`), an error-output filter is closed
by `closure.ErrorFeedback`, the state machine is pull-in ->
track -> extended (-> lost), and lost satellites get the acquisition's full search.
A vector closer (`gnssframework.receiver.navigation.vector_tracking.VectorSampleCloser`) keeps a
`ScalarSampleCloser` for the channels it has not handed over and closes the others through a
navigation filter.
"""

from __future__ import annotations

import abc
from typing import Any

import numpy as np

from ...interfaces import ChannelFilter
from ...signal.correlators import Correlators
from ..acquisition.search import AcquisitionResult
from ..engine.closers import ScalarCloser as EngineScalarCloser
from .channel import SampleChannel
from .closure import ErrorFeedback
from .records import TrackingResult

__all__ = ["SampleCloser", "ScalarSampleCloser"]


class SampleCloser(abc.ABC):
    """The extension points of `SampleTracker` (see the module text); every hook but
    `step` and `advance` (which a closer must define) does nothing here."""

    #: The `tracker.SampleTracker` it closes (not imported here: the tracker imports its closers).
    tracker: SampleTracker

    def bind(self, tracker: SampleTracker) -> None:
        """A run of ``tracker`` starts."""
        self.tracker = tracker

    def added(self, c: SampleChannel, acq: AcquisitionResult) -> None:
        """Channel ``c`` was started (or restarted) from ``acq``, in ``pull-in``."""

    @abc.abstractmethod
    def step(self, filt: ChannelFilter, closure: Any, slots: np.ndarray, wiped: np.ndarray) -> None:
        """Step ``filt``, the filter of channels ``slots`` (a batch, in order), on their
        bit-wiped interval sums ``wiped`` ``(len(slots), taps)``, and move their NCOs."""

    @abc.abstractmethod
    def advance(self, c: SampleChannel, t0: float) -> None:
        """Channel ``c``'s interval starting at ``t0`` (s) is recorded: its state machine."""

    def after_interval(self, idx: np.ndarray) -> None:
        """Channels at slots ``idx`` have completed an interval and recorded it."""

    def reacquire(self, at: int, stop: int) -> None:
        """Re-acquisition time, at sample ``at`` (the recording ends at ``stop``)."""

    def finish(self, result: TrackingResult) -> None:
        """The run is over."""


class ScalarSampleCloser(SampleCloser):
    """Every channel closed alone by its own filter (see the module text)."""

    def step(self, filt: ChannelFilter, closure: ErrorFeedback | None, slots: np.ndarray, w: np.ndarray) -> None:
        t = self.tracker
        correlators = Correlators.trusted(w[:, 0], w[:, 1], w[:, 2])
        if closure is None:  # NCO commands: the loop engine's scalar closer, on these slots' NCOs
            EngineScalarCloser(filt).step(t.nco.at(slots), correlators)
            return
        out = filt.checked_step(
            {"correlators": correlators, "nco_shift_chips": t.shift_chips[slots], "nco_shift_hz": t.shift_hz[slots]}
        )
        t.nco.at(slots).steer_by_errors(
            closure.k_code * np.asarray(out["code_error_chips"], float),
            closure.k_freq * np.asarray(out["freq_error_hz"], float),
        )

    def advance(self, c: SampleChannel, t0: float) -> None:
        """The state machine: pull-in -> track -> extended; lost after ``loss_ms`` out of lock."""
        t = self.tracker
        cfg = t.config
        c.unlocked_ms = 0 if c.locked else c.unlocked_ms + c.coherent_ms
        if c.stage == "pull-in":
            if c.locked and c.stage_ms >= cfg.lock_window_ms:
                c.failures = 0
                c.record.events.append((t0, "locked: tracking with " + cfg.channel_filter))
                t.start_stage(c, "track", float(t.doppler[c.slot]), 1)
            elif c.stage_ms >= cfg.pull_in_ms:
                self.lose(c, t0, f"no lock within {cfg.pull_in_ms} ms of pull-in")
            return
        if c.unlocked_ms >= cfg.loss_ms:
            self.lose(c, t0, f"lock lost for {cfg.loss_ms} ms")
            return
        per_bit = c.periods_per_symbol
        if (
            c.stage == "track"
            and cfg.coherent_ms > 1
            and c.bit_edge is not None
            and (int(t.ms_index[c.slot]) + 1) % per_bit == c.bit_edge % per_bit
        ):
            # The next code period starts a bit: integrations from here on are bit aligned.
            c.record.events.append((t0, f"extended to {cfg.coherent_ms} ms coherent (PLL)"))
            t.start_stage(c, "extended", float(t.doppler[c.slot]), cfg.coherent_ms)

    def lose(self, c: SampleChannel, t0: float, why: str) -> None:
        """Hand the channel back to acquisition: it is searched at the next tick of the
        re-acquisition clock. A satellite whose pull-ins keep failing (a false detection, a
        signal too weak to lock) is searched at the 2nd, 4th ... up to the 32nd tick after
        its loss, so it does not cost a search every interval."""
        t = self.tracker
        if c.stage == "pull-in":
            c.failures += 1
        ticks = 2 ** min(max(c.failures - 1, 0), 5)
        every = t.reacquire_every
        retry_at = (int(t.start_sample[c.slot]) // every + ticks) * every
        t.deactivate(c, retry_at, (t0, f"lost: {why}; back to acquisition"))

    def reacquire(self, at: int, stop: int) -> None:
        """The acquisition's full search for the lost satellites due a retry."""
        t = self.tracker
        lost = tuple(p for p, c in t.channels.items() if c.stage == "lost" and c.retry_at <= at)
        t.search(lost, at, stop)
