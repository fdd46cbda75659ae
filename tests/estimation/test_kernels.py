"""The compiled kernels against the NumPy reference path and against LAPACK.

The NumPy path of every estimator is the reference; the kernels must reproduce it to
1e-12 relative on random nonlinear models (Hypothesis draws the dimensions, the batch
shape and the seed of the model). The UKF is drawn with alpha in [0.3, 1]: at alpha =
1e-3 its centre weight is about -n/alpha^2 and the weighted mean cancels ~1e6-sized
terms, so *both* paths carry ~1e-10 relative rounding and no bitwise order can be
asserted between them.
"""

from __future__ import annotations

import numpy as np
from gnssframework import backend as backend_module
from gnssframework.backend import get_backend, set_backend
import pytest
from hypothesis import given, settings, strategies as st

import gnssframework as gf
from gnssframework.errors import NotPositiveDefiniteError
from gnssframework.estimation import compiled as kernels
from gnssframework.estimation.compiled import dense, drivers, split
from gnssframework.estimation.compiled import loop as kernels_loop
from conftest import create


ENGINES = ("kf", "ekf", "ukf", "ckf", "svd-ckf")
REL = 1e-12


def _separated_pd(rng, n, batch):
    """PD matrices whose eigenvalues are at least 0.3 apart (eigenvectors well defined)."""
    q, _ = np.linalg.qr(rng.standard_normal(batch + (n, n)))
    w = 0.5 + 0.4 * np.arange(n) + 0.1 * rng.random(batch + (n,))
    return (q * w[..., None, :]) @ np.swapaxes(q, -1, -2)


def _problem(seed, n, m, batch):
    rng = np.random.default_rng(seed)
    F = np.eye(n) + 0.2 * rng.standard_normal((n, n))
    H = rng.standard_normal((m, n))
    Q = _separated_pd(rng, n, ()) * 0.1
    R = _separated_pd(rng, m, batch)  # per element: exercises the batched operand
    c = rng.standard_normal(m)

    def f(x):
        return np.sin(x) @ F.T + 0.1 * x

    def h(x):
        return np.tanh(x @ H.T) + c * x[..., :1] ** 2

    state = gf.Gaussian(rng.standard_normal(batch + (n,)), _separated_pd(rng, n, batch))
    z = rng.standard_normal(batch + (m,))
    return gf.NonlinearModel(f, h, Q, R), gf.LinearModel(F, H, Q, R), state, z


def _engine(name, alpha=0.5):
    return create("estimator", name, alpha=alpha) if name == "ukf" else create("estimator", name)


def _close(a, b):
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape
    scale = max(np.max(np.abs(a)), 1e-300)
    assert np.max(np.abs(a - b)) <= REL * scale


def _run(est, backend, state, z, model, **kw):
    est.backend = backend
    prior = est.predict(state, model)
    upd = est.update(prior, z, model, **kw)
    return prior, upd


@settings(max_examples=40, deadline=None)
@given(
    name=st.sampled_from(ENGINES),
    n=st.integers(1, 6),
    m=st.integers(1, 6),
    batch=st.sampled_from([(), (1,), (3,), (2, 3)]),
    seed=st.integers(0, 2**32 - 1),
    alpha=st.floats(0.3, 1.0),
    linear_model=st.booleans(),
)
def test_kernel_path_equals_the_numpy_path(name, n, m, batch, seed, alpha, linear_model):
    # A LinearModel carries compiled F x / H x: sigma-point engines then run fused.
    nonlinear, linear, state, z = _problem(seed, n, m, batch)
    model = linear if (name == "kf" or linear_model) else nonlinear
    est = _engine(name, alpha)
    ref_prior, ref = _run(est, "numpy", state, z, model)
    prior, upd = _run(est, "numba", state, z, model)
    _close(ref_prior.mean, prior.mean)
    _close(ref_prior.cov, prior.cov)
    for field in ("innovation", "innovation_cov", "gain", "cross_cov", "predicted_measurement"):
        _close(getattr(ref, field), getattr(upd, field))
    _close(ref.state.mean, upd.state.mean)
    _close(ref.state.cov, upd.state.cov)
    assert np.array_equal(ref.skipped, upd.skipped)


