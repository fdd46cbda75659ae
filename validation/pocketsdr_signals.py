"""Full searches of SBAS L1, BeiDou B1C and GPS/QZSS L2C in PocketSDR's real recordings (../shared/data/if),
against the satellites PocketSDR's own acquisition finds there (../shared/data/README.md).

Prints one table a file and signal (every PRN above the false-alarm threshold, strongest
first) and exits non-zero if a satellite PocketSDR finds is missed. The tests
(tests/signal/test_sbas_l1.py, tests/signal/test_gps_l2c.py, tests/signal/test_beidou_b1c.py) check the same on slices in tests/data; this
script is the whole-PRN-range search of docs/receiver/more-signals.md (the L2C one takes
minutes: 20 ms coherent blocks, 25 Hz Doppler bins; B1C's too, 10 ms).

    python validation/pocketsdr_signals.py              # SBAS and B1C on both L1 files, then L2C
    python validation/pocketsdr_signals.py --sbas       # SBAS only (seconds)
    python validation/pocketsdr_signals.py --only b1c   # B1C only (minutes)
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from gnssframework import registry
from gnssframework.receiver.frontend import open_recording
from gnssframework.signal.beidou_b1c import BEIDOU_B1C
from gnssframework.signal.gps_l2c import GPS_L2C, QZSS_L2C
from gnssframework.signal.sbas_l1 import SBAS_L1

IF_DIR = Path(__file__).resolve().parents[2] / "shared" / "data" / "if"

#: What PocketSDR finds (../shared/data/README.md), by file and signal.
POCKETSDR = {
    ("pocketsdr_L1_20211202_084700_4MHz_IQ.bin", "sbas-l1"): {128, 130, 137, 140, 143, 144},
    ("pocketsdr_L1_20211125_004000_12MHz_I.bin", "sbas-l1"): {128, 130, 137, 140, 143, 144},
    ("pocketsdr_L2_20211202_084700_4MHz_IQ.bin", "gps-l2c"): {18, 25, 26, 29, 31},
    ("pocketsdr_L2_20211202_084700_4MHz_IQ.bin", "qzss-l2c"): {194, 195, 199},
    ("pocketsdr_L1_20211202_084700_4MHz_IQ.bin", "beidou-b1c"): {21, 22, 27, 29, 30, 36, 39, 40, 45, 46},
    ("pocketsdr_L1_20211125_004000_12MHz_I.bin", "beidou-b1c"): {20, 23, 25, 27, 30, 32, 38, 39, 41},
}
READ = {
    "4MHz_IQ": dict(format="ci8", sample_rate_hz=4e6, if_hz=0.0, q_sign=-1),
    "12MHz_I": dict(format="ri8", sample_rate_hz=12e6, if_hz=3e6),
}


def search(folder: Path, name: str, signal, **params) -> int:
    kind = next(v for k, v in READ.items() if k in name)
    rec = open_recording(folder / name, **kind)
    fs = rec.info.sample_rate_hz
    acq = registry.create("acquisition", "pcps", xcorr_margin_db=None, **params)
    res = acq.acquire(rec.read(0, acq.samples_needed(fs, signal)), fs, rec.info.if_hz, signal=signal)
    found = sorted((r for r in res if r.detected), key=lambda r: -r.test_statistic)
    expected = POCKETSDR[(name, signal.name)]
    print(f"\n{name}, {signal.name}, pcps {params}, threshold {res[0].threshold:.1f}\n")
    print("| PRN | PocketSDR | statistic | Doppler (Hz) | code phase (chips) | C/N0 (dB-Hz) |")
    print("|---|---|---|---|---|---|")
    for r in found:
        print(
            f"| {r.prn} | {'yes' if r.prn in expected else ''} | {r.test_statistic:.1f} | {r.doppler_hz:.1f} | "
            f"{r.code_phase_chips:.1f} | {r.cn0_dbhz:.1f} |"
        )
    missed = expected - {r.prn for r in found}
    if missed:
        print(f"MISSED: {sorted(missed)}")
    return len(missed)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sbas", action="store_true", help="SBAS only")
    ap.add_argument("--only", choices=("sbas", "l2c", "b1c"), help="one signal only")
    ap.add_argument("--data", type=Path, default=IF_DIR, help=f"the recordings' folder (default {IF_DIR})")
    args = ap.parse_args(argv)
    if not args.data.is_dir():
        print(f"no folder {args.data} (--data)", file=sys.stderr)
        return 2
    missed = 0
    only = "sbas" if args.sbas else args.only
    l1_files = ("pocketsdr_L1_20211202_084700_4MHz_IQ.bin", "pocketsdr_L1_20211125_004000_12MHz_I.bin")
    if only in (None, "sbas"):
        for name in l1_files:
            missed += search(args.data, name, SBAS_L1, noncoherent=10)
    if only in (None, "b1c"):
        for name in l1_files:  # one 10 ms block, +-4 kHz in 50 Hz bins
            missed += search(args.data, name, BEIDOU_B1C, noncoherent=1, doppler_max_hz=4000.0)
    if only in (None, "l2c"):
        for signal in (GPS_L2C, QZSS_L2C):
            missed += search(
                args.data, "pocketsdr_L2_20211202_084700_4MHz_IQ.bin", signal, noncoherent=1, doppler_max_hz=4000.0
            )
    return 1 if missed else 0


if __name__ == "__main__":
    sys.exit(main())
