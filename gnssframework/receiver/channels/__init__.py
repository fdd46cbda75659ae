"""Sample-driven channels: code/carrier NCOs, the compiled multi-channel correlator, lock
detectors, C/N0, bit synchronisation and the channel state machine."""

from .channel import SampleChannel
from .closers import SampleCloser, ScalarSampleCloser
from .closure import ErrorFeedback
from .config import WEAK_SIGNAL_SETTINGS, TrackingConfig, tracking_config, weak_signal_tracking
from .correlator import correlate_channels, correlate_numpy
from .lock import BitSync, estimate_cn0, phase_lock_indicator
from .nco import ReplicaNCOs
from .signal_settings import signal_tracking_config, signal_tracking_settings
from .tracker import RECORD_FIELDS, STAGES, ChannelRecord, SampleTracker, TrackingResult

__all__ = [
    "ErrorFeedback",
    "TrackingConfig",
    "tracking_config",
    "weak_signal_tracking",
    "signal_tracking_config",
    "signal_tracking_settings",
    "WEAK_SIGNAL_SETTINGS",
    "correlate_channels",
    "correlate_numpy",
    "BitSync",
    "estimate_cn0",
    "phase_lock_indicator",
    "SampleTracker",
    "TrackingResult",
    "ChannelRecord",
    "STAGES",
    "RECORD_FIELDS",
    "SampleCloser",
    "ScalarSampleCloser",
    "SampleChannel",
    "ReplicaNCOs",
]
