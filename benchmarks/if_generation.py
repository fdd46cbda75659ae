"""Speed of IF-sample generation, ours against gps-sdr-sim, as satellite-seconds of signal per CPU second.

    python benchmarks/if_generation.py [--seconds 10] [--rate 2.6e6] [--repeat 2]

In the same run, each timed as the best of ``--repeat`` (CPU time of the process or of the
child):

- gps-sdr-sim (``../shared/tools/gps-sdr-sim``, built by its ``build.sh``): ``--seconds``
  of every GPS L1 C/A satellite in view of Tokyo from its broadcast file, int8 I/Q at
  ``--rate`` (its signal model also has path loss, antenna gain and the ionosphere);
- ours, `gnssframework.receiver.frontend.synthesize_samples` (noise-free signals of
  `generate_if_samples` summed, unit white noise added) of as many satellites for as long,
  with data bits, converted to int8 I/Q as the test recordings are, under the numba backend
  (one compiled pass per satellite and chunk) and under the NumPy reference.

Printed: each generator's CPU seconds, satellite-seconds per CPU second, and the ratios
ours/gps-sdr-sim and compiled/NumPy. The generators differ in what they model; the rows
say what each costs per satellite and second of signal, not that one is better.
"""

from __future__ import annotations

import argparse
import re
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from gnssframework import backend, registry
from gnssframework.receiver.frontend import SatelliteSignal, synthesize_samples

ROOT = Path(__file__).resolve().parents[1]
SIM_DIR = ROOT.parent / "shared" / "tools" / "gps-sdr-sim"
#: A satellite row of gps-sdr-sim's listing: PRN, azimuth, elevation, range, ionosphere.
_SAT_ROW = re.compile(r"^\s*\d+\s+-?[\d.]+\s+-?[\d.]+\s+[\d.]+\s+[\d.]+\s*$")


def _child_cpu_s() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def gps_sdr_sim(seconds: float, fs: float, folder: Path) -> tuple[float, int] | None:
    """(CPU seconds, satellites) of gps-sdr-sim writing ``seconds`` at ``fs``; None without it."""
    if not (SIM_DIR / "build.sh").exists():
        return None
    out = subprocess.run([str(SIM_DIR / "build.sh"), str(folder / "bin")], check=True, capture_output=True, text=True)
    binary = out.stdout.strip().splitlines()[-1]
    before = _child_cpu_s()
    run = subprocess.run(
        [binary, "-e", str(SIM_DIR / "brdc0010.22n"), "-l", "35.681298,139.766247,10.0", "-d", f"{seconds}"]
        + ["-b", "8", "-s", f"{fs:.0f}", "-o", str(folder / "sim.bin")],
        check=True,
        capture_output=True,
        text=True,
        cwd=folder,
    )
    sats = sum(bool(_SAT_ROW.match(line)) for line in (run.stdout + run.stderr).splitlines())
    return _child_cpu_s() - before, sats


def ours(seconds: float, fs: float, satellites: int, folder: Path, path: str) -> float:
    """CPU seconds of our generator writing ``satellites`` for ``seconds`` at ``fs`` as int8
    I/Q in 0.5 s chunks, on backend ``path``."""
    rng = np.random.default_rng(1)
    sats = [
        SatelliteSignal(
            p, 45.0, float(rng.uniform(-4000, 4000)), float(rng.uniform(0, 1023)), 0.3, first_bit_code_period=3
        )
        for p in range(1, satellites + 1)
    ]
    source = registry.create("sample_source", "ci8")
    backend.set_backend(path)
    try:
        start = time.process_time()
        with open(folder / f"ours_{path}.bin", "wb") as fh:
            for _ in range(int(round(seconds / 0.5))):
                fh.write(source.encode(16.0 * synthesize_samples(sats, 0.5, fs, 0.0, rng)))
        return time.process_time() - start
    finally:
        backend.set_backend(None)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--rate", type=float, default=2.6e6, help="sample rate (Hz), gps-sdr-sim's default")
    ap.add_argument("--repeat", type=int, default=2)
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        peer = [gps_sdr_sim(args.seconds, args.rate, folder) for _ in range(args.repeat)]
        sats = peer[0][1] if peer[0] is not None else 10
        print(f"gps-sdr-sim: {'done' if peer[0] is not None else 'not available'}", file=sys.stderr, flush=True)
        ours(0.5, args.rate, 1, folder, "numba")  # compile outside the timing
        rows = {}
        for path in ("numba", "numpy"):
            rows[path] = min(ours(args.seconds, args.rate, sats, folder, path) for _ in range(args.repeat))
            print(f"ours, {path}: done", file=sys.stderr, flush=True)
    work = sats * args.seconds
    print(f"{sats} satellites x {args.seconds:g} s at {args.rate / 1e6:g} MHz, int8 I/Q (best of {args.repeat})")
    print(f"{'generator':<28}{'CPU s':>8}{'sat-s per CPU s':>18}")
    if peer[0] is not None:
        cpu_peer = min(p[0] for p in peer if p is not None)
        print(f"{'gps-sdr-sim':<28}{cpu_peer:>8.2f}{work / cpu_peer:>18.1f}")
    for path, label in (("numba", "ours, compiled"), ("numpy", "ours, NumPy reference")):
        print(f"{label:<28}{rows[path]:>8.2f}{work / rows[path]:>18.1f}")
    print(f"compiled / NumPy CPU time: {rows['numba'] / rows['numpy']:.2f}")
    if peer[0] is not None:
        print(f"ours (compiled) / gps-sdr-sim CPU time: {rows['numba'] / cpu_peer:.2f}")
    else:
        print("gps-sdr-sim: skipped (needs ../shared/tools/gps-sdr-sim beside the repository)", file=sys.stderr)


if __name__ == "__main__":
    main()
