"""Split a batch kernel between the calling thread and one helper thread, chunk by chunk.

numba's ``parallel=True`` kernels hand the whole batch to its worker threads in equal
static parts while the calling thread waits. In a filter loop the kernels are called
every few milliseconds with Python work in between, the workers go to sleep in between,
and on this project's 2-core virtual machines a sleeping worker (and its idle virtual
CPU) can take about as long to wake as the kernel takes to run (docs/benchmarks.md,
"Why the compiled path is built as it is"). Here the calling thread starts on the first
chunk at once and the helper takes chunks as it wakes (claimed from a shared counter), so the call never waits for a
sleeping thread more than one chunk and takes the second core whenever it is free.

Each chunk runs the *serial* kernel on a slice of the batch (a slice of a C-contiguous
batch array is C-contiguous, so no new numba specialisation), and every element's
arithmetic is the same whichever thread runs it: results are bitwise those of one serial
call. The kernels release the GIL (``nogil=True``). One helper thread per process,
started on first use and again after a fork (`os.getpid` changes); calls from any
thread but the main one run serially (the caller decides, see ``kernels._pick``).
"""

from __future__ import annotations

import itertools
import os
import threading
from collections.abc import Callable

__all__ = ["run_chunks"]


class _Job:
    """One call's chunks: a shared claim counter, and whether the helper is inside a chunk."""

    __slots__ = ("claim", "n_chunks", "run_chunk", "lock", "idle", "busy", "errors")

    def __init__(self, n_chunks: int, run_chunk: Callable[[int], None]) -> None:
        self.claim = itertools.count()
        self.n_chunks = n_chunks
        self.run_chunk = run_chunk
        self.lock = threading.Lock()
        self.idle = threading.Event()
        self.busy = False
        self.errors: list[BaseException] = []

    def next_chunk(self, helper: bool) -> int | None:
        with self.lock:
            i = next(self.claim)
            if i >= self.n_chunks:
                return None
            if helper:
                self.busy = True
                self.idle.clear()
            return i


class _Helper:
    """One daemon thread that runs the chunks of the current job it can claim."""

    def __init__(self) -> None:
        self.pid = os.getpid()
        self.cv = threading.Condition()
        self.job: _Job | None = None
        self.generation = 0
        self.thread = threading.Thread(target=self._work, name="gnssframework-kernel-helper", daemon=True)
        self.thread.start()

    def _work(self) -> None:
        seen = 0
        while True:
            with self.cv:
                while self.generation == seen:
                    self.cv.wait()
                seen = self.generation
                job = self.job
            # A job whose caller already ran every chunk hands out none (late wake-up).
            while (i := job.next_chunk(True)) is not None:
                try:
                    job.run_chunk(i)
                except BaseException as exc:  # pragma: no cover - kernels do not raise
                    job.errors.append(exc)
                finally:
                    with job.lock:
                        job.busy = False
                        job.idle.set()

    def run(self, n_chunks: int, run_chunk: Callable[[int], None]) -> None:
        job = _Job(n_chunks, run_chunk)
        with self.cv:
            self.job = job
            self.generation += 1
            self.cv.notify()
        while (i := job.next_chunk(False)) is not None:
            run_chunk(i)
        with job.lock:  # wait only for a chunk the helper is inside, never for its wake-up
            wait = job.busy
        if wait:
            job.idle.wait()
        if job.errors:  # pragma: no cover
            raise job.errors[0]


_helper: _Helper | None = None
_lock = threading.Lock()


def run_chunks(n_chunks: int, run_chunk: Callable[[int], None]) -> None:
    """Call ``run_chunk(i)`` for ``i = 0 .. n_chunks - 1``, each once, on the calling
    thread and the helper thread as each becomes free; returns when every chunk has run."""
    global _helper
    helper = _helper
    if helper is None or helper.pid != os.getpid():
        with _lock:
            if _helper is None or _helper.pid != os.getpid():
                _helper = _Helper()
            helper = _helper
    helper.run(n_chunks, run_chunk)
