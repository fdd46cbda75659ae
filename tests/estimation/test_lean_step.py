"""The lean sigma-point step (issue 11): one compiled update that reports missing
measurements, failed roots and a non-PD innovation covariance as counts, kernel inputs
handed over writable, shared Q/R views kept between steps, mask tests without NumPy
reductions. Each is held to the NumPy reference path (results to 1e-12 relative, the
same named failures and the same skipped elements). Time is never asserted.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import gnssframework as gf
from gnssframework.errors import InvalidMeasurementError, NumericalError
from gnssframework.estimation import CompiledFunctions, compiled as kernels, linear_f, linear_h
from gnssframework.signal.channel_model import channel_iq_row
from gnssframework.estimation.linalg import all_true, any_true
from conftest import channel_step_problem
from test_kernels import _close, _engine, _kernel_signatures, _problem

SIGMA = ("ukf", "ckf", "svd-ckf")


def _outcome(est, backend, state, z, model, **kw):
    """``("error", type, batch indices)`` or ``("ok", update)`` of one predict + update."""
    est.backend = backend
    try:
        return "ok", est.update(est.predict(state, model), z, model, **kw)
    except (NumericalError, InvalidMeasurementError) as exc:
        return "error", type(exc), exc.batch_indices


@settings(max_examples=40, deadline=None)
@given(
    name=st.sampled_from(SIGMA),
    batch=st.sampled_from([(), (1,), (4,), (2, 3)]),
    seed=st.integers(0, 2**32 - 1),
    nan_z=st.sets(st.integers(0, 5), max_size=3),
    bad_r=st.sets(st.integers(0, 5), max_size=2),
    missing=st.sampled_from(["raise", "skip"]),
    on_failure=st.sampled_from(["raise", "skip"]),
    dims=st.sampled_from([(4, 3), (5, 6)]),
)
def test_lean_update_fails_and_skips_like_the_numpy_path(name, batch, seed, nan_z, bad_r, missing, on_failure, dims):
    # A LinearModel carries compiled F x / H x, so the numba backend takes the lean path;
    # 5 states / 6 measurements take the kernels specialised to those sizes.
    n, m = dims
    _, linear, state, z = _problem(seed, n, m, batch)
    size = int(np.prod(batch))
    z = z.copy().reshape(-1, m)
    R = np.array(linear.R).reshape(-1, m, m)
    for i in nan_z:
        if i < size:
            z[i, i % m] = np.nan if i % 2 else np.inf
    for i in bad_r:
        if i < size:
            R[i] = -1e3 * np.eye(m)  # S = H P H^T + R not PD there
    model = gf.LinearModel(linear.F, linear.H, linear.Q, R.reshape(batch + (m, m)))
    z = z.reshape(batch + (m,))
    est = _engine(name)
    ref = _outcome(est, "numpy", state, z, model, missing=missing, on_failure=on_failure)
    got = _outcome(est, "numba", state, z, model, missing=missing, on_failure=on_failure)
    assert ref[0] == got[0]
    if ref[0] == "error":
        assert ref[1:] == got[1:]
        return
    ref, upd = ref[1], got[1]
    assert np.array_equal(ref.skipped, upd.skipped)
    assert upd.skipped.shape == batch
    for field in ("innovation", "innovation_cov", "gain", "cross_cov", "predicted_measurement"):
        _close(getattr(ref, field), getattr(upd, field))
    _close(ref.state.mean, upd.state.mean)
    _close(ref.state.cov, upd.state.cov)


@pytest.mark.slow
@pytest.mark.other_machines
@settings(max_examples=30, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    root_kind=st.sampled_from([0, 1]),
    batch=st.sampled_from([3, 300]),
    poison=st.sampled_from(["none", "nan-z", "nan-P", "indefinite-P", "S-not-PD"]),
    channel=st.booleans(),
)
def test_size_specialised_fused_kernels_are_bitwise_the_generic_ones(seed, root_kind, batch, poison, channel):
    # The twins compiled for 5 states / 6 measurements run the generic kernels' code with
    # the sizes as constants: the same operations in the same order, so bitwise the same
    # results, statuses and counts (serial below the parallel threshold, parallel above).
    rng = np.random.default_rng(seed)
    mean, P, z, R = channel_step_problem(rng, batch)
    n, m = mean.shape[-1], z.shape[-1]
    i = int(rng.integers(batch))
    if poison == "nan-z":
        z[i, 2] = np.nan
    elif poison == "nan-P":
        P[i, 1, 1] = np.nan
    elif poison == "indefinite-P":
        P[i] = -P[i]
    elif poison == "S-not-PD":
        R[i] = -1e3 * np.eye(m)
    if channel:  # the correlator model of the iq-filter
        functions = (
            linear_f,
            np.eye(n) + 0.01 * rng.standard_normal((n, n)),
            channel_iq_row,
            np.array([[0.5, 0.01, 1.0]]),
        )
    else:
        functions = (linear_f, rng.standard_normal((n, n)), linear_h, rng.standard_normal((m, n)))
    N = 2 * n + (root_kind == 0)
    w = rng.uniform(0.5, 1.5, N) / N
    rule = (root_kind, float(np.sqrt(n)), root_kind == 0, w, w[::-1].copy())
    Q = 1e-3 * np.eye(n)
    outs = []
    for sizes in ((n, m), None):  # drivers with the sizes as constants, then the generic ones
        compiled = CompiledFunctions(*functions, sizes=sizes)
        outs.append(
            kernels.fused_predict(mean, P, rule, compiled, Q)
            + kernels.fused_update(mean, P, z, None, rule, compiled, R)
        )
    got, ref = outs
    assert (got[2] is None) == (ref[2] is None)
    rooted = ref[10] == 0  # elements whose root failed leave their outputs unset
    for a, b in zip(got[10:13], ref[10:13]):  # status, ok, skipped
        assert np.array_equal(a, b)
    assert got[13] == ref[13]  # counts
    for a, b in zip(got[:2] + got[3:10], ref[:2] + ref[3:10]):
        assert np.array_equal(a[rooted], b[rooted], equal_nan=True)


@pytest.mark.parametrize("name", SIGMA)
def test_read_only_inputs_give_the_same_step_and_no_new_specialisation(name):
    _, linear, state, z = _problem(11, 5, 6, (3,))
    est = _engine(name)
    est.backend = "numba"
    kernels.warm_up()
    ref = est.update(est.predict(state, linear), z, linear)
    before = _kernel_signatures()

    def frozen(a):
        a = np.array(a)
        a.setflags(write=False)
        return a

    ro_model = gf.LinearModel(frozen(linear.F), frozen(linear.H), frozen(linear.Q), frozen(linear.R))
    ro_state = gf.Gaussian(frozen(state.mean), frozen(state.cov))
    upd = est.update(est.predict(ro_state, ro_model), frozen(z), ro_model)
    assert _kernel_signatures() == before
    _close(ref.state.mean, upd.state.mean)
    _close(ref.state.cov, upd.state.cov)
    assert not np.shares_memory(upd.state.mean, ro_state.mean)


def test_a_shared_noise_matrix_changed_in_place_is_seen_by_the_next_step():
    # The kernels keep a view of a shared Q/R between steps; a view shares the memory.
    _, linear, state, z = _problem(2, 3, 2, (4,))
    R = np.eye(2)
    model = gf.LinearModel(linear.F, linear.H, linear.Q, R)
    est = _engine("ckf")
    est.backend = "numba"
    est.update(state, z, model)
    R *= 50.0
    upd = est.update(state, z, model)
    est.backend = "numpy"
    ref = est.update(state, z, gf.LinearModel(linear.F, linear.H, linear.Q, 50.0 * np.eye(2)))
    _close(ref.innovation_cov, upd.innovation_cov)
    _close(ref.state.cov, upd.state.cov)


@settings(max_examples=60, deadline=None)
@given(
    shape=st.sampled_from([(), (1,), (5,), (2, 3), (70,), (3, 40)]),
    seed=st.integers(0, 2**32 - 1),
    density=st.sampled_from([0.0, 0.02, 0.5, 1.0]),
    dtype=st.sampled_from([np.bool_, np.int8]),
)
def test_small_mask_tests_equal_numpy_reductions(shape, seed, density, dtype):
    mask = (np.random.default_rng(seed).random(shape) < density).astype(dtype)
    assert any_true(mask) is bool(mask.any())
    assert all_true(mask) is bool(mask.all())
