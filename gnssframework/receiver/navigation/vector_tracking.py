r"""Vector tracking on samples: the navigation filter closes every channel's NCOs.

`VectorSampleTracker` is a `~gnssframework.receiver.channels.SampleTracker` whose loop
closer is a `VectorSampleCloser`: it starts as the scalar receiver (pull-in, PLL, bit sync,
LNAV: its `~gnssframework.receiver.channels.closers.ScalarSampleCloser` closes every channel
not handed over), hands channels over to a navigation filter (``ekf-pv``) at a first fix
(`vector_handover`), and from then on closes them through it every coherent interval
(`vector_navigator`): each channel's error-output filter (``discriminator`` or
``iq-filter``) reports a code and a frequency error, the navigation filter takes them as
pseudorange and rate errors of the replicas, and its state steers every replica to the
pseudorange and rate it predicts (`gnssframework.receiver.channels.nco`, the one NCO
convention of the tracker's closers; no PLL, no carrier phase tracking after the
hand-over). Vector channels that lose the signal leave the loop and are searched again
where the solution predicts them (`vector_reacquire`).

With an `Assistance` (an approximate position and the recording's start time, with RINEX
ephemerides) the loop does not wait for LNAV: each replica's transmit time is resolved
from the prediction, and every acquired channel is closed from its pull-in on
(`vector_handover.try_assisted_handover`).

The settings are `VectorConfig` (`vector_config`); the states go to a `VectorSolution`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ... import registry
from ...errors import ConfigError
from ...interfaces import ChannelFilter
from ...navigation.lnav import IonoUtc
from ...navigation.ephemeris import Ephemerides
from ...signal.gps_l1ca import GPS_L1CA
from ...signal.spec import SignalSpec
from ..acquisition.search import Acquisition, AcquisitionResult
from ..channels import SampleTracker, TrackingConfig, TrackingResult
from ..channels.channel import SampleChannel
from ..channels.closers import SampleCloser, ScalarSampleCloser
from ..channels.factory import FilterFactory, StageFilters
from ..frontend.recording import Recording
from ..engine.closers import check_composition
from .vector_config import Assistance, VectorConfig, assistance, vector_config
from .vector_handover import VECTOR, admit_locked, start_vector, try_assisted_handover, try_handover
from .vector_navigator import VectorNavigator
from .vector_reacquire import drop, reacquire
from .vector_solution import VectorSolution

__all__ = [
    "VectorConfig",
    "vector_config",
    "VectorSampleTracker",
    "VectorSampleCloser",
    "VectorSolution",
    "Assistance",
    "assistance",
]

#: Interval (s) of the assisted start's checks (bit edges, hand-over): each costs an ephemeris evaluation.
_ASSIST_EVERY_S = 0.1


class VectorSampleCloser(SampleCloser):
    """Scalar closing until the hand-over, the navigation filter after it (see the module text).

    Parameters
    ----------
    vector
        `VectorConfig`.
    rinex, ionosphere, reference_week, assist, iono_fallback
        As `VectorSampleTracker`.
    channel_filter
        The vector channels' filter (`FilterFactory` of ``vector.channel_filter`` and its
        parameters), built once; default: built here. Each hand-over takes a copy.

    Attributes
    ----------
    scalar
        The `ScalarSampleCloser` of the channels not (yet) handed over.
    nav
        The `VectorNavigator` once a hand-over has happened, else None.
    solution
        The run's `VectorSolution`.
    """

    def __init__(
        self,
        vector: VectorConfig,
        *,
        rinex: Ephemerides | None = None,
        ionosphere: bool = True,
        reference_week: int | None = None,
        assist: Assistance | None = None,
        iono_fallback: IonoUtc | None = None,
        channel_filter: FilterFactory | None = None,
    ) -> None:
        self.vector = vector
        self.channel_filter = (
            channel_filter
            if channel_filter is not None
            else FilterFactory("channel_filter", vector.channel_filter, vector.channel_params)
        )
        self.rinex = rinex
        self.assist = assist
        self.ionosphere = ionosphere
        self.reference_week = reference_week
        self.iono_fallback = iono_fallback  # Klobuchar where no page 18 is decoded (a RINEX header's)
        self.scalar = ScalarSampleCloser()

    def bind(self, tracker: SampleTracker) -> None:
        super().bind(tracker)
        self.scalar.bind(tracker)
        self.solution = VectorSolution(signal=tracker.signal)
        self.nav: VectorNavigator | None = None
        self.next_try = max(self.vector.earliest_s, self.vector.try_every_s)
        self.next_assist = self.vector.earliest_s
        self.time_corrected = False  # the assisted start time corrected once (`vector_handover`)
        self.acq_doppler = np.zeros(len(tracker.signal.prns))
        self.acq_cn0 = np.zeros(len(tracker.signal.prns))
        self.held: dict[int, Ephemerides] = {}  # the records of dropped vector channels, by slot

    def added(self, c: SampleChannel, acq: AcquisitionResult) -> None:
        self.acq_doppler[c.slot] = acq.doppler_hz
        self.acq_cn0[c.slot] = acq.cn0_dbhz

    def step(self, filt: ChannelFilter, closure: Any, slots: np.ndarray, w: np.ndarray) -> None:
        t = self.tracker
        if slots.size == 1 and getattr(t.channels[t.signal.prns[int(slots[0])]], "vector_pending", False):
            return  # handed over, waiting for its aligned boundary: the NCOs hold the state's prediction
        if closure is not VECTOR:
            self.scalar.step(filt, closure, slots, w)
        else:
            self.nav.measure(filt, slots, w)

    def advance(self, c: SampleChannel, t0: float) -> None:
        t = self.tracker
        if c.stage == "vector":
            c.unlocked_ms = 0 if c.locked else c.unlocked_ms + c.coherent_ms
            # Only an estimate over a full window counts (a rejoined channel's first ones are short).
            low = t.n_prompts[c.slot] >= t.config.cn0_window_ms and c.cn0_dbhz < self.vector.loss_cn0_dbhz
            c.low_cn0_ms = c.low_cn0_ms + c.coherent_ms if low else 0
            if c.low_cn0_ms >= self.vector.loss_ms:
                drop(self, c, t0)
            return
        if getattr(c, "vector_pending", False):  # closed by the filter at its next aligned boundary, never lost
            n = t.config.coherent_ms
            if (int(t.ms_index[c.slot]) + 1 - c.bit_edge) % n == 0:
                c.vector_pending = False
                c.record.events.append(
                    (t0, f"bit edge from the assisted transmit time (ms {c.bit_edge} mod {c.periods_per_symbol})")
                )
                t.start_stage(c, "extended", float(t.doppler[c.slot]), n)
                start_vector(self, c)
            return
        self.scalar.advance(c, t0)

    def after_interval(self, idx: np.ndarray) -> None:
        t = self.tracker
        now = float(t.start_sample[idx].min()) / t.fs
        if self.nav is None:
            if self.assist is not None and now >= self.next_assist:
                self.next_assist = now + _ASSIST_EVERY_S
                try_assisted_handover(self, now)
            elif self.assist is None and now >= self.next_try:
                self.next_try = now + self.vector.try_every_s
                try_handover(self)
        elif self.nav.ready():
            self.nav.step()

    def reacquire(self, at: int, stop: int) -> None:
        """Before the navigation filter runs, the scalar search; after, the aided one
        (`vector_reacquire.reacquire`)."""
        if self.nav is None or not self.nav.started:
            self.scalar.reacquire(at, stop)
        else:
            reacquire(self, at, stop)
            admit_locked(self)

    def finish(self, result: TrackingResult) -> None:
        if self.nav is not None:  # what dates the vector channels' rows (`observables.assisted_timing`)
            t, slots = self.tracker, self.nav.slots
            tx = self.nav.replica_tx(slots)
            self.solution.replica_tx = {
                t.signal.prns[int(i)]: (float(t.start_sample[i]) / t.fs, float(x)) for i, x in zip(slots, tx)
            }


class VectorSampleTracker(SampleTracker):
    """Scalar tracking, then vector tracking from the first fix: a `SampleTracker` with a
    `VectorSampleCloser` (see the module text).

    Parameters
    ----------
    recording, config, acquisition, backend, signal, filters
        As `SampleTracker`.
    vector
        `VectorConfig`.
    rinex
        Ephemerides for satellites whose own have not been decoded yet (as ``--ephemeris``).
    ionosphere
        Apply the decoded Klobuchar model in the first fix and in the predictions.
    reference_week
        Full GPS week near the recording (resolves the decoded 10-bit week).
    assist
        `Assistance`: hand over without LNAV, as soon as four channels are bit-aligned,
        each replica's transmit time from the approximate position and start time
        (`vector_handover.try_assisted_handover`).
    iono_fallback
        Klobuchar coefficients (a RINEX header's) for the LNAV hand-over where no page 18 is decoded.
    """

    def __init__(
        self,
        recording: Recording,
        config: TrackingConfig,
        acquisition: Acquisition,
        vector: VectorConfig | None = None,
        *,
        rinex: Ephemerides | None = None,
        ionosphere: bool = True,
        reference_week: int | None = None,
        assist: Assistance | None = None,
        backend: str | None = None,
        iono_fallback: IonoUtc | None = None,
        signal: SignalSpec = GPS_L1CA,
        filters: StageFilters | None = None,
    ) -> None:
        super().__init__(recording, config, acquisition, backend=backend, signal=signal, filters=filters)
        if assist is not None and rinex is None:
            raise ConfigError(
                "approx_position", "an assisted start needs the ephemerides of a RINEX navigation file (--ephemeris)"
            )
        v = vector or VectorConfig()
        self.vector = v
        self.closer = VectorSampleCloser(
            v,
            rinex=rinex,
            ionosphere=ionosphere,
            reference_week=reference_week,
            assist=assist,
            iono_fallback=iono_fallback,
        )
        check_composition(
            self.closer.channel_filter.prototype, registry.create("nav_filter", v.nav_filter, **v.nav_params)
        )

    @property
    def solution(self) -> VectorSolution:
        """The navigation filter's states of the last run."""
        return self.closer.solution
