"""From a new plugin to a published comparison: a fading-memory Kalman filter against ``kf``.

The path of the tutorial (docs/tutorial/from-plugin-to-comparison.md) in one script:

1. write an ``estimator`` plugin (the fading-memory filter, Simon 2006, sec. 7.4:
   ``P- = alpha^2 F P F^T + Q``, which weighs recent measurements more);
2. test it with ``gnssframework.testing`` (alpha = 1 is the Kalman filter exactly);
3. register it (a package does this with an entry point, see examples/plugin-template);
4. add a ``metric`` plugin (the 95th percentile of the late horizontal error) and run a
   comparison on the ``multipath`` scenario naming it beside the built-in metrics: every
   candidate sees the same measurements (common random numbers), so the per-run
   difference to the reference candidate carries the comparison;
5. read the paired differences with their standard errors from ``summary.json`` and
   state the result the way it is published: difference ± SE, n, significant or not.

Run: python examples/gallery/plugin_to_comparison.py
"""

import json
import pathlib
import tempfile
import types

import numpy as np
from pydantic import Field

import gnssframework as gf
from gnssframework import testing
from gnssframework.experiments import load_config, run_comparison
from gnssframework.experiments.metrics import Metric, MetricValue
from gnssframework.plugin import PluginParams

KF = gf.registry.get("estimator", "kf")


# -- 1. the plugin ----------------------------------------------------------------------
class FadingParams(PluginParams):
    alpha: float = Field(1.02, ge=1.0, le=1.5, description="fading factor: P- = alpha^2 F P F^T + Q")


class FadingKalmanFilter(KF):
    """Fading-memory Kalman filter (Simon 2006, sec. 7.4): the covariance is inflated by
    alpha^2 before each prediction, so old measurements fade geometrically."""

    name = "fading-kf"
    description = "Fading-memory Kalman filter (Simon 2006, sec. 7.4)"
    Params = FadingParams

    def predict(self, state, model):
        return super().predict(gf.Gaussian(state.mean, self.params.alpha**2 * state.cov), model)


# -- 2. test it ---------------------------------------------------------------------------
testing.check_exact_on_linear(FadingKalmanFilter(alpha=1.0))  # alpha = 1: the Kalman filter
testing.check_batched_equals_one_by_one(FadingKalmanFilter(alpha=1.1))
try:
    testing.check_exact_on_linear(FadingKalmanFilter(alpha=1.1))
except AssertionError:
    pass  # alpha > 1 is not the Kalman filter, and the check says so
else:
    raise AssertionError("the exactness check missed the fading factor")

# -- 3. register it -------------------------------------------------------------------------
gf.registry.register_module(
    types.SimpleNamespace(register_estimator=gf.hookimpl(lambda register: register(FadingKalmanFilter))),
    name="fading-example",
)

# It inherits kf's `linear_only = True`: filters on nonlinear models refuse it when the
# config is loaded, naming the estimators that would fit.
try:
    gf.registry.create("channel_filter", "iq-filter", estimator="fading-kf")
except gf.ConfigError as exc:
    assert "linear-only" in str(exc), exc
else:
    raise AssertionError("iq-filter took a linear-only estimator")


