"""What the sample tracker records: one row per channel-filter update and the events of
each channel (`ChannelRecord`), and a run's records (`TrackingResult`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..acquisition.search import AcquisitionResult

__all__ = ["STAGES", "RECORD_FIELDS", "ChannelRecord", "TrackingResult"]

#: Channel states, in the order a channel goes through them.
STAGES = ("pull-in", "track", "extended", "lost", "vector")
#: Columns of a channel's record (one row per channel-filter update).
RECORD_FIELDS = (
    "time_s",
    "cn0_dbhz",
    "pli",
    "doppler_hz",
    "code_phase_chips",
    "carrier_phase_cycles",
    "lock",
    "stage",
    "prompt_i",
    "prompt_q",
    "coherent_ms",
)


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
