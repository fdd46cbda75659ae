"""`pytest -n auto` (the README's test command): a worker per usable core, capped by the
memory each worker needs (tests/conftest.py's hook), and the environment's number obeyed."""

from __future__ import annotations

import os
from types import SimpleNamespace

import psutil
import pytest

import conftest


def _machine(monkeypatch, cores: int, available_mb: float) -> None:
    monkeypatch.delenv("PYTEST_XDIST_AUTO_NUM_WORKERS", raising=False)
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: set(range(cores)), raising=False)
    monkeypatch.setattr(psutil, "virtual_memory", lambda: SimpleNamespace(available=available_mb * 2**20))


@pytest.mark.parametrize(
    "cores, available_mb, workers",
    [
        (2, 22_000, 2),  # CI: both cores
        (16, 6 * conftest.WORKER_BUDGET_MB + 1, 6),  # many cores, the memory holds 6 workers
        (16, 0.5 * conftest.WORKER_BUDGET_MB, 1),  # never fewer than one
    ],
)
def test_auto_workers_are_the_cores_the_memory_holds(monkeypatch, cores, available_mb, workers):
    _machine(monkeypatch, cores, available_mb)
    assert conftest.pytest_xdist_auto_num_workers(config=None) == workers


def test_the_environment_sets_the_number_outright(monkeypatch):
    _machine(monkeypatch, 16, 10 * conftest.WORKER_BUDGET_MB)
    monkeypatch.setenv("PYTEST_XDIST_AUTO_NUM_WORKERS", "3")
    assert conftest.pytest_xdist_auto_num_workers(config=None) == 3
