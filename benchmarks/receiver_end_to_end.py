"""The whole receiver, end to end, against GNSS-SDR on the same gps-sdr-sim file in the same run.

    python benchmarks/receiver_end_to_end.py [--seconds 60] [--cn0 45] [--repeat 3] [--work DIR] [--threads N]
                                             [--workers N] [--profile]

A static receiver simulated by gps-sdr-sim (built from ``../shared/tools/gps-sdr-sim``, its
``brdc0010.22n``, Tokyo, as `validation/gps_sdr_sim_navigation.py`), 2.6 MHz complex int16,
with white noise added for ``--cn0`` dB-Hz (`validation/gps_sdr_sim_tracking.add_noise`).
Both receivers run the whole chain on that one file, each in a fresh process (start-up,
compiled-kernel loading and file reading included), alternately (``--repeat`` rounds, the
order swapped every round; the default, 3 rounds of a 60 s file, takes 2-4 minutes on an
idle 2-core machine, the recording's simulation included; ``--work`` keeps the recording
for the next run):

- gnssframework: `receive` (acquisition of all 32 PRNs, tracking of every satellite found,
  in ``--workers`` processes as the command does by default (`auto`: the cores), LNAV,
  observables, least-squares positions at 1 Hz from the decoded ephemerides, Klobuchar
  from page 18, no troposphere: gps-sdr-sim models none);
- GNSS-SDR 0.0.17 (``gnss-sdr`` on PATH): PCPS acquisition, DLL/PLL tracking, telemetry,
  observables and its RTKLIB PVT (single point) at 1 Hz, 12 channels (more than the
  satellites in view).

Printed per run: wall time, CPU time (the process, its threads and its tracking
processes), peak resident memory (``ru_maxrss`` from ``wait4``: the largest of that process
and its tracking processes, which share the parent's pages), x real time (signal
seconds per wall second), the load average before the run, gnssframework's start-up CPU
(interpreter, imports, plugin registry: before the receiver starts) and, for context, each
receiver's first-fix time (seconds into the file), fixes, satellites used and position
errors against gps-sdr-sim's receiver position; then, per round and their median, the
ratios GNSS-SDR / gnssframework of wall and CPU time, and the load averages (1, 5, 15 min,
as ``uptime``) before and after. Other jobs on the same cores do not slow both receivers
alike: GNSS-SDR runs a thread per processing block, so on a loaded machine it gets a larger
share of the cores than a one-thread process; compare wall ratios from an idle machine.
``--profile`` prints where gnssframework's time goes (cProfile, cumulative).

Exits 2 when gps-sdr-sim cannot be built or ``gnss-sdr`` is not installed.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "validation"))

from gps_sdr_sim_run import LOCATION, SIM_DIR, add_noise, parse_log  # noqa: E402
from gps_sdr_sim_run import simulate as run_gps_sdr_sim  # noqa: E402

from gnss_sdr_config import gnss_sdr_config  # noqa: E402  (beside this script)

FS_HZ = 2.6e6
LEAP_S = 18  # GPS - UTC in 2022 (gps-sdr-sim's brdc0010.22n): GNSS-SDR prints UTC
_TRACKED = re.compile(r"Tracking of GPS L1 C/A signal started on channel \d+ for satellite GPS PRN (\d+)")
_POSITION = re.compile(
    r"Position at \S+ (\d+):(\d+):([\d.]+) UTC using (\d+) observations is Lat = ([-\d.]+) "
    r"\[deg\], Long = ([-\d.]+) \[deg\], Height\s*=\s*([-\d.]+) \[m\]"
)


def errors_m(lat_deg: np.ndarray, lon_deg: np.ndarray, h_m: np.ndarray) -> tuple[float, float]:
    """Horizontal and vertical RMS error (m) of geodetic positions against gps-sdr-sim's."""
    import pymap3d

    e, n, u = pymap3d.geodetic2enu(lat_deg, lon_deg, h_m, *LOCATION)
    return float(np.sqrt(np.mean(np.square(e) + np.square(n)))), float(np.sqrt(np.mean(np.square(u))))


