"""Correlation and tracking speed on samples, as channel-seconds of signal per wall second.

    python benchmarks/sample_tracking.py [--seconds 4] [--channels 8] [--repeat 2] [--threads 2] [--correlation-only]

At 2.6, 4 and 16.3676 MHz (gps-sdr-sim's default rate, the 4 MHz PocketSDR rate, the rate
of reference 002's recording), in the same run:

- correlation alone in channel-MHz per core (channel-samples per CPU second of the process,
  over 1e6) and per wall second, as the tracker calls it (10 ms whole periods of every
  channel per call) on 1, 2 and ``--threads`` threads (``--correlation-only``: these rows
  alone);
- correlation alone: the compiled multi-channel kernel against its NumPy reference and
  against `correlate_if` (the per-channel NumPy path the issue timed at 1.9 ms per channel
  per millisecond at 16.3676 MHz);
- tracking: acquisition excluded, `SampleTracker` with the ``scalar`` filter on a
  generated recording of ``--channels`` satellites at 45 dB-Hz;
- GNSS-SDR, where ``gnss-sdr`` is installed and ``../shared/tools/gps-sdr-sim`` is beside
  the repository: the same number of channels on the same gps-sdr-sim file (``5 *
  --seconds`` long) at each rate, the whole run (acquisition, tracking; GNSS-SDR also
  decodes telemetry and solves PVT) of both, each in its own process, interleaved
  (ours, GNSS-SDR, ours, GNSS-SDR ...) with the load average beside every number, wall
  and CPU time;
- 8 channels at 16.3676 MHz on ONE core: our tracking of that file (acquisition
  excluded) in a process pinned to one CPU (``os.sched_setaffinity``) with one numba and
  one BLAS thread, as a fraction of real time.

Wall time over signal time below 1 is faster than real time for that many channels. The
machine may be shared: other jobs slow every row, so compare the rows of one run, and
read the CPU times (which the load inflates less) beside the wall times.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from gnssframework import registry
from gnssframework.receiver.acquisition.report import acquire_recording
from gnssframework.receiver.channels import SampleTracker, tracking_config
from gnssframework.receiver.channels.correlator import correlate_channels
from gnssframework.receiver.frontend import SatelliteSignal, open_recording, synthesize_samples
from gnssframework.signal.codes import ca_code
from gnssframework.signal.if_samples import IfSignal, correlate_if

from gnss_sdr_config import gnss_sdr_config  # beside this script

RATES_HZ = (2.6e6, 4e6, 16.3676e6)
ROOT = Path(__file__).resolve().parents[1]
SIM_DIR = ROOT.parent / "shared" / "tools" / "gps-sdr-sim"


def _best(fn, repeat: int = 3) -> float:
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times)


def correlation_rates(fs: float, channels: int, rng: np.random.Generator) -> dict[str, float]:
    """Channel-seconds per second of one 1 ms correlation of every channel."""
    n = int(fs * 1e-3)
    x = (rng.standard_normal(n + 100) + 1j * rng.standard_normal(n + 100)).astype(np.complex64)
    codes = np.stack([ca_code(p) for p in range(1, channels + 1)]).astype(np.float32)
    starts, counts = rng.integers(0, 100, channels), np.full(channels, n)
    args = (
        starts,
        counts,
        rng.uniform(0, 1, channels),
        np.full(channels, 1.023e6 / fs),
        rng.uniform(0, 1, channels),
        rng.uniform(-5e3, 5e3, channels) / fs,
        codes,
        np.array([-0.5, 0.0, 0.5]),
    )
    correlate_channels(x, *args, backend="numba")  # compile / load
    loops = 50
    compiled = _best(lambda: [correlate_channels(x, *args, backend="numba") for _ in range(loops)]) / loops
    reference = _best(lambda: correlate_channels(x, *args, backend="numpy"), 1)
    sig = IfSignal(x.astype(np.complex128), fs, 0.0, 1.0, True)
    old = _best(
        lambda: [
            correlate_if(sig, p, np.array(0.3), np.array(1.023e6), np.array(1000.0), np.array(0.0), 1e-3)
            for p in range(1, channels + 1)
        ],
        1,
    )
    return {
        name: channels * 1e-3 / t
        for name, t in (("compiled", compiled), ("numpy reference", reference), ("correlate_if", old))
    }


def channel_mhz_per_core(
    fs: float, channels: int, rng: np.random.Generator, threads: int, coherent_ms: int = 10, loops: int = 40
) -> tuple[float, float]:
    """Correlation alone as the tracker calls it (`correlate_periods`: ``coherent_ms`` whole
    code periods of every channel per call, int8 I/Q as recorded, E/P/L), on ``threads``
    threads: (channel-MHz per CPU second, channel-MHz per wall second), i.e. channel-samples
    correlated per second of the process's CPU time (all its threads) or of wall time, over 1e6."""
    from gnssframework.receiver.channels.correlator import code_tables, correlate_periods

    n = int(fs * 1e-3 * (coherent_ms + 1)) + 400
    comps = rng.integers(-40, 40, 2 * n).astype(np.int8)
    codes = np.stack([ca_code(p) for p in range(1, channels + 1)]).astype(np.float32)
    taps = np.array([-0.5, 0.0, 0.5])
    args = (
        rng.integers(0, 300, channels),
        np.full(channels, coherent_ms),
        rng.uniform(-0.5, 0.5, channels),
        1.023e6 / fs * (1 + rng.uniform(-3e-6, 3e-6, channels)),
        rng.uniform(0, 1, channels),
        rng.uniform(-5e3, 5e3, channels) / fs,
        codes,
        taps,
    )
    tables = code_tables(codes, taps)
    correlate_periods(comps, *args, iq=True, tables=tables, threads=threads)  # compile / load
    best_cpu = best_wall = 0.0
    for _ in range(3):
        w, c = time.perf_counter(), time.process_time()
        counted = 0
        for _ in range(loops):
            counted += int(correlate_periods(comps, *args, iq=True, tables=tables, threads=threads)[1].sum())
        w, c = time.perf_counter() - w, time.process_time() - c
        best_cpu, best_wall = max(best_cpu, counted / c / 1e6), max(best_wall, counted / w / 1e6)
    return best_cpu, best_wall


