"""Figures of docs/receiver/frontend-to-tracking.md: the receiver chain on samples.

    python docs/make_receiver_plots.py

Uses the real 4 MHz PocketSDR slice in tests/data and a recording of the project's own
generator (seeded), so the figures come out the same on any machine.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from gnssframework import registry  # noqa: E402
from gnssframework.receiver.acquisition import noise_floor, search_grid  # noqa: E402
from gnssframework.receiver.acquisition.report import acquire_recording  # noqa: E402
from gnssframework.receiver.channels import SampleTracker, correlate_channels, tracking_config  # noqa: E402
from gnssframework.receiver.channels.correlator import MAX_TAPS  # noqa: E402
from gnssframework.receiver.frontend import (
    SatelliteSignal,
    open_recording,
    synthesize_samples,  # noqa: E402
    write_recording,
)
from gnssframework.signal.codes import ca_code  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
IMG = ROOT / "docs" / "img"
SLICE = ROOT / "tests" / "data" / "pocketsdr_L1_4MHz_IQ_100ms.bin"


def acquisition_figures() -> None:
    fs = 4e6
    rec = open_recording(SLICE, format="ci8", sample_rate_hz=fs, if_hz=0.0, q_sign=-1)
    acq = registry.create("acquisition", "pcps", noncoherent=10)
    x = rec.read(0, acq.samples_needed(fs))
    dopplers = acq.dopplers_hz()
    grid = search_grid(x, fs, 0.0, (26,), 1e-3, 10, dopplers)[0]
    stat = grid / noise_floor(grid, 10)
    res = {r.prn: r for r in acq.acquire(x, fs, 0.0, (26,))}[26]
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.6))
    peak = int(np.argmax(stat.max(axis=0)))
    lo, hi = max(0, peak - 80), min(stat.shape[1], peak + 80)  # +-20 chips around the peak
    im = axes[0].imshow(
        stat[:, lo:hi],
        aspect="auto",
        origin="lower",
        cmap="viridis",
        extent=(lo * 1.023e6 / fs, hi * 1.023e6 / fs, dopplers[0], dopplers[-1]),
    )
    fig.colorbar(im, ax=axes[0], label="test statistic")
    axes[0].set_xlabel("code phase (chips)")
    axes[0].set_ylabel("Doppler (Hz)")
    axes[0].set_title("PRN 26, PocketSDR 4 MHz: 1 ms x 10 sums (zoom)")
    axes[1].plot(np.arange(stat.shape[1]) * 1.023e6 / fs, stat[np.argmax(stat.max(axis=1))], lw=0.7)
    axes[1].axhline(res.threshold, color="r", ls="--", label=f"threshold (pfa {acq.params.pfa:g} per PRN)")
    axes[1].set_xlabel("code phase (chips)")
    axes[1].set_ylabel("test statistic")
    axes[1].set_title(f"the peak's Doppler bin (fine search: {res.doppler_hz:.0f} Hz)")
    axes[1].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(IMG / "receiver-acquisition-grid.png", dpi=90)
    plt.close(fig)

    # The correlation around the peak, from the real samples: the C/A triangle.
    start = res.code_phase_samples
    n = int(fs * 1e-3)
    offsets = np.linspace(-1.5, 1.5, 61)
    codes = ca_code(26)[None].astype(np.float32)
    sums = np.zeros(offsets.size)
    chunks = np.array_split(offsets, -(-offsets.size // MAX_TAPS))  # the kernel takes at most MAX_TAPS taps
    for k in range(9):  # the whole code periods after the first epoch
        c = np.concatenate(
            [
                correlate_channels(
                    x,
                    np.array([start + k * n]),
                    np.array([n]),
                    np.array([0.0]),
                    np.array([1.023e6 / fs]),
                    np.array([res.doppler_hz * (start + k * n) / fs]),
                    np.array([res.doppler_hz / fs]),
                    codes,
                    taps,
                )[0]
                for taps in chunks
            ]
        )
        sums += np.abs(c) ** 2
    fig, ax = plt.subplots(figsize=(5, 3.4))
    ax.plot(offsets, np.sqrt(sums / sums.max()), ".-")
    for o, name in ((-0.5, "E"), (0.0, "P"), (0.5, "L")):
        ax.axvline(o, color="gray", lw=0.5)
        ax.text(o, 1.02, name, ha="center")
    ax.set_xlabel("replica offset (chips)")
    ax.set_ylabel("|correlation| (normalised)")
    ax.set_title("PRN 26 from the recording: the correlation triangle")
    fig.tight_layout()
    fig.savefig(IMG / "receiver-correlation-triangle.png", dpi=90)
    plt.close(fig)


def tracking_figures(tmp: Path) -> None:
    fs = 2.6e6
    rng = np.random.default_rng(7)
    sats = [
        SatelliteSignal(4, 46.0, 1320.0, 210.0, first_bit_code_period=5),
        SatelliteSignal(9, 40.0, -2410.0, 640.0, first_bit_code_period=14),
        SatelliteSignal(21, 34.0, 380.0, 975.0, first_bit_code_period=0),
    ]
    x = synthesize_samples(sats, 3.0, fs, 0.0, rng)
    rec = open_recording(write_recording(tmp / "docs.sigmf-data", x, "ci16_le", fs, 0.0, scale=300.0))
    acq = registry.create("acquisition", "pcps", noncoherent=20)
    found = [r for r in acquire_recording(rec, acq) if r.detected]
    result = SampleTracker(rec, tracking_config(coherent_ms=20, channel_params={"pll_bandwidth_hz": 8.0}), acq).run(
        found
    )
    fig, axes = plt.subplots(3, 1, figsize=(8, 7.5), sharex=True)
    for sat in sats:
        ch = result.channels.get(sat.prn)
        if ch is None:
            continue
        t = ch.column("time_s")
        (line,) = axes[0].plot(t, ch.column("cn0_dbhz"), label=f"PRN {sat.prn} ({sat.cn0_dbhz:g} dB-Hz generated)")
        axes[0].axhline(sat.cn0_dbhz, color=line.get_color(), ls=":", lw=0.8)
        axes[1].plot(t, ch.column("pli"), color=line.get_color())
        axes[2].step(t, ch.column("stage") + 0.04 * sats.index(sat), where="post", color=line.get_color())
    axes[0].set_ylabel("C/N0 estimate (dB-Hz)")
    axes[0].legend(fontsize=8)
    axes[1].set_ylabel("phase-lock indicator")
    axes[2].set_yticks(range(4), ["pull-in", "track", "extended", "lost"])
    axes[2].set_xlabel("time (s)")
    fig.tight_layout()
    fig.savefig(IMG / "receiver-cn0-lock.png", dpi=90)
    plt.close(fig)

    ch = result.channels[9]
    t = ch.column("time_s")
    fig, ax = plt.subplots(figsize=(8, 3.2))
    ax.plot(t, ch.column("prompt_i"), lw=0.8, label="prompt I")
    ax.plot(t, ch.column("prompt_q"), lw=0.8, label="prompt Q")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("correlator (noise sigma units)")
    ax.set_title("PRN 9 at 40 dB-Hz: 1 ms then 20 ms bit-aligned integrations; the data bits are in I")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(IMG / "receiver-prompt.png", dpi=90)
    plt.close(fig)


def main() -> None:
    import tempfile

    IMG.mkdir(parents=True, exist_ok=True)
    acquisition_figures()
    with tempfile.TemporaryDirectory() as tmp:
        tracking_figures(Path(tmp))
    print("wrote docs/img/receiver-*.png")


if __name__ == "__main__":
    main()