@pytest.mark.parametrize("name", ENGINES)
def test_parallel_kernels_equal_the_numpy_path_on_a_large_batch(name):
    batch = (kernels.PARALLEL_MIN_BATCH + 7,)
    nonlinear, linear, state, z = _problem(7, 5, 6, batch)
    model = linear if name == "kf" else nonlinear
    est = _engine(name)
    _, ref = _run(est, "numpy", state, z, model)
    _, upd = _run(est, "numba", state, z, model)
    _close(ref.state.mean, upd.state.mean)
    _close(ref.state.cov, upd.state.cov)
    _close(ref.gain, upd.gain)


@pytest.mark.parametrize("linear_model", (False, True))
@pytest.mark.parametrize("name", ENGINES)
def test_missing_measurements_skip_the_same_elements_in_both_paths(name, linear_model):
    nonlinear, linear, state, z = _problem(3, 4, 3, (5,))
    model = linear if (name == "kf" or linear_model) else nonlinear
    z = z.copy()
    z[[1, 3], 0] = np.nan
    est = _engine(name)
    _, ref = _run(est, "numpy", state, z, model, missing="skip")
    _, upd = _run(est, "numba", state, z, model, missing="skip")
    assert upd.skipped.tolist() == [False, True, False, True, False]
    assert np.array_equal(ref.skipped, upd.skipped)
    _close(ref.state.mean, upd.state.mean)
    _close(ref.state.cov, upd.state.cov)
    _close(ref.gain, upd.gain)
    assert np.all(upd.innovation[[1, 3]] == 0.0)


@pytest.mark.parametrize("linear_model", (False, True))
@pytest.mark.parametrize("name", ("ukf", "ckf"))
def test_a_covariance_that_is_not_pd_is_named_alike_in_both_paths(name, linear_model):
    nonlinear, linear, state, z = _problem(5, 3, 2, (4,))
    model = linear if linear_model else nonlinear
    cov = state.cov.copy()
    cov[2] = -np.eye(3)
    bad = gf.Gaussian(state.mean, cov)
    est = _engine(name)
    for backend in ("numpy", "numba"):
        est.backend = backend
        with pytest.raises(NotPositiveDefiniteError) as err:
            est.predict(bad, model)
        assert err.value.batch_indices == [(2,)], backend
        with pytest.raises(NotPositiveDefiniteError) as err:
            est.update(bad, z, model)
        assert err.value.batch_indices == [(2,)], backend


def test_innovation_covariance_not_pd_is_named_or_skipped_like_numpy():
    _, linear, state, z = _problem(9, 3, 2, (4,))
    R = np.array(linear.R)
    R[1] = -100.0 * np.eye(2)
    model = gf.LinearModel(linear.F, linear.H, linear.Q, R)
    est = create("estimator", "kf")
    for backend in ("numpy", "numba"):
        est.backend = backend
        with pytest.raises(NotPositiveDefiniteError) as err:
            est.update(state, z, model)
        assert err.value.batch_indices == [(1,)], backend
    _, ref = _run(est, "numpy", state, z, model, on_failure="skip")
    _, upd = _run(est, "numba", state, z, model, on_failure="skip")
    assert upd.skipped.tolist() == [False, True, False, False]
    _close(ref.state.cov, upd.state.cov)


@settings(max_examples=30, deadline=None)
@given(n=st.integers(1, 8), seed=st.integers(0, 2**32 - 1))
def test_jacobi_eigensolver_reproduces_lapack_eigenvalues_and_the_matrix(n, seed):
    rng = np.random.default_rng(seed)
    a = rng.standard_normal((n, n))
    sym = a + a.T  # indefinite in general: the svd-ckf root takes |w|
    w = np.empty(n)
    v = np.empty((n, n))
    dense.jacobi_eigh(sym, w, v)
    scale = np.max(np.abs(sym))
    assert np.max(np.abs(np.sort(w) - np.linalg.eigvalsh(sym))) <= 1e-13 * scale
    assert np.max(np.abs((v * w) @ v.T - sym)) <= 1e-13 * scale
    assert np.max(np.abs(v.T @ v - np.eye(n))) <= 1e-13