def simulate(work: Path, seconds: float, cn0_dbhz: float, seed: int) -> tuple[Path, float]:
    """The noisy recording (reused from ``work`` when made with the same settings) and the
    GPS time of week of its first sample."""
    noisy, stamp = work / "noisy.sigmf-data", work / "settings.json"
    settings = {"seconds": seconds, "cn0_dbhz": cn0_dbhz, "seed": seed, "fs_hz": FS_HZ}
    if noisy.exists() and stamp.exists() and json.loads(stamp.read_text())["settings"] == settings:
        return noisy, json.loads(stamp.read_text())["tow0_s"]
    sim, log = run_gps_sdr_sim(work, seconds, FS_HZ)
    _, tow0, sats = parse_log(log)
    add_noise(sim, noisy, cn0_dbhz, FS_HZ, np.random.default_rng(seed))
    sim.unlink()
    stamp.write_text(json.dumps({"settings": settings, "tow0_s": tow0, "satellites": sorted(sats)}))
    return noisy, tow0


def ours_in_this_process(
    path: Path, out: Path, profile: bool, threads: int | None = None, workers: int | str = "auto"
) -> None:
    """Run the library's receiver on ``path``; write what it found to ``out`` (JSON)."""
    from gnssframework import registry
    from gnssframework.backend import set_threads

    set_threads(threads)
    from gnssframework.receiver.channels import tracking_config
    from gnssframework.receiver.frontend import open_recording
    from gnssframework.receiver.navigation.receive import receive

    acquisition = registry.create("acquisition", "pcps")  # loads the plugin registry: start-up
    startup_cpu_s = time.process_time()

    def run():
        return receive(
            open_recording(path),
            acquisition,
            tracking_config(),
            rate_hz=1.0,
            ionosphere=True,
            troposphere=False,
            workers=workers,
        )

    if profile:
        import cProfile
        import pstats

        prof = cProfile.Profile()
        result = prof.runcall(run)
        pstats.Stats(prof, stream=sys.stderr).sort_stats("cumulative").print_stats(25)
    else:
        result = run()
    table = result.positions
    found = {"channels": sorted(int(p) for p in result.tracking.channels), "startup_cpu_s": startup_cpu_s}
    if table is not None and len(table):
        c = table.columns
        found |= {
            "first_fix_s": float(table.sample_time_s[0]),
            "fixes": len(table),
            "sats_median": float(np.median(c["n_sats"])),
            "errors_m": errors_m(c["lat_deg"], c["lon_deg"], c["height_m"]),
        }
    out.write_text(json.dumps(found))


# A process started straight from this one inherits its peak resident memory: Linux keeps
# ``ru_maxrss`` across ``execve``, and this process holds the recording it simulated (the
# first version of this script printed 892 MiB for both receivers). So each receiver is
# forked from a small launcher interpreter, whose ``wait4`` on it reports its own figures.
_LAUNCHER = (
    "import json, os, sys\n"
    "pid = os.fork()\n"
    "if pid == 0:\n"
    "    os.execvp(sys.argv[2], sys.argv[2:])\n"
    "_, status, ru = os.wait4(pid, 0)\n"
    "with open(sys.argv[1], 'w') as f:\n"
    "    json.dump([os.waitstatus_to_exitcode(status), ru.ru_utime + ru.ru_stime, ru.ru_maxrss], f)\n"
)


def timed(cmd: list[str], cwd: Path) -> tuple[subprocess.CompletedProcess, float, float, float, float]:
    """Run ``cmd``: (process, wall s, CPU s of it and its threads, load average before, its
    peak resident memory in MiB), the CPU and memory from ``wait4`` on that process alone,
    read by a launcher it is forked from (`_LAUNCHER`)."""
    load = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        usage_file = Path(tmp) / "usage.json"
        launcher = [sys.executable, "-S", "-c", _LAUNCHER, str(usage_file), *cmd]
        t = time.perf_counter()
        run = subprocess.run(launcher, capture_output=True, text=True, cwd=cwd)
        wall = time.perf_counter() - t
        returncode, cpu_s, maxrss_kib = json.loads(usage_file.read_text())
    run = subprocess.CompletedProcess(cmd, returncode, run.stdout, run.stderr)
    return run, wall, cpu_s, load, maxrss_kib / 1024  # Linux: KiB


