"""Time of the RTS smoother's backward pass against FilterPy's ``rts_smoother``, same run.

Model: the channel filter of benchmarks/estimators.py (5 states, 6 I/Q measurements,
linear transition, nonlinear measurement). For each engine and batch size it times, per
element-step (best of a few repeats after a warm-up):

- ``forward``: ``filter_sequence`` without storing (the filter alone);
- ``forward+store``: with ``store="smoother"`` (the cross covariances recomputed on NumPy);
- ``smooth``: the backward pass ``smooth(result)`` alone, in the engine's default form
  (``Estimator.smoother_gain``: ``"sqrt"`` for the SVD-CKF, ``smoother_sqrt``); for a
  square-root engine a second row times ``smooth(result, form="eigh")`` on the same stored
  run (the covariance form it replaced), its ``forward`` columns repeated;

and FilterPy's ``UnscentedKalmanFilter.rts_smoother`` (``ukf``, ``ckf`` as Merwe points with
alpha 1, beta 0, kappa 0) and ``KalmanFilter.rts_smoother`` (``ekf``: the transition is
linear) on one element's filtered states, whose time per element-step does not depend on
the batch. The ratios printed are FilterPy's time over ours (above 1: ours is faster) and
our backward pass over our forward filter (the issue's goal: at most 1 at batch 8000).

dynamax (where installed: ``pip install -e '.[bench]'``) has no backward pass apart from
its filter: ``unscented_kalman_smoother`` (``ukf`` and ``ckf``: alpha 1, beta 0, kappa 0)
and ``extended_kalman_smoother`` (``ekf``) run the whole filter + smoother under
``jax.jit`` + ``vmap`` over the batch (float64, compile time excluded); the last column is
its time over ours for the same work (``forward+store`` + ``smooth``).

    python benchmarks/smoother.py [--steps 20] [--batches 1 100 1000] [--engines ukf ckf svd-ckf ekf] [--no-dynamax]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import gnssframework as gf
from estimators import F, P0, Q, R, T, X0, f, h  # the channel model of benchmarks/estimators.py
from estimators import make_problem as problem
from gnssframework.estimation import Gaussian, NonlinearModel

REPEATS = 3
MODEL = NonlinearModel(f, h, Q, R, f_jacobian=lambda x: np.broadcast_to(F, x.shape[:-1] + F.shape))


def _best(fn, per: int) -> float:
    fn()  # warm-up (compiles on first use)
    best = np.inf
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        fn()
        best = min(best, (time.perf_counter() - t0) / per)
    return best


def time_ours(engine: str, zs: np.ndarray):
    est = gf.registry.create("estimator", engine, **({"alpha": 1.0, "beta": 0.0} if engine == "ukf" else {}))
    init = Gaussian(X0, P0)
    per = zs.shape[0] * zs.shape[1]
    forward = _best(lambda: gf.filter_sequence(est, MODEL, zs, init), per)
    stored = _best(lambda: gf.filter_sequence(est, MODEL, zs, init, store="smoother"), per)
    result = gf.filter_sequence(est, MODEL, zs, init, store="smoother")
    default = est.smoother_gain
    backward = {default: _best(lambda: gf.smooth(result), per)}
    if default == "sqrt":
        backward["eigh"] = _best(lambda: gf.smooth(result, form="eigh"), per)
    return forward, stored, backward, result


def time_filterpy(engine: str, result) -> float | None:
    try:
        from filterpy.kalman import KalmanFilter, MerweScaledSigmaPoints, UnscentedKalmanFilter
    except ImportError:
        return None
    xs, ps = result.mean[:, 0].copy(), result.cov[:, 0].copy()
    steps = xs.shape[0]
    if engine == "ekf":
        kf = KalmanFilter(dim_x=5, dim_z=6)
        Fs, Qs = np.broadcast_to(F, (steps, 5, 5)), np.broadcast_to(Q, (steps, 5, 5))
        return _best(lambda: kf.rts_smoother(xs, ps, Fs=Fs, Qs=Qs), steps)
    if engine not in ("ukf", "ckf"):
        return None
    points = MerweScaledSigmaPoints(5, alpha=1.0, beta=0.0, kappa=0.0)
    ukf = UnscentedKalmanFilter(dim_x=5, dim_z=6, dt=T, hx=h, fx=lambda x, dt: f(x), points=points)
    ukf.Q = Q
    return _best(lambda: ukf.rts_smoother(xs, ps), steps)


def time_dynamax(engine: str, zs: np.ndarray) -> float | None:
    """dynamax's filter + RTS smoother per element-step (jit + vmap over the batch)."""
    if engine not in ("ukf", "ckf", "ekf"):
        return None
    try:
        import jax
        import jax.numpy as jnp
        from dynamax.nonlinear_gaussian_ssm import (
            ParamsNLGSSM,
            UKFHyperParams,
            extended_kalman_smoother,
            unscented_kalman_smoother,
        )
    except ImportError:
        return None
    from estimators import jax_channel_model

    fj, hj = jax_channel_model()
    # dynamax's first prior is the first step's: our initial predicted once (F linear)
    params = ParamsNLGSSM(jnp.asarray(F @ X0), jnp.asarray(F @ P0 @ F.T + Q), fj, jnp.asarray(Q), hj, jnp.asarray(R))
    if engine == "ekf":

        def one(em):
            return extended_kalman_smoother(params, em).smoothed_means
    else:
        hyper = UKFHyperParams(alpha=1.0, beta=0.0, kappa=0.0)

        def one(em):
            return unscented_kalman_smoother(params, em, hyper).smoothed_means

    run = jax.jit(jax.vmap(one))
    data = jnp.asarray(np.swapaxes(zs, 0, 1))  # (batch, steps, 6)
    return _best(lambda: run(data).block_until_ready(), zs.shape[0] * zs.shape[1])


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--batches", type=int, nargs="+", default=[1, 100, 1000])
    ap.add_argument("--engines", nargs="+", default=["ukf", "ckf", "svd-ckf", "ekf"])
    ap.add_argument("--no-dynamax", action="store_true", help="skip dynamax's smoothers")
    args = ap.parse_args(argv)
    rng = np.random.default_rng(1)
    print(
        f"time per element-step (us), {args.steps} steps; ratios: FilterPy / ours, smooth / forward, "
        "dynamax / ours (filter + smoother)"
    )
    print(
        f"{'engine':8} {'form':>5} {'batch':>6} {'forward':>9} {'fwd+store':>9} {'smooth':>9} {'FilterPy':>9} "
        f"{'FP/smooth':>9} {'smooth/fwd':>10} {'dynamax':>9} {'dmx/ours':>8}"
    )
    for batch in args.batches:
        zs = problem(batch, args.steps, rng)
        for engine in args.engines:
            forward, stored, backwards, result = time_ours(engine, zs)
            ref = time_filterpy(engine, result)
            dmx = None if args.no_dynamax else time_dynamax(engine, zs)
            for form, backward in backwards.items():
                ref_txt = "-" if ref is None else f"{ref * 1e6:9.1f}"
                ratio = "-" if ref is None else f"{ref / backward:9.1f}"
                dmx_txt = "-" if dmx is None else f"{dmx * 1e6:9.2f}"
                dmx_ratio = "-" if dmx is None else f"{dmx / (stored + backward):8.2f}"
                print(
                    f"{engine:8} {form:>5} {batch:6d} {forward * 1e6:9.2f} {stored * 1e6:9.2f} "
                    f"{backward * 1e6:9.2f} {ref_txt:>9} {ratio:>9} {backward / forward:10.2f} {dmx_txt:>9} "
                    f"{dmx_ratio:>8}"
                )


if __name__ == "__main__":
    main()
