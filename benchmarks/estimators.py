"""Per-filter-step time of ukf, ckf and svd-ckf against FilterPy, Stone Soup and dynamax, same run.

Model: Zou et al. (2018)'s correlator-domain channel filter, state [A, dtau, dtheta, df,
dfdot], the six I/Q as measurements (5 states / 6 measurements). gnssframework advances a
whole batch in one call; FilterPy and Stone Soup advance one filter object per element,
so their time per filter-step does not depend on the batch size; dynamax runs the whole
sequence under ``jax.jit`` + ``vmap`` over the batch (float64), compile time excluded.

The CPU columns divide by the process's CPU time instead of the wall time: on a shared
machine they are the steadier numbers (no time spent waiting for a core is counted;
with the parallel kernels at batch >= 256 both threads' time adds up, so they are
one-core figures).

Rows for gnssframework: ``numba`` = compiled kernels with the NumPy model functions;
``numba+cm`` = compiled kernels with the built-in compiled model functions (where the
model supplies them); ``numpy`` = the NumPy reference path. Every time is the best of a
few repeats after a warm-up call (compile time is reported separately).

    python benchmarks/estimators.py [--steps 20] [--batches 1 8 1000 8000] [--no-numpy] [--no-peers]
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np

import gnssframework as gf
from gnssframework.estimation import compiled as compiled_kernels
from gnssframework.signal.channel_model import channel_iq, channel_transition

T = 0.01
SPACING = 0.5
F = channel_transition(T)
Q = np.diag([1e-4, 1e-6, 1e-3, 1e-2, 1e-1])
R = np.eye(6)
P0 = np.diag([4.0, 0.01, 0.1, 4.0, 1.0])
X0 = np.array([40.0, 0.05, 0.1, 2.0, 0.0])
ALPHA = 0.5  # every UKF here: alpha 0.5, beta 2, kappa 0


def h(x):
    return channel_iq(x, SPACING, T)


def f(x):
    return x @ F.T


def make_problem(batch: int, steps: int, rng: np.random.Generator):
    x = np.broadcast_to(X0, (batch, 5)).copy()
    zs = []
    for _ in range(steps):
        x = f(x)
        zs.append(h(x) + rng.standard_normal((batch, 6)))
    return np.stack(zs)


def _model(compiled: bool):
    if compiled:
        from gnssframework.signal.channel_model import channel_model

        return channel_model(T, SPACING, Q, R)
    return gf.NonlinearModel(f, h, Q, R)


def time_ours(name: str, batch: int, steps: int, rng, backend: str, compiled: bool = False) -> float:
    zs = make_problem(batch, steps, rng)
    est = gf.registry.create("estimator", name, alpha=ALPHA) if name == "ukf" else gf.registry.create("estimator", name)
    est.backend = backend
    model = _model(compiled)
    state = gf.Gaussian(np.broadcast_to(X0, (batch, 5)), P0)
    est.update(est.predict(state, model), zs[0], model)  # warm-up (compile/load)
    best = best_cpu = np.inf
    for _ in range(3):
        s = state
        t0, c0 = time.perf_counter(), time.process_time()
        for k in range(steps):
            s = est.update(est.predict(s, model), zs[k], model).state
        best = min(best, (time.perf_counter() - t0) / (steps * batch))
        best_cpu = min(best_cpu, (time.process_time() - c0) / (steps * batch))
    return best, best_cpu


def time_filterpy(filters: int, steps: int, rng) -> float:
    from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

    zs = make_problem(filters, steps, rng)
    objs = []
    for _ in range(filters):
        pts = MerweScaledSigmaPoints(5, alpha=ALPHA, beta=2.0, kappa=0.0)
        u = UnscentedKalmanFilter(dim_x=5, dim_z=6, dt=T, hx=h, fx=lambda x, dt: f(x), points=pts)
        u.x, u.P, u.Q, u.R = X0.copy(), P0.copy(), Q, R
        objs.append(u)
    t0, c0 = time.perf_counter(), time.process_time()
    for k in range(steps):
        for i, u in enumerate(objs):
            u.predict()
            u.update(zs[k, i])
    global FILTERPY_CPU
    FILTERPY_CPU = (time.process_time() - c0) / (steps * filters)
    return (time.perf_counter() - t0) / (steps * filters)


FILTERPY_CPU = None  # FilterPy's CPU time per filter-step, set by time_filterpy


def time_stonesoup(kind: str, filters: int, steps: int, rng) -> float:
    from datetime import datetime, timedelta

    from stonesoup.models.measurement.nonlinear import NonLinearGaussianMeasurement
    from stonesoup.models.transition.linear import LinearGaussianTransitionModel
    from stonesoup.predictor import kalman as pred
    from stonesoup.types.array import StateVector, StateVectors
    from stonesoup.types.detection import Detection
    from stonesoup.types.hypothesis import SingleHypothesis
    from stonesoup.types.state import GaussianState
    from stonesoup.updater import kalman as upd

    class Transition(LinearGaussianTransitionModel):
        @property
        def ndim_state(self):
            return 5

        def matrix(self, **kwargs):
            return F

        def covar(self, **kwargs):
            return Q

    class Measurement(NonLinearGaussianMeasurement):
        @property
        def ndim_meas(self):
            return 6

        def function(self, state, noise=False, **kwargs):
            sv = np.asarray(state.state_vector, dtype=float)
            out = h(sv.T).T
            return StateVectors(out) if out.shape[1] > 1 else StateVector(out)

    mm = Measurement(ndim_state=5, mapping=(0, 1, 2, 3, 4), noise_covar=R)
    tm = Transition()
    if kind == "ukf":
        predictor = pred.UnscentedKalmanPredictor(tm, alpha=ALPHA, beta=2.0, kappa=0.0)
        updater = upd.UnscentedKalmanUpdater(mm, alpha=ALPHA, beta=2.0, kappa=0.0)
    else:
        predictor = pred.CubatureKalmanPredictor(tm)
        updater = upd.CubatureKalmanUpdater(mm)
    zs = make_problem(filters, steps, rng)
    t_start = datetime(2026, 1, 1)
    states = [GaussianState(StateVector(X0), P0, timestamp=t_start) for _ in range(filters)]
    t0 = time.perf_counter()
    for k in range(steps):
        ts = t_start + timedelta(seconds=T * (k + 1))
        for i in range(filters):
            prior = predictor.predict(states[i], timestamp=ts)
            det = Detection(StateVector(zs[k, i]), timestamp=ts, measurement_model=mm)
            states[i] = updater.update(SingleHypothesis(prior, det))
    return (time.perf_counter() - t0) / (steps * filters)


def jax_channel_model():
    """The channel model's transition and measurement functions written in JAX for dynamax
    (64-bit floats switched on): ``(f, h)``, the same model as `f` and `h`."""
    import jax

    jax.config.update("jax_enable_x64", True)
    import jax.numpy as jnp

    Fj = jnp.asarray(F)
    offsets = jnp.array([-SPACING, 0.0, SPACING])

    def hj(x):
        r = jnp.maximum(0.0, 1.0 - jnp.abs(x[1] - offsets))
        common = x[0] * jnp.sinc(x[3] * T)
        phase = jnp.pi * x[3] * T + x[2]
        return jnp.concatenate([common * jnp.cos(phase) * r, common * jnp.sin(phase) * r])

    return (lambda x: Fj @ x), hj


def time_dynamax(batch: int, steps: int, rng) -> float:
    import jax
    import jax.numpy as jnp
    from dynamax.nonlinear_gaussian_ssm import ParamsNLGSSM, UKFHyperParams, unscented_kalman_filter

    fj, hj = jax_channel_model()
    params = ParamsNLGSSM(jnp.asarray(X0), jnp.asarray(P0), fj, jnp.asarray(Q), hj, jnp.asarray(R))
    hyper = UKFHyperParams(alpha=ALPHA, beta=2.0, kappa=0.0)
    zs = jnp.asarray(np.swapaxes(make_problem(batch, steps, rng), 0, 1))  # (batch, steps, 6)

    run = jax.jit(
        jax.vmap(lambda em: unscented_kalman_filter(params, em, hyper, output_fields=["filtered_means"]).filtered_means)
    )
    run(zs).block_until_ready()
    best = np.inf
    for _ in range(3):
        t0 = time.perf_counter()
        run(zs).block_until_ready()
        best = min(best, (time.perf_counter() - t0) / (steps * batch))
    return best


def _optional(label: str, fn, *args):
    try:
        return fn(*args)
    except ImportError as exc:
        print(f"{label}: not installed ({exc.name}); pip install -e '.[bench]'")
    return None


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=20)
    parser.add_argument("--batches", type=int, nargs="+", default=[1, 8, 1000, 8000])
    parser.add_argument("--no-numpy", action="store_true", help="skip the NumPy reference rows")
    parser.add_argument(
        "--no-peers",
        action="store_true",
        help="skip FilterPy, Stone Soup and dynamax (our rows only, e.g. to compare two commits)",
    )
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    print(
        f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"Python {platform.python_version()}, numpy {np.__version__}"
    )
    t0 = time.perf_counter()
    print(f"kernel warm-up (compile or load from cache): {compiled_kernels.warm_up():.2f} s\n")

    refs = {}
    if not args.no_peers:
        refs["FilterPy UKF"] = _optional("FilterPy", time_filterpy, 50, args.steps, rng)
        refs["Stone Soup UKF"] = _optional("Stone Soup", time_stonesoup, "ukf", 10, max(3, args.steps // 4), rng)
        refs["Stone Soup CKF"] = _optional("Stone Soup", time_stonesoup, "ckf", 10, max(3, args.steps // 4), rng)
    for label, t in refs.items():
        if t is not None:
            print(f"{label:15s}: {t * 1e6:9.1f} us per filter-step (one object per element)")
    dmx = {}
    for batch in [] if args.no_peers else args.batches:
        dmx[batch] = _optional("dynamax", time_dynamax, batch, args.steps, rng)
        if dmx[batch] is not None:
            print(f"dynamax UKF (jit+vmap) batch {batch:5d}: {dmx[batch] * 1e6:9.2f} us per filter-step")
    fp = refs.get("FilterPy UKF")

    if FILTERPY_CPU:
        print(f"FilterPy UKF CPU time: {FILTERPY_CPU * 1e6:9.1f} us per filter-step")
    print(
        f"\n{'filter':8s} {'path':9s} {'batch':>6s} {'us/step':>9s} {'vs FilterPy':>12s} {'vs dynamax':>11s} "
        f"{'CPU us/step':>12s} {'CPU vs FilterPy':>16s}"
    )
    paths = [("numba", "numba", False), ("numba+cm", "numba", True)]
    if not args.no_numpy:
        paths.append(("numpy", "numpy", False))
    for name in ("ukf", "ckf", "svd-ckf"):
        for batch in args.batches:
            steps = args.steps if batch < 1000 else max(3, args.steps // 4)
            for label, backend, compiled in paths:
                t, t_cpu = time_ours(name, batch, steps, rng, backend, compiled)
                vs_fp = f"{fp / t:11.1f}x" if fp else f"{'-':>12s}"
                vs_d = f"{dmx[batch] / t:10.2f}x" if dmx.get(batch) else f"{'-':>11s}"
                cpu_fp = f"{FILTERPY_CPU / t_cpu:15.1f}x" if FILTERPY_CPU else f"{'-':>16s}"
                print(
                    f"{name:8s} {label:9s} {batch:6d} {t * 1e6:9.2f} {vs_fp} {vs_d} {t_cpu * 1e6:12.2f} {cpu_fp}",
                    flush=True,
                )
    print(f"\ntotal {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
