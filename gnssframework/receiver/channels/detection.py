"""When and how the sample tracker runs its channels' lock detectors: on the 1 ms prompt
ring buffers of `intervals.ChannelArrays`, every `detect_periods` code periods, on arrays
over the channels whose window is full (`lock.window_detectors`) and one by one for those
still filling it (`lock.phase_lock_indicator`, `lock.estimate_cn0`).
"""

from __future__ import annotations

import numpy as np

from ...signal.spec import SignalSpec
from .channel import SampleChannel
from .config import TrackingConfig
from .intervals import ChannelArrays
from .lock import estimate_cn0, phase_lock_indicator, window_detectors

__all__ = ["detect_periods", "run_detectors"]


def detect_periods(signal: SignalSpec) -> int:
    """Code periods between two runs of a channel's lock detectors on ``signal``, and before
    the first: one data symbol's (20 on L1 C/A, 1 on Galileo E1-B), on a pilot its overlay
    code's (25 on E1-C; `SignalSpec.longest_coherent_s`). The detectors' windows are 10-100
    times longer."""
    return max(1, round(signal.longest_coherent_s / signal.code_period_s))


def run_detectors(
    chans: list[SampleChannel], a: ChannelArrays, config: TrackingConfig, signal: SignalSpec, every: int
) -> None:
    """Lock detectors of channels ``chans`` (their ``pli``, ``cn0_dbhz`` and ``locked`` set),
    evaluated every ``every`` code periods (`detect_periods`); a channel with fewer prompts
    than its shortest window is unlocked."""
    size = a.prompts.shape[1]
    full = []
    for c in chans:
        ms = int(a.ms_index[c.slot])
        if a.n_prompts[c.slot] < min(config.lock_window_ms, every):
            c.locked = False
        elif ms >= c.next_detect:
            c.next_detect = ms + every
            if a.n_prompts[c.slot] >= size:
                full.append(c)
            else:
                _detect_one(c, ms, a, config, signal)
    if not full:
        return
    slots = np.array([c.slot for c in full])
    win = a.prompts[slots[:, None], (a.n_prompts[slots][:, None] - size + np.arange(size)) % size]
    phases = [_bit_phase(c, int(a.ms_index[c.slot]), size) for c in full]
    pli, cn0 = window_detectors(win, phases, config.lock_window_ms, config.cn0_estimator, signal)
    for j, c in enumerate(full):
        c.pli, c.cn0_dbhz = float(pli[j]), float(cn0[j])
        _lock_decision(c, config)


def _window(c: SampleChannel, n: int, a: ChannelArrays) -> np.ndarray:
    """The last ``n`` 1 ms prompts of channel ``c``, oldest first."""
    i = c.slot
    size = a.prompts.shape[1]
    n = min(n, int(a.n_prompts[i]), size)
    return a.prompts[i, (a.n_prompts[i] - n + np.arange(n)) % size]


def _bit_phase(c: SampleChannel, ms: int, n: int) -> int | None:
    """Index in a window of the last ``n`` prompts up to ``ms`` of the first ms of a bit."""
    return None if c.bit_edge is None else (c.bit_edge - (ms - n + 1)) % c.periods_per_symbol


def _lock_decision(c: SampleChannel, config: TrackingConfig) -> None:
    strong = c.cn0_dbhz > config.cn0_threshold_dbhz
    c.locked = strong and (c.pli > config.pli_threshold or not c.phase_locking)


def _detect_one(c: SampleChannel, ms: int, a: ChannelArrays, config: TrackingConfig, signal: SignalSpec) -> None:
    """Lock detectors of a channel whose window is not full yet."""
    c.pli = phase_lock_indicator(_window(c, config.lock_window_ms, a))
    prompts = _window(c, config.cn0_window_ms, a)
    c.cn0_dbhz = estimate_cn0(prompts, config.cn0_estimator, _bit_phase(c, ms, prompts.size), signal)
    _lock_decision(c, config)
