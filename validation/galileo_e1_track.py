"""Track one Galileo E1-C pilot (BOC(1,1) replica) over the whole 0.5 s real 4 MHz recording.

    python validation/galileo_e1_track.py 27      # PRN; reads ../shared/data/if/ beside the clone

Acquisition (pcps, 4 ms x 4), then, with 4 ms intervals aligned to the primary code, 25
open-loop prompts whose consecutive products are matched against CS25_1's (blind to the
residual Doppler): the best shift is the secondary-code phase, the product's angle a
frequency correction. Then the engine's scalar loop (registry defaults: eml-envelope DLL
with d = 0.2 chip, Costas PLL, FLL assist) on the compiled correlators with CS25_1 wiped off.
`tests/signal/test_galileo_e1.py` does the same on the 100 ms slice; docs/receiver/galileo-e1.md
holds what this printed.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from gnssframework import registry
from gnssframework.receiver.channels.correlator import replica_codes
from gnssframework.receiver.engine.channel import Channel
from gnssframework.receiver.engine.closers import ScalarCloser
from gnssframework.receiver.engine.samples import SampleSource
from gnssframework.receiver.frontend.recording import open_recording
from gnssframework.signal.correlators import Correlators
from gnssframework.signal.galileo_codes import GALILEO_E1C_SECONDARY_CS25
from gnssframework.signal.galileo_e1 import GALILEO_E1C_BOC11 as SPEC
from gnssframework.signal.overlay import overlay_sync

SHARED = Path(__file__).resolve().parents[2] / "shared"  # ../shared beside the clone (--shared)
FS, T, D = 4e6, 4e-3, 0.2


def main(prn: int, shared: Path = SHARED) -> None:
    rec = open_recording(
        shared / "data" / "if" / "pocketsdr_L1_20211202_084700_4MHz_IQ.bin",
        format="ci8",
        sample_rate_hz=FS,
        if_hz=0.0,
        q_sign=-1,
    )
    x = np.asarray(rec.read(0, rec.n_samples), np.complex64)
    acq = registry.create("acquisition", "pcps", noncoherent=4, doppler_max_hz=5000.0, xcorr_margin_db=None)
    r = acq.acquire(x[: acq.samples_needed(FS, SPEC)], FS, 0.0, prns=(prn,), signal=SPEC)[0]
    print(
        f"acquisition: PRN {prn} detected {r.detected}, Doppler {r.doppler_hz:.1f} Hz, code start sample "
        f"{r.code_phase_samples}, C/N0 {r.cn0_dbhz:.1f} dB-Hz"
    )
    source = SampleSource(
        x,
        FS,
        0.0,
        replica_codes(SPEC, (prn,)),
        T,
        early_late_spacing_chips=D,
        noise_std=float(np.std(x.real)),
        start_sample=r.code_phase_samples,
        subchips_per_chip=SPEC.subchips_per_chip,
    )
    cs = np.array(GALILEO_E1C_SECONDARY_CS25, float)
    channel = Channel.start((1,), 0.0, r.doppler_hz, signal=SPEC)
    prompts = []
    for k in range(25):
        channel.run_interval(T)
        prompts.append(complex(np.ravel(source.correlate(channel, k).prompt)[0]))
        channel.steer_frequency(channel.carrier_freq_hz, channel.code_rate_chips_s)
    sync = overlay_sync(np.array(prompts), cs, T)
    shift, df = sync.shift, sync.freq_error_hz
    print(f"secondary code: phase {shift}, score {sync.margin:.2f} x the runner-up, frequency correction {df:+.1f} Hz")
    channel = Channel.start((1,), 0.0, r.doppler_hz + df, signal=SPEC)
    closer = ScalarCloser(registry.create("channel_filter", "scalar"))
    closer.reset(channel, T, early_late_spacing_chips=D, cn0_dbhz=40.0)
    n = (x.size - r.code_phase_samples) // int(FS * T)
    tracked, freq = [], []
    for k in range(n):
        channel.run_interval(T)
        c = source.correlate(channel, k)
        s = cs[(k + shift) % 25]
        c = Correlators.trusted(c.early * s, c.prompt * s, c.late * s)
        tracked.append(complex(np.ravel(c.prompt)[0]))
        closer.step(channel, c)
        freq.append(float(np.ravel(channel.carrier_freq_hz)[0]))
    p = np.array(tracked)[25:]
    same = np.mean(np.sign(p.real) == np.sign(np.sum(p.real)))
    cn0 = 10 * np.log10(np.mean(p.real) ** 2 / (2 * np.var(p.imag)) / T)
    print(
        f"tracked {n} intervals ({n * T:.3f} s); after the first 25: {same:.3f} of the prompts of one sign, "
        f"mean |I| / mean |Q| = {np.mean(np.abs(p.real)) / np.mean(np.abs(p.imag)):.1f}, C/N0 from the prompts "
        f"{cn0:.1f} dB-Hz, carrier NCO {freq[0]:.1f} -> {freq[-1]:.1f} Hz"
    )


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("prn", type=int, nargs="?", default=27, help="the Galileo PRN to track (default 27)")
    ap.add_argument(
        "--shared", type=Path, default=SHARED, help=f"the shared folder holding data/if/ (default {SHARED})"
    )
    args = ap.parse_args()
    main(args.prn, args.shared)
