"""Validate acquisition and tracking against gps-sdr-sim, an independent GPS L1 C/A generator.

    python validation/gps_sdr_sim_tracking.py [--cn0 45] [--duration 6] [--fs 2.6e6] [--seed 1]

Builds gps-sdr-sim from ``../shared/tools/gps-sdr-sim`` (beside the repository) into a
temporary folder, simulates a static receiver with every satellite at one fixed power
(``-p``: no path loss, so each has the same C/N0), adds complex white noise for the chosen
C/N0, then acquires and tracks with the library (``pcps``, ``scalar``). The truth comes
from gps-sdr-sim's geometry (the broadcast ephemeris it used, `sim_truth`). Checks, each a
line of the report:

- every simulated satellite is acquired, with its Doppler within half a Doppler bin and its
  code phase within one sample, and no other PRN is;
- every one is locked at the end, with a C/N0 estimate within 1 dB of the injected one
  once the other simulated satellites are counted as noise: each adds its power
  ``a^2`` to the noise density, ``N0 + I0 = (2 sigma^2 + (n - 1) a^2) / fs``, which at 45
  dB-Hz, 2.6 MHz and 11 satellites is 0.5 dB (the same loss shows on the project's own
  generator; the estimate alone against the injected C/N0 is reported too);
- code error (truth minus replica code phase) under 0.1 chip RMS, Doppler error under
  5 Hz RMS, over the last second; the carrier phase error after removing its start
  (gps-sdr-sim's carrier starts at an arbitrary phase) is reported.

Exits 1 when a check fails, 2 when gps-sdr-sim cannot be built or run.
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import sim_truth  # noqa: E402

from gnssframework import registry  # noqa: E402
from gnssframework.receiver.acquisition.report import acquire_recording  # noqa: E402
from gnssframework.receiver.channels import SampleTracker, tracking_config  # noqa: E402
from gnssframework.receiver.frontend import open_recording  # noqa: E402
from gnssframework.receiver.frontend.sigmf_meta import write_sigmf_meta  # noqa: E402

SIM_DIR = HERE.parent.parent / "shared" / "tools" / "gps-sdr-sim"
#: gps-sdr-sim's per-satellite amplitude with -b 16 and -p 128: its 250-level carrier
#: table times the gain 128, shifted right by 7 (gpssim.c, the sample loop).
AMPLITUDE_LSB = 250.0
LOCATION = (35.681298, 139.766247, 10.0)


def build_and_simulate(work: Path, duration_s: float, fs: float) -> tuple[Path, str]:
    binary = subprocess.run([str(SIM_DIR / "build.sh"), str(work / "bin")], check=True, capture_output=True,
                            text=True).stdout.strip().splitlines()[-1]
    out = work / "sim.bin"
    lat, lon, h = LOCATION
    run = subprocess.run([binary, "-e", str(SIM_DIR / "brdc0010.22n"), "-l", f"{lat},{lon},{h}", "-d",
                          f"{duration_s}", "-b", "16", "-s", f"{fs:.0f}", "-p", "128", "-o", str(out)],
                         check=True, capture_output=True, text=True, cwd=work)
    return out, run.stderr


def parse_log(log: str) -> tuple[int, float, dict[int, tuple[float, float, float, float]]]:
    """GPS week, time of week at the start, and per PRN (azimuth, elevation, range, iono delay)."""
    m = re.search(r"Start time = .*\((\d+):([\d.]+)\)", log)
    if m is None:
        raise RuntimeError(f"no start time in gps-sdr-sim's output:\n{log}")
    sats = {}
    for line in log[m.end():].splitlines():
        parts = line.split()
        if len(parts) == 5 and re.fullmatch(r"\d\d", parts[0]):
            sats[int(parts[0])] = tuple(float(p) for p in parts[1:])
    return int(m.group(1)), float(m.group(2)), sats


def add_noise(src: Path, dst: Path, cn0_dbhz: float, fs: float, rng: np.random.Generator) -> None:
    """Add complex white noise of the standard deviation that gives ``cn0_dbhz`` to every
    satellite of amplitude `AMPLITUDE_LSB`: a = sqrt(2 sigma^2 c / fs) (complex samples,
    the law of `gnssframework.signal.if_samples`), so sigma = a sqrt(fs / (2 c)). A block at
    a time (the same draws as one call), so a 40 s file never sits in memory as floats."""
    sigma = AMPLITUDE_LSB * np.sqrt(fs / (2 * 10 ** (cn0_dbhz / 10)))
    raw = np.memmap(src, dtype="<i2", mode="r")
    block = 1 << 23
    with open(dst, "wb") as out:
        for start in range(0, raw.size, block):
            noisy = raw[start:start + block] + sigma * rng.standard_normal(min(block, raw.size - start))
            if np.abs(noisy).max() > 32767:
                raise RuntimeError("noise clips int16: choose a higher C/N0")
            out.write(np.rint(noisy).astype("<i2").tobytes())
    write_sigmf_meta(dst.with_suffix(".sigmf-meta"), format="ci16_le", sigmf_datatype="ci16_le", sample_rate_hz=fs,
                     if_hz=0.0, description=f"gps-sdr-sim at {cn0_dbhz} dB-Hz with added white noise")


def ephemerides(tow0: float) -> dict[int, dict]:
    """Per PRN, the navigation record gps-sdr-sim uses: toc within an hour of the start."""
    import georinex

    nav = georinex.load(SIM_DIR / "brdc0010.22n")
    out = {}
    for sv in nav.sv.values:
        rec = nav.sel(sv=sv).dropna("time", how="all", subset=["sqrtA"])
        if rec.time.size == 0:
            continue
        times = rec.time.values
        toc_tow = np.array([(t - np.datetime64("1980-01-06")) / np.timedelta64(1, "s") % sim_truth.SECONDS_IN_WEEK
                            for t in times])
        k = int(np.argmin(np.abs(sim_truth._wrap_week(tow0 - toc_tow))))
        eph = {v: float(rec[v].values[k]) for v in rec.data_vars}
        eph["toc_tow"] = toc_tow[k]
        out[int(sv[1:])] = eph
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cn0", type=float, default=45.0, help="C/N0 of every satellite (dB-Hz)")
    ap.add_argument("--duration", type=float, default=6.0, help="seconds simulated")
    ap.add_argument("--fs", type=float, default=2.6e6, help="sample rate")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--channel-filter", default="scalar")
    args = ap.parse_args(argv)
    import pymap3d

    failures = []

    def check(ok: bool, text: str) -> None:
        print(("  ok    " if ok else "  FAIL  ") + text)
        if not ok:
            failures.append(text)

    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        try:
            sim, log = build_and_simulate(work, args.duration, args.fs)
        except (subprocess.CalledProcessError, FileNotFoundError, OSError) as exc:
            print(f"cannot build or run gps-sdr-sim from {SIM_DIR}: {exc}", file=sys.stderr)
            return 2
        week, tow0, sats = parse_log(log)
        rec_path = work / "noisy.sigmf-data"
        add_noise(sim, rec_path, args.cn0, args.fs, np.random.default_rng(args.seed))
        rec = open_recording(rec_path)
        receiver = np.array(pymap3d.geodetic2ecef(*LOCATION))
        ephs = ephemerides(tow0)
        print(f"gps-sdr-sim: week {week}, tow {tow0:.0f} s, {len(sats)} satellites {sorted(sats)}, "
              f"{args.duration} s at {args.fs:g} Hz, noise for {args.cn0} dB-Hz")

        # The truth's own check: our orbits give gps-sdr-sim's printed ranges.
        for prn, (_, _, rng_m, _) in sats.items():
            _, geometric = sim_truth.pseudorange_m(ephs[prn], receiver, np.array([tow0]))
            check(abs(geometric[0] - rng_m) < 1.0, f"PRN {prn:2d} truth: range {geometric[0]:.1f} m vs "
                  f"gps-sdr-sim's {rng_m:.1f} m")

        acq = registry.create("acquisition", "pcps")
        t_acq = time.perf_counter()
        results = acquire_recording(rec, acq)
        t_acq = time.perf_counter() - t_acq
        found = {r.prn: r for r in results if r.detected}
        check(set(found) == set(sats), f"acquired {sorted(found)} (simulated {sorted(sats)}) in {t_acq:.1f} s")
        sample_chips = 1.023e6 / args.fs
        for prn in sorted(set(found) & set(sats)):
            r = found[prn]
            pr, _ = sim_truth.pseudorange_m(ephs[prn], receiver, np.array([tow0]), sats[prn][3])
            code_truth = sim_truth.code_phase_chips(pr, np.array([0.0]))[0]
            dop_truth = sim_truth.doppler_hz(ephs[prn], receiver, np.array([tow0]), sats[prn][3])[0]
            code_err = (r.code_phase_chips - code_truth + 511.5) % 1023 - 511.5
            check(abs(r.doppler_hz - dop_truth) <= 250 and abs(code_err) <= sample_chips,
                  f"PRN {prn:2d} acquisition: Doppler {r.doppler_hz:8.1f} Hz (truth {dop_truth:8.1f}), code phase "
                  f"error {code_err:+.3f} chips (one sample {sample_chips:.3f}), C/N0 {r.cn0_dbhz:.1f} dB-Hz")

        c_lin = 10 ** (args.cn0 / 10)
        cn0_eff = args.cn0 - 10 * np.log10(1 + (len(sats) - 1) * c_lin / args.fs)
        print(f"C/(N0 + I0) with the other {len(sats) - 1} satellites as noise: {cn0_eff:.2f} dB-Hz")
        config = tracking_config(channel_filter=args.channel_filter)
        t_trk = time.perf_counter()
        result = SampleTracker(rec, config, acq).run(list(found.values()))
        t_trk = time.perf_counter() - t_trk
        print(f"tracked {len(found)} channels x {result.duration_s:.1f} s in {t_trk:.1f} s wall "
              f"({len(found) * result.duration_s / t_trk:.1f} channel-seconds per second)")
        for prn in sorted(set(found) & set(sats)):
            ch = result.channels[prn]
            t = ch.column("time_s")
            last = t > result.duration_s - 1.0
            pr, _ = sim_truth.pseudorange_m(ephs[prn], receiver, tow0 + t, sats[prn][3])
            code_err = (sim_truth.code_phase_chips(pr, t) - ch.column("code_phase_chips") + 511.5) % 1023 - 511.5
            dop = sim_truth.doppler_hz(ephs[prn], receiver, tow0 + t, sats[prn][3])
            dop_err = ch.column("doppler_hz") - dop
            # Carrier: the replica's accumulated Doppler phase against the truth's
            # (-pseudorange / lambda), both from the first locked row on.
            locked = np.flatnonzero(ch.column("lock"))
            carrier_txt = "no lock"
            if locked.size:
                k0 = locked[0]
                truth_cyc = -(pr - pr[k0]) / sim_truth.L1_WAVELENGTH
                rep_cyc = ch.column("carrier_phase_cycles") - ch.column("carrier_phase_cycles")[k0]
                carrier_err = (truth_cyc - rep_cyc)[last]
                carrier_err -= np.round(np.median(carrier_err) * 2) / 2  # half-cycle ambiguity of a Costas loop
                carrier_txt = f"carrier error {np.std(carrier_err):.3f} cycles std (last 1 s)"
            cn0 = float(np.median(ch.column("cn0_dbhz")[last])) if last.any() else float("nan")
            code_rms = float(np.sqrt(np.mean(code_err[last] ** 2))) if last.any() else float("inf")
            dop_rms = float(np.sqrt(np.mean(dop_err[last] ** 2))) if last.any() else float("inf")
            ok = (last.any() and bool(ch.column("lock")[last].all()) and abs(cn0 - cn0_eff) < 1.0
                  and code_rms < 0.1 and dop_rms < 5.0)
            check(ok, f"PRN {prn:2d} tracking: C/N0 {cn0:5.2f} dB-Hz ({cn0 - args.cn0:+.2f} from the injected, "
                  f"{cn0 - cn0_eff:+.2f} from C/(N0 + I0)), code error {code_rms:.4f} chips RMS "
                  f"({code_rms * 293.05:.1f} m), Doppler error {dop_rms:.2f} Hz RMS, {carrier_txt}, "
                  f"locked {100 * ch.column('lock')[last].mean() if last.any() else 0:.0f} % of the last second")
    print("PASS" if not failures else f"FAIL: {len(failures)} check(s)")
    return 0 if not failures else 1


if __name__ == "__main__":
    sys.exit(main())
