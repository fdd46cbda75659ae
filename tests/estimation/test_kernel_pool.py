"""The split of a fused kernel between the calling thread and a helper thread
(`gnssframework.estimation.compiled.pool`, issue 11) against one serial call: bitwise the
same results, statuses and counts, every chunk run once, and a working helper again in
a forked child. Time is never asserted.

Bitwise by construction on any machine: each chunk runs the serial kernel's code on its
own elements, so no element's operations or their order depend on the split, and numba
compiles without fastmath (no reassociation, no FMA contraction). Marked
``other_machines``: .ci/other_machines.sh checks that under other compile targets."""

from __future__ import annotations

import multiprocessing
import threading

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from conftest import channel_step_problem
from gnssframework.estimation import CompiledFunctions, compiled as kernels, linear_f
from gnssframework.estimation.compiled import loop as kernels_loop, pool as kernel_pool, split
from gnssframework.signal.channel_model import channel_iq_row
from gnssframework_plugins.nav_filters import range_rate_jacobian, range_rate_row

pytestmark = pytest.mark.other_machines


def _problem(seed, batch, poison):
    rng = np.random.default_rng(seed)
    mean, P, z, R = channel_step_problem(rng, batch)
    n, m = mean.shape[-1], z.shape[-1]
    for i in rng.integers(batch, size=3):
        if poison == "nan-z":
            z[i, 2] = np.nan
        elif poison == "indefinite-P":
            P[i] = -P[i]
        elif poison == "S-not-PD":
            R[i] = -1e3 * np.eye(m)
    compiled = CompiledFunctions(
        linear_f,
        np.eye(n) + 0.01 * rng.standard_normal((n, n)),
        channel_iq_row,
        np.array([[0.5, 0.01, 1.0]]),
        sizes=(n, R.shape[-1]),
    )
    return mean, P, z, R, compiled


def _step(mean, P, z, R, compiled, root_kind, shared_r):
    n = mean.shape[-1]
    N = 2 * n + (root_kind == 0)
    w = np.full(N, 1.0 / N)
    rule = (root_kind, float(np.sqrt(n)), root_kind == 0, w, w)
    return kernels.fused_predict(mean, P, rule, compiled, 1e-3 * np.eye(n)) + kernels.fused_update(
        mean, P, z, None, rule, compiled, R[0] if shared_r else R
    )


def _assert_same(got, ref):
    status = ref[10]
    rooted = status == 0  # elements whose root failed leave their outputs unset
    assert (got[2] is None) == (ref[2] is None)
    for a, b in zip(got[10:13], ref[10:13]):
        assert np.array_equal(a, b)
    assert got[13] == ref[13]
    for a, b in zip(got[:2] + got[3:10], ref[:2] + ref[3:10]):
        assert np.array_equal(a[rooted], b[rooted], equal_nan=True)


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    batch=st.integers(kernels.PARALLEL_MIN_BATCH, 1100),
    root_kind=st.sampled_from([0, 1]),
    shared_r=st.booleans(),
    poison=st.sampled_from(["none", "nan-z", "indefinite-P", "S-not-PD"]),
    chunks=st.sampled_from([2, 8, 13]),
)
def test_split_fused_kernels_are_bitwise_one_serial_call(seed, batch, root_kind, shared_r, poison, chunks):
    args = _problem(seed, batch, poison)
    assert split.SPLIT == "pool"
    with pytest.MonkeyPatch.context() as m:
        m.setattr(split, "SPLIT_CHUNKS", chunks)
        chunked = _step(*args, root_kind, shared_r)
        m.setattr(split, "pick", lambda pair, batch, min_batch=None: pair[0])
        serial = _step(*args, root_kind, shared_r)
    _assert_same(chunked, serial)
    # (A shared R is R[0], maybe clean; the eigen-decomposition root takes an indefinite P.)
    if poison != "none" and not (shared_r and poison == "S-not-PD") and not (root_kind and poison == "indefinite-P"):
        assert sum(chunked[13]) + (chunked[2] is not None) > 0  # the failures were seen and counted


def test_every_chunk_runs_once_on_either_thread():
    for n_chunks in (1, 2, 7, 64):
        for _ in range(20):
            seen, threads = [], set()

            def run(i, seen=seen, threads=threads):
                seen.append(i)
                threads.add(threading.current_thread().name)

            kernel_pool.run_chunks(n_chunks, run)
            assert sorted(seen) == list(range(n_chunks))
            # The caller's thread or a helper ("gnssframework-kernel-helper-<n>", `pool._Helpers`):
            # which one claims a chunk is a race (a helper that wakes first takes some).
            main = threading.current_thread().name
            assert all(t == main or t.startswith("gnssframework-kernel-helper-") for t in threads), threads


def _child(queue):
    queue.put(_step(*_problem(7, 600, "nan-z"), 1, False))


