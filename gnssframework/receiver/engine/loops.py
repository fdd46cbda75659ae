"""Loop drivers of the engine: a channel, a correlator source and a closer, interval by interval."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ...signal.correlators import Correlators
from .channel import Channel
from .closers import ScalarCloser
from .sources import CorrelatorSource
from .truth import LoopTruth

__all__ = ["TrackingRecord", "run_scalar"]


@dataclass
class TrackingRecord:
    """Per-interval record of a closed-loop run, time on axis 0 (K intervals): the replica's
    true errors (truth minus replica: code chips, mid-interval phase rad wrapped, frequency
    Hz), its carrier NCO frequency, and the channel outputs asked for."""

    code_error_chips: np.ndarray
    phase_error_rad: np.ndarray
    freq_error_hz: np.ndarray
    carrier_freq_hz: np.ndarray
    outputs: dict[str, np.ndarray] = field(default_factory=dict)


def run_scalar(
    closer: ScalarCloser,
    source: CorrelatorSource,
    channel: Channel,
    truth: LoopTruth,
    record: tuple[str, ...] = (),
    on_correlators: Callable[[Correlators], None] | None = None,
) -> TrackingRecord:
    """Close ``closer`` over ``channel`` on ``source`` for every interval of ``truth``
    (phases form), recording the replica's true errors.

    The closer must have been reset on ``channel`` (`ScalarCloser.reset`). ``on_correlators``
    sees each interval's correlators before the closer does (a lock detector's ``observe``).
    """
    T = truth.coherent_time_s
    code, carrier = truth.code_phase_chips, truth.carrier_phase_rad
    rec: dict[str, list] = {k: [] for k in ("code", "phase", "freq", "fnco", *record)}
    for k in range(truth.epochs):
        err = channel.errors(code[k], code[k + 1], carrier[k], carrier[k + 1], T)
        fnco = channel.carrier_freq_hz
        corr = source.correlate(channel, k, err)
        if on_correlators is not None:
            on_correlators(corr)
        out = closer.step(channel, corr)
        rec["code"].append(err.code_chips)
        rec["phase"].append(err.mid_phase_rad(T))
        rec["freq"].append(err.freq_hz)
        rec["fnco"].append(fnco)
        for name in record:
            rec[name].append(out[name])
    stack = {k: np.stack(v) for k, v in rec.items()}
    return TrackingRecord(stack.pop("code"), stack.pop("phase"), stack.pop("freq"), stack.pop("fnco"), stack)