def run_ours(path: Path, work: Path, profile: bool = False, threads: int | None = None, workers: int | str = 1) -> dict:
    out = work / "ours.json"
    cmd = [sys.executable, str(Path(__file__).resolve()), "--ours-only", str(path), "--result", str(out)]
    cmd += ["--threads", str(threads)] if threads is not None else []
    cmd += ["--workers", str(workers)]
    run, wall, cpu, load, peak = timed(cmd + (["--profile"] if profile else []), work)
    if run.returncode != 0:
        raise SystemExit(f"gnssframework failed:\n{run.stderr[-3000:]}")
    if profile:
        print(run.stderr[-6000:])
    return {"wall_s": wall, "cpu_s": cpu, "load": load, "peak_mib": peak, **json.loads(out.read_text())}


def _static_errors_m(fixes: np.ndarray, _t_s: np.ndarray) -> tuple[float, float]:
    """`errors_m` of ``(F, 3)`` latitudes, longitudes and heights (the static receiver: time unused)."""
    return errors_m(fixes[:, 0], fixes[:, 1], fixes[:, 2])


def run_gnss_sdr(
    path: Path,
    work: Path,
    tow0: float,
    *,
    name: str = "gnss-sdr",
    acquisition: dict[str, object] | None = None,
    tracking: dict[str, object] | None = None,
    errors: Callable[[np.ndarray, np.ndarray], tuple[float, float]] | None = None,
) -> dict:
    """GNSS-SDR on ``path`` (its config, output folder and log under ``work``, named
    ``name``; ``acquisition`` and ``tracking`` override the benchmarks' settings,
    `gnss_sdr_config`): wall and CPU time, load, peak memory, exit code, the PRNs its
    channels tracked and, with fixes, the first fix's time into the file, the fixes, the
    satellites used (median, least, most) and ``errors(fixes, t_s)``, horizontal and
    vertical RMS error of the ``(F, 3)`` latitudes, longitudes and heights at file times
    ``t_s`` (default: against gps-sdr-sim's static position, `errors_m`)."""
    exe = shutil.which("gnss-sdr")
    out = work / name
    out.mkdir(exist_ok=True)
    conf = work / f"{name}.conf"
    conf.write_text(
        gnss_sdr_config(
            path,
            FS_HZ,
            out,
            channels=12,
            item_type="ishort",
            output_rate_ms=1000,
            display_rate_ms=1000,
            pvt_models=True,
            acquisition=acquisition,
            tracking=tracking,
        )
    )
    run, wall, cpu, load, peak = timed([exe or "gnss-sdr", f"--config_file={conf}"], out)
    text = run.stdout + run.stderr
    (work / f"{name}.log").write_text(text)
    fixes = [m.groups() for m in _POSITION.finditer(text)]
    found = {
        "wall_s": wall,
        "cpu_s": cpu,
        "load": load,
        "peak_mib": peak,
        "exit": run.returncode,
        "channels": sorted({int(p) for p in _TRACKED.findall(text)}),
    }
    if fixes:
        f = np.array(fixes, dtype=float)
        t_s = (f[:, 0] * 3600 + f[:, 1] * 60 + f[:, 2] + LEAP_S - tow0 % 86400) % 86400
        found |= {
            "first_fix_s": float(t_s[0]),
            "fixes": len(f),
            "sats_median": float(np.median(f[:, 3])),
            "sats": (int(f[:, 3].min()), int(f[:, 3].max())),
            "errors_m": (errors or _static_errors_m)(f[:, 4:7], t_s),
        }
    return found


