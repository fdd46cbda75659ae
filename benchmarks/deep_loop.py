"""Epochs per second of the deep-integration loop (reference 002) at 8 channels, 1 run and a batch of runs.

Real time is 1000 epochs per second (T = 1 ms), so "x real time, all runs" is
epochs/s x runs / 1000. Times the candidates of ``examples/deep_integration.toml``
that matter for speed: ``deep`` (iq-filter prefilters with ukf, ins-ekf with the
carrier-phase prefilter, NCOs re-aided every 5 ms), ``loose`` (scalar loops, fixes
into ins-ekf) and ``vector`` (iq-filter + ekf-pv, no INS), on the ``deep-integration``
scenario (pull-up profile, 45 dB-Hz). A short warm-up run first, so kernel compile/load
time is not counted. Each line is the whole ``run_batch`` (truth, IMU simulation, loop,
metrics).

Wall time depends on what else runs on the machine; the CPU-time column (the process's
CPU time) is the steadier one on a shared machine (with parallel kernels it adds up
both threads' time).

    python benchmarks/deep_loop.py [--duration 2] [--runs 8] [--candidates deep loose vector]
"""

from __future__ import annotations

import argparse
import os
import platform
import time
import tomllib
from pathlib import Path

import numpy as np

from gnssframework.experiments import get_scenario

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "deep_integration.toml"


def candidates() -> dict[str, dict]:
    """The candidates of the example (channel_filter and nav_filter specs), by name."""
    cfg = tomllib.loads(EXAMPLE.read_text())
    return {
        c["name"]: {"channel_filter": c["channel_filter"], "nav_filter": c["nav_filter"]} for c in cfg["candidates"]
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=2.0, help="simulated seconds per run (multiple of 0.1)")
    parser.add_argument("--runs", type=int, default=8, help="runs of the batched line")
    parser.add_argument("--candidates", nargs="+", default=["deep", "loose", "vector"])
    args = parser.parse_args()
    specs = candidates()
    base = {"kind": "deep-integration", "profile": "pull-up", "channels": 8, "settle_s": 0.0}
    scen = get_scenario({**base, "duration_s": args.duration})
    # Warm-up long enough that every path runs (loose: its first fix comes after the pull-in update).
    short = get_scenario({**base, "duration_s": 0.5})
    epochs = int(round(args.duration / scen.params.coherent_time_s))
    print(
        f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, load average "
        f"{os.getloadavg()[0]:.1f} at start; {args.duration} s simulated per run"
    )
    print(
        f"{'candidate':12s} {'runs':>5s} {'epochs/s':>10s} {'x real time, all runs':>22s} "
        f"{'same, CPU time':>16s} {'wall s':>8s} {'CPU s':>8s}"
    )
    for name in args.candidates:
        for runs in (1, args.runs):
            short.run_batch({"cn0_dbhz": 45.0}, short.build(specs[name]), runs, np.random.default_rng(1))  # warm-up
            plugins = scen.build(specs[name])
            t0, c0 = time.perf_counter(), time.process_time()
            scen.run_batch({"cn0_dbhz": 45.0}, plugins, runs, np.random.default_rng(0))
            dt, dc = time.perf_counter() - t0, time.process_time() - c0
            rate = epochs / dt
            print(
                f"{name:12s} {runs:5d} {rate:10.1f} {rate * runs / 1000:22.2f} {epochs / dc * runs / 1000:16.2f} "
                f"{dt:8.2f} {dc:8.2f}",
                flush=True,
            )
    print(f"load average {os.getloadavg()[0]:.1f} at the end")


if __name__ == "__main__":
    main()
