"""Search every Galileo E1 PRN (1-50) on both real L1 recordings, E1-B and E1-C, and print a table.

    python validation/galileo_e1_acquire.py     # reads ../shared/data/if/ beside the clone

pcps with the BOC(1,1) replica, 4 ms coherent (one E1-B symbol, one E1-C secondary chip) x 8
non-coherent (32 ms, inside the 12 MHz file's first 86 ms), Doppler +-5 kHz in 125 Hz bins, a
false-alarm probability of 1e-3 per PRN search, no cross-correlation margin. A satellite is
*confirmed* when E1-B and E1-C (different code families) both detect it within 250 Hz and one
sample. PocketSDR's list (../shared/data/README.md) is the independent truth for the strong
ones; docs/receiver/galileo-e1.md holds the table this printed.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from gnssframework import registry
from gnssframework.receiver.frontend.recording import open_recording
from gnssframework.signal.galileo_e1 import GALILEO_E1B_BOC11, GALILEO_E1C_BOC11

SHARED = Path(__file__).resolve().parents[2] / "shared"  # ../shared beside the clone (--shared)
FILES = {
    "L1 12 MHz real": ("pocketsdr_L1_20211125_004000_12MHz_I.bin", "ri8", 12e6, 3e6, None, {3, 8, 13, 15, 25}),
    "L1 4 MHz complex": ("pocketsdr_L1_20211202_084700_4MHz_IQ.bin", "ci8", 4e6, 0.0, -1, {7, 15, 27, 30}),
}


def main(shared: Path = SHARED) -> None:
    acq = registry.create("acquisition", "pcps", noncoherent=8, xcorr_margin_db=None)
    print(
        "| file | PRN | PocketSDR | E1-B C/N0 (dB-Hz) | E1-B Doppler (Hz) | E1-B code phase (samples) "
        "| E1-C C/N0 | E1-C Doppler | E1-C code phase | E1-B stat / threshold | confirmed |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for label, (name, fmt, fs, if_hz, q_sign, listed) in FILES.items():
        rec = open_recording(
            shared / "data" / "if" / name,
            format=fmt,
            sample_rate_hz=fs,
            if_hz=if_hz,
            **({} if q_sign is None else {"q_sign": q_sign}),
        )
        x = rec.read(0, acq.samples_needed(fs, GALILEO_E1B_BOC11))
        b = {r.prn: r for r in acq.acquire(x, fs, if_hz, signal=GALILEO_E1B_BOC11)}
        c = {r.prn: r for r in acq.acquire(x, fs, if_hz, signal=GALILEO_E1C_BOC11)}
        for p in sorted(b):
            rb, rc = b[p], c[p]
            if not (rb.detected or rc.detected or p in listed):
                continue
            ok = (
                rb.detected
                and rc.detected
                and abs(rb.doppler_hz - rc.doppler_hz) <= 250
                and abs(rb.code_phase_samples - rc.code_phase_samples) <= 1
            )
            print(
                f"| {label} | {p} | {'yes' if p in listed else ''} | {rb.cn0_dbhz:.1f}{'' if rb.detected else ' (no)'}"
                f" | {rb.doppler_hz:.0f} | {rb.code_phase_samples} | {rc.cn0_dbhz:.1f}"
                f"{'' if rc.detected else ' (no)'} | {rc.doppler_hz:.0f} | {rc.code_phase_samples} "
                f"| {rb.test_statistic / rb.threshold:.2f} | {'yes' if ok else 'no'} |",
                flush=True,
            )


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument(
        "--shared", type=Path, default=SHARED, help=f"the shared folder holding data/if/ (default {SHARED})"
    )
    main(ap.parse_args().shared)
