"""What the ``track`` command writes: ``tracking.csv``, ``summary.csv``, ``events.txt`` and plots."""

from __future__ import annotations

import csv
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ...io.files import atomic_open
from ...signal.gps_l1ca import GPS_L1CA
from ...signal.spec import SignalSpec
from .tracker import STAGES, TrackingResult

__all__ = ["TRACKING_COLUMNS", "SUMMARY_COLUMNS", "write_tracking_outputs", "channel_summary", "locked_channels"]

#: Columns of tracking.csv: one row per channel and integration. ``time_s`` is the
#: integration's first sample (seconds from the recording's first sample), where the
#: replica's code phase is ``code_phase_chips`` (a code epoch: within one sample of 0);
#: ``carrier_phase_cycles`` is the replica's accumulated Doppler phase there.
TRACKING_COLUMNS = (
    "time_s",
    "prn",
    "cn0_dbhz",
    "doppler_hz",
    "code_phase_chips",
    "lock",
    "prompt_i",
    "prompt_q",
    "carrier_phase_cycles",
    "pli",
    "stage",
    "coherent_ms",
)
SUMMARY_COLUMNS = (
    "prn",
    "acq_doppler_hz",
    "acq_cn0_dbhz",
    "tracked_s",
    "locked_fraction",
    "cn0_dbhz_locked",
    "doppler_hz_last",
    "final_stage",
)


def channel_summary(
    result: TrackingResult, signal: SignalSpec = GPS_L1CA, signal_of: Callable[[int], SignalSpec] | None = None
) -> list[dict]:
    """One dict per channel (`SUMMARY_COLUMNS`). ``signal`` is the tracked signal, or
    ``signal_of(prn)`` each channel's when the run tracked several (`multi_receive.SignalSet`):
    the record's ``coherent_ms`` counts its code periods (4 ms each on Galileo E1)."""
    acq = {a.prn: a for a in result.acquisitions}
    out = []
    for prn, ch in sorted(result.channels.items()):
        if not ch.rows:
            lock = np.zeros(0)
        else:
            lock = ch.column("lock").astype(bool)
        code_period_s = (signal_of(prn) if signal_of is not None else signal).code_period_s
        span = ch.column("coherent_ms") * code_period_s if ch.rows else np.zeros(0)
        cn0 = ch.column("cn0_dbhz")[lock] if lock.any() else np.zeros(0)
        out.append(
            {
                "prn": prn,
                "acq_doppler_hz": acq[prn].doppler_hz,
                "acq_cn0_dbhz": acq[prn].cn0_dbhz,
                "tracked_s": float(span.sum()),
                "locked_fraction": float(span[lock].sum() / span.sum()) if span.sum() else 0.0,
                "cn0_dbhz_locked": float(np.median(cn0)) if cn0.size else float("nan"),
                "doppler_hz_last": float(ch.column("doppler_hz")[-1]) if ch.rows else float("nan"),
                "final_stage": STAGES[int(ch.column("stage")[-1])] if ch.rows else "pull-in",
            }
        )
    return out


def locked_channels(result: TrackingResult) -> list[tuple[int, object]]:
    """``(prn, ChannelRecord)`` of the channels that were locked at some row, by PRN."""
    return [
        (prn, ch) for prn, ch in sorted(result.channels.items()) if ch.rows and ch.column("lock").astype(bool).any()
    ]


def _fmt(v) -> str:
    """A summary cell: a float to 6 digits, a missing value (a never-locked channel's C/N0)
    empty, as CSV readers (pandas) take a missing number, never the text ``nan``."""
    if isinstance(v, float):
        return f"{v:.6g}" if math.isfinite(v) else ""
    return str(v)