def test_backend_selection_is_validated_and_falls_back_to_numpy(monkeypatch):
    from gnssframework.errors import ConfigError

    with pytest.raises(ConfigError, match="numba"):
        set_backend("fortran")
    try:
        # The environment is read at import and by set_backend(None), not on every step.
        # (Either way round: the suite also runs under GNSSFRAMEWORK_BACKEND=numpy.)
        before = get_backend()
        other = "numpy" if before == "numba" else "numba"
        monkeypatch.setenv("GNSSFRAMEWORK_BACKEND", other)
        assert get_backend() == before
        set_backend(None)
        assert get_backend() == other
        monkeypatch.setenv("GNSSFRAMEWORK_BACKEND", "numba")
        set_backend(None)
        assert get_backend() == "numba"
        monkeypatch.setenv("GNSSFRAMEWORK_BACKEND", "fortran")
        set_backend(None)
        with pytest.raises(ConfigError, match="GNSSFRAMEWORK_BACKEND"):
            get_backend()
        monkeypatch.setenv("GNSSFRAMEWORK_BACKEND", "numba")
        set_backend(None)
        monkeypatch.setattr(backend_module, "HAVE_NUMBA", False)
        assert get_backend() == "numpy"
    finally:
        monkeypatch.undo()
        set_backend(None)


@pytest.mark.parametrize("name", ("ukf", "ckf", "svd-ckf"))
def test_compiled_channel_model_equals_the_numpy_channel_model(name):
    from gnssframework.signal.channel_model import channel_model

    rng = np.random.default_rng(11)
    Q = np.diag([1e-4, 1e-6, 1e-3, 1e-2, 1e-1])
    R = np.eye(6) + 0.2  # correlated taps
    compiled = channel_model(0.01, 0.5, Q, R)
    assert compiled.compiled is not None
    plain = gf.NonlinearModel(compiled.f, compiled.h, Q, R)  # same NumPy functions, no twins
    x = np.array([40.0, 0.05, 0.1, 2.0, 0.0]) + rng.standard_normal((6, 5)) * [1.0, 0.3, 1.0, 5.0, 1.0]
    x[0, 3] = 0.0  # sinc's removable singularity
    x[1, 1] = 1.2  # beyond the triangle's support on every tap
    state = gf.Gaussian(x, np.diag([4.0, 0.01, 0.1, 4.0, 1.0]))
    z = compiled.h(x) + rng.standard_normal((6, 6))
    est = _engine(name)
    ref_prior, ref = _run(est, "numpy", state, z, plain)
    prior, upd = _run(est, "numba", state, z, compiled)
    _close(ref_prior.mean, prior.mean)
    _close(ref_prior.cov, prior.cov)
    for field in ("innovation", "innovation_cov", "gain", "cross_cov", "predicted_measurement"):
        _close(getattr(ref, field), getattr(upd, field))
    _close(ref.state.mean, upd.state.mean)
    _close(ref.state.cov, upd.state.cov)


def _parallel_update_in_child(seed):
    _, linear, state, z = _problem(seed, 3, 2, (kernels.PARALLEL_MIN_BATCH,))
    est = _engine("ckf")
    est.backend = "numba"
    return est.update(est.predict(state, linear), z, linear).state.mean


def test_a_process_forked_after_a_parallel_kernel_runs_parallel_kernels():
    # GNU OpenMP aborts such a child; `compare` forks its workers from a parent that may
    # have filtered a large batch already. Also checks the child computes the same thing.
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    here = _parallel_update_in_child(1)
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("fork")) as pool:
        there = pool.submit(_parallel_update_in_child, 1).result(timeout=120)
    assert np.array_equal(here, there)


