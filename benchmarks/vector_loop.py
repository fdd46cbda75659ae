"""Epochs per second of the whole vector tracking loop at 8 channels, 1 and 100 batched runs.

Real time is 100 epochs per second (T = 10 ms), so "x real time, all runs" is
epochs/s x runs / 100 (100 runs at 3x real time each count as 300x). Times the
`discriminator` and `iq-filter` (svd-ckf, ckf, ukf, each with the innovation adapter)
channel filters, all with ekf-pv, on the vector-tracking scenario. A short warm-up run first, so kernel compile/load time is not counted.

The last column divides by the process's CPU time instead of the wall time: on a
machine shared with other jobs it is the far steadier number (it counts no time spent
waiting for a core; with parallel kernels it adds up both threads' time, so it is the
one-core figure).

    python benchmarks/vector_loop.py [--duration 2]
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np

from gnssframework.experiments import get_scenario


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=2.0, help="simulated seconds per run")
    args = parser.parse_args()
    scen = get_scenario({"kind": "vector-tracking", "duration_s": args.duration, "channels": 8, "settle_s": 0.0})
    epochs = int(round(args.duration / scen.params.coherent_time_s))
    print(
        f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, load average "
        f"{os.getloadavg()[0]:.1f} at start"
    )
    print(
        f"{'channel filter':18s} {'runs':>5s} {'epochs/s':>10s} {'x real time, all runs':>22s} {'same, CPU time':>16s}"
    )
    for name, params in (
        ("discriminator", {}),
        ("iq-filter", {"estimator": "svd-ckf"}),
        ("iq-filter", {"estimator": "ckf"}),
        ("iq-filter", {"estimator": "ukf"}),
    ):
        label = name + (f" ({params['estimator']})" if params else "")
        for runs in (1, 100):
            plugins = scen.build(
                {
                    "channel_filter": {"name": name, "params": params},
                    "nav_filter": {"name": "ekf-pv", "params": {"clock": "ocxo"}},
                }
            )
            short = get_scenario({"kind": "vector-tracking", "duration_s": 0.05, "channels": 8, "settle_s": 0.0})
            short.run_batch(
                {"cn0_dbhz": 45.0},
                short.build(
                    {
                        "channel_filter": {"name": name, "params": params},
                        "nav_filter": {"name": "ekf-pv", "params": {"clock": "ocxo"}},
                    }
                ),
                runs,
                np.random.default_rng(1),
            )  # warm-up
            t0, c0 = time.perf_counter(), time.process_time()
            scen.run_batch({"cn0_dbhz": 45.0}, plugins, runs, np.random.default_rng(0))
            dt, dc = time.perf_counter() - t0, time.process_time() - c0
            rate = epochs / dt
            print(
                f"{label:18s} {runs:5d} {rate:10.1f} {rate * runs / 100:22.1f} {epochs / dc * runs / 100:16.1f}",
                flush=True,
            )
    print(f"load average {os.getloadavg()[0]:.1f} at the end")


if __name__ == "__main__":
    main()
