"""Time of the RTS smoother's backward pass against FilterPy's ``rts_smoother``, same run.

Model: the channel filter of benchmarks/estimators.py (5 states, 6 I/Q measurements,
linear transition, nonlinear measurement). For each engine and batch size it times, per
element-step (best of a few repeats after a warm-up):

- ``forward``: ``filter_sequence`` without storing (the filter alone);
- ``forward+store``: with ``store="smoother"`` (the cross covariances recomputed on NumPy);
- ``smooth``: the backward pass ``smooth(result)`` alone;

and FilterPy's ``UnscentedKalmanFilter.rts_smoother`` (``ukf``, ``ckf`` as Merwe points with
alpha 1, beta 0, kappa 0) and ``KalmanFilter.rts_smoother`` (``ekf``: the transition is
linear) on one element's filtered states, whose time per element-step does not depend on
the batch. The ratios printed are FilterPy's time over ours (above 1: ours is faster) and
our backward pass over our forward filter (the issue's goal: at most 1 at batch 8000).

    python benchmarks/smoother.py [--steps 20] [--batches 1 100 1000] [--engines ukf ckf svd-ckf ekf]
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
    backward = _best(lambda: gf.smooth(result), per)
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


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--batches", type=int, nargs="+", default=[1, 100, 1000])
    ap.add_argument("--engines", nargs="+", default=["ukf", "ckf", "svd-ckf", "ekf"])
    args = ap.parse_args(argv)
    rng = np.random.default_rng(1)
    print(f"time per element-step (us), {args.steps} steps; ratios: FilterPy / ours, smooth / forward")
    print(f"{'engine':8} {'batch':>6} {'forward':>9} {'fwd+store':>9} {'smooth':>9} {'FilterPy':>9} "
          f"{'FP/smooth':>9} {'smooth/fwd':>10}")
    for batch in args.batches:
        zs = problem(batch, args.steps, rng)
        for engine in args.engines:
            forward, stored, backward, result = time_ours(engine, zs)
            ref = time_filterpy(engine, result)
            ref_txt = "-" if ref is None else f"{ref * 1e6:9.1f}"
            ratio = "-" if ref is None else f"{ref / backward:9.1f}"
            print(f"{engine:8} {batch:6d} {forward * 1e6:9.2f} {stored * 1e6:9.2f} {backward * 1e6:9.2f} "
                  f"{ref_txt:>9} {ratio:>9} {backward / forward:10.2f}")


if __name__ == "__main__":
    main()
