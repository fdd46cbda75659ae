"""Write a noisy gps-sdr-sim recording for the ``sample-recording`` comparison.

    python validation/gps_sdr_sim_recording.py OUT.sigmf-data [--cn0 45] [--duration 30] [--fs 2.6e6] [--seed 1]

gps-sdr-sim (built and run by `gps_sdr_sim_run`) simulates the static receiver at
``LOCATION`` from ``brdc0010.22n`` with every satellite at one power; complex white noise
for ``--cn0`` is added from ``--seed``. Writes ``OUT.sigmf-data`` and its
``OUT.sigmf-meta`` (ci16_le, the rate, IF 0). ``examples/recorded/sample_recording.toml`` reads
``build/gps_sdr_sim_45dbhz.sigmf-data``. Exits 2 when gps-sdr-sim cannot be built or run.
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from gps_sdr_sim_run import LOCATION, SimulatorError, exit_unavailable, noisy_recording  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path, help="the recording to write (.sigmf-data; its .sigmf-meta beside it)")
    ap.add_argument("--cn0", type=float, default=45.0, help="C/N0 of every satellite (dB-Hz)")
    ap.add_argument("--duration", type=float, default=30.0, help="seconds simulated")
    ap.add_argument("--fs", type=float, default=2.6e6, help="sample rate")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args(argv)
    if args.out.suffix != ".sigmf-data":
        print(f"{args.out}: the recording must end in .sigmf-data (its metadata goes beside it)", file=sys.stderr)
        return 2
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        try:
            sim = noisy_recording(Path(tmp), args.duration, args.fs, args.cn0, args.seed)
        except SimulatorError as exc:
            return exit_unavailable(exc)
        shutil.move(sim.path, args.out)
        shutil.move(sim.path.with_suffix(".sigmf-meta"), args.out.with_suffix(".sigmf-meta"))
    print(
        f"{args.out}: gps-sdr-sim, week {sim.week}, tow {sim.tow0_s:.0f} s, {len(sim.satellites)} satellites, "
        f"{args.duration:g} s at {args.fs:g} Hz, {args.cn0:g} dB-Hz, receiver at {LOCATION}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
