"""A comparison with a C/N0 sweep: two vector-tracking candidates on common random numbers.

The sweep is a list of cases; every candidate sees the same signals and noise in each
case and batch, so the paired difference per run carries the comparison.

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
[executor]
workers = 1
[scenario]
kind = "vector-tracking"
duration_s = 0.6
channels = 6
settle_s = 0.2
[[cases]]
name = "cn0-45"
cn0_dbhz = 45.0
[[cases]]
name = "cn0-35"
cn0_dbhz = 35.0
[[candidates]]
name = "discriminators"
channel_filter = { name = "discriminator" }
nav_filter = { name = "ekf-pv", params = { clock = "ocxo" } }
[[candidates]]
name = "iq-ckf"
channel_filter = { name = "iq-filter", params = { estimator = "ckf" } }
nav_filter = { name = "ekf-pv", params = { clock = "ocxo" } }
"""

with tempfile.TemporaryDirectory() as tmp:
    path = pathlib.Path(tmp) / "sweep.toml"
    path.write_text(CONFIG)
    summary = run_comparison(load_config(path), pathlib.Path(tmp) / "out", progress=False)
    rows = json.loads(summary.read_text())["rows"]

by = {(r["case"], r["candidate"], r["metric"]): r for r in rows}
for case in ("cn0-45", "cn0-35"):
    a = by[(case, "discriminators", "code_phase_error_rmse")]
    b = by[(case, "iq-ckf", "code_phase_error_rmse")]
    print(f"{case}: code RMSE discriminators {a['mean']:.4f}, iq-ckf {b['mean']:.4f} chips ({a['runs']} runs)")
    assert np.isfinite(a["mean"]) and np.isfinite(b["mean"]) and a["runs"] == 4
# Lower C/N0, larger code error, for both candidates.
for cand in ("discriminators", "iq-ckf"):
    assert by[("cn0-35", cand, "code_phase_error_rmse")]["mean"] > by[("cn0-45", cand, "code_phase_error_rmse")]["mean"]