def tracking_rate(path: Path, channels: int, duration_s: float | None = None) -> tuple[float, float, int]:
    """(channel-seconds per second, wall seconds, channels) of tracking a recording; the
    CPU seconds of the run in ``tracking_rate.cpu_s``."""
    rec = open_recording(path)
    acq = registry.create("acquisition", "pcps")
    detected = [r for r in acquire_recording(rec, acq) if r.detected]
    found = sorted(detected, key=lambda r: -r.test_statistic)[:channels]  # the strongest, as GNSS-SDR's channels
    tracker = SampleTracker(rec, tracking_config(), acq)
    tracker.run(found, 0.05)  # warm: compiled kernels loaded
    t, c = time.perf_counter(), time.process_time()
    result = tracker.run(found, duration_s)
    wall = time.perf_counter() - t
    tracking_rate.cpu_s = time.process_time() - c
    return len(found) * result.duration_s / wall, wall, len(found)


def boc_cost(
    fs: float, seconds: float, channels: int, folder: Path, rng: np.random.Generator, repeat: int = 2
) -> dict[str, tuple[float, float]]:
    """CPU and wall seconds per channel-second of tracking ``channels`` GPS L1 C/A and as
    many Galileo E1-B (BOC(1,1) replica: code times sub-carrier, two table entries a chip)
    channels on generated recordings at ``fs`` (45 dB-Hz, the same tracking config for
    both: 0.2-chip spacing, one code period a coherent interval: 1 ms on C/A, 4 ms on E1-B);
    the best of ``repeat`` runs, acquisition excluded."""
    from gnssframework.receiver.frontend import write_recording
    from gnssframework.signal.galileo_e1 import GALILEO_E1B_BOC11
    from gnssframework.signal.gps_l1ca import GPS_L1CA

    out = {}
    for spec in (GPS_L1CA, GALILEO_E1B_BOC11):
        sats = [
            SatelliteSignal(
                p,
                45.0,
                float(rng.uniform(-4000, 4000)),
                float(rng.uniform(0, spec.code_length_chips)),
                float(rng.uniform(0, 2 * np.pi)),
                first_bit_code_period=0,
                signal=spec,
            )
            for p in range(1, channels + 1)
        ]
        x = synthesize_samples(sats, seconds, fs, 0.0, rng)
        rec = open_recording(
            write_recording(folder / f"{spec.name}_{fs:.0f}.sigmf-data", x, "ci16_le", fs, 0.0, scale=300.0)
        )
        del x
        acq = registry.create("acquisition", "pcps")
        found = [r for r in acquire_recording(rec, acq, prns=tuple(range(1, channels + 1)), signal=spec) if r.detected]
        tracker = SampleTracker(rec, tracking_config(early_late_spacing_chips=0.2, coherent_ms=1), acq, signal=spec)
        tracker.run(found, 0.05)  # warm: compiled kernels loaded
        best = None
        for _ in range(repeat):
            t, c = time.perf_counter(), time.process_time()
            result = tracker.run(found)
            wall, cpu = time.perf_counter() - t, time.process_time() - c
            per = len(found) * result.duration_s
            if best is None or cpu / per < best[0]:
                best = (cpu / per, wall / per)
        out[spec.name] = best + (len(found),)
    return out


