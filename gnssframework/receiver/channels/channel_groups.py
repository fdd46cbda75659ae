"""Channels of one correlator call in contiguous groups, run on several threads.

The compiled correlators (`correlator.correlate_channels`, `correlator.correlate_periods`)
release the GIL: a call's channels split into groups, each correlated by the same serial
kernel on slices of the per-channel arrays, run on the calling thread and the helper threads
of `gnssframework.estimation.compiled.pool`. Each channel's sums are those of one call over
all channels, whichever thread ran its group: results are bit-identical whatever the number
of threads (`gnssframework.backend.set_threads`, ``--threads``).
"""

from __future__ import annotations

from collections.abc import Callable

from ...backend import get_threads

__all__ = ["SPLIT_SAMPLES", "split_channels", "run_groups"]


#: Samples (all channels of a call) below which a call runs on the calling thread alone:
#: a helper thread's hand-over costs about as much as correlating this many.
SPLIT_SAMPLES = 20_000


def split_channels(n_channels: int, work_samples: int, threads: int | None) -> list[tuple[int, int]]:
    """Contiguous channel groups ``[lo, hi)`` of a call, for ``threads`` threads: one group
    when one thread or a small call, else about two groups per thread (the calling thread
    takes the groups a helper has not claimed yet, `pool.run_chunks`)."""
    n_threads = get_threads() if threads is None else int(threads)
    if n_threads < 2 or n_channels < 2 or work_samples < SPLIT_SAMPLES:
        return [(0, n_channels)]
    n_groups = min(n_channels, 2 * n_threads)
    edges = [k * n_channels // n_groups for k in range(n_groups + 1)]
    return list(zip(edges[:-1], edges[1:]))


def run_groups(groups: list[tuple[int, int]], call: Callable[[int, int], None], threads: int | None) -> None:
    """``call(lo, hi)`` for every channel group: each runs the serial kernel on slices of the
    per-channel arrays (C-contiguous slices: the same compiled specialisation), so every
    channel's sums are those of one call over all channels, whichever thread ran its group."""
    if len(groups) == 1:
        call(*groups[0])
    else:
        from ...estimation.compiled import pool  # (numba's thread pool: only the compiled path splits)

        pool.run_chunks(len(groups), lambda g: call(*groups[g]), get_threads() if threads is None else int(threads))
