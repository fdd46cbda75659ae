"""A tracking-threshold curve at issue 40's size: 7 C/N0 points x 7 candidates x 200 runs.

The `tracking-threshold` scenario of ``examples/tracking_threshold.toml`` (static, 6 s at
T = 10 ms on the analytic correlator model), its static case only, swept from 15 to
45 dB-Hz in 5 dB steps, with seven channel filters: 2nd-order Costas PLLs at 10 and 18 Hz,
a 3rd-order one at 18 Hz, the 18 Hz PLL with a 10 Hz FLL assist, the Kalman carrier
loop, and ``iq-filter`` with an SVD-CKF and with a UKF (R fixed at the correlators' true
covariance, closed by its own estimates: `gnssframework.receiver.engine.EstimateCloser`).
Two thresholds on the same runs: the phase-lock one (``loss_of_lock``) and the
code-and-frequency one (``loss_of_code_freq_lock``, the criterion of the vector loop's
threshold, ``examples/tracking_threshold_vector.toml``). Runs on the local executor (a
process per core), then, with ``--dask``, again on a Dask LocalCluster of as many workers,
and checks that every number of the two summaries is the same (the runs' random streams
come from the seed and the run, never from where a batch runs).

Printed: the wall time of the whole comparison (the sweeps' points and their threshold
bootstraps included), the load average before and after, whether it met the issue's
budget (under 10 minutes on 2 cores), and the thresholds with their paired-bootstrap
intervals.

    python benchmarks/threshold_curve.py [--runs 200] [--dask] [--work DIR]
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BUDGET_S = 600.0

CANDIDATES = {
    "pll-2-10": '{ name = "scalar", params = { pll_bandwidth_hz = 10.0, pll_order = 2, fll_bandwidth_hz = 0.0, '
    "dll_bandwidth_hz = 0.5 } }",
    "pll-2-18": '{ name = "scalar", params = { pll_bandwidth_hz = 18.0, pll_order = 2, fll_bandwidth_hz = 0.0, '
    "dll_bandwidth_hz = 0.5 } }",
    "pll-3-18": '{ name = "scalar", params = { pll_bandwidth_hz = 18.0, pll_order = 3, fll_bandwidth_hz = 0.0, '
    "dll_bandwidth_hz = 0.5 } }",
    "fll-pll-18": '{ name = "scalar", params = { pll_bandwidth_hz = 18.0, pll_order = 2, fll_bandwidth_hz = 10.0, '
    "dll_bandwidth_hz = 0.5 } }",
    "kf": '{ name = "kf-carrier-loop", params = { q = [0.01, 0.1], r = 5.0, angle_unit = "deg", '
    "dll_bandwidth_hz = 0.5 } }",
    "iq-ckf": '{ name = "iq-filter", params = { estimator = "svd-ckf", adaptive = false, output = "filtered" } }',
    "iq-ukf": '{ name = "iq-filter", params = { estimator = "ukf", adaptive = false, output = "filtered" } }',
}


def config_text(runs: int, executor: str) -> str:
    """The benchmark's comparison: the example's scenario, its static case, 7 points, 5 candidates."""
    example = tomllib.loads((ROOT / "examples" / "tracking_threshold.toml").read_text())
    scenario = "\n".join(f"{k} = {json.dumps(v)}" for k, v in example["scenario"].items())
    candidates = "\n".join(
        f'[[candidates]]\nname = "{name}"\nchannel_filter = {ref}\n' for name, ref in CANDIDATES.items()
    )
    sweeps = "".join(
        f"""[[sweeps]]
name = "{name}"
path = "cases.cn0_dbhz"
start = 15.0
stop = 45.0
step = 5.0
threshold = {{ metric = "{metric}", level = 0.5, bootstrap = 2000, time_metric = "{time_metric}" }}
"""
        for name, metric, time_metric in (
            ("cn0", "loss_of_lock", "time_to_loss_s"),
            ("cn0-cf", "loss_of_code_freq_lock", "time_to_code_freq_loss_s"),
        )
    )
    return f"""name = "threshold_curve_benchmark"
runs = {runs}
batch_size = {min(runs, 100)}
seed = 2
reference = "pll-2-18"
[executor]
kind = "{executor}"
[scenario]
{scenario}
[[cases]]
name = "static"
cn0_dbhz = 30.0
{candidates}
{sweeps}"""


def run(runs: int, executor: str, work: Path) -> tuple[float, dict]:
    """Wall seconds and the summary."""
    from gnssframework.experiments import load_config, run_comparison

    path = work / f"{executor}.toml"
    path.write_text(config_text(runs, executor))
    config = load_config(path)
    t0 = time.perf_counter()
    summary = run_comparison(config, work / executor, progress=False)
    wall = time.perf_counter() - t0
    return wall, json.loads(summary.read_text())


def _fmt(x) -> str:
    """A threshold bound: a number to 0.1 dB, or its out-of-grid word as stored."""
    return "n/a" if x is None else x if isinstance(x, str) else f"{x:.1f}"


def print_thresholds(summary: dict) -> None:
    """Each sweep's thresholds (dB-Hz) and differences to the reference, with their
    paired-bootstrap 95 % intervals."""
    for sweep in summary["sweeps"]:
        t = sweep.get("threshold")
        if not t:
            continue
        for case in t["cases"]:
            print(
                f"threshold of {t['metric']} at P = {t['level']} along {t['sweep']} ({case['case']}, "
                f"{case['runs']} paired runs), dB-Hz [95 %]:"
            )
            for row in case["rows"]:
                est = row["where"] if row["threshold"] is None else _fmt(row["threshold"])
                line = f"  {row['candidate']:<12} {est:>16} [{_fmt(row['ci95'][0])}, {_fmt(row['ci95'][1])}]"
                d = row.get("difference")
                if d and d["estimate"] is not None:
                    line += f"   - {d['reference']}: {d['estimate']:+.1f} [{_fmt(d['ci95'][0])}, {_fmt(d['ci95'][1])}]"
                print(line, flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=200, help="runs per candidate and C/N0 point (default 200)")
    parser.add_argument("--dask", action="store_true", help="run again on a Dask LocalCluster and compare numbers")
    parser.add_argument("--work", type=Path, help="folder for the results (default: a temporary one)")
    args = parser.parse_args()
    work = args.work or Path(tempfile.mkdtemp(prefix="threshold_curve_"))
    work.mkdir(parents=True, exist_ok=True)
    print(
        f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} before; 7 C/N0 points x "
        f"{len(CANDIDATES)} candidates x {args.runs} runs of 6 s; results in {work}",
        flush=True,
    )
    wall, local = run(args.runs, "local", work)
    verdict = "within" if wall <= BUDGET_S else "OVER"
    print(
        f"local: {wall:.1f} s wall, {verdict} the {BUDGET_S:.0f} s budget; load average {os.getloadavg()[0]:.1f} after",
        flush=True,
    )
    print_thresholds(local)
    if args.dask:
        wall_d, dask = run(args.runs, "dask", work)
        same = local == dask  # every row, paired difference, sweep point and threshold
        print(f"dask:  {wall_d:.1f} s wall; every number of the summary the same as local: {same}", flush=True)
        if not same:
            raise SystemExit(1)


if __name__ == "__main__":
    main()
