"""Regenerate the inertial page's figures into docs/img/ (about 10 s on one core).

    python docs/make_inertial_plots.py

Figure 1: reference 002's flight as this project defines it (the paper's figure was lost).
Figure 2: free-inertial errors on that flight with the paper's IMU grade, Monte Carlo
(20 runs, fixed seed) beside the linear 15-state model's 1-sigma.
"""

from __future__ import annotations

import pathlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from gnssframework.inertial import (  # noqa: E402
    STANDARD_GRAVITY_MPS2,
    MechanisationOptions,
    NavState,
    TrajectoryModel,
    integrate,
    paper_profile,
)
from gnssframework.inertial.error_model import error_state_transition, navigation_error  # noqa: E402
from gnssframework.inertial.frames import ecef_to_enu_offset, euler_ned_deg  # noqa: E402
from gnssframework.inertial.imu import ImuGrade, simulate_imu  # noqa: E402

OUT = pathlib.Path(__file__).resolve().parent / "img"
DT_S = 0.005


def _save(fig, name: str) -> None:
    fig.tight_layout()
    fig.savefig(OUT / name, dpi=90)
    plt.close(fig)


def trajectory_figure(model: TrajectoryModel) -> None:
    t = np.arange(0.0, model.profile.duration_s + 1e-9, 0.01)
    tr = model.evaluate(t)
    enu = ecef_to_enu_offset(tr.position_ecef_m, tr.position_ecef_m[0])
    g0 = STANDARD_GRAVITY_MPS2
    fig, ax = plt.subplots(2, 2, figsize=(10, 7))
    horiz = np.hypot(enu[:, 0], enu[:, 1])
    ax[0, 0].plot(horiz / 1e3, enu[:, 2] / 1e3)
    for ts in (10, 20, 30, 40):
        k = int(ts / 0.01)
        ax[0, 0].annotate(f"{ts} s", (horiz[k] / 1e3, enu[k, 2] / 1e3), fontsize=8)
    ax[0, 0].set(
        xlabel="horizontal distance (km, heading 45 deg)",
        ylabel="height above start (km)",
        title="track in the vertical plane",
    )
    ax[0, 1].plot(t, np.linalg.norm(tr.velocity_ecef_mps, axis=-1), label="speed (m/s)")
    ax[0, 1].axhline(1000, color="k", ls=":", lw=0.8)
    ax[0, 1].set(xlabel="time (s)", ylabel="m/s", title="speed (limit 1 km/s)")
    ax[1, 0].plot(t, np.linalg.norm(tr.acceleration_ecef_mps2, axis=-1) / g0, label="|a| (g)")
    ax[1, 0].plot(t, np.linalg.norm(tr.jerk_ecef_mps3, axis=-1) / g0, label="|jerk| (g/s)")
    ax[1, 0].axhline(30, color="C0", ls=":", lw=0.8)
    ax[1, 0].axhline(50, color="C1", ls=":", lw=0.8)
    ax[1, 0].set(xlabel="time (s)", xlim=(8, 22), title="acceleration and jerk (limits 30 g, 50 g/s)")
    ax[1, 0].legend()
    rpy = euler_ned_deg(tr.q_b_e, tr.position_ecef_m)
    for i, name in enumerate(("roll", "pitch", "yaw")):
        ax[1, 1].plot(t, rpy[:, i], label=name)
    ax[1, 1].set(xlabel="time (s)", ylabel="deg", title="attitude w.r.t. local NED")
    ax[1, 1].legend()
    _save(fig, "inertial-trajectory.png")


def free_inertial_figure(model: TrajectoryModel, runs: int = 20) -> None:
    n = int(round(model.profile.duration_s / DT_S))
    truth = model.evaluate(DT_S * np.arange(n + 1))
    dth, dv = model.increments(DT_S, n)
    grade = ImuGrade()
    mth, mdv, _ = simulate_imu(dth, dv, DT_S, grade, np.random.default_rng(2017), (runs,))
    series = integrate(truth.nav_state(0), mth, mdv, DT_S, MechanisationOptions())
    every = 20
    idx = np.arange(0, n + 1, every)
    est = NavState(series.q_b_e[idx], series.velocity_ecef_mps[idx], series.position_ecef_m[idx])
    tru = NavState(truth.q_b_e[idx, None], truth.velocity_ecef_mps[idx, None], truth.position_ecef_m[idx, None])
    err = navigation_error(est, tru)
    # linear model: P propagated with the same grade, biases as constants of variance bias^2 + markov^2
    states = NavState(truth.q_b_e[:-1], truth.velocity_ecef_mps[:-1], truth.position_ecef_m[:-1])
    phi, qd = error_state_transition(states, dv / DT_S, DT_S, grade, bias_model="constant", method="second-order")
    P = np.zeros((15, 15))
    P[9:12, 9:12] = np.eye(3) * (grade.gyro_bias_rad_s**2 + grade.gyro_markov_sigma_rad_s**2)
    P[12:15, 12:15] = np.eye(3) * (grade.accel_bias_mps2**2 + grade.accel_markov_sigma_mps2**2)
    sig = [np.sqrt(np.diag(P))]
    for k in range(n):
        P = phi[k] @ P @ phi[k].T + qd[k]
        if (k + 1) % every == 0:
            sig.append(np.sqrt(np.diag(P)))
    sig = np.array(sig)
    t = truth.time_s[idx]
    fig, ax = plt.subplots(1, 3, figsize=(12, 3.6))
    for j, (block, label, scale) in enumerate(
        (
            (slice(0, 3), "attitude error (deg)", 180 / np.pi),
            (slice(3, 6), "velocity error (m/s)", 1.0),
            (slice(6, 9), "position error (m)", 1.0),
        )
    ):
        rms = np.sqrt(np.mean(np.sum(err[..., block] ** 2, axis=-1), axis=1))
        ax[j].plot(t, rms * scale, label=f"Monte Carlo RMS ({runs} runs)")
        ax[j].plot(t, np.sqrt(np.sum(sig[:, block] ** 2, axis=-1)) * scale, "--", label="linear model 1-sigma")
        ax[j].set(xlabel="time (s)", title=label)
    ax[0].legend(fontsize=8)
    _save(fig, "inertial-free-errors.png")


if __name__ == "__main__":
    model = TrajectoryModel(paper_profile())
    trajectory_figure(model)
    free_inertial_figure(model)