def test_parallel_kernels_are_not_used_off_the_main_thread():
    import threading

    picked = []
    t = threading.Thread(target=lambda: picked.append(split.pick(("serial", "parallel"), 10**6)))
    t.start()
    t.join()
    assert picked == ["serial"]
    assert split.pick(("serial", "parallel"), 10**6) == "parallel"
    assert split.pick(("serial", "parallel"), 1) == "serial"


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(1, 8),
    seed=st.integers(0, 2**32 - 1),
    batch=st.sampled_from([(), (5,), (2, 3), (300,), (kernels.PD_MASK_PARALLEL_MIN_BATCH + 52,)]),
)
def test_pd_mask_kernel_agrees_with_lapack_eigenvalues(n, seed, batch):
    # Truth from LAPACK's eigenvalues: each matrix has its smallest eigenvalue set to
    # +-(0.01..1) of its largest, far from rounding level, or holds a NaN/inf.
    rng = np.random.default_rng(seed)
    q, _ = np.linalg.qr(rng.standard_normal(batch + (n, n)))
    w = rng.uniform(0.5, 2.0, batch + (n,))
    w[..., 0] = rng.uniform(0.01, 1.0, batch) * rng.choice([-1.0, 1.0], batch)
    a = (q * w[..., None, :]) @ np.swapaxes(q, -1, -2)
    a = 0.5 * (a + np.swapaxes(a, -1, -2))
    spoil = rng.random(batch) < 0.1
    a[spoil, n - 1, 0] = rng.choice([np.nan, np.inf])
    truth = (w[..., 0] > 0) & ~spoil
    assert np.array_equal(kernels.pd_mask(a), truth)
    from gnssframework.estimation.linalg import cholesky_masked

    assert np.array_equal(cholesky_masked(a)[1], truth)


def _count_lapack(monkeypatch):
    calls = []
    for fn in ("cholesky", "eigvalsh", "eigh", "solve", "inv"):
        real = getattr(np.linalg, fn)
        monkeypatch.setattr(np.linalg, fn, lambda *a, _r=real, _n=fn, **k: (calls.append(_n), _r(*a, **k))[1])
    return calls


@pytest.mark.parametrize("estimator", ("ckf", "svd-ckf"))
def test_the_step_of_iq_filter_makes_no_lapack_call(monkeypatch, estimator):
    # The lean step: with the compiled kernels and the channel model's compiled h, a
    # filter step (boundary checks, predict, update, posterior check) runs without
    # NumPy's batched LAPACK wrappers. Counting the calls is what a per-step
    # re-validation (a Cholesky of P only to test it) would break; time is never asserted.
    from gnssframework import registry
    from gnssframework.interfaces import RunContext
    from gnssframework.signal.correlators import Correlators

    set_backend("numba")
    try:
        ch = registry.create("channel_filter", "iq-filter", estimator=estimator, adaptive=False)
        batch = (4, 3)
        ch.reset(
            batch,
            RunContext(
                coherent_time_s=0.01, early_late_spacing_chips=1.0, epoch_interval_s=0.01, cn0_dbhz=np.full(batch, 45.0)
            ),
        )
        rng = np.random.default_rng(3)
        x_true = np.array([10.0, 0.0, 0.3, 0.0, 0.0])

        def inputs():
            iq = ch.model.h(np.broadcast_to(x_true, batch + (5,))) + rng.standard_normal(batch + (6,))
            corr = Correlators(
                early=iq[..., 0] + 1j * iq[..., 3],
                prompt=iq[..., 1] + 1j * iq[..., 4],
                late=iq[..., 2] + 1j * iq[..., 5],
            )
            return {
                "correlators": corr,
                "nco_shift_chips": np.zeros(batch),
                "nco_shift_hz": np.zeros(batch),
                "data_bit": 1.0,
            }

        ch.step(inputs())  # the first step starts the sequence (boundary checks)
        calls = _count_lapack(monkeypatch)
        outs = [ch.step(inputs()) for _ in range(3)]
        monkeypatch.undo()
        assert calls == []
        assert np.isfinite(outs[-1]["code_error_chips"]).all()
    finally:
        set_backend(None)


