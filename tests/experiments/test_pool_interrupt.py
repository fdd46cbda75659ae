"""A Ctrl-C at any moment of a local multi-process run leaves no worker behind.

CI's real Ctrl-C test (tests/core/test_cli_failures.py) hung once under load: the signal
landed while the pool forked its workers, between ``Process.start()`` and the pool
recording the process, so the runner's `_stop` could not terminate that worker, and the
orphan held the test's pipes open. Here the signal is sent at exactly that moment, with a
second thread alive as in any real process (pytest-xdist's, OpenBLAS's): the kernel may hand
the signal to that thread, so blocking it in the main thread alone is not a fix.
"""

from __future__ import annotations

import os
import signal
import threading
import time
from multiprocessing.process import BaseProcess

import pytest

from gnssframework import backend
from gnssframework.experiments import runner
from gnssframework.experiments.config import Executor


def _wait_in_worker(plan, task):
    time.sleep(60.0)  # a batch that is still computing when the Ctrl-C comes


def _ends_within(process: BaseProcess, timeout_s: float) -> bool:
    """Whether ``process`` has ended within ``timeout_s``, asked of the kernel.

    Not ``process.join(); not process.is_alive()``: the pool's manager thread joins its
    workers on shutdown too, and when its ``waitpid`` reaps a worker first, this thread's
    ``waitpid`` fails (ECHILD), which multiprocessing reads as "still running" (an ended
    worker was reported alive in about 1 run of 3 alone)."""
    deadline = time.monotonic() + timeout_s
    while True:
        if process.exitcode is not None:
            return True
        try:
            pid, _ = os.waitpid(process.pid, os.WNOHANG)  # reaps it if it ended unreaped
        except ChildProcessError:
            return True  # ended, and already reaped by the pool's thread
        if pid != 0:
            return True
        if time.monotonic() > deadline:
            return False
        time.sleep(0.05)


@pytest.mark.slow
def test_a_ctrl_c_while_the_pool_forks_its_workers_leaves_none_running(monkeypatch):
    started: list[BaseProcess] = []
    start = BaseProcess.start

    def start_then_ctrl_c(self):
        start(self)
        started.append(self)
        if len(started) == 1:  # the first worker forked, not yet recorded by the pool
            os.kill(os.getpid(), signal.SIGINT)

    monkeypatch.setattr(BaseProcess, "start", start_then_ctrl_c)
    monkeypatch.setattr(runner, "run_task_in_worker", _wait_in_worker)
    monkeypatch.setattr(backend, "compiled", lambda: False)  # no kernel warm-up: the pool at once
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    other_thread_ends = threading.Event()
    other_thread = threading.Thread(target=other_thread_ends.wait, daemon=True)
    other_thread.start()
    try:
        results = runner._execute([(None, None)] * 3, Executor(kind="local", workers=2))
        with pytest.raises(KeyboardInterrupt):
            next(results)
        assert len(started) == 2  # the signal waited until the pool had both workers
        assert [_ends_within(p, 10.0) for p in started] == [True, True]
    finally:
        other_thread_ends.set()
        signal.signal(signal.SIGINT, previous)
        for process in started:
            if process.is_alive():
                process.kill()
