"""Closed-loop simulation of channel tracking on the analytic correlator model.

A composition of the loop engine (`gnssframework.receiver.engine`): a `Channel` started
from the acquisition, the `AnalyticSource` (correlators drawn at the replica's true
errors, truth minus replica, so they reflect the loop's own errors) and a `ScalarCloser`
(the ``channel_filter`` steering its NCOs by the commands it returns).

Channel-filter command names (outputs of ``ChannelFilter.step``):

- ``carrier_freq_hz``: carrier NCO frequency (Doppler, Hz) for the next interval;
- ``code_freq_hz``: code NCO rate (chips/s) for the next interval;
- ``carrier_phase_step_rad`` (optional): a phase correction applied to the carrier
  NCO at the start of the next interval, used by Kalman loops that estimate phase.
"""

from __future__ import annotations

import numpy as np

from ...interfaces import ChannelFilter
from ...signal.correlator_model import CorrelatorSimulator, amplitude_from_cn0
from ..engine.channel import Channel
from ..engine.closers import NCO_COMMANDS, ScalarCloser, check_closed_loop
from ..engine.loops import TrackingRecord, run_scalar
from ..engine.sources import AnalyticSource
from ..engine.truth import LoopTruth, SignalTruth

__all__ = ["SignalTruth", "TrackingRecord", "run_closed_loop", "check_closed_loop", "NCO_COMMANDS"]


def run_closed_loop(
    channel: ChannelFilter,
    truth: LoopTruth,
    rng: np.random.Generator,
    *,
    initial_doppler_hz: np.ndarray | float = 0.0,
    initial_code_phase_chips: np.ndarray | float | None = None,
    early_late_spacing_chips: float = 1.0,
    record: tuple[str, ...] = (),
    on_correlators=None,
) -> TrackingRecord:
    """Track ``truth`` with ``channel`` in closed loop.

    Parameters
    ----------
    channel
        A ``channel_filter`` that requires ``correlators`` and provides
        ``carrier_freq_hz`` and ``code_freq_hz``.
    truth
        True signal phases (`SignalTruth`, a phases-form `LoopTruth`).
    rng
        Source of the correlator noise.
    initial_doppler_hz
        The acquisition's Doppler estimate (carrier NCO at start).
    initial_code_phase_chips
        The acquisition's code phase (default: the true one).
    record
        Further channel outputs to keep (e.g. ``("phase_disc_rad",)``).
    on_correlators
        Optional callable given each interval's `Correlators` (a lock detector's ``observe``).
    """
    closer = ScalarCloser(channel, record)
    T = truth.coherent_time_s
    batch = truth.code_phase_chips.shape[1:]
    code0 = truth.code_phase_chips[0] if initial_code_phase_chips is None else initial_code_phase_chips
    replica = Channel.start(batch, code0, initial_doppler_hz, signal=truth.signal)
    closer.reset(replica, T, early_late_spacing_chips=early_late_spacing_chips, cn0_dbhz=truth.cn0_dbhz)
    source = AnalyticSource(
        CorrelatorSimulator(T, early_late_spacing_chips),
        amplitude_from_cn0(truth.cn0_dbhz, T),
        rng,
        amplitude_scale=truth.amplitude_scale,
    )
    return run_scalar(closer, source, replica, truth, record, on_correlators)