def write_tracking_outputs(
    out_dir: str | Path,
    result: TrackingResult,
    plots: bool = True,
    signal: SignalSpec = GPS_L1CA,
    signal_of: Callable[[int], SignalSpec] | None = None,
) -> list[Path]:
    """Write the files of a tracking run into ``out_dir``; returns their paths
    (``signal``, ``signal_of``: the tracked signal or each channel's, `channel_summary`)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = [out / "tracking.csv", out / "summary.csv", out / "events.txt"]
    rows = []
    for prn, ch in result.channels.items():
        for r in ch.rows:
            rec = dict(
                zip(
                    (
                        "time_s",
                        "cn0_dbhz",
                        "pli",
                        "doppler_hz",
                        "code_phase_chips",
                        "carrier_phase_cycles",
                        "lock",
                        "stage",
                        "prompt_i",
                        "prompt_q",
                        "coherent_ms",
                    ),
                    r,
                )
            )
            rec["prn"] = prn
            rec["stage"] = STAGES[rec["stage"]]
            rows.append(rec)
    rows.sort(key=lambda r: (r["time_s"], r["prn"]))
    with atomic_open(written[0], "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(TRACKING_COLUMNS)
        for r in rows:
            w.writerow(
                [
                    f"{r['time_s']:.9f}",
                    r["prn"],
                    f"{r['cn0_dbhz']:.2f}",
                    f"{r['doppler_hz']:.3f}",
                    f"{r['code_phase_chips']:.6f}",
                    r["lock"],
                    f"{r['prompt_i']:.4f}",
                    f"{r['prompt_q']:.4f}",
                    f"{r['carrier_phase_cycles']:.6f}",
                    f"{r['pli']:.3f}",
                    r["stage"],
                    r["coherent_ms"],
                ]
            )
    summary = channel_summary(result, signal, signal_of)
    with atomic_open(written[1], "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(SUMMARY_COLUMNS)
        for s in summary:
            w.writerow([_fmt(s[c]) for c in SUMMARY_COLUMNS])
    with atomic_open(written[2], "w") as fh:
        for prn, ch in sorted(result.channels.items()):
            for t, text in ch.events:
                fh.write(f"{t:10.4f} s  PRN {prn:2d}  {text}\n")
    if plots:
        written += _plots(out / "plots", result)
    return written


def _plots(folder: Path, result: TrackingResult) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    folder.mkdir(parents=True, exist_ok=True)
    # A channel that never locked has a C/N0 estimate of noise (e.g. -97 dB-Hz) that would squash
    # the others' scale: it is left out and named.
    locked = locked_channels(result)
    never = sorted(set(result.channels) - {prn for prn, _ in locked})
    fig, axes = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
    for prn, ch in locked:
        t = ch.column("time_s")
        axes[0].plot(t, ch.column("cn0_dbhz"), label=f"PRN {prn}")
        axes[1].plot(t, ch.column("pli"))
        axes[2].plot(t, ch.column("doppler_hz"))
    axes[0].set_ylabel("C/N0 (dB-Hz)")
    axes[0].set_title(
        "channels that locked" + (f" (never locked, not shown: PRN {', '.join(map(str, never))})" if never else ""),
        fontsize=9,
    )
    if locked:
        axes[0].legend(fontsize=7, ncol=4)
    axes[1].set_ylabel("phase-lock indicator")
    axes[2].set_ylabel("Doppler (Hz)")
    axes[2].set_xlabel("time (s)")
    fig.tight_layout()
    path = folder / "cn0_lock_doppler.png"
    fig.savefig(path, dpi=90)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(5, 5))
    for prn, ch in locked:
        lock = ch.column("lock").astype(bool)
        ax.plot(ch.column("prompt_i")[lock], ch.column("prompt_q")[lock], ".", ms=2, label=f"PRN {prn}")
    ax.set_xlabel("prompt I")
    ax.set_ylabel("prompt Q")
    ax.set_title("prompt correlators while locked")
    ax.axis("equal")
    if locked:
        ax.legend(fontsize=7, markerscale=4)
    fig.tight_layout()
    path2 = folder / "prompt_iq.png"
    fig.savefig(path2, dpi=90)
    plt.close(fig)
    return [path, path2]
