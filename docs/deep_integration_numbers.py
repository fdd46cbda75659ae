"""Numbers and figure of docs/experiments/deep-integration.md (about 20 s on one core).

Run: ``MPLBACKEND=Agg python docs/deep_integration_numbers.py``. Not part of CI: GNSS-only
navigator (`PvaNavigator`) experiments on constant-jerk flights, beside the runner scenario.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pymap3d

from gnssframework.receiver.deep.aided_tracking import DeepTruth, loss_of_lock, run_aided_tracking
from gnssframework.receiver.deep.navigators import PvaNavigator
from gnssframework.registry import create
from gnssframework.simulation.constellation import nominal_constellation

G = 9.80665
RUNS = 16


def flight(jerk_g_s: float, seconds: float, cn0_dbhz: float):
    """50 m/s per ENU axis from 34.23 N 108.3576 E 590.6 m, constant jerk straight up."""
    const = nominal_constellation()
    lat, lon, h = 34.23, 108.3576, 590.6
    sats = const.subset(const.visible(0.0, lat, lon, h, 10.0, 6))
    r0 = np.array(pymap3d.geodetic2ecef(lat, lon, h))
    v0 = np.array(pymap3d.enu2uvw(50.0, 50.0, 50.0, lat, lon))
    j = jerk_g_s * G * np.array(pymap3d.enu2uvw(0.0, 0.0, 1.0, lat, lon))

    def rx(t):
        return tuple(np.broadcast_to(a, (RUNS, 3)) for a in (r0 + v0 * t + j * t**3 / 6, v0 + j * t**2 / 2, j * t))

    K = int(round(seconds / 1e-3))
    clock = np.zeros((K + 1, RUNS, 2))
    clock[..., 0] = 100.0
    return DeepTruth(lambda t: sats.state(np.asarray(t)), rx, clock, cn0_dbhz, 1e-3), rx


def closed_loop(jerk_g_s: float, cn0_dbhz: float, accel_aiding: bool, seconds: float = 1.5):
    truth, rx = flight(jerk_g_s, seconds, cn0_dbhz)
    g = np.random.default_rng(8)
    P0 = np.diag([25.0] * 3 + [1.0] * 3 + [4.0] * 3)
    x0 = np.concatenate(rx(0.0), -1) + g.normal(size=(RUNS, 9)) @ np.linalg.cholesky(P0).T
    c0 = np.array([100.0, 0.0]) + g.normal(size=(RUNS, 2)) * [3.0, 0.3]
    nav = PvaNavigator(x0[:, :3], x0[:, 3:6], x0[:, 6:], P0, c0, np.diag([9.0, 0.09]),
                       jerk_psd_m2_s5=(jerk_g_s * G) ** 2 * 0.1)
    errs, times = [], []
    update = nav.update

    def recorded(t, *args):
        update(t, *args)
        errs.append(nav.x - np.concatenate(rx(t), -1))
        times.append(t)

    nav.update = recorded
    # Each interval's new information (the harness needs it: a filtered output handed over every
    # interval counts old correlators again).
    channel = create("channel_filter", "iq-filter", adapter=None, estimator="ukf", output="equivalent")
    rec = run_aided_tracking(channel, nav, truth, np.random.default_rng(5), accel_aiding=accel_aiding,
                             nco_interval_s=0.1, update_interval_s=0.1)
    return np.array(times), np.array(errs), rec


def main() -> None:
    out = Path(__file__).parent / "img"
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.6))
    for cn0 in (45.0, 35.0):
        res = {acc: closed_loop(5.0, cn0, acc) for acc in (True, False)}
        metrics = {}
        for acc, (t, e, rec) in res.items():
            keep = t >= 0.5
            metrics[acc] = {
                "position_m": np.sqrt(np.mean(e[keep][..., :3] ** 2, axis=(0, 2))),
                "velocity_m_s": np.sqrt(np.mean(e[keep][..., 3:6] ** 2, axis=(0, 2))),
                "freq_hz": np.sqrt(np.mean(rec.freq_error_hz[500:] ** 2, axis=(0, 2))),
                "code_chips": np.sqrt(np.mean(rec.code_error_chips[500:] ** 2, axis=(0, 2))),
                "loss_of_lock": loss_of_lock(rec.code_error_chips, rec.freq_error_hz, 1e-3).mean(axis=(0, 2)),
            }
            if cn0 == 45.0:
                label = "with accel aiding" if acc else "without"
                ax[0].plot(t, np.median(np.linalg.norm(e[..., 3:6], axis=-1), axis=1), label=label)
                ax[1].plot(rec.time_s[::10], np.median(np.abs(rec.freq_error_hz[::10]), axis=(1, 2)), label=label)
        for m in metrics[True]:
            d = metrics[False][m] - metrics[True][m]
            print(f"{cn0:.0f} dB-Hz {m}: accel {metrics[True][m].mean():.4g}  no-accel {metrics[False][m].mean():.4g}"
                  f"  diff {d.mean():.4g} +- {d.std(ddof=1) / np.sqrt(RUNS):.2g}")
    # GNSS-only vector tracking under a sustained 50 g/s jerk (acceleration to 75 g by 1.5 s).
    t, e, rec = closed_loop(50.0, 45.0, True)
    lol = loss_of_lock(rec.code_error_chips, rec.freq_error_hz, 1e-3).mean(axis=(0, 2))
    print(f"50 g/s, 45 dB-Hz, accel aiding: loss of lock {lol.mean():.4g} +- {lol.std(ddof=1) / np.sqrt(RUNS):.2g}, "
          f"velocity RMS per axis {np.sqrt(np.mean(e[t >= 0.5][..., 3:6] ** 2)):.4g} m/s, replica frequency RMS "
          f"{np.sqrt(np.mean(rec.freq_error_hz[500:] ** 2)):.4g} Hz, largest |frequency error| "
          f"{np.max(np.abs(rec.freq_error_hz[500:])):.4g} Hz")
    ax[0].set(xlabel="time (s)", ylabel="velocity error (m/s), median over runs", yscale="log")
    ax[1].set(xlabel="time (s)", ylabel="|replica frequency error| (Hz), median", yscale="log")
    ax[0].legend()
    fig.suptitle("GNSS-only navigator in the deep harness, 5 g/s jerk, 45 dB-Hz, NCO re-aided at 10 Hz")
    fig.tight_layout()
    fig.savefig(out / "deep-integration-accel-aiding.png", dpi=110)


if __name__ == "__main__":
    main()
