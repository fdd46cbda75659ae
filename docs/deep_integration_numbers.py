"""Numbers and figure of docs/experiments/deep-integration.md.

Run: ``MPLBACKEND=Agg python docs/deep_integration_numbers.py`` (CI's real-files-and-figures
lane runs it). GNSS-only navigator (`PvaNavigator`) experiments on constant-jerk flights,
beside the runner scenario, and the replica's own error with a perfect navigator. Writes
``docs/experiments/generated/deep_integration_numbers.json`` (the numbers) and, rendered from
it by `closed_loop_markdown`, `sustained_jerk_markdown` and `first_number_markdown`, the
page's tables ``deep_integration_accel_closed_loop.md``, ``deep_integration_sustained_jerk.md``
and ``deep_integration_accel_first_number.md``.
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
from experiment_tables import save, save_summary  # noqa: E402  (docs/: the generated files' writer)

G = 9.80665
RUNS = 16
METRICS = {  # key: (label, digits)
    "position_m": ("position error RMS per ECEF axis (m)", 3),
    "velocity_m_s": ("velocity error RMS per axis (m/s)", 3),
    "freq_hz": ("replica frequency error RMS (Hz)", 3),
    "code_chips": ("replica code error RMS (chip)", 2),
}


def flight(jerk_g_s: float, seconds: float, cn0_dbhz: float, runs: int = RUNS):
    """50 m/s per ENU axis from 34.23 N 108.3576 E 590.6 m, constant jerk straight up."""
    const = nominal_constellation()
    lat, lon, h = 34.23, 108.3576, 590.6
    sats = const.subset(const.visible(0.0, lat, lon, h, 10.0, 6))
    r0 = np.array(pymap3d.geodetic2ecef(lat, lon, h))
    v0 = np.array(pymap3d.enu2uvw(50.0, 50.0, 50.0, lat, lon))
    j = jerk_g_s * G * np.array(pymap3d.enu2uvw(0.0, 0.0, 1.0, lat, lon))

    def rx(t):
        return tuple(np.broadcast_to(a, (runs, 3)) for a in (r0 + v0 * t + j * t**3 / 6, v0 + j * t**2 / 2, j * t))

    K = int(round(seconds / 1e-3))
    clock = np.zeros((K + 1, runs, 2))
    clock[..., 0] = 100.0
    return DeepTruth(lambda t: sats.state(np.asarray(t)), rx, clock, cn0_dbhz, 1e-3), rx


def closed_loop(jerk_g_s: float, cn0_dbhz: float, accel_aiding: bool, seconds: float = 1.5):
    truth, rx = flight(jerk_g_s, seconds, cn0_dbhz)
    g = np.random.default_rng(8)
    P0 = np.diag([25.0] * 3 + [1.0] * 3 + [4.0] * 3)
    x0 = np.concatenate(rx(0.0), -1) + g.normal(size=(RUNS, 9)) @ np.linalg.cholesky(P0).T
    c0 = np.array([100.0, 0.0]) + g.normal(size=(RUNS, 2)) * [3.0, 0.3]
    nav = PvaNavigator(
        x0[:, :3], x0[:, 3:6], x0[:, 6:], P0, c0, np.diag([9.0, 0.09]), jerk_psd_m2_s5=(jerk_g_s * G) ** 2 * 0.1
    )
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
    rec = run_aided_tracking(
        channel,
        nav,
        truth,
        np.random.default_rng(5),
        accel_aiding=accel_aiding,
        nco_interval_s=0.1,
        update_interval_s=0.1,
    )
    return np.array(times), np.array(errs), rec


class TruthNavigator:
    """A perfect navigator: predicts the true kinematics and clock, ignores its updates (open loop)."""

    def __init__(self, rx, clock: tuple[float, float] = (100.0, 0.0)) -> None:
        self.rx, self.clock = rx, clock

    def kinematics(self, t):
        p, v, a = self.rx(t)
        return p, v, a, self.clock[0], self.clock[1]

    def update(self, t, res, cov, los, cn0) -> None:
        pass


def first_number(seconds: float = 0.6, jerk_g_s: float = 50.0, cn0_dbhz: float = 45.0) -> dict:
    """Replica error with a perfect navigator under a constant jerk, per NCO interval and aiding.

    RMS over all epochs, runs and channels; ``spread_*`` is the largest difference between
    runs' RMS (0 when the replica's error is deterministic, as a perfect navigator makes it).
    """
    out = {"seconds": seconds, "jerk_g_s": jerk_g_s, "cn0_dbhz": cn0_dbhz, "rows": []}
    for nco in (0.005, 0.1):
        row = {"nco_interval_s": nco}
        for acc in (True, False):
            truth, rx = flight(jerk_g_s, seconds, cn0_dbhz)
            channel = create("channel_filter", "iq-filter", adapter=None, estimator="ukf", output="equivalent")
            rec = run_aided_tracking(
                channel,
                TruthNavigator(rx),
                truth,
                np.random.default_rng(5),
                accel_aiding=acc,
                nco_interval_s=nco,
                update_interval_s=0.1,
            )
            key = "accel" if acc else "no_accel"
            f_run = np.sqrt(np.mean(rec.freq_error_hz**2, axis=(0, 2)))
            c_run = np.sqrt(np.mean(rec.code_error_chips**2, axis=(0, 2)))
            row[key] = {
                "freq_hz": float(np.sqrt(np.mean(rec.freq_error_hz**2))),
                "code_chips": float(np.sqrt(np.mean(rec.code_error_chips**2))),
                "spread_freq_hz": float(np.ptp(f_run)),
                "spread_code_chips": float(np.ptp(c_run)),
                "lost_lock": int(loss_of_lock(rec.code_error_chips, rec.freq_error_hz, 1e-3).sum()),
            }
        out["rows"].append(row)
    return out


def _se(d) -> float:
    d = np.asarray(d)
    return float(d.std(ddof=1) / np.sqrt(len(d)))


def closed_loop_markdown(s: dict) -> str:
    """Table of the closed-loop acceleration-aiding comparison from the summary `main` writes."""
    lines = [
        "<!-- generated by docs/deep_integration_numbers.py from deep_integration_numbers.json: do not edit -->",
        "",
        "| C/N0 | metric | with acceleration aiding | without | difference without − with ± SE |",
        "| --- | --- | --- | --- | --- |",
    ]
    for cn0, c in s["closed_loop"].items():
        for m, (label, digits) in METRICS.items():
            a, b = np.asarray(c["accel"][m]), np.asarray(c["no_accel"][m])
            d = b - a
            lines.append(
                f"| {cn0} dB-Hz | {label} | {a.mean():.{digits}g} | {b.mean():.{digits}g} | "
                f"{d.mean():.{digits}g} ± {_se(d):.2g} |"
            )
    lost = {
        cn0: {k: int(np.count_nonzero(np.asarray(c[k]["loss_of_lock"]) > 0)) for k in ("accel", "no_accel")}
        for cn0, c in s["closed_loop"].items()
    }
    lines += [
        "",
        f"{s['runs']} runs per setting, common random numbers; mean over runs of each run's RMS; paired "
        "difference ± standard error over runs. Runs with a channel-epoch out of lock (with / without): "
        + ", ".join(f"{v['accel']} / {v['no_accel']} at {cn0} dB-Hz" for cn0, v in lost.items())
        + ".",
    ]
    return "\n".join(lines) + "\n"


def sustained_jerk_markdown(s: dict) -> str:
    """One-line summary of the 50 g/s sustained-jerk run (GNSS-only navigator, accel aiding)."""
    j = s["sustained_jerk"]
    lol = np.asarray(j["loss_of_lock"])
    return (
        "<!-- generated by docs/deep_integration_numbers.py from deep_integration_numbers.json: do not edit -->\n\n"
        f"Runs with a channel-epoch out of lock: {int(np.count_nonzero(lol > 0))} of {len(lol)} (fraction of "
        f"channel-epochs {lol.mean():.3g} ± {_se(lol):.2g}); velocity error {j['velocity_rms_m_s']:.2f} m/s RMS per "
        f"axis; replica frequency error {j['freq_rms_hz']:.2g} Hz RMS, largest {j['freq_max_hz']:.2g} Hz.\n"
    )


def first_number_markdown(s: dict) -> str:
    """Table of the replica's error with a perfect navigator, from the summary `main` writes."""
    f = s["first_number"]
    lines = [
        "<!-- generated by docs/deep_integration_numbers.py from deep_integration_numbers.json: do not edit -->",
        "",
        "| NCO interval | frequency error RMS, with / without acceleration aiding | code error RMS (chip), "
        "with / without | largest difference between runs (Hz, chip) | channel-epochs out of lock |",
        "| --- | --- | --- | --- | --- |",
    ]
    for r in f["rows"]:
        a, b = r["accel"], r["no_accel"]
        spread_f = max(a["spread_freq_hz"], b["spread_freq_hz"])
        spread_c = max(a["spread_code_chips"], b["spread_code_chips"])
        lines.append(
            f"| {r['nco_interval_s'] * 1e3:g} ms | {a['freq_hz']:.2g} Hz / {b['freq_hz']:.3g} Hz | "
            f"{a['code_chips']:.1e} / {b['code_chips']:.1e} | {spread_f:.1e}, {spread_c:.1e} | "
            f"{a['lost_lock']} / {b['lost_lock']} |"
        )
    return "\n".join(lines) + "\n"