def test_adapter_guard_pays_eigh_only_for_estimates_outside_the_bounds(monkeypatch):
    # Estimates that are PSD and inside [floor, ceiling] x R0 pass unchanged with no
    # LAPACK call (compiled PD tests, the reference's eigen-decomposition kept); one
    # estimate above the ceiling is clamped by the compiled guard, still with no LAPACK
    # call (under the numpy backend it costs one eigh on that element alone).
    from gnssframework import registry

    set_backend("numba")
    try:
        rng = np.random.default_rng(5)
        R0 = _separated_pd(rng, 4, ())
        R0 = 0.5 * (R0 + R0.T)  # exactly symmetric: the guard's symmetrisation leaves it bitwise
        run = registry.create("noise_adapter", "innovation").start(np.eye(2), R0)
        raw = np.broadcast_to(2.0 * R0, (50, 4, 4)).copy()
        run.guard(raw, R0, 0.01, 100.0)  # first call: the reference's eigen-decomposition
        calls = _count_lapack(monkeypatch)
        out = run.guard(raw, R0, 0.01, 100.0)
        assert calls == []
        assert np.array_equal(out, raw)
        raw[7] = 1e3 * R0
        out = run.guard(raw, R0, 0.01, 100.0)
        assert calls == []
        np.testing.assert_allclose(out[7], 100.0 * R0, rtol=1e-10)  # clamped onto the ceiling
        assert np.array_equal(out[:7], raw[:7])
        set_backend("numpy")
        run = registry.create("noise_adapter", "innovation").start(np.eye(2), R0)
        run.guard(raw[:7], R0, 0.01, 100.0)  # first call: the reference's eigen-decomposition
        calls.clear()
        out_np = run.guard(raw, R0, 0.01, 100.0)
        monkeypatch.undo()
        assert calls.count("eigh") == 1  # the reference path: eigh on the clamped element only
        np.testing.assert_allclose(out_np[7], 100.0 * R0, rtol=1e-10)
        assert np.array_equal(out_np[:7], raw[:7])
    finally:
        set_backend(None)


def _range_rate_problem(seed, name, r0, sat_range_m, sat_speed_m_s, pos_std_m):
    from gnssframework import registry
    from gnssframework.interfaces import RunContext

    rng = np.random.default_rng(seed)
    n_ch, runs = 6, 5
    u = rng.standard_normal((n_ch, 3))
    sat_pos = r0 + sat_range_m * u / np.linalg.norm(u, axis=-1, keepdims=True)
    sat_vel = sat_speed_m_s * rng.standard_normal((n_ch, 3))
    x = np.concatenate(
        [
            r0 + pos_std_m * rng.standard_normal((runs, 3)),
            rng.standard_normal((runs, 3)),
            10.0 + rng.standard_normal((runs, 1)),
            rng.standard_normal((runs, 1)),
        ],
        axis=-1,
    )
    # Eigenvalues 0.3 apart: svd-ckf's eigenvectors (and so its points) are well defined.
    P = np.diag(np.linspace(1.0, 3.1, 8)) * pos_std_m**2
    nav = registry.create("nav_filter", "ekf-pv", estimator=name)
    nav.reset((runs,), RunContext(coherent_time_s=0.01, initial_state=x, initial_cov=P))
    R = np.diag([pos_std_m**2] * n_ch + [0.01] * n_ch)
    model = nav._model(sat_pos, sat_vel, R)
    z = model.h(x) + rng.standard_normal((runs, 2 * n_ch)) * np.sqrt(np.diag(R))
    return model, gf.Gaussian(x, P), z, sat_pos, sat_vel


def test_compiled_range_rate_h_equals_predicted_range_at_gps_distances():
    from gnssframework.receiver.tracking.vector import predicted_range

    model, state, _, sat_pos, sat_vel = _range_rate_problem(
        21, "ckf", np.array([4.2e6, 1.7e5, 4.78e6]), 2.02e7, 3.9e3, 30.0
    )
    from gnssframework_plugins.nav_filters import range_rate_row

    assert model.compiled is not None and model.compiled.h is range_rate_row
    X = state.mean[0] + 10.0 * np.random.default_rng(2).standard_normal((17, 8))
    for k, x in enumerate(X):
        zc = np.empty((1, 12))
        range_rate_row(model.compiled.h_params, X, k, zc, 0)
        rho, rate, _ = predicted_range(x, sat_pos, sat_vel)
        _close(rho, zc[0, :6])
        _close(rate, zc[0, 6:])