def generated(fs: float, seconds: float, channels: int, folder: Path, rng: np.random.Generator) -> Path:
    """``channels`` satellites at 45 dB-Hz with data bits, written in 0.25 s chunks so memory
    stays bounded (each chunk draws its own bits; their edges stay on the same code epochs)."""
    from gnssframework.receiver.frontend.sigmf_meta import write_sigmf_meta
    from gnssframework.signal.constants import CA_CHIP_RATE_HZ, L1_FREQ_HZ

    base = [
        SatelliteSignal(
            p,
            45.0,
            float(rng.uniform(-4000, 4000)),
            float(rng.uniform(0, 1023)),
            float(rng.uniform(0, 2 * np.pi)),
            first_bit_code_period=int(rng.integers(0, 20)),
        )
        for p in range(1, channels + 1)
    ]
    path = folder / f"gen_{fs:.0f}.bin"
    source = registry.create("sample_source", "ci8")
    chunk = 0.25
    with open(path, "wb") as fh:
        for k in range(int(round(seconds / chunk))):
            t = k * chunk
            sats = []
            for b in base:
                chips = b.code_phase_chips + CA_CHIP_RATE_HZ * (1 + b.doppler_hz / L1_FREQ_HZ) * t
                first_epoch = int(np.ceil(chips / 1023)) - 1  # index of the chunk's first code epoch
                sats.append(
                    SatelliteSignal(
                        b.prn,
                        b.cn0_dbhz,
                        b.doppler_hz,
                        chips % 1023,
                        b.carrier_phase_rad + 2 * np.pi * b.doppler_hz * t,
                        first_bit_code_period=(b.first_bit_code_period - first_epoch) % 20,
                    )
                )
            fh.write(source.encode(8.0 * synthesize_samples(sats, chunk, fs, 0.0, rng)))
    write_sigmf_meta(path.with_suffix(".sigmf-meta"), format="ci8", sigmf_datatype="ci8", sample_rate_hz=fs, if_hz=0.0)
    return path


def gps_sdr_sim_file(fs: float, seconds: float, folder: Path) -> Path | None:
    if not (SIM_DIR / "build.sh").exists():
        return None
    binary = (
        subprocess.run([str(SIM_DIR / "build.sh"), str(folder / "bin")], check=True, capture_output=True, text=True)
        .stdout.strip()
        .splitlines()[-1]
    )
    out = folder / f"sim_{fs:.0f}.bin"
    subprocess.run(
        [
            binary,
            "-e",
            str(SIM_DIR / "brdc0010.22n"),
            "-l",
            "35.681298,139.766247,10.0",
            "-d",
            f"{seconds}",
            "-b",
            "8",
            "-s",
            f"{fs:.0f}",
            "-o",
            str(out),
        ],
        check=True,
        capture_output=True,
        cwd=folder,
    )
    return out


