"""A first filter: track a 1-D constant-acceleration target with the registry's `kf`.

Run: python examples/gallery/first_filter.py
"""

import numpy as np

import gnssframework as gf

rng = np.random.default_rng(0)
dt_s, steps, runs = 1.0, 200, 50
F = np.array([[1.0, dt_s, dt_s**2 / 2], [0.0, 1.0, dt_s], [0.0, 0.0, 1.0]])
H = np.array([[1.0, 0.0, 0.0]])
G = np.array([[dt_s**3 / 6], [dt_s**2 / 2], [dt_s]])
Q = 1e-3 * G @ G.T  # white jerk
R = np.array([[4.0]])  # 2 m position noise

# Truth and measurements for a batch of runs, batch-first: (steps, runs, ...).
x = np.zeros((runs, 3))
truth, zs = [], []
for _ in range(steps):
    x = x @ F.T + rng.multivariate_normal(np.zeros(3), Q + 1e-15 * np.eye(3), size=runs)
    truth.append(x)
    zs.append(x @ H.T + rng.normal(0.0, 2.0, size=(runs, 1)))
truth, zs = np.array(truth), np.array(zs)

kf = gf.registry.create("estimator", "kf")
initial = gf.Gaussian(np.zeros((runs, 3)), np.diag([100.0, 10.0, 1.0]))
result = gf.filter_sequence(kf, gf.LinearModel(F, H, Q, R), zs, initial)

raw_rmse_m = np.sqrt(np.mean((zs[50:, :, 0] - truth[50:, :, 0]) ** 2))
kf_rmse_m = np.sqrt(np.mean((result.mean[50:, :, 0] - truth[50:, :, 0]) ** 2))
print(f"position RMSE: measurements {raw_rmse_m:.2f} m, kf {kf_rmse_m:.2f} m")
assert kf_rmse_m < 0.75 * raw_rmse_m  # the filter beats the raw fixes
