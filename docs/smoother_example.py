"""Filter, fixed-lag and fixed-interval RTS smoother RMSE on a pendulum (docs/estimators/smoothers.md).

A pendulum's angle and rate, x' = (a + dt w, w - dt g sin a) + noise, seen through the
horizontal position of its bob, z = sin(a) + noise; 200 runs of 100 steps, every
engine, the same data. ``python docs/smoother_example.py`` prints the table of the page;
tests/estimation/test_smoother.py checks the page shows what this prints.
"""

from __future__ import annotations

import numpy as np

import gnssframework as gf
from gnssframework.estimation import Gaussian, NonlinearModel

DT_S, G_M_S2 = 0.05, 9.81
ENGINES = ("ekf", "ukf", "ckf", "svd-ckf")
LAG = 10


def pendulum() -> NonlinearModel:
    def f(x):
        return np.stack([x[..., 0] + DT_S * x[..., 1], x[..., 1] - DT_S * G_M_S2 * np.sin(x[..., 0])], -1)

    def h(x):
        return np.sin(x[..., :1])

    q = 0.01  # rate noise density (rad/s)^2/s
    Q = q * np.array([[DT_S**3 / 3, DT_S**2 / 2], [DT_S**2 / 2, DT_S]])
    return NonlinearModel(f, h, Q, np.array([[0.1**2]]))


def rmse_rows(seed: int = 1, runs: int = 200, steps: int = 100) -> list[tuple[str, float, float, float]]:
    """``(engine, filter, fixed-lag, smoother)`` RMSE of the angle (rad) over runs and steps."""
    rng = np.random.default_rng(seed)
    model = pendulum()
    P0 = np.diag([0.2**2, 0.2**2])
    x = np.array([1.0, 0.0]) + rng.multivariate_normal(np.zeros(2), P0, size=runs)
    truth, zs = [], []
    for _ in range(steps):
        x = model.f(x) + rng.multivariate_normal(np.zeros(2), model.Q, size=runs)
        truth.append(x)
        zs.append(model.h(x) + 0.1 * rng.standard_normal((runs, 1)))
    truth, zs = np.array(truth), np.array(zs)
    initial = Gaussian(np.array([1.0, 0.0]), P0)
    rows = []
    for engine in ENGINES:
        result = gf.filter_sequence(gf.registry.create("estimator", engine), model, zs, initial, store="smoother")
        smoothed, lagged = gf.smooth(result), gf.fixed_lag_smooth(result, LAG)
        rows.append((engine, *(_angle_rmse(mean, truth) for mean in (result.mean, lagged.mean, smoothed.mean))))
    return rows


def _angle_rmse(mean: np.ndarray, truth: np.ndarray) -> float:
    """RMSE of the angle (rad) over runs and steps."""
    return float(np.sqrt(np.mean((mean[..., 0] - truth[..., 0]) ** 2)))


def table() -> str:
    lines = [f"| engine | filter | fixed-lag, L = {LAG} | smoother |", "| --- | --- | --- | --- |"]
    lines += [f"| `{e}` | {a:.4f} | {b:.4f} | {c:.4f} |" for e, a, b, c in rmse_rows()]
    return "\n".join(lines)


if __name__ == "__main__":
    print(table())