def gnss_sdr_run(path: Path, fs: float, channels: int, folder: Path) -> tuple[float, float] | None:
    """(wall, CPU) seconds of GNSS-SDR's whole run on ``path``, or None where it did not track."""
    exe = shutil.which("gnss-sdr")
    if exe is None:
        return None
    conf = folder / f"gnss-sdr_{fs:.0f}.conf"
    conf.write_text(gnss_sdr_config(path, fs, folder, channels=channels))
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    run = subprocess.run([exe, f"--config_file={conf}"], capture_output=True, text=True, cwd=folder)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    text = run.stdout + run.stderr
    if run.returncode != 0 or "Error" in text or "Tracking of GPS L1 C/A signal started" not in text:
        print(f"  gnss-sdr did not track (exit {run.returncode}): {text.strip().splitlines()[-3:]}")
        return None
    return wall, (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)


def worker(path: Path, fs: float, channels: int, with_acquisition: bool) -> dict[str, float]:
    """Our run on a gps-sdr-sim file in this process: (wall, CPU) seconds of acquisition
    plus tracking (or tracking alone), the compiled kernels loaded first."""
    from gnssframework.receiver.frontend.sigmf_meta import write_sigmf_meta

    meta = path.with_suffix(".sigmf-meta")
    if not meta.exists():
        write_sigmf_meta(meta, format="ci8", sigmf_datatype="ci8", sample_rate_hz=fs, if_hz=0.0)
    rec = open_recording(path)
    acq = registry.create("acquisition", "pcps")
    found = sorted([r for r in acquire_recording(rec, acq) if r.detected], key=lambda r: -r.test_statistic)[:channels]
    tracker = SampleTracker(rec, tracking_config(), acq)
    tracker.run(found, 0.05)  # warm: compiled kernels loaded
    wall0, cpu0 = time.perf_counter(), time.process_time()
    if with_acquisition:
        found = sorted([r for r in acquire_recording(rec, acq) if r.detected], key=lambda r: -r.test_statistic)[
            :channels
        ]
    result = tracker.run(found)
    return {
        "wall": time.perf_counter() - wall0,
        "cpu": time.process_time() - cpu0,
        "signal": result.duration_s,
        "channels": len(found),
    }


