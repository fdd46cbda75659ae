"""Per-filter-step time of ukf, ckf and svd-ckf against FilterPy's UKF, same run.

Model: reference 000's correlator-domain channel filter, state [A, dtau, dtheta, df,
dfdot], the six I/Q as measurements. gnssframework advances a whole batch in one call;
FilterPy advances one filter object per element, so its time per filter-step does not
depend on the batch size. Prints a table of microseconds per filter-step and the
speed-up (FilterPy time / gnssframework time).

    python benchmarks/estimators.py [--steps 20]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import gnssframework as gf
from gnssframework.signal.channel_model import channel_iq, channel_transition

T = 0.01
SPACING = 0.5
F = channel_transition(T)
Q = np.diag([1e-4, 1e-6, 1e-3, 1e-2, 1e-1])
R = np.eye(6)


def h(x):
    return channel_iq(x, SPACING, T)


def f(x):
    return x @ F.T


def make_problem(batch: int, steps: int, rng: np.random.Generator):
    x0 = np.array([40.0, 0.05, 0.1, 2.0, 0.0])
    x = np.broadcast_to(x0, (batch, 5)).copy()
    zs = []
    for _ in range(steps):
        x = f(x)
        zs.append(h(x) + rng.standard_normal((batch, 6)))
    return np.stack(zs), x0


def time_ours(name: str, batch: int, steps: int, rng) -> float:
    zs, x0 = make_problem(batch, steps, rng)
    est = gf.registry.create("estimator", name, alpha=0.5) if name == "ukf" else gf.registry.create("estimator", name)
    model = gf.NonlinearModel(f, h, Q, R)
    state = gf.Gaussian(np.broadcast_to(x0, (batch, 5)), np.diag([4.0, 0.01, 0.1, 4.0, 1.0]))
    best = np.inf
    for _ in range(3):
        s = state
        t0 = time.perf_counter()
        for k in range(steps):
            s = est.update(est.predict(s, model), zs[k], model).state
        best = min(best, (time.perf_counter() - t0) / (steps * batch))
    return best


def time_filterpy(filters: int, steps: int, rng) -> float:
    from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

    zs, x0 = make_problem(filters, steps, rng)
    objs = []
    for _ in range(filters):
        pts = MerweScaledSigmaPoints(5, alpha=0.5, beta=2.0, kappa=0.0)
        u = UnscentedKalmanFilter(dim_x=5, dim_z=6, dt=T, hx=h, fx=lambda x, dt: f(x), points=pts)
        u.x, u.P, u.Q, u.R = x0.copy(), np.diag([4.0, 0.01, 0.1, 4.0, 1.0]), Q, R
        objs.append(u)
    t0 = time.perf_counter()
    for k in range(steps):
        for i, u in enumerate(objs):
            u.predict()
            u.update(zs[k, i])
    return (time.perf_counter() - t0) / (steps * filters)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=20)
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    ref = time_filterpy(50, args.steps, rng)
    print(f"FilterPy UKF: {ref * 1e6:9.1f} us per filter-step (one object per element)\n")
    print(f"{'filter':8s} {'batch':>6s} {'us/filter-step':>15s} {'speed-up vs FilterPy':>21s}")
    for name in ("ukf", "ckf", "svd-ckf"):
        for batch in (1, 8, 8000):
            steps = args.steps if batch < 8000 else max(3, args.steps // 4)
            t = time_ours(name, batch, steps, rng)
            print(f"{name:8s} {batch:6d} {t * 1e6:15.2f} {ref / t:20.1f}x")


if __name__ == "__main__":
    main()