@pytest.mark.parametrize("name", ("ekf", "ukf", "ckf", "svd-ckf"))
def test_compiled_range_rate_model_of_ekf_pv_equals_its_numpy_model(name):
    # ekf-pv's model carries a compiled pseudorange/rate h (and its linear f): the fused
    # sigma-point step must equal the step on the NumPy functions. A small geometry
    # (satellites 100 m away): at GPS distances the sigma-point deviations Z - z_hat
    # cancel 2e7 m to a few metres, so *both* paths carry ~1e-9 relative rounding in S
    # and C and no 1e-12 agreement can be asserted between them.
    model, state, z, _, _ = _range_rate_problem(21, name, np.array([10.0, -5.0, 3.0]), 100.0, 10.0, 1.0)
    assert model.compiled is not None
    from dataclasses import replace

    plain = replace(model, compiled=None)  # the same NumPy f, h and analytic Jacobians
    est = _engine(name)
    ref_prior, ref = _run(est, "numpy", state, z, plain)
    prior, upd = _run(est, "numba", state, z, model)
    _close(ref_prior.mean, prior.mean)
    _close(ref_prior.cov, prior.cov)
    for field in ("innovation", "innovation_cov", "gain", "cross_cov", "predicted_measurement"):
        _close(getattr(ref, field), getattr(upd, field))
    _close(ref.state.mean, upd.state.mean)
    _close(ref.state.cov, upd.state.cov)


def _kernel_signatures():
    sigs = {
        (name, i): len(d.signatures)
        for name in dir(drivers)
        if name.endswith("_kernels") and isinstance(getattr(drivers, name), tuple)
        for i, d in enumerate(getattr(drivers, name))
    }
    # The drivers compiled for a model's functions (and sizes), one pair per model.
    sigs.update(
        {
            ("model", key, i): len(d.signatures)
            for key, pair in drivers._model_drivers.items()
            for i, d in enumerate(pair)
        }
    )
    # The loop checks' kernels (kernels_loop.warm_up), the adapter guard and window among them.
    sigs.update(
        {
            ("kernels_loop", name): len(getattr(kernels_loop, name).signatures)
            for name in dir(kernels_loop)
            if name.endswith("_body") and hasattr(getattr(kernels_loop, name), "signatures")
        }
    )
    return sigs


def test_warm_up_compiles_every_specialisation_a_run_uses():
    # `compare` warms the kernels up once before forking its workers; a run that needed
    # another numba specialisation (readonly or writable operands, another layout) would
    # compile it again in every worker. Runs every built-in engine on shared and
    # per-element operands, below and above the parallel threshold, and a vector loop.
    from gnssframework.experiments import get_scenario

    set_backend("numba")
    try:
        kernels.warm_up()
        kernels_loop.warm_up()
        before = _kernel_signatures()
        for batch in ((3,), (kernels.PARALLEL_MIN_BATCH + 1,)):
            nonlinear, linear, state, z = _problem(4, 5, 6, batch)
            z = z.copy()
            z[0, 0] = np.nan
            for name in ENGINES:
                for model in (linear,) if name == "kf" else (linear, nonlinear):
                    est = _engine(name)
                    est.update(est.predict(state, model), z, model, missing="skip")
        # Long enough (0.3 s) for the innovation adapter to pass its warm-up: its compiled
        # guard runs too, split between two threads at 40 runs.
        scen = get_scenario({"kind": "vector-tracking", "duration_s": 0.3, "channels": 8, "settle_s": 0.0})
        for est_name in ("svd-ckf", "ukf"):
            for runs in (1, 40):
                plugins = scen.build(
                    {
                        "channel_filter": {"name": "iq-filter", "params": {"estimator": est_name}},
                        "nav_filter": {"name": "ekf-pv", "params": {"clock": "ocxo"}},
                    }
                )
                scen.run_batch({"cn0_dbhz": 45.0}, plugins, runs, np.random.default_rng(0))
        after = _kernel_signatures()
        assert {k: (before[k], after[k]) for k in after if after[k] != before[k]} == {}
    finally:
        set_backend(None)
