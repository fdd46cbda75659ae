"""GNSS-SDR as the peer on the weak-signal files: its default and its weak-signal settings.

    python validation/gnss_sdr_weak.py [--cn0 35 30] [--duration 70] [--moving] [--seed 1] [--work DIR]

The files of `gps_sdr_sim_weak.py --cold-start` (gps-sdr-sim's static receiver at Tokyo, or
``--moving`` its 100 m circle at 15 m/s, 2.6 MHz complex int16, every satellite at one
C/N0 by added white noise, the same seed), each run through GNSS-SDR 0.0.17 (``gnss-sdr``
on PATH: Debian's package) twice, cold (no position, time or ephemeris, as ``receive
--weak``):

- ``default``: the benchmarks' configuration (`benchmarks/gnss_sdr_config.py`: 1 ms PCPS,
  30 Hz PLL, 2 Hz DLL, the RTKLIB PVT with Klobuchar and no troposphere);
- ``weak``: the same with GNSS-SDR's own weak-signal options (`WEAK_ACQUISITION`,
  `WEAK_TRACKING`: 10 ms acquisition with its bit-transition search, 20 ms coherent tracking
  after bit synchronisation with a 5 Hz PLL, its loss-of-lock tests relaxed to 20 dB-Hz and
  a lock indicator of 0.3). These are our choices among its documented options; a GNSS-SDR
  user may know better ones, and the table says which were used.

Printed per file and configuration: the satellites GNSS-SDR tracked, its first fix (seconds
into the file), the fixes at 1 Hz and their horizontal and vertical RMS error against
gps-sdr-sim's receiver (the circle at each fix's time when moving); a markdown row per run
for docs/receiver/navigation.md. A validation, not a test: it asserts nothing about the
peer and exits 2 only when gps-sdr-sim cannot be built or ``gnss-sdr`` is not installed.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "benchmarks"))
from gnss_sdr_config import WEAK_ACQUISITION, WEAK_TRACKING  # noqa: E402
from gps_sdr_sim_run import LOCATION, add_noise, circle_truth, parse_log, simulate  # noqa: E402
from receiver_end_to_end import FS_HZ, run_gnss_sdr  # noqa: E402

CONFIGS = {"default": ({}, {}), "weak": (WEAK_ACQUISITION, WEAK_TRACKING)}


def fix_errors_m(fixes: np.ndarray, t_s: np.ndarray, moving: bool) -> tuple[float, float]:
    """Horizontal and vertical RMS error (m) of GNSS-SDR's geodetic fixes ``(F, 3)`` at file
    times ``t_s`` against gps-sdr-sim's receiver (ENU at LOCATION's axes)."""
    import pymap3d

    xyz = np.stack(pymap3d.geodetic2ecef(fixes[:, 0], fixes[:, 1], fixes[:, 2]), axis=-1)
    truth = circle_truth(t_s)[0] if moving else np.array(pymap3d.geodetic2ecef(*LOCATION))[None]
    d = xyz - truth
    e, n, u = pymap3d.ecef2enuv(d[:, 0], d[:, 1], d[:, 2], *LOCATION[:2])
    return float(np.sqrt(np.mean(e**2 + n**2))), float(np.sqrt(np.mean(u**2)))


def run(path: Path, work: Path, tow0: float, name: str, moving: bool) -> dict:
    """GNSS-SDR with configuration ``name`` on ``path`` (`receiver_end_to_end.run_gnss_sdr`)."""
    acquisition, tracking = CONFIGS[name]
    return run_gnss_sdr(
        path,
        work,
        tow0,
        name=name,
        acquisition=acquisition,
        tracking=tracking,
        errors=lambda fixes, t_s: fix_errors_m(fixes, t_s, moving),
    )


def row(name: str, moving: bool, cn0: float, r: dict, epochs: int, simulated: set[int]) -> str:
    """The run's line in the cold-start table of docs/receiver/navigation.md: the PRNs it
    tracked (of them, the simulated ones), first fix, fixes, satellites used, errors."""
    real = len(simulated & set(r["channels"]))
    head = (
        f"| GNSS-SDR 0.0.17, {name} settings | {'moving' if moving else 'static'} | {cn0:g} "
        f"| {len(r['channels'])}, {real} of them simulated |"
    )
    if r["exit"] != 0:  # a failed run is not a "no fix": its log says why
        return head + f" GNSS-SDR exited with {r['exit']} (its log beside its config) | - | - | - | - |"
    if "fixes" not in r:
        return head + " no fix | 0 | - | - | - |"
    h, v = r["errors_m"]
    lo, hi = r["sats"]
    after = epochs - int(r["first_fix_s"]) + 1  # the 1 Hz epochs from the first fix to the file's end
    return head + f" {r['first_fix_s']:.1f} | {r['fixes']} of {after} | {lo}-{hi} | {h:.2f} | {v:.2f} |"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cn0", type=float, nargs="+", default=[35.0, 30.0], help="C/N0 of every satellite (dB-Hz)")
    ap.add_argument("--duration", type=float, default=70.0, help="seconds simulated")
    ap.add_argument("--moving", action="store_true", help="the receiver on gps-sdr-sim's circle")
    ap.add_argument("--seed", type=int, default=1, help="the noise draw (gps_sdr_sim_weak's default)")
    ap.add_argument("--work", type=Path, help="keep the files and GNSS-SDR's logs here")
    args = ap.parse_args(argv)
    if shutil.which("gnss-sdr") is None:
        print("gnss-sdr is not installed (Debian: apt-get install gnss-sdr)", file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory() as tmp:
        work = args.work or Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        try:
            sim, log = simulate(work, args.duration, FS_HZ, args.moving)
        except (subprocess.CalledProcessError, OSError) as exc:
            print(f"cannot build or run gps-sdr-sim: {exc}", file=sys.stderr)
            return 2
        _, tow0, sats = parse_log(log)
        print(f"gps-sdr-sim: {len(sats)} satellites {sorted(sats)}, {args.duration:g} s")
        rows = []
        for cn0 in args.cn0:
            path = work / f"noisy_{cn0:g}.sigmf-data"
            add_noise(sim, path, cn0, FS_HZ, np.random.default_rng(args.seed))
            for name in CONFIGS:
                (work / f"{cn0:g}").mkdir(exist_ok=True)
                r = run(path, work / f"{cn0:g}", tow0, name, args.moving)
                print(f"{cn0:g} dB-Hz, {name}: {r}", flush=True)
                rows.append(row(name, args.moving, cn0, r, int(np.ceil(args.duration)) - 1, set(sats)))
        print("\n".join(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
