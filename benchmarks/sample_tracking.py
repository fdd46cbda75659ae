"""Correlation and tracking speed on samples, as channel-seconds of signal per wall second.

    python benchmarks/sample_tracking.py [--seconds 4] [--channels 8]

At 2.6, 4 and 16.3676 MHz (gps-sdr-sim's default rate, the 4 MHz PocketSDR rate, the rate
of reference 002's recording), in the same run:

- correlation alone: the compiled multi-channel kernel against its NumPy reference and
  against `correlate_if` (the per-channel NumPy path the issue timed at 1.9 ms per channel
  per millisecond at 16.3676 MHz);
- tracking: acquisition excluded, `SampleTracker` with the ``scalar`` filter on a
  generated recording of ``--channels`` satellites at 45 dB-Hz;
- GNSS-SDR, where ``gnss-sdr`` is installed and ``../shared/tools/gps-sdr-sim`` is beside
  the repository: the same number of channels on a gps-sdr-sim file at 2.6 and 4 MHz,
  wall time of the whole run against the library's on the same file.

Tracking rows also give the wall time as a fraction of the signal's duration: below 1 is
faster than real time for that many channels. The machine's load is printed: other jobs
on the same cores slow every row alike, so compare rows of one run.
"""

from __future__ import annotations

import argparse
import os
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
    args = (starts, counts, rng.uniform(0, 1, channels), np.full(channels, 1.023e6 / fs), rng.uniform(0, 1, channels),
            rng.uniform(-5e3, 5e3, channels) / fs, codes, np.array([-0.5, 0.0, 0.5]))
    correlate_channels(x, *args, backend="numba")  # compile / load
    loops = 50
    compiled = _best(lambda: [correlate_channels(x, *args, backend="numba") for _ in range(loops)]) / loops
    reference = _best(lambda: correlate_channels(x, *args, backend="numpy"), 1)
    sig = IfSignal(x.astype(np.complex128), fs, 0.0, 1.0, True)
    old = _best(lambda: [correlate_if(sig, p, np.array(0.3), np.array(1.023e6), np.array(1000.0), np.array(0.0), 1e-3)
                         for p in range(1, channels + 1)], 1)
    return {name: channels * 1e-3 / t for name, t in
            (("compiled", compiled), ("numpy reference", reference), ("correlate_if", old))}


def tracking_rate(path: Path, channels: int, duration_s: float | None = None) -> tuple[float, float, int]:
    """(channel-seconds per second, wall seconds, channels) of tracking a recording."""
    rec = open_recording(path)
    acq = registry.create("acquisition", "pcps")
    detected = [r for r in acquire_recording(rec, acq) if r.detected]
    found = sorted(detected, key=lambda r: -r.test_statistic)[:channels]  # the strongest, as GNSS-SDR's channels
    tracker = SampleTracker(rec, tracking_config(), acq)
    tracker.run(found, 0.05)  # warm: compiled kernels loaded
    t = time.perf_counter()
    result = tracker.run(found, duration_s)
    wall = time.perf_counter() - t
    return len(found) * result.duration_s / wall, wall, len(found)


def generated(fs: float, seconds: float, channels: int, folder: Path, rng: np.random.Generator) -> Path:
    """``channels`` satellites at 45 dB-Hz with data bits, written in 0.25 s chunks so memory
    stays bounded (each chunk draws its own bits; their edges stay on the same code epochs)."""
    from gnssframework.receiver.frontend.sigmf_meta import write_sigmf_meta
    from gnssframework.signal.constants import CA_CHIP_RATE_HZ, L1_FREQ_HZ

    base = [SatelliteSignal(p, 45.0, float(rng.uniform(-4000, 4000)), float(rng.uniform(0, 1023)),
                            float(rng.uniform(0, 2 * np.pi)), first_bit_code_period=int(rng.integers(0, 20)))
            for p in range(1, channels + 1)]
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
                sats.append(SatelliteSignal(b.prn, b.cn0_dbhz, b.doppler_hz, chips % 1023,
                                            b.carrier_phase_rad + 2 * np.pi * b.doppler_hz * t,
                                            first_bit_code_period=(b.first_bit_code_period - first_epoch) % 20))
            fh.write(source.encode(8.0 * synthesize_samples(sats, chunk, fs, 0.0, rng)))
    write_sigmf_meta(path.with_suffix(".sigmf-meta"), format="ci8", sigmf_datatype="ci8", sample_rate_hz=fs,
                     if_hz=0.0)
    return path


