"""Sample-driven tracking: channel filters on real (or generated) samples.

Each channel integrates over exactly one code period of its own replica, from code
epoch to code epoch (not fixed-length blocks): the number of samples of the next
integration is what the code NCO needs to reach the next epoch. All channels advance one
code period per iteration and are correlated by one call of the compiled multi-channel
correlator (`correlator.correlate_channels`), on a buffer that streams the recording in
blocks. The 1 ms correlators, scaled to unit-variance I and Q noise like the analytic
model's (`gnssframework.signal.correlator_model`), are summed over the coherent interval
in force and then handed to the channel filter exactly as `gnssframework.receiver.tracking`
hands them: ``checked_step({"correlators": ...})`` once per interval, whose
``carrier_freq_hz`` and ``code_freq_hz`` (and optional ``carrier_phase_step_rad``) steer
the NCOs of the next interval. Filters that output errors instead (the vector-tracking
channel filters) are closed by `closure.ErrorFeedback`.

Noise scaling: the I and Q noise of a 1 ms sum of N samples of power P (one real or
complex sample's mean square) against a ±1 code and a unit carrier is N P / 2 per
component for white noise; the scale is measured on every block read.
"""

from __future__ import annotations

from collections import deque
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
from ..tracking import NCO_COMMANDS
from .closure import ERROR_OUTPUTS, ErrorFeedback
from .config import TrackingConfig
from .correlator import correlate_channels
from .lock import BitSync, estimate_cn0, phase_lock_indicator

__all__ = ["ChannelRecord", "TrackingResult", "SampleTracker", "STAGES", "RECORD_FIELDS"]

#: Channel states, in the order a channel goes through them.
STAGES = ("pull-in", "track", "extended", "lost")
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


