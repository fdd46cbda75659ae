"""Scalar tracking in worker processes: the channels split into groups, one process each.

One `SampleTracker` runs its channels' loops in Python between compiled calls, and that
Python holds one core (docs/benchmarks.md, "Against GNSS-SDR"). Scalar channels do not
talk to each other, so `track_in_groups` hands each of ``workers`` processes a share of the
acquired satellites and merges their records: tracking's wall time drops with cores, and
on a machine other programs load, the receiver's processes get their share of it.

Why the grouping does not change the records: nothing a channel computes depends on the
other channels of its tracker. Its interval sums are scaled by the power of the block of
the block grid its interval starts in (`SampleTracker._samples`), not of whichever block a
channel read last; re-acquisition runs at the re-acquisition clock's ticks, not at the
channels' lead; each channel runs to its own last whole interval of the recording. The
filters of the channels of one process and stage step as one batch (`batch.FilterBatch`),
element by element: the built-in filters give the same bits in a batch of any size
(tested: groupings of 2, 3 and 4 processes give one process's records to the bit, with a
satellite lost and re-acquired; and batched against stepped alone). A plugin filter whose
arithmetic on a channel depended on the batch's size would round differently.

Forked processes (``fork``, where the platform has it; elsewhere one process tracks
everything): the recording, the acquisition and the built filters are the parent's, not
pickled; each process reads the recording itself (the operating system's page cache
shares the file) and uses one compiled-kernel thread. Only scalar tracking runs so: a
vector or deep closer couples the channels through its navigation filter, and a live
stream cannot be read by several processes.
"""

from __future__ import annotations

import multiprocessing
import os
import pickle
import traceback
from collections.abc import Callable
from multiprocessing.connection import Connection, wait
from typing import Any

from ...backend import available_cores, set_threads
from ...errors import ConfigError
from ...signal.gps_l1ca import GPS_L1CA
from ...signal.spec import SignalSpec
from ..acquisition.search import Acquisition, AcquisitionResult
from ..frontend.recording import Recording
from .config import TrackingConfig
from .factory import StageFilters
from .records import TrackingResult
from .tracker import SampleTracker

__all__ = ["can_fork", "split_acquisitions", "track_in_groups", "resolve_workers", "check_workers"]

#: Seconds between two looks at the workers' progress.
POLL_S = 0.5
#: Signal (s) tracked in the parent before the fork, so the processes inherit the loaded kernels.
WARM_UP_S = 0.05


def can_fork() -> bool:
    """Whether worker processes can be forked here (Linux and other POSIX systems)."""
    return "fork" in multiprocessing.get_all_start_methods()


def resolve_workers(workers: int | str | None, channels: int) -> int:
    """Processes for ``channels`` scalar channels: ``workers`` as given (at most one per
    channel), ``"auto"`` the cores available, ``None`` or 1 one process (the tracker in
    this process). Refuses anything but a whole number of at least 1 or ``"auto"``."""
    if workers is None:
        return 1
    check_workers(workers)
    n = available_cores() if workers == "auto" else int(workers)
    return max(1, min(n, channels))


def check_workers(workers: object) -> None:
    """Refuse ``workers`` unless a whole number of at least 1 or ``"auto"`` (the library's
    and the CLI's ``--workers`` check, one message)."""
    if workers == "auto":
        return
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ConfigError("workers", f"must be a whole number of at least 1 or 'auto', got {workers!r}")


def split_acquisitions(found: list[AcquisitionResult], groups: int) -> list[list[AcquisitionResult]]:
    """``found`` dealt into ``groups`` groups by descending acquisition C/N0 (the strongest
    to the first group, the next to the second, ...): as many channels in each, give or
    take one, and the strong and the weak (whose pull-ins and re-acquisitions cost more)
    spread over them. Empty groups are dropped."""
    ranked = sorted(found, key=lambda r: (-r.cn0_dbhz, r.prn))
    return [g for g in (ranked[i::groups] for i in range(groups)) if g]


def _track_group(
    conn: Connection,
    slot: int,
    shared_progress: Any,
    make_tracker: Callable[[], SampleTracker],
    group: list[AcquisitionResult],
    duration_s: float | None,
) -> None:  # pragma: no cover - runs in the forked worker (its results are tested in the parent)
    try:
        set_threads(1)  # one process per core already

        def progress(fraction: float) -> None:
            shared_progress[slot] = fraction

        tracker = make_tracker()
        zeroed = tracker.rec.nonfinite_zeroed
        result = tracker.run(group, duration_s, progress)
        answer = (result, tracker.rec.nonfinite_zeroed - zeroed)  # the values this process zeroed, for the report
        conn.send_bytes(pickle.dumps(("ok", answer), protocol=pickle.HIGHEST_PROTOCOL))
    except BaseException as error:  # noqa: BLE001 - every failure goes back to the parent, named
        text = f"{type(error).__name__}: {error}"
        try:
            pickled: bytes | None = pickle.dumps(error)
        except Exception:  # noqa: BLE001 - an exception that cannot be pickled goes as its text
            pickled = None
        conn.send_bytes(pickle.dumps(("error", (text, pickled, traceback.format_exc()))))
    finally:
        conn.close()
        os._exit(0)  # no atexit handlers of the parent's state in the child


