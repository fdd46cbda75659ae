"""The tracking-loop engine: a `Channel` (a signal description and its replica's NCOs), a
correlator source (the analytic model or IF samples) and a loop closer (scalar: a channel
filter per channel; vector: a navigation filter over all channels; deep: a navigator aiding
every channel's NCOs, fed by prefilters).

Modules: `truth` (`LoopTruth`), `channel` (`Channel`, `ReplicaErrors`, the one NCO and
sign convention), `sources` (`CorrelatorSource`, `AnalyticSource`), `samples`
(`SampleSource`), `truth_samples` (IF samples of a geometry-form truth), `closers` (`ScalarCloser`, `VectorCloser`), `deep_closer` (`DeepCloser`), `loops` (`run_scalar`,
`TrackingRecord`). Names are importable from here; the modules are loaded on first use
(so the channel package's tracker may import the engine without a circle at import time).
"""

from __future__ import annotations

import importlib

_WHERE = {
    "LoopTruth": "truth",
    "SignalTruth": "truth",
    "VectorTruth": "truth",
    "DeepTruth": "truth",
    "code_phase_of_range": "truth",
    "Channel": "channel",
    "ReplicaErrors": "channel",
    "CorrelatorSource": "sources",
    "AnalyticSource": "sources",
    "SampleSource": "samples",
    "truth_samples": "truth_samples",
    "range_nco": "channel",
    "ScalarCloser": "closers",
    "EstimateCloser": "closers",
    "VectorCloser": "closers",
    "check_closed_loop": "closers",
    "check_estimate_loop": "closers",
    "check_composition": "closers",
    "ESTIMATE_OUTPUTS": "closers",
    "NCO_COMMANDS": "closers",
    "CHANNEL_OUTPUTS": "closers",
    "NAV_OUTPUTS": "closers",
    "HARNESS_INPUTS": "closers",
    "SubFilterBank": "filter_bank",
    "DeepCloser": "deep_closer",
    "Navigator": "deep_closer",
    "TrackingRecord": "loops",
    "run_scalar": "loops",
}

__all__ = sorted(_WHERE)


def __getattr__(name: str):
    if name in _WHERE:
        return getattr(importlib.import_module(f".{_WHERE[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
