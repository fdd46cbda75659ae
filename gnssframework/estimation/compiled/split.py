"""How a compiled call runs its batch: serially, split over the calling thread and one
helper (`gnssframework.estimation.compiled.pool`), or by numba's ``parallel=True`` twin.
"""

from __future__ import annotations

import threading

import numpy as np

from . import pool

__all__ = [
    "PARALLEL_MIN_BATCH",
    "PD_MASK_PARALLEL_MIN_BATCH",
    "SPLIT",
    "SPLIT_CHUNKS",
    "SPLIT_MIN_WORK",
    "run_split",
    "split_by_work",
    "work_chunks",
    "pick",
]

#: Batch size from which the ``parallel=True`` kernels are used.
PARALLEL_MIN_BATCH = 256


#: Batch size from which `pd_mask` runs in parallel: an element is cheap beside the
#: launch of a parallel kernel, which pays only from a few thousand elements.
PD_MASK_PARALLEL_MIN_BATCH = 2048


#: How a fused predict/update runs from `PARALLEL_MIN_BATCH` on: ``"pool"`` splits the
#: batch into `SPLIT_CHUNKS` chunks that the calling thread and one helper thread take
#: as each becomes free (`gnssframework.estimation.compiled.pool`: the call never waits
#: for a sleeping thread to wake), ``"numba"`` runs the ``parallel=True`` twin.
SPLIT = "pool"
#: Chunks per split: each costs a kernel call and a few slices, and a helper that wakes
#: late finds fewer to take. Measured on the 100-run vector loop (svd-ckf, quiet
#: machine): 4 chunks 283-287x real time, 8 269-275x, 16 243-253x.
SPLIT_CHUNKS = 4


#: Work (batch x n x m^2) from which the KF/EKF update and moments split their batch
#: like the fused kernels: that of `PARALLEL_MIN_BATCH` channel-filter elements (5
#: states, 6 measurements). ``ekf-pv``'s 100 runs x (8 states, 16 measurements) pass it.
SPLIT_MIN_WORK = PARALLEL_MIN_BATCH * 5 * 6 * 6


def run_split(
    pair,
    B: int,
    args: tuple,
    batched,
    counts: np.ndarray | None = None,
    by_work: bool = False,
    chunks: int | None = None,
) -> None:
    """``kernel(*args[, counts])`` of a driver pair: serial below `PARALLEL_MIN_BATCH`
    (unless ``by_work``), above it split by `SPLIT` (``"pool"``: chunks on the calling
    thread and the helper; ``"numba"``: the parallel twin; only from the main thread).
    ``batched()``: indices of the arguments whose first axis is the batch (sliced per
    chunk; asked only when splitting); ``counts`` is summed over the chunks. Every
    element runs the same serial code whichever thread takes it (bitwise)."""
    if B < PARALLEL_MIN_BATCH and not by_work:  # the common small batch: no more tests
        kernel = pair[0]
    elif SPLIT != "pool":
        kernel = pair[0] if by_work and B < PARALLEL_MIN_BATCH else pick(pair, B)
    elif threading.current_thread() is not threading.main_thread():
        kernel = pair[0]
    else:
        kernel = None
    if kernel is not None:
        kernel(*args) if counts is None else kernel(*args, counts)
        return
    idx = batched()
    n = min(SPLIT_CHUNKS, B) if chunks is None else chunks
    per_chunk = None if counts is None else np.zeros((n, counts.shape[0]), dtype=np.int64)
    serial = pair[0]

    def run_chunk(i: int) -> None:
        lo, hi = (i * B) // n, ((i + 1) * B) // n
        chunk = [a[lo:hi] if j in idx else a for j, a in enumerate(args)]
        serial(*chunk) if per_chunk is None else serial(*chunk, per_chunk[i])

    pool.run_chunks(n, run_chunk)
    if counts is not None:
        counts[:] = per_chunk.sum(axis=0)


def split_by_work(B: int, n: int, m: int) -> bool:
    """True where a batch of ``B`` updates of ``n`` states / ``m`` measurements is worth
    splitting below `PARALLEL_MIN_BATCH` (see `SPLIT_MIN_WORK`)."""
    return 2 <= B < PARALLEL_MIN_BATCH and B * n * m * m >= SPLIT_MIN_WORK


def work_chunks(B: int, n: int, m: int) -> int | None:
    """Chunks for a split by work: about twice `SPLIT_MIN_WORK` each (each chunk costs a
    kernel call and a few slices, so small work is not cut finer), 2 to `SPLIT_CHUNKS`;
    None (the default) from `PARALLEL_MIN_BATCH` on."""
    if B >= PARALLEL_MIN_BATCH:
        return None
    return max(2, min(SPLIT_CHUNKS, B * n * m * m // (2 * SPLIT_MIN_WORK)))


def pick(pair, batch: int, min_batch: int | None = None):
    if (
        batch >= (PARALLEL_MIN_BATCH if min_batch is None else min_batch)
        and threading.current_thread() is threading.main_thread()
    ):
        return pair[1]
    return pair[0]
