"""A pilot's overlay synchronised on open-loop prompts, then tracked with the overlay wiped
off: what the E1-C tests do on real and generated samples, and the L5 and E5a tests on
generated ones (any `SignalSpec` whose tracked component has an overlay)."""

from __future__ import annotations

import numpy as np

from gnssframework import registry
from gnssframework.signal.spec import SignalSpec


def pilot_sync_and_track(
    x: np.ndarray,
    fs: float,
    spec: SignalSpec,
    prn: int,
    doppler_hz: float,
    code_start_sample: int,
    intervals: int,
    *,
    sync_prompts: int,
    early_late_spacing_chips: float = 0.2,
    cn0_dbhz: float = 40.0,
) -> tuple[int, float, np.ndarray]:
    """The tracked component of ``spec`` for ``prn`` on complex samples ``x`` (IF 0), one
    primary period an interval, the first starting at ``code_start_sample`` (chip 0): the
    overlay's phase from ``sync_prompts`` open-loop prompts, whose consecutive products are
    matched against the overlay's at each shift (`overlay.overlay_sync`: blind to the
    residual Doppler, whose phase step the best match's angle gives), then the engine's
    scalar loop with the overlay wiped off.

    Returns the overlay phase (the overlay chip of the first interval), its score over the
    runner-up's, and the wiped prompts of the closed loop."""
    from gnssframework.receiver.channels.correlator import replica_codes
    from gnssframework.receiver.engine.channel import Channel
    from gnssframework.receiver.engine.closers import ScalarCloser
    from gnssframework.receiver.engine.samples import SampleSource
    from gnssframework.signal.correlators import Correlators
    from gnssframework.signal.overlay import overlay_sync

    T, d = spec.code_period_s, early_late_spacing_chips
    source = SampleSource(
        x,
        fs,
        0.0,
        replica_codes(spec, (prn,)),
        T,
        early_late_spacing_chips=d,
        noise_std=float(np.std(x.real)),
        start_sample=code_start_sample,
        subchips_per_chip=spec.subchips_per_chip,
    )
    overlay = np.array(spec.overlay(prn), float)
    channel = Channel.start((1,), 0.0, doppler_hz, signal=spec)
    prompts = []
    for k in range(sync_prompts):
        channel.run_interval(T)
        prompts.append(complex(np.ravel(source.correlate(channel, k).prompt)[0]))
        channel.steer_frequency(channel.carrier_freq_hz, channel.code_rate_chips_s)
    sync = overlay_sync(np.array(prompts), overlay, T)
    shift = sync.shift
    channel = Channel.start((1,), 0.0, doppler_hz + sync.freq_error_hz, signal=spec)
    closer = ScalarCloser(registry.create("channel_filter", "scalar"))
    closer.reset(channel, T, early_late_spacing_chips=d, cn0_dbhz=cn0_dbhz)
    tracked = []
    for k in range(intervals):
        channel.run_interval(T)
        c = source.correlate(channel, k)
        sign = overlay[(k + shift) % overlay.size]
        c = Correlators.trusted(c.early * sign, c.prompt * sign, c.late * sign)
        tracked.append(complex(np.ravel(c.prompt)[0]))
        closer.step(channel, c)
    return shift, sync.margin, np.array(tracked)
