"""Validate acquisition and tracking against gps-sdr-sim, an independent GPS L1 C/A generator.

    python validation/gps_sdr_sim_tracking.py [--cn0 45] [--duration 6] [--fs 2.6e6] [--seed 1]

gps-sdr-sim simulates a static receiver with every satellite at one fixed power, with
complex white noise added for the chosen C/N0 (`gps_sdr_sim_run.noisy_recording`); the
library then acquires and tracks (``pcps``, ``scalar``). The truth comes
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
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import sim_truth  # noqa: E402
from gps_sdr_sim_run import LOCATION, NAV, Checks, SimulatorError, exit_unavailable, noisy_recording  # noqa: E402

from gnssframework import registry  # noqa: E402
from gnssframework.receiver.acquisition.report import acquire_recording  # noqa: E402
from gnssframework.receiver.channels import SampleTracker, tracking_config  # noqa: E402
from gnssframework.receiver.frontend import open_recording  # noqa: E402


def ephemerides(tow0: float) -> dict[int, dict]:
    """Per PRN, the navigation record gps-sdr-sim uses: toc within an hour of the start."""
    import georinex

    nav = georinex.load(NAV)
    out = {}
    for sv in nav.sv.values:
        rec = nav.sel(sv=sv).dropna("time", how="all", subset=["sqrtA"])
        if rec.time.size == 0:
            continue
        times = rec.time.values
        toc_tow = np.array(
            [(t - np.datetime64("1980-01-06")) / np.timedelta64(1, "s") % sim_truth.SECONDS_IN_WEEK for t in times]
        )
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

    check = Checks()
    with tempfile.TemporaryDirectory() as tmp:
        try:
            sim = noisy_recording(Path(tmp), args.duration, args.fs, args.cn0, args.seed)
        except SimulatorError as exc:
            return exit_unavailable(exc)
        week, tow0, sats, rec_path = sim.week, sim.tow0_s, sim.satellites, sim.path
        rec = open_recording(rec_path)
        receiver = np.array(pymap3d.geodetic2ecef(*LOCATION))
        ephs = ephemerides(tow0)
        print(
            f"gps-sdr-sim: week {week}, tow {tow0:.0f} s, {len(sats)} satellites {sorted(sats)}, "
            f"{args.duration} s at {args.fs:g} Hz, noise for {args.cn0} dB-Hz"
        )

        # The truth's own check: our orbits give gps-sdr-sim's printed ranges.
        for prn, (_, _, rng_m, _) in sats.items():
            _, geometric = sim_truth.pseudorange_m(ephs[prn], receiver, np.array([tow0]))
            check(
                abs(geometric[0] - rng_m) < 1.0,
                f"PRN {prn:2d} truth: range {geometric[0]:.1f} m vs gps-sdr-sim's {rng_m:.1f} m",
            )

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
            check(
                abs(r.doppler_hz - dop_truth) <= 250 and abs(code_err) <= sample_chips,
                f"PRN {prn:2d} acquisition: Doppler {r.doppler_hz:8.1f} Hz (truth {dop_truth:8.1f}), code phase "
                f"error {code_err:+.3f} chips (one sample {sample_chips:.3f}), C/N0 {r.cn0_dbhz:.1f} dB-Hz",
            )

        c_lin = 10 ** (args.cn0 / 10)
        cn0_eff = args.cn0 - 10 * np.log10(1 + (len(sats) - 1) * c_lin / args.fs)
        print(f"C/(N0 + I0) with the other {len(sats) - 1} satellites as noise: {cn0_eff:.2f} dB-Hz")
        config = tracking_config(channel_filter=args.channel_filter)
        t_trk = time.perf_counter()
        result = SampleTracker(rec, config, acq).run(list(found.values()))
        t_trk = time.perf_counter() - t_trk
        print(
            f"tracked {len(found)} channels x {result.duration_s:.1f} s in {t_trk:.1f} s wall "
            f"({len(found) * result.duration_s / t_trk:.1f} channel-seconds per second)"
        )
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
            ok = (
                last.any()
                and bool(ch.column("lock")[last].all())
                and abs(cn0 - cn0_eff) < 1.0
                and code_rms < 0.1
                and dop_rms < 5.0
            )
            check(
                ok,
                f"PRN {prn:2d} tracking: C/N0 {cn0:5.2f} dB-Hz ({cn0 - args.cn0:+.2f} from the injected, "
                f"{cn0 - cn0_eff:+.2f} from C/(N0 + I0)), code error {code_rms:.4f} chips RMS "
                f"({code_rms * 293.05:.1f} m), Doppler error {dop_rms:.2f} Hz RMS, {carrier_txt}, "
                f"locked {100 * ch.column('lock')[last].mean() if last.any() else 0:.0f} % of the last second",
            )
    return check.summary()


if __name__ == "__main__":
    sys.exit(main())
