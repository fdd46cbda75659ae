"""A comparison with a C/N0 sweep: two vector-tracking candidates on common random numbers.

The ``[[sweeps]]`` table runs the whole comparison at each C/N0; every candidate sees the
same signals and noise at each point, so the paired difference per run (candidate minus
the reference candidate, with its standard error) carries the comparison.

Run: python examples/gallery/comparison_sweep.py
"""

import json
import pathlib
import tempfile

import numpy as np

from gnssframework.experiments import load_config, run_comparison

CONFIG = """
name = "gallery-sweep"
runs = 4
batch_size = 2
seed = 1
reference = "discriminators"
[executor]
workers = 1
[scenario]
kind = "vector-tracking"
duration_s = 0.6
channels = 6
settle_s = 0.2
[[cases]]
name = "static"
cn0_dbhz = 45.0
[[candidates]]
name = "discriminators"
channel_filter = { name = "discriminator" }
nav_filter = { name = "ekf-pv", params = { clock = "ocxo" } }
[[candidates]]
name = "iq-ckf"
channel_filter = { name = "iq-filter", params = { estimator = "ckf" } }
nav_filter = { name = "ekf-pv", params = { clock = "ocxo" } }
[[sweeps]]
name = "cn0"
path = "cases.cn0_dbhz"
values = [45.0, 35.0]
"""

with tempfile.TemporaryDirectory() as tmp:
    path = pathlib.Path(tmp) / "sweep.toml"
    path.write_text(CONFIG)
    summary = run_comparison(load_config(path), pathlib.Path(tmp) / "out", progress=False)
    sweep = json.loads(summary.read_text())["sweeps"][0]
    assert (pathlib.Path(tmp) / "out" / "plots" / "sweep-cn0-static.png").exists()

means = {(r["value"], r["candidate"], r["metric"]): r for r in sweep["rows"]}
paired = {(p["value"], p["metric"]): p for p in sweep["paired"]}
for cn0 in (45.0, 35.0):
    a = means[(cn0, "discriminators", "code_phase_error_rmse")]
    b = means[(cn0, "iq-ckf", "code_phase_error_rmse")]
    d = paired[(cn0, "code_phase_error_rmse")]
    print(
        f"C/N0 {cn0:.0f} dB-Hz: code RMSE discriminators {a['mean']:.4f} ± {a['se']:.4f}, "
        f"iq-ckf {b['mean']:.4f} ± {b['se']:.4f} chips; paired difference {d['diff']:+.4f} ± {d['se']:.4f} "
        f"({'significant' if d['significant'] else 'not significant'}, {d['n']} runs)"
    )
    assert np.isfinite(a["mean"]) and np.isfinite(b["mean"]) and a["n"] == 4 and d["n"] == 4
# Lower C/N0, larger code error, for both candidates.
for cand in ("discriminators", "iq-ckf"):
    assert means[(35.0, cand, "code_phase_error_rmse")]["mean"] > means[(45.0, cand, "code_phase_error_rmse")]["mean"]