def run_worker(path: Path, fs: float, channels: int, with_acquisition: bool, one_cpu: int | None = None) -> dict:
    """`worker` in a fresh process (pinned to CPU ``one_cpu`` with one thread, if given)."""
    env = dict(os.environ)
    if one_cpu is not None:
        env.update(NUMBA_NUM_THREADS="1", OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1")
    cmd = [sys.executable, __file__, "--worker", str(path), "--fs", str(fs), "--channels", str(channels)]
    if with_acquisition:
        cmd.append("--with-acquisition")
    pin = (lambda: os.sched_setaffinity(0, {one_cpu})) if one_cpu is not None else None
    out = subprocess.run(cmd, check=True, capture_output=True, text=True, env=env, preexec_fn=pin)
    return json.loads(out.stdout.strip().splitlines()[-1])


def _load() -> str:
    return f"load {os.getloadavg()[0]:.1f}"


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=4.0, help="signal length of the tracking runs")
    ap.add_argument("--channels", type=int, default=8)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--repeat", type=int, default=2, help="interleaved runs of ours and GNSS-SDR per rate")
    ap.add_argument(
        "--threads",
        type=int,
        default=2,
        help="threads of the correlation rows (besides 1 and 2), and of the tracking runs (default %(default)s)",
    )
    ap.add_argument("--correlation-only", action="store_true", help="the channel-MHz rows only")
    ap.add_argument("--worker", type=Path, help=argparse.SUPPRESS)
    ap.add_argument("--fs", type=float, help=argparse.SUPPRESS)
    ap.add_argument("--with-acquisition", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--boc-only", action="store_true", help="only the BOC against C/A cost rows")
    args = ap.parse_args(argv)
    from gnssframework.backend import set_threads

    set_threads(args.threads)
    if args.worker is not None:
        print(json.dumps(worker(args.worker, args.fs, args.channels, args.with_acquisition)))
        return
    rng = np.random.default_rng(args.seed)
    print(f"{_load()} at start, {os.cpu_count()} cores; {args.channels} channels")
    boc_rows(args, rng)
    if args.boc_only:
        return
    print(
        "\ncorrelation alone, channel-MHz per core (per CPU second of the process) and per wall second, "
        "10 ms whole periods per call as the tracker after bit sync"
    )
    for fs in RATES_HZ:
        cells = []
        for threads in sorted({1, 2, args.threads}):
            cpu, wall = channel_mhz_per_core(fs, args.channels, rng, threads)
            cells.append(f"{threads} thread{'s' if threads > 1 else ''}: {cpu:5.0f} per core, {wall:5.0f} per wall s")
        print(f"{fs / 1e6:9.4f} MHz  " + "; ".join(cells) + f"  ({_load()})")
    if args.correlation_only:
        return
    print("\ncorrelation, channel-seconds per second (x real time per channel)")
    print(f"{'rate MHz':>9s} {'compiled':>10s} {'numpy ref':>10s} {'correlate_if':>13s} {'compiled/if':>12s}")
    for fs in RATES_HZ:
        r = correlation_rates(fs, args.channels, rng)
        print(
            f"{fs / 1e6:9.4f} {r['compiled']:10.1f} {r['numpy reference']:10.2f} {r['correlate_if']:13.2f} "
            f"{r['compiled'] / r['correlate_if']:12.0f}  ({_load()})"
        )
    print(
        f"\ntracking ({args.seconds} s generated, scalar: 1 ms until bit sync, then 10 ms), channel-seconds per "
        f"second; real time for {args.channels} channels = {args.channels}"
    )
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for fs in RATES_HZ:
            rate, wall, n = tracking_rate(generated(fs, args.seconds, args.channels, folder, rng), args.channels)
            per_core = n * fs * args.seconds / tracking_rate.cpu_s / 1e6
            print(
                f"{fs / 1e6:9.4f} MHz: {rate:6.1f} channel-s/s ({n} channels, {wall:.1f} s wall for "
                f"{args.seconds} s: {wall / args.seconds:.2f} of real time; {per_core:.0f} channel-MHz per core, "
                f"tracking included; {_load()})"
            )
        if not SIM_DIR.exists():
            print("\ngps-sdr-sim rows: skipped (needs ../shared/tools/gps-sdr-sim)")
            return
        secs = args.seconds * 5
        have_peer = shutil.which("gnss-sdr") is not None
        print(
            f"\nsame gps-sdr-sim file ({secs:.0f} s, int8 I/Q), whole run: wall and CPU time over signal time"
            + ("" if have_peer else " (GNSS-SDR skipped: gnss-sdr is not on PATH)")
        )
        sims = {}
        for fs in RATES_HZ:
            sims[fs] = sim = gps_sdr_sim_file(fs, secs, folder)
            ours, theirs = [], []
            for _ in range(args.repeat):
                r = run_worker(sim, fs, args.channels, True)
                ours.append((r["wall"] / r["signal"], r["cpu"] / r["signal"], os.getloadavg()[0]))
                print(
                    f"  {fs / 1e6:7.4f} MHz gnssframework: wall {ours[-1][0]:.3f}, CPU {ours[-1][1]:.3f} "
                    f"({r['channels']} channels; {_load()})"
                )
                if have_peer:
                    g = gnss_sdr_run(sim, fs, args.channels, folder)
                    if g is not None:
                        theirs.append((g[0] / secs, g[1] / secs, os.getloadavg()[0]))
                        print(
                            f"  {fs / 1e6:7.4f} MHz GNSS-SDR:      wall {theirs[-1][0]:.3f}, CPU "
                            f"{theirs[-1][1]:.3f} ({_load()})"
                        )
            best_ours = min(o[0] for o in ours)
            line = f"{fs / 1e6:7.4f} MHz: gnssframework best wall {best_ours:.3f} of real time"
            if theirs:
                best_theirs = min(t[0] for t in theirs)
                cpu_ratio = min(t[1] for t in theirs) / min(o[1] for o in ours)
                line += (
                    f", GNSS-SDR {best_theirs:.3f}; GNSS-SDR time / ours: wall {best_theirs / best_ours:.2f}, "
                    f"CPU {cpu_ratio:.2f} (above 1: ours faster)"
                )
            print(line)
        cpu = sorted(os.sched_getaffinity(0))[-1]
        fs = RATES_HZ[-1]
        runs = [run_worker(sims[fs], fs, args.channels, False, one_cpu=cpu) for _ in range(args.repeat)]
        best = min(runs, key=lambda r: r["wall"])
        print(
            f"\n{best['channels']} channels at {fs / 1e6:.4f} MHz on ONE core (CPU {cpu}, one thread), tracking: "
            f"wall {best['wall'] / best['signal']:.3f} of real time, CPU {best['cpu'] / best['signal']:.3f} "
            f"(best of {len(runs)}; {_load()})"
        )


def boc_kernel_cost(fs: float, channels: int, rng: np.random.Generator) -> tuple[float, float]:
    """CPU seconds per channel-second of the compiled correlator alone (4 ms of samples,
    three taps) with C/A code tables and with Galileo E1-B BOC(1,1) sub-chip tables
    (`replica_codes`, phases, steps and offsets in sub-chips): what the sub-carrier
    itself costs per sample, without the per-interval work."""
    from gnssframework.receiver.channels.correlator import replica_codes, to_table_units
    from gnssframework.signal.galileo_e1 import GALILEO_E1B_BOC11
    from gnssframework.signal.gps_l1ca import GPS_L1CA

    n = int(fs * 4e-3)
    x = (rng.standard_normal(n + 100) + 1j * rng.standard_normal(n + 100)).astype(np.complex64)
    starts, counts = rng.integers(0, 100, channels), np.full(channels, n)
    carrier = (rng.uniform(0, 1, channels), rng.uniform(-5e3, 5e3, channels) / fs)
    out = []
    for spec in (GPS_L1CA, GALILEO_E1B_BOC11):
        codes = replica_codes(spec, range(1, channels + 1))
        args = (
            starts,
            counts,
            to_table_units(rng.uniform(0, 1, channels), spec),
            to_table_units(np.full(channels, 1.023e6 / fs), spec),
            *carrier,
            codes,
            to_table_units(np.array([-0.1, 0.0, 0.1]), spec),
        )
        correlate_channels(x, *args, backend="numba")  # compile / load
        loops = 20
        c = time.process_time()
        for _ in range(loops):
            correlate_channels(x, *args, backend="numba")
        out.append((time.process_time() - c) / (loops * channels * 4e-3))
    return out[0], out[1]


def boc_rows(args: argparse.Namespace, rng: np.random.Generator) -> None:
    """Issue 39: a BOC channel costs at most twice a C/A channel of the same rate."""
    seconds = min(args.seconds, 2.0)
    print(f"\nBOC(1,1) against C/A, correlation alone ({args.channels} channels, 4 ms), CPU seconds per channel-second")
    for fs in (4e6, 16.3676e6):
        ca, boc = boc_kernel_cost(fs, args.channels, rng)
        print(f"{fs / 1e6:9.4f} MHz: C/A {ca:.4f}, E1-B BOC(1,1) {boc:.4f}; BOC / C/A ratio {boc / ca:.2f} ({_load()})")
    print(
        f"\nBOC(1,1) against C/A, tracking {seconds} s generated, {args.channels} channels each, "
        "CPU (wall) seconds per channel-second"
    )
    with tempfile.TemporaryDirectory() as tmp:
        for fs in (4e6, 16.3676e6):
            r = boc_cost(fs, seconds, args.channels, Path(tmp), rng, args.repeat)
            ca, boc = r["gps-l1ca"], r["galileo-e1b-boc11"]
            print(
                f"{fs / 1e6:9.4f} MHz: C/A {ca[0]:.4f} ({ca[1]:.4f}) on {ca[2]}, E1-B BOC(1,1) {boc[0]:.4f} "
                f"({boc[1]:.4f}) on {boc[2]}; BOC / C/A CPU ratio {boc[0] / ca[0]:.2f} ({_load()})"
            )


if __name__ == "__main__":
    sys.exit(main())
