"""Figures of docs/experiments/deep-integration.md: the flight, and the errors over time of a run of
examples/deep_integration.toml.

Run (after ``gnssframework compare examples/deep_integration.toml --out
results/deep_integration``): ``MPLBACKEND=Agg python docs/deep_integration_plots.py
[results/deep_integration]``. Not in CI: the example takes too long (see the page).
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from gnssframework.inertial.earth import STANDARD_GRAVITY_MPS2 as G0
from gnssframework.experiments.scenarios.deep_integration_flight import make_flight

OUT = Path(__file__).parent / "img"
CANDIDATES = ("deep", "deep-no-accel", "vector", "vector-pva", "vector-given", "loose")
COLORS = dict(zip(CANDIDATES, ("C0", "C1", "C2", "C4", "C5", "C3")))


def _series(run: Path, case: str, cand: str):
    files = sorted((run / "raw" / case / cand).glob("run*.npz"))
    if not files:
        return None, {}
    parts = [np.load(f) for f in files]
    keys = [k for k in parts[0].files if k not in ("time_s", "first_run")]
    return parts[0]["time_s"], {k: np.concatenate([p[k] for p in parts], axis=-1) for k in keys}


def trajectory_figure() -> None:
    f = make_flight("pull-up", 34.23, 108.3576, 590.6, 50.0)
    t = np.linspace(0.0, 50.0, 2001)
    tr = f.truth(t)
    speed = np.linalg.norm(tr.velocity_ecef_mps, axis=-1)
    acc = np.linalg.norm(tr.acceleration_ecef_mps2, axis=-1) / G0
    jerk = np.linalg.norm(tr.jerk_ecef_mps3, axis=-1) / G0
    import pymap3d

    _, _, h = pymap3d.ecef2geodetic(*tr.position_ecef_m.T)
    fig, ax = plt.subplots(4, 1, figsize=(7, 7), sharex=True)
    for a, y, lab in zip(
        ax, (h / 1e3, speed, acc, jerk), ("height (km)", "speed (m/s)", "acceleration (g)", "jerk (g/s)")
    ):
        a.plot(t, y)
        a.set_ylabel(lab)
        a.grid(alpha=0.3)
    ax[-1].set_xlabel("time (s)")
    fig.suptitle("Reference 002's flight as defined here (inertial.trajectory.paper_profile)")
    fig.tight_layout()
    fig.savefig(OUT / "deep-integration-trajectory.png", dpi=90)


def error_figure(run: Path, case: str) -> None:
    names = [
        ("horizontal_position_error_rmse", "horizontal position (m)"),
        ("height_error_rmse", "height (m)"),
        ("horizontal_velocity_error_rmse", "horizontal velocity (m/s)"),
        ("vertical_velocity_error_rmse", "vertical velocity (m/s)"),
        ("attitude_error_rmse", "attitude, max axis (deg)"),
        ("freq_tracking_error_rmse", "replica frequency error (Hz)"),
        ("code_tracking_error_rmse", "replica code error (chip)"),
    ]
    fig, ax = plt.subplots(len(names), 1, figsize=(7, 12), sharex=True)
    for cand in CANDIDATES:
        t, s = _series(run, case, cand)
        if t is None:
            continue
        for a, (n, lab) in zip(ax, names):
            if n in s and np.isfinite(s[n]).any():
                a.semilogy(t, np.sqrt(np.nanmean(s[n] ** 2, axis=-1)), label=cand, color=COLORS[cand])
            a.set_ylabel(lab, fontsize=8)
    for a in ax:
        a.grid(alpha=0.3)
        a.axvspan(10.0, 18.625, color="0.9", zorder=0)
    ax[0].legend(fontsize=8, ncol=3)
    ax[-1].set_xlabel("time (s); grey: boost and pull-up")
    fig.suptitle(f"RMS over runs, {case}")
    fig.tight_layout()
    fig.savefig(OUT / f"deep-integration-errors-{case}.png", dpi=90)


if __name__ == "__main__":
    run = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("results/deep_integration")
    trajectory_figure()
    for case in ("45dBHz", "35dBHz"):
        error_figure(run, case)