RENDER = {
    "deep_integration_accel_closed_loop.md": closed_loop_markdown,
    "deep_integration_sustained_jerk.md": sustained_jerk_markdown,
    "deep_integration_accel_first_number.md": first_number_markdown,
}


def main() -> None:
    out = Path(__file__).parent / "img"
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.6))
    summary: dict = {"runs": RUNS, "closed_loop": {}}
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
        summary["closed_loop"][f"{cn0:.0f}"] = {
            ("accel" if acc else "no_accel"): {k: v.tolist() for k, v in m.items()} for acc, m in metrics.items()
        }
        for m in metrics[True]:
            d = metrics[False][m] - metrics[True][m]
            print(
                f"{cn0:.0f} dB-Hz {m}: accel {metrics[True][m].mean():.4g}  no-accel {metrics[False][m].mean():.4g}"
                f"  diff {d.mean():.4g} +- {d.std(ddof=1) / np.sqrt(RUNS):.2g}"
            )
    # GNSS-only vector tracking under a sustained 50 g/s jerk (acceleration to 75 g by 1.5 s).
    t, e, rec = closed_loop(50.0, 45.0, True)
    lol = loss_of_lock(rec.code_error_chips, rec.freq_error_hz, 1e-3).mean(axis=(0, 2))
    print(
        f"50 g/s, 45 dB-Hz, accel aiding: loss of lock {lol.mean():.4g} +- {lol.std(ddof=1) / np.sqrt(RUNS):.2g}, "
        f"velocity RMS per axis {np.sqrt(np.mean(e[t >= 0.5][..., 3:6] ** 2)):.4g} m/s, replica frequency RMS "
        f"{np.sqrt(np.mean(rec.freq_error_hz[500:] ** 2)):.4g} Hz, largest |frequency error| "
        f"{np.max(np.abs(rec.freq_error_hz[500:])):.4g} Hz"
    )
    summary["sustained_jerk"] = {
        "jerk_g_s": 50.0,
        "cn0_dbhz": 45.0,
        "loss_of_lock": lol.tolist(),
        "velocity_rms_m_s": float(np.sqrt(np.mean(e[t >= 0.5][..., 3:6] ** 2))),
        "freq_rms_hz": float(np.sqrt(np.mean(rec.freq_error_hz[500:] ** 2))),
        "freq_max_hz": float(np.max(np.abs(rec.freq_error_hz[500:]))),
    }
    summary["first_number"] = first_number()
    save_summary("deep_integration_numbers", summary, indent=1)
    for name, render in RENDER.items():
        save(name, render(summary))
        print(render(summary))
    ax[0].set(xlabel="time (s)", ylabel="velocity error (m/s), median over runs", yscale="log")
    ax[1].set(xlabel="time (s)", ylabel="|replica frequency error| (Hz), median", yscale="log")
    ax[0].legend()
    fig.suptitle("GNSS-only navigator in the deep harness, 5 g/s jerk, 45 dB-Hz, NCO re-aided at 10 Hz")
    fig.tight_layout()
    fig.savefig(out / "deep-integration-accel-aiding.png", dpi=110)


if __name__ == "__main__":
    main()
