"""Sample-driven tracking: channel filters on real (or generated) samples.

Each channel integrates over whole code periods of its own replica, from code epoch to
code epoch (not fixed-length blocks): a period ends on the sample at which the code NCO
reaches the next epoch. One call of the compiled multi-channel correlator
(`correlator.correlate_periods`) runs every channel through its whole coherent interval
(1 ms, or ``coherent_ms`` after bit synchronisation) and returns every period's sums, on
a buffer that streams the recording in blocks (the next one read ahead on a second
thread, `prefetch.BlockReader`); a channel ahead of the others by more than `LAG_LIMIT_S`
waits. The per-millisecond bookkeeping (normalised sums, NCO
advance, prompts for the detectors, bit-sync votes) is one compiled pass over the channels
(`intervals.close_periods`), the bit wipe-off and the lock detectors are done on arrays
over the channels, and the filters of the channels in one stage and coherent interval step as one
batch (`batch.FilterBatch`; the channels of a batch always run together); Python runs per
channel once per coherent interval only for its state machine and record. The 1 ms sums, scaled to unit-variance I and Q
noise like the analytic model's (`gnssframework.signal.correlator_model`), are summed
over the coherent interval in force and then handed to the channel filter exactly as `gnssframework.receiver.tracking.scalar`
hands them: ``checked_step({"correlators": ...})`` once per interval, whose
``carrier_freq_hz`` and ``code_freq_hz`` (and optional ``carrier_phase_step_rad``) steer
the NCOs of the next interval. Filters that output errors instead (the vector-tracking
channel filters) are closed by `closure.ErrorFeedback`.

What the filters' outputs do to the NCOs, the channels' state machine and re-acquisition
are the tracker's loop closer's (`closers.SampleCloser`, called at documented points of the
run): `closers.ScalarSampleCloser` by default; vector tracking
(`gnssframework.receiver.navigation.vector_tracking`) hands the tracker a closer that
closes the channels through a navigation filter.

The signal is a `gnssframework.signal.spec.SignalSpec` (default `GPS_L1CA`) held by the
tracker and by each channel: its code generator, code length, chip rate, carrier frequency
and code periods per data symbol (the bit-sync histogram's length) come from it.

Noise scaling: the I and Q noise of a 1 ms sum of N samples of power P (one real or
complex sample's mean square) against a replica :math:`r_i` and a unit carrier is
:math:`P / 2 \\sum_i r_i^2` per component for white noise: N P / 2 for a ±1 code, N P d / 2
for a component sent in a share d of the time whose replica is 0 elsewhere (GPS L2 CM, d =
1/2: `SignalSpec.replica_duty`); P is measured per block of the block grid (``block_ms``),
and an interval is scaled by the P of the block it starts in. That, re-acquisition at the
ticks of its clock and each channel running to its own last interval make a channel's
records independent of the other channels of its tracker (`groups`: channels split
between processes).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ...errors import ConfigError
from ...interfaces import ChannelFilter
from ...signal.correlator_model import tap_offsets
from ...signal.correlators import Correlators
from ...signal.gps_l1ca import GPS_L1CA
from ...signal.spec import SignalSpec
from ..acquisition.search import Acquisition, AcquisitionResult, check_contract
from ..frontend.recording import Recording
from .batch import FilterBatch, batch_layout
from .channel import NCO_COMMANDS, SampleChannel, stage_context, supports
from .factory import StageFilters
from .closers import SampleCloser, ScalarSampleCloser
from .config import TrackingConfig
from .correlator import code_tables, correlate_periods, replica_code_pair, to_table_units
from .intervals import ChannelArrays, close_periods
from .nco import ReplicaNCOs
from .prefetch import BlockReader
from .sampling import warn_if_commensurate
from .records import RECORD_FIELDS, STAGES, ChannelRecord, TrackingResult
from .detection import detect_periods, run_detectors
from .lock import bit_edge_by_energy, bit_edge_from_votes

__all__ = ["ChannelRecord", "TrackingResult", "SampleTracker", "STAGES", "RECORD_FIELDS"]

#: How far (s) a channel may run ahead of the last one before it waits.
LAG_LIMIT_S = 0.025


class SampleTracker:
    """Track the satellites an acquisition found, on a recording's samples.

    Parameters
    ----------
    recording
        The samples (`gnssframework.receiver.frontend.open_recording`).
    config
        `TrackingConfig`.
    acquisition
        Used again to re-acquire lost satellites.
    backend
        Correlator backend (``"numba"``, ``"numpy"``; default: the library's).
    batch
        Step the filters of the channels in the same stage and coherent interval as one
        batch (`gnssframework.receiver.channels.batch`); ``False`` steps every channel's
        filter alone (the reference the batched stepping is tested against).
    read_ahead
        Read the next block of the recording on a second thread while the channels
        correlate the current one (`prefetch.BlockReader`: the same samples and power);
        ``False`` reads every block when it is needed.
    closer
        The loop closer (`closers.SampleCloser`); default `closers.ScalarSampleCloser`.
    signal
        The signal every channel tracks (`SignalSpec`); default `GPS_L1CA`.
    filters
        The stages' channel filters (`factory.StageFilters` of ``config``), built once for a
        task that runs several trackers; default: built here.

    Notes
    -----
    The channel API a closer uses: the per-slot NCO arrays (``code_phase`` chips at
    ``start_sample``, ``code_rate`` chips/s, ``doppler`` Hz, ``doppler_cycles``,
    ``shift_chips`` and ``shift_hz`` the last moves, ``ms_index`` code periods tracked,
    ``acc_t0`` the last interval's start; ``nco`` steers them, `nco.ReplicaNCOs`),
    ``channels`` (`SampleChannel` by PRN), ``records``, ``active``, and the methods `add`,
    `start_stage`, `leave_batch`, `deactivate` and `search`.
    """

    def __init__(
        self,
        recording: Recording,
        config: TrackingConfig,
        acquisition: Acquisition,
        backend: str | None = None,
        batch: bool = True,
        read_ahead: bool = True,
        closer: SampleCloser | None = None,
        signal: SignalSpec = GPS_L1CA,
        filters: StageFilters | None = None,
    ) -> None:
        self.signal = signal
        self.closer = closer if closer is not None else ScalarSampleCloser()
        self.rec = recording
        self.batch = batch
        self.read_ahead = read_ahead
        self.config = config
        self.acquisition = check_contract(acquisition)  # re-acquisition passes it the signal
        self.backend = backend
        self.fs = recording.info.sample_rate_hz
        warn_if_commensurate(self.fs, signal)
        self.if_hz = recording.info.if_hz
        self.offsets = np.array(list(tap_offsets(config.early_late_spacing_chips).values()))
        # Every stage's filter validated and built once (a bad one refused before any work);
        # the channels take copies.
        self.filters = filters if filters is not None else StageFilters(config)
        if self.filters.config != config:
            raise ConfigError("filters", "the StageFilters were built for another tracking config")
        # One row per slot: the spreading waveform (code times sub-carrier, `replica_codes`), in
        # sub-chips for BOC; the kernels then take phases, steps and tap offsets in its units
        # (`to_table_units`). A CBOC waveform is not ±1 and is refused there (its -boc11 replica is).
        # A time-multiplexed component (L2C's CM, 0 in CL's slots) is two ±1 tables whose mean
        # it is (`replica_code_pair`): each interval correlates with both and takes the mean.
        self.codes, self.codes_other = replica_code_pair(signal, signal.prns)
        self.table_offsets = to_table_units(self.offsets, signal)
        #: Prompts a channel holds before its lock detectors first run, and code periods
        #: between two of their runs (`detect_periods`).
        self.detect_periods = detect_periods(signal)

    def slot(self, prn: int) -> int:
        """The index of ``prn``'s channel in the tracker's arrays."""
        return self.signal.prns.index(prn)

    def _reset_state(self) -> None:
        n, w = len(self.signal.prns), self.config.cn0_window_ms
        self.active = np.zeros(n, bool)
        self.finished = np.zeros(n, bool)  # active, but its next interval would pass the end
        self.start_sample = np.zeros(n, np.int64)
        self.code_phase = np.zeros(n)  # chips at start_sample
        self.code_rate = np.zeros(n)  # chips/s
        self.doppler = np.zeros(n)  # Hz
        self.doppler_cycles = np.zeros(n)  # accumulated replica Doppler phase at start_sample
        self.ms_index = np.zeros(n, np.int64)
        self.coherent = np.ones(n, np.int64)
        self.acc_t0 = np.zeros(n)
        self.acc_phase = np.zeros(n)
        self.acc_cycles = np.zeros(n)
        self.prompts = np.zeros((n, w), complex)  # ring buffers of 1 ms prompts
        self.n_prompts = np.zeros(n, np.int64)
        self.votes = np.zeros((n, self.signal.code_periods_per_symbol), np.int64)  # bit-sync histograms
        self.voting = np.zeros(n, bool)
        self.previous_prompt = np.zeros(n, complex)
        self.bit_sign = np.ones(n)  # decision-directed bit wipe-off
        self.last_prompt = np.zeros(n, complex)  # last wiped prompt handed to the filter
        self.shift_chips = np.zeros(n)  # NCO moves of an error-output filter's closure
        self.shift_hz = np.zeros(n)
        self.nco = ReplicaNCOs(
            self.signal,
            self.code_phase,
            self.code_rate,
            self.doppler,
            self.doppler_cycles,
            self.shift_chips,
            self.shift_hz,
        )
        self.arrays = ChannelArrays(
            self.acc_t0,
            self.acc_phase,
            self.acc_cycles,
            self.start_sample,
            self.code_phase,
            self.doppler_cycles,
            self.prompts,
            self.n_prompts,
            self.ms_index,
            self.previous_prompt,
            self.voting,
            self.votes,
        )
        self.batches: dict[tuple[str, int], FilterBatch] = {}
        self.largest_batch = 0  # the most channels a batch has held this run
        self.layouts: dict[tuple[str, int], frozenset | None] = {}

    def add(self, prn: int, acq: AcquisitionResult, first_sample: int) -> None:
        """Start (or restart) ``prn``'s channel in ``pull-in`` at its acquisition's code epoch."""
        ch = self.channels.get(prn)
        if ch is None:
            ch = self.channels[prn] = SampleChannel(
                prn, self.slot(prn), self.signal, self.records.setdefault(prn, ChannelRecord(prn)), self.filters
            )
        i = ch.slot
        self.active[i] = True
        self.finished[i] = False
        self.start_sample[i] = first_sample + acq.code_phase_samples
        self.code_phase[i] = 0.0  # a code epoch
        self.doppler[i] = acq.doppler_hz
        self.code_rate[i] = self.signal.code_freq_hz(acq.doppler_hz)
        self.doppler_cycles[i] = 0.0
        self.ms_index[i] = 0
        self.n_prompts[i] = 0
        self.votes[i] = 0
        self.voting[i] = True
        self.previous_prompt[i] = 0j
        ch.cn0_dbhz = acq.cn0_dbhz
        self.start_stage(ch, "pull-in", acq.doppler_hz, 1)
        self.closer.added(ch, acq)

    def start_stage(self, ch: SampleChannel, stage: str, doppler_hz: float, coherent_ms: int) -> None:
        """Channel ``ch`` enters scalar ``stage`` (a new filter at ``doppler_hz``, intervals of ``coherent_ms``)."""
        self.leave_batch(ch)
        ch.start(stage, doppler_hz, coherent_ms)
        i = ch.slot
        self.bit_sign[i] = 1.0
        self.last_prompt[i] = 0j
        self.shift_chips[i] = self.shift_hz[i] = 0.0
        self.coherent[i] = coherent_ms
        self.voting[i] = stage != "extended"

    def _samples(self, lo: int, hi: int) -> tuple[np.ndarray, int]:
        """A buffer holding samples ``[lo, hi)``, read in whole blocks of the block grid
        (block ``k`` is samples ``[k B, (k + 1) B)``, B = ``block_ms``) as the file stores
        them (`Recording.read_components`: interleaved I/Q components or real values, no
        float copy); ``(buffer, its first sample)``. Each block's mean square is kept
        beside it (`_block_power`): what a channel's interval is scaled by depends on the
        samples and the grid only, never on which channels read them (so channels tracked
        in separate processes, `groups`, get the same numbers)."""
        per = 2 if self.rec.is_complex else 1  # buffer values per sample
        size = self.block_samples
        held = self.buf.shape[0] // per
        if self.buf_start <= lo and hi <= self.buf_start + held:
            return self.buf, self.buf_start
        first_block = lo // size * size
        if lo < self.buf_start or lo >= self.buf_start + held:  # behind what is held, or past it
            self.buf, self.buf_start, self.buf_power, held = self.buf[:0], first_block, self.buf_power[:0], 0
        elif first_block > self.buf_start:  # whole blocks before lo's are done with
            drop = (first_block - self.buf_start) // size
            self.buf, self.buf_power = self.buf[drop * size * per :], self.buf_power[drop:]
            self.buf_start, held = first_block, held - drop * size
        parts, powers = [self.buf], [self.buf_power]
        end = self.buf_start + held
        while end < hi:
            new, squares = self.reader.read(end, size)
            if not new.size:
                break
            parts.append(new)
            # mean square of a sample (|I|^2 + |Q|^2 for I/Q); no BLAS call (its threads spin)
            powers.append(np.array([squares * per / new.size]))
            end += new.size // per
            if new.size < size * per:  # the recording's (or a live stream's) end
                break
        self.buf, self.buf_power = np.concatenate(parts), np.concatenate(powers)
        return self.buf, self.buf_start

    def _block_power(self, starts: np.ndarray) -> np.ndarray:
        """Mean square of a sample in the block each of ``starts`` lies in (held by the buffer)."""
        return self.buf_power[(starts - self.buf_start) // self.block_samples]

    def run(
        self, acquisitions: list[AcquisitionResult], duration_s: float | None = None, progress: Any = None
    ) -> TrackingResult:
        """Track every detected satellite of ``acquisitions`` (made on the first samples)
        for ``duration_s`` (default: the whole recording)."""
        self.block_samples = int(self.config.block_ms * 1e-3 * self.fs)
        self.reader = BlockReader(self.rec, self.block_samples if self.read_ahead else 0)
        try:
            return self._track(acquisitions, duration_s, progress)
        finally:
            self.reader.close()

    def _track(self, acquisitions: list[AcquisitionResult], duration_s: float | None, progress: Any) -> TrackingResult:
        cfg = self.config
        fs = self.fs
        stop = self.rec.n_samples if duration_s is None else min(self.rec.n_samples, int(duration_s * fs))
        self.channels: dict[int, SampleChannel] = {}
        self.records: dict[int, ChannelRecord] = {}
        self._reset_state()
        self.buf = self.rec.read_components(0, 0)
        self.buf_start = 0
        self.buf_power = np.zeros(0)
        tables_for, tables, tables_other = None, None, None
        code_length = self.signal.code_length_chips
        self.closer.bind(self)
        for acq in acquisitions:
            if acq.detected:
                self.add(acq.prn, acq, 0)
        every = self.reacquire_every = int(cfg.reacquire_every_ms * 1e-3 * fs)  # the clock's period (samples)
        next_reacq = every
        lag_limit = int(LAG_LIMIT_S * fs)
        while True:
            live = np.flatnonzero(self.active & ~self.finished)
            if live.size == 0:  # every channel lost (or at the end): only re-acquisition can go on
                if not self.channels or next_reacq >= min(stop, self.rec.n_samples):  # (a stream's, once ended)
                    break
                self.closer.reacquire(next_reacq, stop)
                next_reacq += every
                continue
            # Each channel runs its whole coherent interval per call; one that is ahead of
            # the last by more than LAG_LIMIT_S waits, so the buffer stays short.
            lead = self.start_sample[live]
            ok = lead <= lead.min() + lag_limit
            if self.batches and not ok.all():  # a batch's channels step together: all of it runs, or none
                for b in self.batches.values():
                    if len(b.slots) > 1:
                        in_batch = np.zeros(self.active.size, bool)
                        in_batch[b.slots] = True
                        members = in_batch[live]
                        if ok[members].any():
                            ok |= members
            idx = live[ok]
            steps = self.code_rate[idx] / fs
            phases = self.code_phase[idx]
            periods = self.coherent[idx]
            starts = self.start_sample[idx]
            ends = starts + np.ceil((periods * code_length - phases) / steps + 1).astype(np.int64)
            over = ends > stop
            if over.any():  # each channel runs to its own last whole interval, whatever the others do
                for i in idx[over].tolist():
                    self.finished[i] = True
                    self.leave_batch(self.channels[self.signal.prns[i]])
                continue
            buf, first = self._samples(int(starts.min()), int(ends.max()))
            if first + buf.shape[0] // (2 if self.rec.is_complex else 1) < ends.max():
                break  # a live stream ended
            if self.rec.dropped_between(int(starts.min()), int(ends.max())) is not None:  # a live stream's overrun
                after = self._lose_across(idx, starts, ends)
                if after is not None:
                    next_reacq = after
                    continue
            dop = self.doppler[idx]
            carrier0 = (self.if_hz * starts / fs) % 1.0 + self.doppler_cycles[idx]
            if tables_for is None or not np.array_equal(tables_for, idx):  # channel set changed: new tables
                tables_for, tables = idx, code_tables(self.codes[idx], self.table_offsets)
                if self.codes_other is not None:
                    tables_other = code_tables(self.codes_other[idx], self.table_offsets)

            pairs = [(self.codes, tables)]
            if self.codes_other is not None:  # the mean of the two ±1 tables' sums (`replica_code_pair`)
                pairs.append((self.codes_other, tables_other))
            results = [
                correlate_periods(
                    buf,
                    starts - first,
                    periods,
                    to_table_units(phases, self.signal),
                    to_table_units(steps, self.signal),
                    carrier0,
                    (self.if_hz + dop) / fs,
                    codes[idx],
                    self.table_offsets,
                    backend=self.backend,
                    tables=code_tables_,
                    iq=self.rec.is_complex,
                    q_sign=self.rec.info.q_sign,
                )
                for codes, code_tables_ in pairs
            ]
            sums, counts = results[0]
            if len(results) > 1:
                sums = 0.5 * (sums + results[1][0])
            # Normalised sums, NCO bookkeeping, 1 ms prompts and bit-sync votes (`intervals`).
            interval = close_periods(
                self.arrays,
                idx,
                sums,
                counts,
                starts,
                phases,
                steps,
                periods,
                dop,
                self._block_power(starts) * self.signal.replica_duty,  # the replica's sum of squares per sample
                fs,
                code_length,
                backend=self.backend,
            )
            self._step_filters(idx, interval)
            chans = [self.channels[self.signal.prns[i]] for i in idx.tolist()]
            for c in chans:
                self._bit_sync(c)
            run_detectors(chans, self.arrays, self.config, self.signal, self.detect_periods)
            # The rows' values as Python floats in one conversion per column.
            columns = zip(
                self.acc_t0[idx].tolist(),
                self.doppler[idx].tolist(),
                self.acc_phase[idx].tolist(),
                self.acc_cycles[idx].tolist(),
                interval[:, 1],
            )
            for c, values in zip(chans, columns):
                self._update(c, *values)
            if self.batch:
                self._join_batches(idx)
            self.closer.after_interval(idx)
            if progress is not None:
                progress(int(lead.min()) / stop)
            if lead.min() >= next_reacq:  # at the clock's tick, whichever channels run (`groups`)
                self.closer.reacquire(next_reacq, stop)
                next_reacq += every
        stop = min(stop, self.rec.n_samples)  # a live stream's length is known at its end
        result = TrackingResult(self.records, list(acquisitions), stop / fs, cfg.channel_filter)
        self.closer.finish(result)
        return result

    def search(self, prns: tuple[int, ...], at: int, stop: int) -> None:
        """The acquisition's full search for ``prns`` on the samples from ``at``; the ones
        found restart in ``pull-in`` (nothing when the recording ends first)."""
        need = self.acquisition.samples_needed(self.fs, self.signal)
        if not prns or at + need > stop:
            return
        samples = self.rec.read(at, need)
        if samples.shape[0] < need:  # a live stream ended
            return
        found = self.acquisition.acquire(samples, self.fs, self.if_hz, prns, self.signal)
        for acq in found:
            if acq.detected:
                self.records[acq.prn].events.append((at / self.fs, "re-acquired"))
                self.add(acq.prn, acq, at)

    def _lose_across(self, idx: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> int | None:
        """Channels of ``idx`` whose next interval ``[starts, ends)`` crosses samples a live
        stream dropped (an overrun) are lost (`deactivate`) until re-acquisition after the
        gap: their NCOs are not carried across it, so nothing is measured over it. The last
        such gap's end (None: no interval crosses one)."""
        after = None
        for i, lo, hi in zip(idx.tolist(), starts.tolist(), ends.tolist()):
            gap = self.rec.dropped_between(lo, hi)
            if gap is not None:
                what = (
                    f"overrun: samples {gap[0]}-{gap[1]} ({(gap[1] - gap[0]) / self.fs:.3f} s) dropped: lost "
                    "until re-acquired after them"
                )
                self.deactivate(self.channels[self.signal.prns[i]], gap[1], (gap[0] / self.fs, what))
                after = gap[1] if after is None else max(after, gap[1])
        return after

    def deactivate(self, c: SampleChannel, retry_at: int, event: tuple[float, str]) -> None:
        """Channel ``c`` is ``lost``: out of its batch and of the active channels until
        re-acquisition restarts it (not before sample ``retry_at``); ``event`` recorded."""
        c.stage = "lost"
        self.leave_batch(c)
        self.active[c.slot] = False
        c.retry_at = retry_at
        c.record.events.append(event)

    def _step_filters(self, idx: np.ndarray, acc: np.ndarray) -> None:
        """The coherent intervals of channels ``idx`` are complete (their E/P/L sums ``acc``,
        ``(len(idx), 3)``): step their filters, each batch at once, and steer their NCOs."""
        # Decision-directed bit wipe-off: a prompt turned by more than 90 degrees from the
        # previous one (more than a residual frequency error can turn it in one interval)
        # carries the other bit. Costas loops do not care; frequency discriminators on
        # consecutive prompts (FLL assist, the vector channels' FLL) would see a jump.
        sign = self.bit_sign[idx]
        sign = np.where((acc[:, 1] * sign * np.conj(self.last_prompt[idx])).real < 0, -sign, sign)
        self.bit_sign[idx] = sign
        wiped = acc * sign[:, None]
        self.last_prompt[idx] = wiped[:, 1]
        done: set[int] = set()
        step = self.closer.step
        prns = self.signal.prns
        for j, i in enumerate(idx.tolist()):
            c = self.channels[prns[i]]
            if c.batch is None:
                step(c.filter, c.closure, idx[j : j + 1], wiped[j : j + 1])
            elif id(c.batch) not in done:
                done.add(id(c.batch))
                slots = np.array(c.batch.slots)
                step(c.batch.filter, c.closure, slots, wiped[np.searchsorted(idx, slots)])  # idx ascends

    def _layout(self, key: tuple[str, int]) -> frozenset | None:
        """Per-channel state of the filter of stage ``key`` (`batch.batch_layout`), probed once."""
        if key not in self.layouts:
            stage, coherent_ms = key
            cfg = self.config
            T = coherent_ms * self.signal.code_period_s

            def make(shape: tuple[int, ...]) -> ChannelFilter:
                f = self.filters.new(stage)
                f.reset(shape, stage_context(cfg, T, 40.0, 0.0, self.signal))
                return f

            def step(f: ChannelFilter, k: int) -> None:
                one = np.ones(k)
                inputs: dict[str, Any] = {
                    "correlators": Correlators.trusted((5 + 1j) * one, (10 + 2j) * one, (4 - 1j) * one)
                }
                if not supports(type(f), *NCO_COMMANDS):
                    inputs.update(nco_shift_chips=0.0 * one, nco_shift_hz=0.0 * one)
                f.checked_step(inputs)

            try:
                self.layouts[key] = batch_layout(make, step)
            except Exception:  # noqa: BLE001 - a filter that cannot be probed steps alone
                self.layouts[key] = None
        return self.layouts[key]

    def _join_batches(self, idx: np.ndarray) -> None:
        """Merge the channels of ``idx`` that step alone into the batch of their stage."""
        for i in idx:
            c = self.channels[self.signal.prns[int(i)]]
            if c.batch is not None or not self.active[c.slot] or c.join_tries >= 3 or c.stage_ms == 0:
                continue  # (stage_ms 0: a stage just started, its filter has not stepped yet)
            key = (c.stage, c.coherent_ms)
            paths = self._layout(key)
            if paths is None:
                c.join_tries = 3
                continue
            b = self.batches.get(key)
            if b is None:
                if not FilterBatch.fits(c.filter, paths):
                    c.join_tries += 1
                    continue
                b = self.batches[key] = FilterBatch(c.filter, c.slot, paths)
            elif not b.join(c.filter, c.slot):
                c.join_tries += 1
                continue
            c.batch, c.filter = b, None
            self.largest_batch = max(self.largest_batch, len(b.slots))

    def leave_batch(self, c: SampleChannel) -> None:
        """Channel ``c`` steps alone from now on (out of the batch it was in, if any)."""
        b = c.batch
        if b is None:
            return
        key = next(k for k, v in self.batches.items() if v is b)
        if len(b.slots) == 1:
            del self.batches[key]
        else:
            b.leave(c.slot)
        c.batch = None

    def _bit_sync(self, c: SampleChannel) -> None:
        """Channel ``c`` in ``track``: its bit edge, once the histogram (or, with ``bit_sync =
        "energy"``, a full ring of prompts in lock) has decided it."""
        if c.stage == "track" and c.bit_edge is None:
            if self.config.bit_sync == "energy":
                edge = self._energy_edge(c)
            else:
                edge = bit_edge_from_votes(self.votes[c.slot], self.config.bit_sync_votes)
            if edge is not None:
                c.bit_edge = edge
                c.record.events.append(
                    (float(self.acc_t0[c.slot]), f"bit sync (edge at ms {edge} mod {c.periods_per_symbol})")
                )

    def _energy_edge(self, c: SampleChannel) -> int | None:
        """Channel ``c``'s bit edge by whole-bit energy (`lock.bit_edge_by_energy`) over its
        prompt ring, once the whole ring was tracked in lock (``track``)."""
        size = self.prompts.shape[1]
        per_bit = c.periods_per_symbol
        if c.stage_ms < size or self.n_prompts[c.slot] < size:
            return None
        i = c.slot
        window = self.prompts[i, (self.n_prompts[i] - size + np.arange(size)) % size]
        first = int(self.ms_index[i]) - size + 1
        return bit_edge_by_energy(window, first, per_bit, size // per_bit - 1)

    def _update(
        self,
        c: SampleChannel,
        t0: float,
        doppler_hz: float,
        code_phase_chips: float,
        carrier_cycles: float,
        prompt: complex,
    ) -> None:
        """Channel ``c``'s coherent interval is complete (its start time ``t0``, its NCOs
        then, its prompt sum; its filter has stepped, its detectors have run): run its state
        machine, record the row."""
        c.stage_ms += c.coherent_ms
        state = (int(c.locked), STAGES.index(c.stage), prompt.real, prompt.imag, c.coherent_ms)
        c.record.rows.append((t0, c.cn0_dbhz, c.pli, doppler_hz, code_phase_chips, carrier_cycles, *state))
        self.closer.advance(c, t0)
