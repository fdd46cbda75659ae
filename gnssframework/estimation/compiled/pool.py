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
call. The kernels release the GIL (``nogil=True``). One helper thread per process by
default (``threads=2``), more for a caller that asks for more threads, started on first
use and again after a fork (`os.getpid` changes); calls from any
thread but the main one run serially (the caller decides, see ``kernels._pick``).
"""

from __future__ import annotations

import itertools
import os
import threading
from collections.abc import Callable

__all__ = ["run_chunks"]


class _Job:
    """One call's chunks: a shared claim counter, how many helpers may join it, and how
    many are inside a chunk."""

    __slots__ = ("claim", "n_chunks", "run_chunk", "lock", "idle", "busy", "errors", "seats")

    def __init__(self, n_chunks: int, run_chunk: Callable[[int], None], helpers: int) -> None:
        self.claim = itertools.count()
        self.n_chunks = n_chunks
        self.run_chunk = run_chunk
        self.lock = threading.Lock()
        self.idle = threading.Event()
        self.busy = 0
        self.seats = helpers  # helpers that may still join
        self.errors: list[BaseException] = []

    def join(self) -> bool:
        """A helper takes a seat (False when the call wants no more helpers)."""
        with self.lock:
            if self.seats <= 0:
                return False
            self.seats -= 1
            return True

    def next_chunk(self, helper: bool) -> int | None:
        with self.lock:
            i = next(self.claim)
            if i >= self.n_chunks:
                return None
            if helper:
                self.busy += 1
                self.idle.clear()
            return i

    def done(self) -> None:
        """A helper left its chunk."""
        with self.lock:
            self.busy -= 1
            if self.busy == 0:
                self.idle.set()


class _Helpers:
    """Daemon threads that run the chunks of the current job they can claim (as many as
    the largest call asked for; a call takes at most the helpers it asks for)."""

    def __init__(self) -> None:
        self.pid = os.getpid()
        self.cv = threading.Condition()
        self.job: _Job | None = None
        self.generation = 0
        self.threads: list[threading.Thread] = []

    def ensure(self, n: int) -> None:
        while len(self.threads) < n:
            t = threading.Thread(
                target=self._work,
                args=(self.generation,),
                name=f"gnssframework-kernel-helper-{len(self.threads) + 1}",
                daemon=True,
            )
            self.threads.append(t)
            t.start()

    def _work(self, seen: int) -> None:
        while True:
            with self.cv:
                while self.generation == seen:
                    self.cv.wait()
                seen = self.generation
                job = self.job
            # A job whose caller already ran every chunk hands out none (late wake-up).
            if not job.join():
                continue
            while (i := job.next_chunk(True)) is not None:
                try:
                    job.run_chunk(i)
                except BaseException as exc:  # pragma: no cover - kernels do not raise
                    job.errors.append(exc)
                finally:
                    job.done()

    def run(self, n_chunks: int, run_chunk: Callable[[int], None], helpers: int) -> None:
        job = _Job(n_chunks, run_chunk, helpers)
        with self.cv:
            self.job = job
            self.generation += 1
            if helpers == 1:
                self.cv.notify()
            else:
                self.cv.notify_all()
        while (i := job.next_chunk(False)) is not None:
            run_chunk(i)
        with job.lock:  # wait only for chunks helpers are inside, never for their wake-up
            wait = job.busy > 0
        if wait:
            job.idle.wait()
        if job.errors:  # pragma: no cover
            raise job.errors[0]


_helpers: _Helpers | None = None
_lock = threading.Lock()


def run_chunks(n_chunks: int, run_chunk: Callable[[int], None], threads: int = 2) -> None:
    """Call ``run_chunk(i)`` for ``i = 0 .. n_chunks - 1``, each once, on the calling
    thread and up to ``threads - 1`` helper threads as each becomes free; returns when
    every chunk has run (``threads`` 1: all on the calling thread)."""
    global _helpers
    n_help = min(int(threads), n_chunks) - 1
    if n_help < 1:
        for i in range(n_chunks):
            run_chunk(i)
        return
    helpers = _helpers
    if helpers is None or helpers.pid != os.getpid() or len(helpers.threads) < n_help:
        with _lock:
            if _helpers is None or _helpers.pid != os.getpid():
                _helpers = _Helpers()
            _helpers.ensure(n_help)
            helpers = _helpers
    helpers.run(n_chunks, run_chunk, n_help)