@pytest.mark.skipif("fork" not in multiprocessing.get_all_start_methods(), reason="needs fork")
def test_a_forked_child_splits_with_a_helper_of_its_own():
    # `compare` forks its workers after warm-up; the parent's helper thread does not
    # exist in the child, which must start its own instead of waiting for it.
    parent = _step(*_problem(7, 600, "nan-z"), 1, False)  # the parent's helper runs
    ctx = multiprocessing.get_context("fork")
    queue = ctx.Queue()
    proc = ctx.Process(target=_child, args=(queue,))
    proc.start()
    child = queue.get(timeout=60)
    proc.join(timeout=60)
    assert proc.exitcode == 0
    _assert_same(child, parent)


def _serial(m):
    """Patch every split decision to one serial call."""
    m.setattr(split, "pick", lambda pair, batch, min_batch=None: pair[0])
    m.setattr(split, "split_by_work", lambda B, n, mm: False)
    m.setattr(split, "SPLIT", "numba")


@settings(max_examples=15, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1), batch=st.sampled_from([60, 100, 300]), joseph=st.booleans(), bad=st.integers(0, 3)
)
def test_split_kf_update_and_ekf_moments_are_bitwise_one_serial_call(seed, batch, joseph, bad):
    # ekf-pv's sizes (8 states, 16 measurements): split from about 45 elements on.
    rng = np.random.default_rng(seed)
    n, m = 8, 16
    assert split.split_by_work(batch, n, m) or batch >= kernels.PARALLEL_MIN_BATCH
    mean = rng.standard_normal((batch, n)) * 100 + np.array([6.4e6, 0, 0, 0, 0, 0, 0, 0])
    A = rng.standard_normal((batch, n, n))
    P = A @ np.swapaxes(A, -1, -2) + np.eye(n)
    R = np.broadcast_to(np.eye(m), (batch, m, m)).copy()
    R[:bad] = -1e9 * np.eye(m)  # S not PD there
    sat = np.concatenate([2e7 * rng.standard_normal((m // 2, 3)), 1e3 * rng.standard_normal((m // 2, 3))], axis=1)
    compiled = CompiledFunctions(linear_f, np.eye(n), range_rate_row, sat, range_rate_jacobian)
    z = rng.standard_normal((batch, m))
    bad_z = np.zeros(batch, bool)
    bad_z[-1] = True
    H = rng.standard_normal((m, n))

    def run():
        zh, S, C = kernels.ekf_moments(mean, P, compiled, R)
        return (zh, S, C) + kernels.update(mean, P, z, zh, S, C, bad_z, joseph, H, R)

    chunked = run()
    with pytest.MonkeyPatch.context() as mp:
        _serial(mp)
        serial = run()
    for a, b in zip(chunked, serial):
        assert np.array_equal(a, b, equal_nan=True)
    assert (~chunked[-1]).sum() == bad


def _guard_problem(seed, batch, spread, k=6):
    """Raw 6 x 6 estimates spread over decades around a random reference, some indefinite:
    the raw estimates, the reference's (w, v) and k."""
    from gnssframework.estimation.linalg import regularised

    rng = np.random.default_rng(seed)
    A = rng.standard_normal((k, k))
    ref = A @ A.T + 0.1 * np.eye(k)
    B_ = rng.standard_normal((batch, k, k))
    raw = 10.0**spread * (B_ @ np.swapaxes(B_, -1, -2)) / k + 0.5 * rng.standard_normal((batch, k, k))
    return raw, regularised(ref), k


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), batch=st.sampled_from([256, 801]), spread=st.floats(-3.0, 3.0))
def test_split_guard_is_bitwise_one_serial_call(seed, batch, spread):

    raw, (w, v), k = _guard_problem(seed, batch, spread)
    chunked = kernels_loop.guard(raw, (v * w) @ v.T, (w, v), 0.01, 100.0)
    with pytest.MonkeyPatch.context() as mp:
        _serial(mp)
        serial = kernels_loop.guard(raw, (v * w) @ v.T, (w, v), 0.01, 100.0)
    assert chunked is not None and np.array_equal(chunked, serial)


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), batch=st.sampled_from([1, 9, 300]), spread=st.floats(-3.0, 3.0))
def test_size_specialised_guard_is_bitwise_the_generic_one(seed, batch, spread):
    # The 6 x 6 guard (the channel filter's R) compiled with its size as a constant runs
    # the generic kernel's operations in the same order: bitwise the same estimates.

    raw, (w, v), k = _guard_problem(seed, batch, spread)
    assert k in kernels_loop._GUARD_BY_SIZE
    special = kernels_loop.guard(raw, (v * w) @ v.T, (w, v), 0.01, 100.0)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(kernels_loop, "_GUARD_BY_SIZE", {})
        generic = kernels_loop.guard(raw, (v * w) @ v.T, (w, v), 0.01, 100.0)
    assert special is not None and np.array_equal(special, generic)
