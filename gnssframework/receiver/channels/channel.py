"""One satellite's channel of the sample tracker: its signal, stage, filter and detectors.

A `SampleChannel`'s NCOs and sums live in the tracker's arrays (at ``slot``, the index of
its PRN in its signal's PRN list) so that every channel correlates and closes its
intervals in one compiled call; the object holds what runs per channel once per coherent
interval: the stage of the state machine, the channel filter, the lock detectors'
values, and the signal it tracks (`gnssframework.signal.spec.SignalSpec`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ...interfaces import RunContext
from ...signal.spec import SignalSpec
from ..engine.closers import NCO_COMMANDS
from .closure import ErrorFeedback
from .config import TrackingConfig
from .factory import StageFilters, supports

from .records import ChannelRecord

if TYPE_CHECKING:
    from .batch import FilterBatch

__all__ = ["SampleChannel", "NCO_COMMANDS", "supports", "stage_context"]


def stage_context(
    c: TrackingConfig, T: float, cn0_dbhz: float, doppler_hz: float, signal: SignalSpec | None = None
) -> RunContext:
    """What a channel filter is reset with at the start of a stage (``signal`` the tracked one)."""
    return RunContext(
        coherent_time_s=T,
        early_late_spacing_chips=c.early_late_spacing_chips,
        epoch_interval_s=T,
        cn0_dbhz=cn0_dbhz,
        doppler_hz=doppler_hz,
        signal=signal,
    )


class SampleChannel:
    """One satellite's channel: its signal, stage, filter and detectors.

    Attributes
    ----------
    prn, slot, spec
        The satellite, its index in the tracker's arrays, its signal.
    filters
        The task's `StageFilters`: a stage's filter is a fresh copy of its configuration.
    config
        The `TrackingConfig` the filters were built for (``filters.config``).
    stage
        One of `tracker.STAGES`.
    coherent_ms
        Code periods per coherent interval in this stage (the record's ``coherent_ms``).
    filter, closure, batch
        The stage's channel filter; how its outputs move the NCOs (``None``: NCO commands;
        `ErrorFeedback`; or a closer's own marker); the `FilterBatch` it steps in, if any.
    cn0_dbhz, pli, locked
        The lock detectors' last values.
    """

    def __init__(self, prn: int, slot: int, spec: SignalSpec, record: ChannelRecord, filters: StageFilters) -> None:
        self.prn = prn
        self.filters = filters
        self.slot = slot
        self.spec = spec
        self.config = filters.config  # the stages' tracking configuration
        self.record = record
        self.cn0_dbhz = 0.0
        self.pli = 0.0
        self.locked = False
        self.failures = 0  # pull-ins in a row that ended without lock
        self.retry_at = 0  # first sample at which re-acquisition may try again
        self.batch: FilterBatch | None = None

    @property
    def periods_per_symbol(self) -> int:
        """Code periods per data symbol: the bit-sync histogram's length (20 on L1 C/A)."""
        return self.spec.code_periods_per_symbol

    def start(self, stage: str, doppler_hz: float, coherent_ms: int) -> None:
        """Enter a scalar stage: a new filter reset at ``doppler_hz``, ``coherent_ms`` code periods per interval."""
        c = self.config
        self.stage = stage
        self.coherent_ms = coherent_ms
        self.filter = self.filters.new(stage)
        T = coherent_ms * self.spec.code_period_s
        self.closure = (
            None
            if supports(type(self.filter), *NCO_COMMANDS)
            else ErrorFeedback(c.closure_fll_bandwidth_hz, c.closure_dll_bandwidth_hz, T)
        )
        cn0 = self.cn0_dbhz if self.cn0_dbhz > 0 else 40.0
        # A batch of one: the tracker merges it into the batch of its stage (`batch`).
        self.filter.reset((1,), stage_context(c, T, cn0, doppler_hz, self.spec))
        self.batch = None
        self.join_tries = 0
        self.stage_ms = 0
        if stage == "pull-in":
            self.unlocked_ms = 0
            self.bit_edge: int | None = None
            self.next_detect = 0

    @property
    def phase_locking(self) -> bool:
        """Whether its filter tracks carrier phase (NCO commands): the PLI counts for its lock."""
        return self.closure is None