def _rebuilt(slot: int, text: str, pickled: bytes | None, where: str) -> BaseException:
    """The exception a channel group's process raised (its own type where it unpickles,
    else a `RuntimeError` with its text), its traceback there as a note (a bug's traceback
    shows it; the commands print a library error's one line only)."""
    error: BaseException | None = None
    if pickled is not None:
        try:
            error = pickle.loads(pickled)
        except Exception:  # noqa: BLE001 - then its text
            error = None
    if not isinstance(error, BaseException):
        error = RuntimeError(f"channel group {slot}: {text}")
    error.add_note(f"raised in the process of channel group {slot}:\n{where}")
    return error


def merge_results(parts: list[TrackingResult], acquisitions: list[AcquisitionResult]) -> TrackingResult:
    """One `TrackingResult` of the groups' results (channels ordered by PRN)."""
    channels = {prn: ch for part in parts for prn, ch in part.channels.items()}
    first = parts[0]
    return TrackingResult(
        {prn: channels[prn] for prn in sorted(channels)}, list(acquisitions), first.duration_s, first.channel_filter
    )


def track_in_groups(
    recording: Recording,
    config: TrackingConfig,
    acquisition: Acquisition,
    acquisitions: list[AcquisitionResult],
    duration_s: float | None = None,
    *,
    workers: int | str | None,
    signal: SignalSpec = GPS_L1CA,
    filters: StageFilters | None = None,
    backend: str | None = None,
    progress: Callable[[float], Any] | None = None,
) -> TrackingResult:
    """Scalar tracking of the detected satellites of ``acquisitions`` (as
    `SampleTracker.run`), their channels split over ``workers`` forked processes
    (`resolve_workers`: a number, ``"auto"``, or None for one; `split_acquisitions`);
    ``progress`` is called with the slowest process's fraction. One process (this one)
    where ``workers`` is 1 or None, there is one channel or none, the platform cannot
    fork, or ``recording`` is a live stream (`Recording.is_live`)."""
    found = [r for r in acquisitions if r.detected]
    filters = filters if filters is not None else StageFilters(config)  # a bad filter refused here, once

    def make_tracker() -> SampleTracker:
        return SampleTracker(recording, config, acquisition, backend=backend, signal=signal, filters=filters)

    groups = split_acquisitions(found, resolve_workers(workers, len(found)))
    if len(groups) <= 1 or not can_fork() or recording.is_live:
        return make_tracker().run(acquisitions, duration_s, progress)
    # The compiled kernels loaded here once (numba's cache), not in every process: a few
    # milliseconds of the strongest channel, records dropped.
    make_tracker().run(groups[0][:1], min(WARM_UP_S, recording.n_samples / recording.info.sample_rate_hz))
    ctx = multiprocessing.get_context("fork")
    shared = ctx.Array("d", len(groups), lock=False)
    receivers: list[Connection] = []
    processes = []
    for slot, group in enumerate(groups):
        mine, theirs = ctx.Pipe(duplex=False)
        p = ctx.Process(
            target=_track_group,
            args=(theirs, slot, shared, make_tracker, group, duration_s),
            name=f"gnssframework-channels-{slot}",
            daemon=True,
        )
        p.start()
        theirs.close()
        receivers.append(mine)
        processes.append(p)
    outcomes: dict[int, tuple[str, Any]] = {}
    try:
        pending = dict(enumerate(receivers))
        while pending:
            for ready in wait(list(pending.values()), timeout=POLL_S):
                slot = next(s for s, c in pending.items() if c is ready)
                try:
                    outcomes[slot] = pickle.loads(pending[slot].recv_bytes())
                except EOFError:  # the process died (killed, out of memory) before it could answer
                    outcomes[slot] = ("error", ("it ended without a result (killed?)", None, ""))
                del pending[slot]
            if progress is not None:
                progress(min(shared[:]))
    finally:
        for p in processes:
            p.join(timeout=5)
            if p.is_alive():
                p.kill()
        for conn in receivers:
            conn.close()
    for slot in range(len(groups)):
        kind, value = outcomes[slot]
        if kind == "error":
            raise _rebuilt(slot, *value)
    recording.nonfinite_zeroed += sum(outcomes[s][1][1] for s in range(len(groups)))
    return merge_results([outcomes[s][1][0] for s in range(len(groups))], acquisitions)
