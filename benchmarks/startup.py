"""Startup cost of the compiled kernels: import, cold compile, and load from the disk cache.

Each measurement runs in a fresh interpreter (``python -c``) with its own numba cache
directory: the first run compiles every kernel and writes the cache, the second loads
it. ``gnssframework compare`` pays this once in the parent before forking its workers
(`gnssframework.estimation.compiled.warm_up_kernels`, then the loop checks'
`gnssframework.estimation.compiled.loop.warm_up`); forked workers inherit the loaded kernels.

    python benchmarks/startup.py
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile

_PROBE = """
import json, time
t0 = time.perf_counter()
from gnssframework.estimation import compiled
t1 = time.perf_counter()
warm = compiled.warm_up_kernels()
t2 = time.perf_counter()
compiled.loop.warm_up()
print(json.dumps({"import_s": t1 - t0, "warm_up_s": warm, "loop_warm_up_s": time.perf_counter() - t2}))
"""


def _probe(cache_dir: str) -> dict:
    env = dict(os.environ, NUMBA_CACHE_DIR=cache_dir)
    out = subprocess.run([sys.executable, "-c", _PROBE], env=env, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    argparse.ArgumentParser(description=__doc__.splitlines()[0]).parse_args()  # --help: no two-minute run
    print(f"load average {os.getloadavg()[0]:.1f} at start, {os.cpu_count()} cores")
    with tempfile.TemporaryDirectory() as cache:
        cold = _probe(cache)
        warm = _probe(cache)
    print(f"{'':28s} {'import s':>9s} {'warm_up s':>10s} {'loop warm_up s':>15s}")
    for label, r in (("cold (compile, write cache)", cold), ("cached (load from disk)", warm)):
        print(f"{label:28s} {r['import_s']:9.2f} {r['warm_up_s']:10.2f} {r['loop_warm_up_s']:15.2f}")


if __name__ == "__main__":
    main()