GNSS_SDR_CONF = """[GNSS-SDR]
GNSS-SDR.internal_fs_sps={fs:.0f}
SignalSource.implementation=File_Signal_Source
SignalSource.filename={path}
SignalSource.item_type=ibyte
SignalSource.sampling_frequency={fs:.0f}
SignalSource.samples=0
SignalSource.repeat=false
SignalConditioner.implementation=Signal_Conditioner
DataTypeAdapter.implementation=Ibyte_To_Complex
InputFilter.implementation=Pass_Through
InputFilter.item_type=gr_complex
Resampler.implementation=Pass_Through
Resampler.item_type=gr_complex
Channels_1C.count={channels}
Channels.in_acquisition=1
Channel.signal=1C
Acquisition_1C.implementation=GPS_L1_CA_PCPS_Acquisition
Acquisition_1C.item_type=gr_complex
Acquisition_1C.coherent_integration_time_ms=1
Acquisition_1C.pfa=0.01
Acquisition_1C.doppler_max=5000
Acquisition_1C.doppler_step=250
Acquisition_1C.max_dwells=1
Tracking_1C.implementation=GPS_L1_CA_DLL_PLL_Tracking
Tracking_1C.item_type=gr_complex
Tracking_1C.pll_bw_hz=30.0
Tracking_1C.dll_bw_hz=2.0
Tracking_1C.early_late_space_chips=0.5
TelemetryDecoder_1C.implementation=GPS_L1_CA_Telemetry_Decoder
Observables.implementation=Hybrid_Observables
PVT.implementation=RTKLIB_PVT
PVT.positioning_mode=Single
PVT.output_rate_ms=100
PVT.display_rate_ms=500
PVT.output_path={out}
"""


def gps_sdr_sim_file(fs: float, seconds: float, folder: Path) -> Path | None:
    if not (SIM_DIR / "build.sh").exists():
        return None
    binary = subprocess.run([str(SIM_DIR / "build.sh"), str(folder / "bin")], check=True, capture_output=True,
                            text=True).stdout.strip().splitlines()[-1]
    out = folder / f"sim_{fs:.0f}.bin"
    subprocess.run([binary, "-e", str(SIM_DIR / "brdc0010.22n"), "-l", "35.681298,139.766247,10.0", "-d",
                    f"{seconds}", "-b", "8", "-s", f"{fs:.0f}", "-o", str(out)], check=True, capture_output=True,
                   cwd=folder)
    return out


def gnss_sdr_wall(path: Path, fs: float, channels: int, folder: Path) -> float | None:
    exe = shutil.which("gnss-sdr")
    if exe is None:
        return None
    conf = folder / f"gnss-sdr_{fs:.0f}.conf"
    conf.write_text(GNSS_SDR_CONF.format(fs=fs, path=path, channels=channels, out=folder))
    t = time.perf_counter()
    run = subprocess.run([exe, f"--config_file={conf}"], capture_output=True, text=True, cwd=folder)
    wall = time.perf_counter() - t
    text = run.stdout + run.stderr
    if run.returncode != 0 or "Error" in text or "Tracking of GPS L1 C/A signal started" not in text:
        print(f"  gnss-sdr did not track (exit {run.returncode}): {text.strip().splitlines()[-3:]}")
        return None
    return wall


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=4.0, help="signal length of the tracking runs")
    ap.add_argument("--channels", type=int, default=8)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    rng = np.random.default_rng(args.seed)
    print(f"load average {os.getloadavg()[0]:.1f} at start, {os.cpu_count()} cores; {args.channels} channels")
    print("\ncorrelation, channel-seconds per second (x real time per channel)")
    print(f"{'rate MHz':>9s} {'compiled':>10s} {'numpy ref':>10s} {'correlate_if':>13s} {'compiled/if':>12s}")
    for fs in RATES_HZ:
        r = correlation_rates(fs, args.channels, rng)
        print(f"{fs / 1e6:9.4f} {r['compiled']:10.1f} {r['numpy reference']:10.2f} {r['correlate_if']:13.2f} "
              f"{r['compiled'] / r['correlate_if']:12.0f}")
    print(f"\ntracking ({args.seconds} s generated, scalar: 1 ms until bit sync, then 10 ms), channel-seconds per "
          f"second; real time for "
          f"{args.channels} channels = {args.channels}")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for fs in RATES_HZ:
            rate, wall, n = tracking_rate(generated(fs, args.seconds, args.channels, folder, rng), args.channels)
            print(f"{fs / 1e6:9.4f} MHz: {rate:6.1f} channel-s/s ({n} channels, {wall:.1f} s wall for "
                  f"{args.seconds} s: {wall / args.seconds:.2f} of real time)")
        if shutil.which("gnss-sdr") is None or not SIM_DIR.exists():
            print("\nGNSS-SDR peer: skipped (needs gnss-sdr on PATH and ../shared/tools/gps-sdr-sim)")
            return
        print("\nsame gps-sdr-sim file, whole run wall time (GNSS-SDR includes its acquisition, telemetry, PVT)")
        for fs in (2.6e6, 4e6):
            sim = gps_sdr_sim_file(fs, args.seconds * 5, folder)
            meta = sim.with_suffix(".sigmf-meta")
            from gnssframework.receiver.frontend.sigmf_meta import write_sigmf_meta

            write_sigmf_meta(meta, format="ci8", sigmf_datatype="ci8", sample_rate_hz=fs, if_hz=0.0)
            t = time.perf_counter()
            _, wall_track, n = tracking_rate(sim, args.channels)
            ours = time.perf_counter() - t
            theirs = gnss_sdr_wall(sim, fs, args.channels, folder)
            secs = args.seconds * 5
            line = f"{fs / 1e6:6.1f} MHz, {secs:.0f} s, {n} channels: gnssframework {ours / secs:.2f} of real time"
            if theirs is not None:
                line += f", GNSS-SDR {theirs / secs:.2f}; ratio GNSS-SDR/gnssframework speed {ours / theirs:.2f}"
            print(line)


if __name__ == "__main__":
    sys.exit(main())