class _Channel:
    """One satellite's channel: its state machine, filter and detectors."""

    def __init__(self, prn: int, config: TrackingConfig, record: ChannelRecord) -> None:
        self.prn = prn
        self.config = config
        self.record = record
        self.code = ca_code(prn).astype(np.float32)
        self.prompts: deque = deque(maxlen=config.cn0_window_ms)
        self.cn0_dbhz = 0.0
        self.pli = 0.0

    def start(self, stage: str, doppler_hz: float, coherent_ms: int, ms_index: int = 0) -> None:
        c = self.config
        self.stage = stage
        self.coherent_ms = coherent_ms
        name, params = (c.pull_in_filter, c.pull_in_params) if stage == "pull-in" else (c.channel_filter,
                                                                                      c.channel_params)
        self.filter = _create_filter(name, params, pll_only=stage == "extended")
        T = coherent_ms * 1e-3
        self.closure = (None if _supports(type(self.filter), *NCO_COMMANDS)
                        else ErrorFeedback(c.closure_fll_bandwidth_hz, c.closure_dll_bandwidth_hz, T))
        cn0 = self.cn0_dbhz if self.cn0_dbhz > 0 else 40.0
        self.filter.reset((), RunContext(coherent_time_s=T, early_late_spacing_chips=c.early_late_spacing_chips,
                                         epoch_interval_s=T, cn0_dbhz=cn0, doppler_hz=doppler_hz))
        self.acc = np.zeros(3, complex)
        self.acc_n = 0
        self.bit_sign = 1.0
        self.last_prompt = 0j
        self.shift = (0.0, 0.0)
        if stage == "pull-in":
            self.ms_index = ms_index
            self.stage_ms = 0
            self.unlocked_ms = 0
            self.bit_sync = BitSync(c.bit_sync_votes)
            self.bit_edge: int | None = None
            self.prompts.clear()

    @property
    def phase_locking(self) -> bool:
        return self.closure is None


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
    """

    def __init__(self, recording: Recording, config: TrackingConfig, acquisition: Acquisition,
                 backend: str | None = None) -> None:
        self.rec = recording
        self.config = config
        self.acquisition = acquisition
        self.backend = backend
        self.fs = recording.info.sample_rate_hz
        self.if_hz = recording.info.if_hz
        self.offsets = np.array(list(tap_offsets(config.early_late_spacing_chips).values()))
        _create_filter(config.channel_filter, config.channel_params)  # refuse a bad filter before any work
        _create_filter(config.pull_in_filter, config.pull_in_params)

    # -- channel NCO state, one slot per channel ------------------------------------
    def _add(self, prn: int, acq: AcquisitionResult, first_sample: int) -> None:
        ch = self.channels.get(prn)
        if ch is None:
            ch = self.channels[prn] = _Channel(prn, self.config, self.records.setdefault(prn, ChannelRecord(prn)))
        ch.start_sample = first_sample + acq.code_phase_samples
        ch.code_phase = 0.0  # chips at start_sample: a code epoch
        ch.doppler_hz = acq.doppler_hz
        ch.code_rate_hz = CA_CHIP_RATE_HZ * (1 + acq.doppler_hz / L1_FREQ_HZ)
        ch.doppler_cycles = 0.0
        ch.cn0_dbhz = acq.cn0_dbhz
        ch.start("pull-in", acq.doppler_hz, 1)

    def _samples(self, lo: int, hi: int) -> tuple[np.ndarray, int]:
        """A buffer holding samples ``[lo, hi)``, read in blocks; ``(buffer, its first sample)``."""
        if self.buf_start <= lo and hi <= self.buf_start + self.buf.shape[0]:
            return self.buf, self.buf_start
        keep = self.buf[max(0, lo - self.buf_start):] if lo < self.buf_start + self.buf.shape[0] else self.buf[:0]
        first = max(lo, self.buf_start + self.buf.shape[0]) if keep.size else lo
        block = max(hi - first, int(self.config.block_ms * 1e-3 * self.fs))
        new = self.rec.read(first, block)
        self.buf = np.concatenate([keep, new]) if keep.size else new
        self.buf_start = first - keep.shape[0]
        x = new.astype(np.complex128) if np.iscomplexobj(new) else new.astype(float)
        self.power = float(np.mean(np.abs(x) ** 2)) if x.size else self.power
        return self.buf, self.buf_start

    def run(self, acquisitions: list[AcquisitionResult], duration_s: float | None = None,
            progress: Any = None) -> TrackingResult:
        """Track every detected satellite of ``acquisitions`` (made on the first samples)
        for ``duration_s`` (default: the whole recording)."""
        cfg = self.config
        stop = self.rec.n_samples if duration_s is None else min(self.rec.n_samples, int(duration_s * self.fs))
        self.channels: dict[int, _Channel] = {}
        self.records: dict[int, ChannelRecord] = {}
        self.buf = self.rec.read(0, 0)
        self.buf_start = 0
        self.power = 1.0
        for acq in acquisitions:
            if acq.detected:
                self._add(acq.prn, acq, 0)
        every = int(cfg.reacquire_every_ms * 1e-3 * self.fs)
        next_reacq = every
        while True:
            active = [c for c in self.channels.values() if c.stage != "lost"]
            if not active:  # every channel lost: only re-acquisition can go on
                if not self.channels or next_reacq >= stop:
                    break
                self._reacquire(next_reacq, stop)
                next_reacq += every
                continue
            steps = np.array([c.code_rate_hz / self.fs for c in active])
            phases = np.array([c.code_phase for c in active])
            counts = np.ceil((CA_CODE_LENGTH - phases) / steps).astype(np.int64)
            starts = np.array([c.start_sample for c in active], np.int64)
            if (starts + counts).max() > stop:
                break
            buf, first = self._samples(int(starts.min()), int((starts + counts).max()))
            carrier_step = np.array([(self.if_hz + c.doppler_hz) / self.fs for c in active])
            carrier0 = np.array([self.if_hz * c.start_sample / self.fs % 1.0 + c.doppler_cycles for c in active])
            corr = correlate_channels(buf, starts - first, counts, phases, steps, carrier0, carrier_step,
                                      np.stack([c.code for c in active]), self.offsets, backend=self.backend)
            corr /= np.sqrt(counts * self.power / 2)[:, None]
            for c, n, row in zip(active, counts, corr):
                self._epoch(c, int(n), row)
            if progress is not None:
                progress(int(starts.min()) / stop)
            if starts.min() >= next_reacq:
                self._reacquire(int(starts.max()), stop)
                next_reacq += every
        return TrackingResult(self.records, list(acquisitions), stop / self.fs, cfg.channel_filter)

    def _reacquire(self, at: int, stop: int) -> None:
        lost = tuple(p for p, c in self.channels.items() if c.stage == "lost")
        need = self.acquisition.samples_needed(self.fs)
        if not lost or at + need > stop:
            return
        found = self.acquisition.acquire(self.rec.read(at, need), self.fs, self.if_hz, lost)
        for acq in found:
            if acq.detected:
                self.records[acq.prn].events.append((at / self.fs, "re-acquired"))
                self._add(acq.prn, acq, at)

    def _epoch(self, c: _Channel, n: int, taps: np.ndarray) -> None:
        """Book one code period of channel ``c``; step its filter when its interval is complete."""
        cfg = self.config
        t0 = c.start_sample / self.fs
        start_phase = c.code_phase
        c.start_sample += n
        c.code_phase += n * c.code_rate_hz / self.fs - CA_CODE_LENGTH
        c.doppler_cycles += n * c.doppler_hz / self.fs
        prompt = complex(taps[1])
        c.prompts.append(prompt)
        c.ms_index += 1
        c.stage_ms += 1
        if c.stage != "extended":
            edge = c.bit_sync.add(c.ms_index, prompt)
            if edge is not None and c.bit_edge is None and c.stage == "track":
                c.bit_edge = edge
                c.record.events.append((t0, f"bit sync (edge at ms {edge} mod 20)"))
        if c.acc_n == 0:
            c.acc_t0, c.acc_phase = t0, start_phase
            c.acc_cycles = c.doppler_cycles - n * c.doppler_hz / self.fs
        c.acc += taps
        c.acc_n += 1
        if c.acc_n < c.coherent_ms:
            return
        # Decision-directed bit wipe-off: a prompt turned by more than 90 degrees from the
        # previous one (more than a residual frequency error can turn it in one interval)
        # carries the other bit. Costas loops do not care; frequency discriminators on
        # consecutive prompts (FLL assist, the vector channels' FLL) would see a jump.
        if (c.acc[1] * c.bit_sign * np.conj(c.last_prompt)).real < 0:
            c.bit_sign = -c.bit_sign
        wiped = c.acc * c.bit_sign
        c.last_prompt = wiped[1]
        corr = Correlators.trusted(np.asarray(wiped[0]), np.asarray(wiped[1]), np.asarray(wiped[2]))
        inputs: dict[str, Any] = {"correlators": corr}
        if c.closure is not None:
            inputs.update(nco_shift_chips=np.asarray(c.shift[0]), nco_shift_hz=np.asarray(c.shift[1]))
        out = c.filter.checked_step(inputs)
        if c.closure is None:
            c.doppler_hz = float(out["carrier_freq_hz"])
            c.code_rate_hz = float(out["code_freq_hz"])
            step = float(out.get("carrier_phase_step_rad", 0.0)) / (2 * np.pi)
            c.doppler_cycles += step
        else:
            code_step, freq_step = c.closure.moves(out)
            c.shift = (code_step, freq_step)
            c.doppler_hz += freq_step
            c.code_phase += code_step
            c.code_rate_hz = CA_CHIP_RATE_HZ * (1 + c.doppler_hz / L1_FREQ_HZ)
        prompt_sum = complex(c.acc[1])
        c.acc[:] = 0.0
        c.acc_n = 0
        self._detect(c, t0)
        c.record.rows.append((c.acc_t0, c.cn0_dbhz, c.pli, c.doppler_hz, c.acc_phase, c.acc_cycles, int(c.locked),
                              STAGES.index(c.stage), prompt_sum.real, prompt_sum.imag, c.coherent_ms))
        self._advance(c, t0)

    def _detect(self, c: _Channel, t0: float) -> None:
        cfg = self.config
        window = list(c.prompts)[-cfg.lock_window_ms:]
        if len(window) < min(cfg.lock_window_ms, 20):
            c.locked = False
            return
        c.pli = phase_lock_indicator(window)
        bit_phase = None
        if c.bit_edge is not None:  # index in the window of the first ms of a bit
            first_ms = c.ms_index - len(c.prompts) + 1
            bit_phase = (c.bit_edge - first_ms) % 20
        c.cn0_dbhz = estimate_cn0(np.array(c.prompts), cfg.cn0_estimator, bit_phase)
        strong = c.cn0_dbhz > cfg.cn0_threshold_dbhz
        c.locked = strong and (c.pli > cfg.pli_threshold or not c.phase_locking)

    def _advance(self, c: _Channel, t0: float) -> None:
        """The state machine: pull-in -> track -> extended; lost after ``loss_ms`` out of lock."""
        cfg = self.config
        c.unlocked_ms = 0 if c.locked else c.unlocked_ms + c.coherent_ms
        if c.stage == "pull-in":
            if c.locked and c.stage_ms >= cfg.lock_window_ms:
                c.record.events.append((t0, "locked: tracking with " + cfg.channel_filter))
                c.start("track", c.doppler_hz, 1)
                c.stage_ms = 0
            elif c.stage_ms >= cfg.pull_in_ms:
                self._lose(c, t0, f"no lock within {cfg.pull_in_ms} ms of pull-in")
            return
        if c.unlocked_ms >= cfg.loss_ms:
            self._lose(c, t0, f"lock lost for {cfg.loss_ms} ms")
            return
        if (c.stage == "track" and cfg.coherent_ms > 1 and c.bit_edge is not None
                and (c.ms_index + 1) % 20 == c.bit_edge % 20):
            # The next millisecond starts a bit: integrations from here on are bit aligned.
            c.record.events.append((t0, f"extended to {cfg.coherent_ms} ms coherent (PLL)"))
            c.start("extended", c.doppler_hz, cfg.coherent_ms)

    def _lose(self, c: _Channel, t0: float, why: str) -> None:
        c.stage = "lost"
        c.record.events.append((t0, f"lost: {why}; back to acquisition"))