def line(name: str, r: dict, seconds: float) -> str:
    fix = (
        (
            f"first fix {r['first_fix_s']:5.1f} s, {r['fixes']:3d} fixes, {r['sats_median']:.0f} sats, H/V RMS "
            f"{r['errors_m'][0]:5.1f}/{r['errors_m'][1]:5.1f} m"
        )
        if "fixes" in r
        else "no fix"
    )
    startup = f" (start-up {r['startup_cpu_s']:.1f})" if "startup_cpu_s" in r else ""
    return (
        f"{name:13s} wall {r['wall_s']:6.1f} s  CPU {r['cpu_s']:6.1f} s{startup}  peak {r['peak_mib']:4.0f} MiB  "
        f"x{seconds / r['wall_s']:5.2f} "
        f"real time  load {r['load']:4.1f}  {len(r['channels']):2d} channels  {fix}"
    )


def uptime() -> str:
    """The load averages over 1, 5 and 15 minutes, as ``uptime`` prints them."""
    return "load average: " + ", ".join(f"{x:.2f}" for x in os.getloadavg())


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=60.0, help="length of the simulated recording")
    ap.add_argument("--cn0", type=float, default=45.0, help="C/N0 of the noise added (dB-Hz)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--repeat", type=int, default=3, help="rounds of both receivers, alternating which goes first")
    ap.add_argument("--work", type=Path, help="folder for the recording (kept and reused); default: a temporary one")
    ap.add_argument("--profile", action="store_true", help="print gnssframework's cProfile (slows it)")
    ap.add_argument("--threads", type=int, help="gnssframework's threads (receive --threads; default: the cores)")
    ap.add_argument(
        "--workers",
        default="auto",
        help="gnssframework's tracking processes (receive --workers: a number, or auto, the default: the cores)",
    )
    ap.add_argument("--ours-only", type=Path, help=argparse.SUPPRESS)
    ap.add_argument("--result", type=Path, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.ours_only:
        workers = args.workers if args.workers == "auto" else int(args.workers)
        ours_in_this_process(args.ours_only, args.result, args.profile, args.threads, workers)
        return 0
    if shutil.which("gnss-sdr") is None or not (SIM_DIR / "build.sh").exists():
        print("needs gnss-sdr on PATH and ../shared/tools/gps-sdr-sim beside the repository", file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory() as tmp:
        work = args.work or Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        try:
            path, tow0 = simulate(work, args.seconds, args.cn0, args.seed)
        except (subprocess.CalledProcessError, OSError) as exc:
            print(f"cannot build or run gps-sdr-sim from {SIM_DIR}: {exc}", file=sys.stderr)
            return 2
        print(
            f"{args.seconds:.0f} s gps-sdr-sim at {FS_HZ / 1e6:.1f} MHz, {args.cn0:g} dB-Hz; {os.cpu_count()} cores; "
            f"before: {uptime()}"
        )
        rows = []
        for k in range(args.repeat):
            order = ("ours", "gnss-sdr") if k % 2 == 0 else ("gnss-sdr", "ours")
            round_ = {}
            for who in order:
                round_[who] = (
                    run_ours(path, work, threads=args.threads, workers=args.workers)
                    if who == "ours"
                    else run_gnss_sdr(path, work, tow0)
                )
                print(line("gnssframework" if who == "ours" else "GNSS-SDR", round_[who], args.seconds), flush=True)
            rows.append(round_)
        wall = np.array([r["gnss-sdr"]["wall_s"] / r["ours"]["wall_s"] for r in rows])
        cpu = np.array([r["gnss-sdr"]["cpu_s"] / r["ours"]["cpu_s"] for r in rows])
        print(
            f"GNSS-SDR / gnssframework (above 1: gnssframework faster), per round: wall time "
            f"{', '.join(f'{x:.2f}' for x in wall)}, CPU time {', '.join(f'{x:.2f}' for x in cpu)}; median: wall "
            f"{np.median(wall):.2f}, CPU {np.median(cpu):.2f}; after: {uptime()}"
        )
        if args.profile:
            print("\nwhere gnssframework's time goes (cProfile, a separate untimed run):")
            run_ours(path, work, profile=True, threads=args.threads, workers=args.workers)
    return 0


if __name__ == "__main__":
    sys.exit(main())
