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

Noise scaling: the I and Q noise of a 1 ms sum of N samples of power P (one real or
complex sample's mean square) against a ±1 code and a unit carrier is N P / 2 per
component for white noise; the scale is measured on every block read.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ... import registry
from ...errors import ConfigError
from ...interfaces import ChannelFilter, RunContext
from ...signal.codes import ca_code
from ...signal.constants import CA_CHIP_RATE_HZ, CA_CODE_LENGTH, L1_FREQ_HZ
from ...signal.correlator_model import tap_offsets
from ...signal.correlators import Correlators
from ..acquisition.search import Acquisition, AcquisitionResult
from ..frontend.recording import Recording
from ..tracking.scalar import NCO_COMMANDS
from .batch import FilterBatch, batch_layout
from .closure import ERROR_OUTPUTS, ErrorFeedback
from .config import TrackingConfig
from .correlator import code_tables, correlate_periods
from .prefetch import BlockReader
from .intervals import ChannelArrays, close_periods
from ...signal.cn0 import cn0_moments
from .lock import bit_edge_from_votes, cn0_nwpr_bits, estimate_cn0, phase_lock_indicator

__all__ = ["ChannelRecord", "TrackingResult", "SampleTracker", "STAGES", "RECORD_FIELDS"]

#: How far (s) a channel may run ahead of the last one before it waits.
LAG_LIMIT_S = 0.025
#: Interval (ms) between two evaluations of a channel's lock detectors.
DETECT_MS = 20
#: Channel states, in the order a channel goes through them.
STAGES = ("pull-in", "track", "extended", "lost", "vector")
#: Columns of a channel's record (one row per channel-filter update).
RECORD_FIELDS = ("time_s", "cn0_dbhz", "pli", "doppler_hz", "code_phase_chips", "carrier_phase_cycles", "lock",
                 "stage", "prompt_i", "prompt_q", "coherent_ms")


@dataclass
class ChannelRecord:
    """What one satellite's channel did: one row per channel-filter update (`RECORD_FIELDS`),
    and the events (``(time_s, text)``: lock, bit sync, loss, re-acquisition)."""

    prn: int
    rows: list[tuple] = field(default_factory=list)
    events: list[tuple[float, str]] = field(default_factory=list)

    def column(self, name: str) -> np.ndarray:
        i = RECORD_FIELDS.index(name)
        return np.array([r[i] for r in self.rows])


@dataclass
class TrackingResult:
    """Records per PRN, the acquisition that started them, and what the run covered."""

    channels: dict[int, ChannelRecord]
    acquisitions: list[AcquisitionResult]
    duration_s: float
    channel_filter: str


def _supports(cls: type, *names: str) -> bool:
    return all(n in cls.provides for n in names)


def _create_filter(name: str, params: dict[str, Any], *, pll_only: bool = False) -> ChannelFilter:
    cls = registry.get("channel_filter", name)
    if "correlators" not in cls.requires or not (_supports(cls, *NCO_COMMANDS) or _supports(cls, *ERROR_OUTPUTS)):
        raise ConfigError("channel_filter", f"{name!r} cannot track on samples: it must require 'correlators' and "
                          f"provide {', '.join(NCO_COMMANDS)} or {', '.join(ERROR_OUTPUTS)}")
    params = dict(params)
    if pll_only and "fll_bandwidth_hz" in cls.Params.model_fields:
        params["fll_bandwidth_hz"] = 0.0  # the PLL stage: no FLL assist
    return registry.create("channel_filter", name, **params)


def stage_context(c: TrackingConfig, T: float, cn0_dbhz: float, doppler_hz: float) -> RunContext:
    """What a channel filter is reset with at the start of a stage."""
    return RunContext(coherent_time_s=T, early_late_spacing_chips=c.early_late_spacing_chips, epoch_interval_s=T,
                      cn0_dbhz=cn0_dbhz, doppler_hz=doppler_hz)


def _stage_filter(c: TrackingConfig, stage: str) -> tuple[str, dict[str, Any]]:
    return (c.pull_in_filter, c.pull_in_params) if stage == "pull-in" else (c.channel_filter, c.channel_params)


class _Channel:
    """One satellite's channel: its stage, filter and detectors (its NCOs and sums live in
    the tracker's arrays, at slot ``prn - 1``)."""

    def __init__(self, prn: int, config: TrackingConfig, record: ChannelRecord) -> None:
        self.prn = prn
        self.slot = prn - 1
        self.config = config
        self.record = record
        self.cn0_dbhz = 0.0
        self.pli = 0.0
        self.locked = False
        self.failures = 0  # pull-ins in a row that ended without lock
        self.retry_at = 0  # first sample at which re-acquisition may try again

    def start(self, stage: str, doppler_hz: float, coherent_ms: int) -> None:
        c = self.config
        self.stage = stage
        self.coherent_ms = coherent_ms
        name, params = _stage_filter(c, stage)
        self.filter = _create_filter(name, params, pll_only=stage == "extended")
        T = coherent_ms * 1e-3
        self.closure = (None if _supports(type(self.filter), *NCO_COMMANDS)
                        else ErrorFeedback(c.closure_fll_bandwidth_hz, c.closure_dll_bandwidth_hz, T))
        cn0 = self.cn0_dbhz if self.cn0_dbhz > 0 else 40.0
        # A batch of one: the tracker merges it into the batch of its stage (`batch`).
        self.filter.reset((1,), stage_context(c, T, cn0, doppler_hz))
        self.batch: FilterBatch | None = None
        self.join_tries = 0
        self.stage_ms = 0
        if stage == "pull-in":
            self.unlocked_ms = 0
            self.bit_edge: int | None = None
            self.next_detect = 0

    @property
    def phase_locking(self) -> bool:
        return self.closure is None


_SLOTS = 32  # one per GPS PRN


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
    """

    def __init__(self, recording: Recording, config: TrackingConfig, acquisition: Acquisition,
                 backend: str | None = None, batch: bool = True, read_ahead: bool = True) -> None:
        self.rec = recording
        self.batch = batch
        self.read_ahead = read_ahead
        self.config = config
        self.acquisition = acquisition
        self.backend = backend
        self.fs = recording.info.sample_rate_hz
        self.if_hz = recording.info.if_hz
        self.offsets = np.array(list(tap_offsets(config.early_late_spacing_chips).values()))
        _create_filter(config.channel_filter, config.channel_params)  # refuse a bad filter before any work
        _create_filter(config.pull_in_filter, config.pull_in_params)
        self.codes = np.stack([ca_code(p) for p in range(1, _SLOTS + 1)]).astype(np.float32)

    def _reset_state(self) -> None:
        n, w = _SLOTS, self.config.cn0_window_ms
        self.active = np.zeros(n, bool)
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
        self.votes = np.zeros((n, 20), np.int64)  # bit-sync histograms
        self.voting = np.zeros(n, bool)
        self.previous_prompt = np.zeros(n, complex)
        self.bit_sign = np.ones(n)  # decision-directed bit wipe-off
        self.last_prompt = np.zeros(n, complex)  # last wiped prompt handed to the filter
        self.shift_chips = np.zeros(n)  # NCO moves of an error-output filter's closure
        self.shift_hz = np.zeros(n)
        self.arrays = ChannelArrays(self.acc_t0, self.acc_phase, self.acc_cycles, self.start_sample, self.code_phase,
                                    self.doppler_cycles, self.prompts, self.n_prompts, self.ms_index,
                                    self.previous_prompt, self.voting, self.votes)
        self.batches: dict[tuple[str, int], FilterBatch] = {}
        self.layouts: dict[tuple[str, int], frozenset | None] = {}

    def _add(self, prn: int, acq: AcquisitionResult, first_sample: int) -> None:
        ch = self.channels.get(prn)
        if ch is None:
            ch = self.channels[prn] = _Channel(prn, self.config, self.records.setdefault(prn, ChannelRecord(prn)))
        i = ch.slot
        self.active[i] = True
        self.start_sample[i] = first_sample + acq.code_phase_samples
        self.code_phase[i] = 0.0  # a code epoch
        self.doppler[i] = acq.doppler_hz
        self.code_rate[i] = CA_CHIP_RATE_HZ * (1 + acq.doppler_hz / L1_FREQ_HZ)
        self.doppler_cycles[i] = 0.0
        self.ms_index[i] = 0
        self.n_prompts[i] = 0
        self.votes[i] = 0
        self.voting[i] = True
        self.previous_prompt[i] = 0j
        ch.cn0_dbhz = acq.cn0_dbhz
        self._start(ch, "pull-in", acq.doppler_hz, 1)

    def _start(self, ch: _Channel, stage: str, doppler_hz: float, coherent_ms: int) -> None:
        self._leave_batch(ch)
        ch.start(stage, doppler_hz, coherent_ms)
        i = ch.slot
        self.bit_sign[i] = 1.0
        self.last_prompt[i] = 0j
        self.shift_chips[i] = self.shift_hz[i] = 0.0
        self.coherent[i] = coherent_ms
        self.voting[i] = stage != "extended"

    def _samples(self, lo: int, hi: int) -> tuple[np.ndarray, int]:
        """A buffer holding samples ``[lo, hi)``, read in blocks as the file stores them
        (`Recording.read_components`: interleaved I/Q components or real values, no float
        copy); ``(buffer, its first sample)``."""
        per = 2 if self.rec.is_complex else 1  # buffer values per sample
        held = self.buf.shape[0] // per
        if self.buf_start <= lo and hi <= self.buf_start + held:
            return self.buf, self.buf_start
        keep = self.buf[max(0, lo - self.buf_start) * per:] if lo < self.buf_start + held else self.buf[:0]
        first = max(lo, self.buf_start + held) if keep.size else lo
        block = max(hi - first, int(self.config.block_ms * 1e-3 * self.fs))
        new, squares = self.reader.read(first, block)
        self.buf = np.concatenate([keep, new]) if keep.size else new
        self.buf_start = first - keep.shape[0] // per
        if new.size:  # mean square of a sample (|I|^2 + |Q|^2 for I/Q); no BLAS call (its threads spin)
            self.power = squares * per / new.size
        return self.buf, self.buf_start

    def run(self, acquisitions: list[AcquisitionResult], duration_s: float | None = None,
            progress: Any = None) -> TrackingResult:
        """Track every detected satellite of ``acquisitions`` (made on the first samples)
        for ``duration_s`` (default: the whole recording)."""
        ahead = int(self.config.block_ms * 1e-3 * self.fs) if self.read_ahead else 0
        self.reader = BlockReader(self.rec, ahead)
        try:
            return self._track(acquisitions, duration_s, progress)
        finally:
            self.reader.close()

    def _track(self, acquisitions: list[AcquisitionResult], duration_s: float | None,
               progress: Any) -> TrackingResult:
        cfg = self.config
        fs = self.fs
        stop = self.rec.n_samples if duration_s is None else min(self.rec.n_samples, int(duration_s * fs))
        self.channels: dict[int, _Channel] = {}
        self.records: dict[int, ChannelRecord] = {}
        self._reset_state()
        self.buf = self.rec.read_components(0, 0)
        self.buf_start = 0
        self.power = 1.0
        tables_for, tables = None, None
        for acq in acquisitions:
            if acq.detected:
                self._add(acq.prn, acq, 0)
        every = int(cfg.reacquire_every_ms * 1e-3 * fs)
        next_reacq = every
        lag_limit = int(LAG_LIMIT_S * fs)
        while True:
            live = np.flatnonzero(self.active)
            if live.size == 0:  # every channel lost: only re-acquisition can go on
                if not self.channels or next_reacq >= stop:
                    break
                self._reacquire(next_reacq, stop)
                next_reacq += every
                continue
            # Each channel runs its whole coherent interval per call; one that is ahead of
            # the last by more than LAG_LIMIT_S waits, so the buffer stays short.
            lead = self.start_sample[live]
            ok = lead <= lead.min() + lag_limit
            if self.batches and not ok.all():  # a batch's channels step together: all of it runs, or none
                for b in self.batches.values():
                    if len(b.slots) > 1:
                        in_batch = np.zeros(_SLOTS, bool)
                        in_batch[b.slots] = True
                        members = in_batch[live]
                        if ok[members].any():
                            ok |= members
            idx = live[ok]
            steps = self.code_rate[idx] / fs
            phases = self.code_phase[idx]
            periods = self.coherent[idx]
            starts = self.start_sample[idx]
            ends = starts + np.ceil((periods * CA_CODE_LENGTH - phases) / steps + 1).astype(np.int64)
            if ends.max() > stop:
                break
            buf, first = self._samples(int(starts.min()), int(ends.max()))
            dop = self.doppler[idx]
            carrier0 = (self.if_hz * starts / fs) % 1.0 + self.doppler_cycles[idx]
            if tables_for is None or not np.array_equal(tables_for, idx):  # channel set changed: new tables
                tables_for, tables = idx, code_tables(self.codes[idx], self.offsets)
            sums, counts = correlate_periods(buf, starts - first, periods, phases, steps, carrier0,
                                             (self.if_hz + dop) / fs, self.codes[idx], self.offsets,
                                             backend=self.backend, tables=tables, iq=self.rec.is_complex,
                                             q_sign=self.rec.info.q_sign)
            # Normalised sums, NCO bookkeeping, 1 ms prompts and bit-sync votes (`intervals`).
            interval = close_periods(self.arrays, idx, sums, counts, starts, phases, steps, periods, dop, self.power,
                                     fs, CA_CODE_LENGTH, backend=self.backend)
            self._step_filters(idx, interval)
            chans = [self.channels[i + 1] for i in idx.tolist()]
            for c in chans:
                self._bit_sync(c)
            self._detect(chans)
            # The rows' values as Python floats in one conversion per column.
            columns = zip(self.acc_t0[idx].tolist(), self.doppler[idx].tolist(), self.acc_phase[idx].tolist(),
                          self.acc_cycles[idx].tolist(), interval[:, 1])
            for c, values in zip(chans, columns):
                self._update(c, *values)
            if self.batch:
                self._join_batches(idx)
            self._after_interval(idx)
            if progress is not None:
                progress(int(lead.min()) / stop)
            if lead.min() >= next_reacq:
                self._reacquire(int(lead.max()), stop)
                next_reacq += every
        return TrackingResult(self.records, list(acquisitions), stop / fs, cfg.channel_filter)

    def _after_interval(self, idx: np.ndarray) -> None:
        """Channels ``idx`` have completed an interval and recorded it (a subclass's hook:
        `gnssframework.receiver.navigation.vector_tracking` closes their NCOs here)."""

    def _reacquire(self, at: int, stop: int) -> None:
        lost = tuple(p for p, c in self.channels.items() if c.stage == "lost" and c.retry_at <= at)
        need = self.acquisition.samples_needed(self.fs)
        if not lost or at + need > stop:
            return
        found = self.acquisition.acquire(self.rec.read(at, need), self.fs, self.if_hz, lost)
        for acq in found:
            if acq.detected:
                self.records[acq.prn].events.append((at / self.fs, "re-acquired"))
                self._add(acq.prn, acq, at)

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
        for j, i in enumerate(idx.tolist()):
            c = self.channels[i + 1]
            if c.batch is None:
                self._step(c.filter, c.closure, idx[j:j + 1], wiped[j:j + 1])
            elif id(c.batch) not in done:
                done.add(id(c.batch))
                slots = np.array(c.batch.slots)
                self._step(c.batch.filter, c.closure, slots, wiped[np.searchsorted(idx, slots)])  # idx ascends

    def _step(self, filt: ChannelFilter, closure: ErrorFeedback | None, slots: np.ndarray, w: np.ndarray) -> None:
        """One step of the filter of channels ``slots`` (its batch, in order) on their wiped sums ``w``."""
        inputs: dict[str, Any] = {"correlators": Correlators.trusted(w[:, 0], w[:, 1], w[:, 2])}
        if closure is not None:
            inputs.update(nco_shift_chips=self.shift_chips[slots], nco_shift_hz=self.shift_hz[slots])
        out = filt.checked_step(inputs)
        if closure is None:
            self.doppler[slots] = out["carrier_freq_hz"]
            self.code_rate[slots] = out["code_freq_hz"]
            if "carrier_phase_step_rad" in out:
                self.doppler_cycles[slots] += np.asarray(out["carrier_phase_step_rad"], float) / (2 * np.pi)
        else:
            code_step = closure.k_code * np.asarray(out["code_error_chips"], float)
            freq_step = closure.k_freq * np.asarray(out["freq_error_hz"], float)
            self.shift_chips[slots] = code_step
            self.shift_hz[slots] = freq_step
            self.doppler[slots] += freq_step
            self.code_phase[slots] += code_step
            self.code_rate[slots] = CA_CHIP_RATE_HZ * (1 + self.doppler[slots] / L1_FREQ_HZ)

    def _layout(self, key: tuple[str, int]) -> frozenset | None:
        """Per-channel state of the filter of stage ``key`` (`batch.batch_layout`), probed once."""
        if key not in self.layouts:
            stage, coherent_ms = key
            cfg = self.config
            name, params = _stage_filter(cfg, stage)
            T = coherent_ms * 1e-3

            def make(shape: tuple[int, ...]) -> ChannelFilter:
                f = _create_filter(name, params, pll_only=stage == "extended")
                f.reset(shape, stage_context(cfg, T, 40.0, 0.0))
                return f

            def step(f: ChannelFilter, k: int) -> None:
                one = np.ones(k)
                inputs: dict[str, Any] = {"correlators": Correlators.trusted((5 + 1j) * one, (10 + 2j) * one,
                                                                              (4 - 1j) * one)}
                if not _supports(type(f), *NCO_COMMANDS):
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
            c = self.channels[int(i) + 1]
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

    def _leave_batch(self, c: _Channel) -> None:
        b = getattr(c, "batch", None)
        if b is None:
            return
        key = next(k for k, v in self.batches.items() if v is b)
        if len(b.slots) == 1:
            del self.batches[key]
        else:
            b.leave(c.slot)
        c.batch = None

    def _bit_sync(self, c: _Channel) -> None:
        """Channel ``c`` in ``track``: its bit edge, once the histogram has decided it."""
        if c.stage == "track" and c.bit_edge is None:
            edge = bit_edge_from_votes(self.votes[c.slot], self.config.bit_sync_votes)
            if edge is not None:
                c.bit_edge = edge
                c.record.events.append((float(self.acc_t0[c.slot]), f"bit sync (edge at ms {edge} mod 20)"))

    def _update(self, c: _Channel, t0: float, doppler_hz: float, code_phase_chips: float, carrier_cycles: float,
                prompt: complex) -> None:
        """Channel ``c``'s coherent interval is complete (its start time ``t0``, its NCOs
        then, its prompt sum; its filter has stepped, its detectors have run): run its state
        machine, record the row."""
        c.stage_ms += c.coherent_ms
        c.record.rows.append((t0, c.cn0_dbhz, c.pli, doppler_hz, code_phase_chips, carrier_cycles, int(c.locked),
                              STAGES.index(c.stage), prompt.real, prompt.imag, c.coherent_ms))
        self._advance(c, t0)

    def _window(self, c: _Channel, n: int) -> np.ndarray:
        """The last ``n`` 1 ms prompts of channel ``c``, oldest first."""
        i = c.slot
        size = self.prompts.shape[1]
        n = min(n, int(self.n_prompts[i]), size)
        return self.prompts[i, (self.n_prompts[i] - n + np.arange(n)) % size]

    def _detect(self, chans: list[_Channel]) -> None:
        """Lock detectors of channels ``chans``, evaluated every `DETECT_MS` (their windows are
        10-100 times longer): on arrays over the channels whose prompt window is full."""
        cfg = self.config
        size = self.prompts.shape[1]
        full = []
        for c in chans:
            ms = int(self.ms_index[c.slot])
            if self.n_prompts[c.slot] < min(cfg.lock_window_ms, 20):
                c.locked = False
            elif ms >= c.next_detect:
                c.next_detect = ms + DETECT_MS
                if self.n_prompts[c.slot] >= size:
                    full.append(c)
                else:
                    self._detect_one(c, ms)
        if not full:
            return
        slots = np.array([c.slot for c in full])
        win = self.prompts[slots[:, None], (self.n_prompts[slots][:, None] - size + np.arange(size)) % size]
        lock = win[:, size - min(cfg.lock_window_ms, size):]
        power = np.sum(lock.real**2 + lock.imag**2, axis=1)
        pli = np.sum(lock.real**2 - lock.imag**2, axis=1) / np.where(power > 0, power, 1.0)
        pli[power <= 0] = 0.0
        # C/N0: NWPR on each channel's whole bits from its bit phase (index in the window of
        # a bit's first ms) on, all such channels in one pass; moments, which need no bit
        # phase, on the others.
        phases = [self._bit_phase(c, int(self.ms_index[c.slot]), size) for c in full]
        cn0 = np.zeros(len(full))
        nwpr = [j for j, bp in enumerate(phases)
                if cfg.cn0_estimator == "nwpr" and bp is not None and size - bp >= 20]
        rest = sorted(set(range(len(full))) - set(nwpr))
        if rest:
            cn0[rest] = cn0_moments(win[rest].T, 1e-3)
        if nwpr:
            cn0[nwpr] = cn0_nwpr_bits(win[nwpr], np.array([phases[j] for j in nwpr]), 1e-3, m=20)
        for j, c in enumerate(full):
            c.pli, c.cn0_dbhz = float(pli[j]), float(cn0[j])
            self._lock_decision(c)

    @staticmethod
    def _bit_phase(c: _Channel, ms: int, n: int) -> int | None:
        """Index in a window of the last ``n`` prompts up to ``ms`` of the first ms of a bit."""
        return None if c.bit_edge is None else (c.bit_edge - (ms - n + 1)) % 20

    def _lock_decision(self, c: _Channel) -> None:
        cfg = self.config
        strong = c.cn0_dbhz > cfg.cn0_threshold_dbhz
        c.locked = strong and (c.pli > cfg.pli_threshold or not c.phase_locking)

    def _detect_one(self, c: _Channel, ms: int) -> None:
        """Lock detectors of a channel whose window is not full yet."""
        cfg = self.config
        c.pli = phase_lock_indicator(self._window(c, cfg.lock_window_ms))
        prompts = self._window(c, cfg.cn0_window_ms)
        c.cn0_dbhz = estimate_cn0(prompts, cfg.cn0_estimator, self._bit_phase(c, ms, prompts.size))
        self._lock_decision(c)

    def _advance(self, c: _Channel, t0: float) -> None:
        """The state machine: pull-in -> track -> extended; lost after ``loss_ms`` out of lock."""
        cfg = self.config
        c.unlocked_ms = 0 if c.locked else c.unlocked_ms + c.coherent_ms
        if c.stage == "pull-in":
            if c.locked and c.stage_ms >= cfg.lock_window_ms:
                c.failures = 0
                c.record.events.append((t0, "locked: tracking with " + cfg.channel_filter))
                self._start(c, "track", float(self.doppler[c.slot]), 1)
            elif c.stage_ms >= cfg.pull_in_ms:
                self._lose(c, t0, f"no lock within {cfg.pull_in_ms} ms of pull-in")
            return
        if c.unlocked_ms >= cfg.loss_ms:
            self._lose(c, t0, f"lock lost for {cfg.loss_ms} ms")
            return
        if (c.stage == "track" and cfg.coherent_ms > 1 and c.bit_edge is not None
                and (int(self.ms_index[c.slot]) + 1) % 20 == c.bit_edge % 20):
            # The next millisecond starts a bit: integrations from here on are bit aligned.
            c.record.events.append((t0, f"extended to {cfg.coherent_ms} ms coherent (PLL)"))
            self._start(c, "extended", float(self.doppler[c.slot]), cfg.coherent_ms)

    def _lose(self, c: _Channel, t0: float, why: str) -> None:
        """Hand the channel back to acquisition. A satellite whose pull-ins keep failing (a
        false detection, a signal too weak to lock) is searched again after 1, 2, 4 ...
        up to 32 re-acquisition intervals, so it does not cost a search every interval."""
        if c.stage == "pull-in":
            c.failures += 1
        c.stage = "lost"
        self._leave_batch(c)
        self.active[c.slot] = False
        wait = self.config.reacquire_every_ms * 1e-3 * self.fs * 2 ** min(max(c.failures - 1, 0), 5)
        c.retry_at = int(self.start_sample[c.slot] + wait)
        c.record.events.append((t0, f"lost: {why}; back to acquisition"))
