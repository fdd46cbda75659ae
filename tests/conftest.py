"""Shared test helpers: random PD matrices and a constant-acceleration model."""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence

import numpy as np
import pytest

import gnssframework as gf
from gnssframework.receiver.channels import ChannelRecord
from gnssframework.receiver.channels.records import RECORD_FIELDS

#: Memory one pytest-xdist worker may need: in `pytest -n 2` over the whole suite the largest
#: process peaked at 3.9 GB resident (time -v; the examples run whole in test_result_files),
#: a worker otherwise at 0.9-1.4 GB (its numba kernels, hypothesis, Monte Carlo arrays).
WORKER_BUDGET_MB = 4000


@pytest.hookimpl(optionalhook=True)  # xdist's hook: `-p no:xdist` (one process) must not fail on it
def pytest_xdist_auto_num_workers(config) -> int:
    """``pytest -n auto`` (the README's command): one worker per core this process may use,
    but no more than the available memory holds at WORKER_BUDGET_MB each, so a many-core
    machine does not start a numba compile per core beyond its RAM.
    PYTEST_XDIST_AUTO_NUM_WORKERS still sets the number outright, as pytest-xdist documents."""
    if os.environ.get("PYTEST_XDIST_AUTO_NUM_WORKERS"):
        return int(os.environ["PYTEST_XDIST_AUTO_NUM_WORKERS"])
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    try:
        import psutil  # with dask[distributed], a test extra
    except ImportError:
        return cores
    return max(1, min(cores, int(psutil.virtual_memory().available / 2**20 // WORKER_BUDGET_MB)))


def random_pd(rng: np.random.Generator, n: int, batch: tuple[int, ...] = (), scale: float = 1.0) -> np.ndarray:
    a = rng.standard_normal(batch + (n, n))
    return scale * (a @ np.swapaxes(a, -1, -2) / n + 0.1 * np.eye(n))


def channel_step_problem(rng: np.random.Generator, batch: int):
    """A random batch of channel-filter steps (5 states, 6 measurements): mean, P, z, R."""
    n, m = 5, 6
    A = rng.standard_normal((batch, n, n))
    P = A @ np.swapaxes(A, -1, -2) * 1e-2 + 1e-3 * np.eye(n)
    mean = np.array([1.0, 0.1, 0.2, 5.0, 0.0]) + 0.1 * rng.standard_normal((batch, n))
    z = rng.standard_normal((batch, m))
    R = np.broadcast_to(0.5 * np.eye(m), (batch, m, m)).copy()
    return mean, P, z, R


def ca_matrices(dt: float = 1.0, q: float = 0.01) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Constant-acceleration F, H (position measured) and Q (white jerk, Gamma q Gamma^T)."""
    F = np.array([[1.0, dt, dt**2 / 2], [0.0, 1.0, dt], [0.0, 0.0, 1.0]])
    H = np.array([[1.0, 0.0, 0.0]])
    G = np.array([[dt**3 / 6], [dt**2 / 2], [dt]])
    return F, H, q * (G @ G.T)


def psd_sqrt(a: np.ndarray) -> np.ndarray:
    """A square root of a PSD matrix that may be singular (rank-deficient Q)."""
    w, v = np.linalg.eigh(a)
    return v * np.sqrt(np.clip(w, 0, None))


def simulate_linear(rng, F, H, Q, R, x0, steps, batch=()):
    """Truth and measurements of x' = F x + w, z = H x + v, batch-first, time on axis 0."""
    n, m = F.shape[0], H.shape[0]
    Lq, Lr = psd_sqrt(Q), psd_sqrt(R)
    x = np.broadcast_to(x0, batch + (n,)).copy()
    xs, zs = [], []
    for _ in range(steps):
        x = x @ F.T + rng.standard_normal(batch + (n,)) @ Lq.T
        xs.append(x)
        zs.append(x @ H.T + rng.standard_normal(batch + (m,)) @ Lr.T)
    return np.stack(xs), np.stack(zs)


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20261122)


def create(kind: str, name: str, **params):
    return gf.registry.create(kind, name, **params)


#: The distribution whose entry point registers the built-in plugins (and the core's scenarios).
BUILTIN_DISTRIBUTION = "gnssframework"


def builtin_plugins(kind: str | None = None) -> list:
    """The registry's entries of this project's own distribution (of ``kind``, or every kind),
    sorted by kind then name. A test of the built-ins selects these, never the whole registry:
    a plugin another package installed beside the project (its ``coherent-eml``), or one a
    test registered at run time, is not a built-in (tests/core/test_outside_plugin.py)."""
    return [
        i for i in gf.registry.describe() if i.distribution == BUILTIN_DISTRIBUTION and (kind is None or i.kind == kind)
    ]


def builtin_names(kind: str) -> list[str]:
    """Names of the built-in plugins of ``kind``, sorted."""
    return [i.name for i in builtin_plugins(kind)]


@pytest.fixture
def scratch_registry():
    """For tests that register plugins at run time: the registry is rebuilt from the entry
    points afterwards, so those plugins do not leak into other tests."""
    yield gf.registry
    gf.registry.reload()


def _channel_record(
    prn: int,
    time_s: Sequence[float],
    prompt_i: Sequence[float],
    coherent_ms: Sequence[int],
    code_phase_chips: Sequence[float] | None = None,
) -> ChannelRecord:
    """A locked channel's record from its prompts (in phase), one row an interval of
    ``coherent_ms``: the other columns a steady 45 dB-Hz channel's (no Doppler, Q 0)."""
    n = len(time_s)
    code = np.zeros(n) if code_phase_chips is None else code_phase_chips
    rows = []
    for t, p, c, k in zip(time_s, prompt_i, code, coherent_ms):
        values = dict(
            time_s=t,
            cn0_dbhz=45.0,
            pli=1.0,
            doppler_hz=0.0,
            code_phase_chips=c,
            carrier_phase_cycles=0.0,
            lock=1,
            stage=1,
            prompt_i=p,
            prompt_q=0.0,
            coherent_ms=k,
        )
        rows.append(tuple(values[f] for f in RECORD_FIELDS))
    return ChannelRecord(prn, rows)


@pytest.fixture
def channel_record() -> Callable[..., ChannelRecord]:
    """`_channel_record`: ``channel_record(prn, time_s, prompt_i, coherent_ms, code_phase_chips=None)``,
    for the message decoders' tests (I/NAV, SBAS, CNAV) that read prompts as symbols."""
    return _channel_record