# -- 4. a metric of your own, and the comparison -----------------------------------------------
class LateErrorP95(Metric):
    """95th percentile of the horizontal error over the second half of the run."""

    name = "late_horizontal_error_p95"
    unit = "m"
    description = "95th percentile of the horizontal error, second half of the run"
    requires = ("horizontal_error_m",)  # a series the multipath scenario declares in `outputs`

    def compute(self, series, time_s, scenario):
        h = series["horizontal_error_m"]  # (K, runs)
        return MetricValue(np.percentile(h[h.shape[0] // 2 :], 95, axis=0))


gf.registry.register_module(
    types.SimpleNamespace(register_metric=gf.hookimpl(lambda register: register(LateErrorP95))), name="p95-example"
)

CONFIG = """
name = "fading-vs-kf"
description = "Fading-memory KF against the KF on a static receiver with AR(1) multipath"
runs = 40
batch_size = 20
seed = 11
reference = "kf"
metrics = ["horizontal_error_rmse", "convergence_epoch", "late_horizontal_error_p95"]
[executor]
workers = 1            # a plugin registered in this script lives in this process only
[scenario]
kind = "multipath"
epochs = 300
[[cases]]
name = "white"
psi = 0.0
[[cases]]
name = "colored"
psi = 0.95
# position-ca tuned for a static receiver (small Q) and the true variance 3^2 + 0.5^2 as R.
[[candidates]]
name = "kf"
nav_filter = { name = "position-ca", params = { q0 = [1e-4, 1e-6, 1e-8], r0 = 9.25 } }
estimator = "kf"
[[candidates]]
name = "fading-1.00"   # must equal kf run by run: a check of the pairing and of the plugin
nav_filter = { name = "position-ca", params = { q0 = [1e-4, 1e-6, 1e-8], r0 = 9.25 } }
estimator = { name = "fading-kf", params = { alpha = 1.0 } }
[[candidates]]
name = "fading-1.05"
nav_filter = { name = "position-ca", params = { q0 = [1e-4, 1e-6, 1e-8], r0 = 9.25 } }
estimator = { name = "fading-kf", params = { alpha = 1.05 } }
"""

with tempfile.TemporaryDirectory() as tmp:
    path = pathlib.Path(tmp) / "fading.toml"
    path.write_text(CONFIG)
    out = pathlib.Path(tmp) / "out"
    summary = json.loads(run_comparison(load_config(path), out, progress=False).read_text())
    report = (out / "report.md").read_text()
    # The new metric was computed once per batch from the stored series: check it by hand.
    p95 = {(r["case"], r["candidate"]): r for r in summary["rows"] if r["metric"] == "late_horizontal_error_p95"}
    for (case, cand), row in p95.items():
        h = np.concatenate(
            [np.load(f)["horizontal_error_m"] for f in sorted((out / "raw" / case / cand).glob("*.npz"))], axis=1
        )
        # 150 late values; the linear-interpolation percentile sits at rank 0.95 * 149 = 141.55
        assert h.shape == (300, 40), h.shape
        hand = [np.sort(h[150:, r])[[141, 142]] @ [0.45, 0.55] for r in range(40)]
        assert row["unit"] == "m" and row["runs"] == 40 and np.isclose(row["mean"], np.mean(hand), rtol=1e-12), row
    assert len(p95) == 6 and "| late_horizontal_error_p95 | m |" in report

# -- 5. the paired differences, as published ----------------------------------------------------
paired = {(p["case"], p["candidate"], p["metric"]): p for p in summary["paired"]}
rows = {(r["case"], r["candidate"], r["metric"]): r for r in summary["rows"]}
for case in ("white", "colored"):
    same = paired[(case, "fading-1.00", "horizontal_error_rmse")]
    assert same["diff"] == 0.0 and not same["significant"], same  # identical runs: no difference at all
    d = paired[(case, "fading-1.05", "horizontal_error_rmse")]
    kf, fading = rows[(case, "kf", "horizontal_error_rmse")], rows[(case, "fading-1.05", "horizontal_error_rmse")]
    # Why pair: the SE of the paired difference against that of two independent samples.
    unpaired_se = np.hypot(kf["std"], fading["std"]) / np.sqrt(kf["runs"])
    print(
        f"{case}: horizontal RMSE kf {kf['mean']:.3f} m, fading-1.05 {fading['mean']:.3f} m; "
        f"paired difference {d['diff']:+.4f} ± {d['se']:.4f} m (n = {d['n']}, "
        f"{'significant' if d['significant'] else 'not significant'}; unpaired SE would be {unpaired_se:.4f})"
    )
    assert d["n"] == 40 and 0 < d["se"] < unpaired_se
# White noise: every past measurement is as informative as the last, so forgetting them
# costs (the KF is the optimal linear filter there). Colored noise (psi 0.95): the data do
# not show a difference at this n; the script reports it as such rather than claim one.
white = paired[("white", "fading-1.05", "horizontal_error_rmse")]
assert white["diff"] > 0 and white["significant"]
assert "fading-1.05" in report and "Paired differences" in report
for case in ("white", "colored"):
    d = paired[(case, "fading-1.05", "late_horizontal_error_p95")]
    print(
        f"{case}: late 95th percentile, fading-1.05 - kf: {d['diff']:+.4f} ± {d['se']:.4f} m (n = {d['n']}, "
        f"{'significant' if d['significant'] else 'not significant'})"
    )
    assert paired[(case, "fading-1.00", "late_horizontal_error_p95")]["diff"] == 0.0
