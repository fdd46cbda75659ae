"""Where `deep`'s NEES above its dimension comes from (docs/experiments/deep-integration.md, "`deep`'s NEES: the cause").

Run: ``python docs/deep_integration_nees_split.py`` (not in CI: several CPU-minutes; the page
says so). Runs the ``deep`` candidate of ``examples/deep_integration_ci.toml`` as it was before
the code-shrinkage fix (``iq-filter`` with the ukf's default ``alpha``) in the real scenario
(real strapdown INS, real prefilters, closed loop) on the straight 20 s flight, 12 runs, common
seeds, and records at every integration update after the settle: the range and rate handed to
``ins-ekf``, the same quantities from the truth (true minus the navigator's prediction), the
covariance handed over, and the INS error against ``ins-ekf``'s covariance after the update.
Rows: the candidate as it is; its range and/or rate replaced by truth plus white noise of
their stated covariance (a consistent, white measurement); and three prefilter variants.
Writes ``docs/experiments/generated/deep_integration_nees_split.json`` and, by `markdown`
of it, ``deep_integration_nees_split.md``. ``tests/receiver/test_deep_nees_split.py`` uses `measure`.
"""

from __future__ import annotations

import sys

import numpy as np

import gnssframework as gf
from gnssframework.estimation.consistency import nees
from gnssframework.experiments.scenarios import deep_integration_runs
from gnssframework.experiments.scenarios.deep_integration import DeepIntegrationParams, DeepIntegrationScenario
from gnssframework.receiver.deep.aiding import line_of_sight_kinematics
from gnssframework.receiver.deep.ins_navigator import InsNavigator
from experiment_tables import save, save_summary  # noqa: E402  (docs/: the generated files' writer)

SEED = 2222  # examples/deep_integration_ci.toml's
RUNS, DURATION_S, SETTLE_S = 12, 20.0, 5.0
Q = [0.001, 1e-8, 1e-5, 1e-4, 35.4]  # the CI example's tuned prefilter q


def deep_plugins(**channel) -> dict:
    """The ``deep`` candidate of examples/deep_integration_ci.toml before the fix (ukf ``alpha``
    1e-3, the default); ``channel`` overrides ``iq-filter``'s parameters."""
    params = {"estimator": "ukf", "adaptive": False, "output": "equivalent", "q": Q, **channel}
    return {
        "channel_filter": gf.registry.create("channel_filter", "iq-filter", **params),
        "nav_filter": gf.registry.create(
            "nav_filter",
            "ins-ekf",
            accel_aiding=True,
            carrier_filter={"name": "kf-carrier-loop", "params": {"states": 2, "q": [0.0, 0.001], "r": 0.05}},
        ),
    }


def measure(
    runs: int,
    duration_s: float,
    settle_s: float,
    cn0_dbhz: float = 45.0,
    profile: str = "straight",
    seed: int = SEED,
    plugins: dict | None = None,
    replace: tuple[int, ...] = (),
) -> dict[str, np.ndarray]:
    """Run ``deep`` and return, from ``settle_s`` on, per update: the handed-over errors normalised by
    their stated standard deviation ``z (U, runs, ch, 2)`` [range, rate], the same errors ``e`` and
    their stated variances ``var`` (m, m/s; same shape), the navigator's own
    (true minus predicted) range and rate ``x (U, runs, ch, 2)``, and the NEES after the update of
    position, velocity and both ``(U, runs)``.

    ``replace`` lists the components (0 range, 1 rate) handed over as the true value plus white
    Gaussian noise of the stated variance instead of the prefilter's.
    """
    scenario = DeepIntegrationScenario(
        DeepIntegrationParams(
            profile=profile,
            duration_s=duration_s,
            coherent_time_s=0.001,
            imu_interval_s=0.005,
            nco_interval_s=0.005,
            update_interval_s=0.1,
            channels=8,
            clock="ocxo",
            settle_s=settle_s,
        )
    )
    cap: dict[str, list] = {"t": [], "z": [], "e": [], "var": [], "x": [], "nees_pos": [], "nees_vel": [], "nees": []}
    original_run, original_update = deep_integration_runs.run_deep, InsNavigator.update
    noise = np.random.default_rng([seed, 99])

    def run_deep(scenario_, plugins_, flight, truth, runs_, rng, lock=None):
        def update(self, t_s, residual_m, residual_cov, los, cn0):
            self.ins.advance(t_s)
            s, sv, sa = truth.sat_state(np.asarray(t_s))
            p, v, a = self.ins.kinematics()
            rho, rate, _, _ = line_of_sight_kinematics(p, v, a, s, sv, sa, *self.clock.at(t_s))
            k = int(round(t_s / truth.coherent_time_s))
            rho_t, rate_t, _, _ = line_of_sight_kinematics(
                *truth.receiver_state(t_s), s, sv, sa, truth.clock_m[k, :, 0], truth.clock_m[k, :, 1]
            )
            true = np.stack([rho_t - rho, rate_t - rate], -1)
            sd = np.sqrt(np.diagonal(residual_cov, axis1=-2, axis2=-1))
            if replace:
                residual_m = np.array(residual_m, dtype=float)
                for i in replace:
                    residual_m[..., i] = true[..., i] + sd[..., i] * noise.normal(size=true[..., i].shape)
            original_update(self, t_s, residual_m, residual_cov, los, cn0)
            if self.updates <= self.pull_in_updates or t_s < settle_s - 1e-9:
                return
            cap["t"].append(t_s)
            cap["z"].append((residual_m - true) / sd)
            cap["e"].append(residual_m - true)
            cap["var"].append(sd**2)
            cap["x"].append(true)
            tr, st, P = flight.truth(t_s), self.ins.state, self.ekf.cov
            dv, dp = st.velocity_ecef_mps - tr.velocity_ecef_mps[0], st.position_ecef_m - tr.position_ecef_m[0]
            cap["nees_vel"].append(nees(dv, P[:, 3:6, 3:6]))
            cap["nees_pos"].append(nees(dp, P[:, 6:9, 6:9]))
            cap["nees"].append(nees(np.concatenate([dv, dp], -1), P[:, 3:9, 3:9]))

        InsNavigator.update = update
        try:
            return original_run(scenario_, plugins_, flight, truth, runs_, rng, lock)
        finally:
            InsNavigator.update = original_update

    deep_integration_runs.run_deep = run_deep
    try:
        scenario.run_batch({"cn0_dbhz": cn0_dbhz}, plugins or deep_plugins(), runs, seed)
    finally:
        deep_integration_runs.run_deep = original_run
    return {k: np.asarray(v) for k, v in cap.items()}


ROWS = {  # label: (plugin overrides, replaced components)
    "`deep`": ({}, ()),
    "range replaced by truth + white noise of its stated covariance": ({}, (0,)),
    "rate replaced the same way": ({}, (1,)),
    "both replaced": ({}, (0, 1)),
    'prefilter reset after each update (`output = "reset"`, issue 22\'s suggestion)': ({"output": "reset"}, ()),
    'code from the discriminator (`equivalent_code = "discriminator"`)': ({"equivalent_code": "discriminator"}, ()),
    'UKF spread over the prior (`estimator = { name = "ukf", params = { alpha = 1.0 } }`)': (
        {"estimator": {"name": "ukf", "params": {"alpha": 1.0}}},
        (),
    ),
}


def handed_over(m: dict[str, np.ndarray]) -> dict:
    """Normalised square and lag-1 correlation between updates, per component:
    $\\overline{z^2}$ (1 for a consistent variance) and $\\overline{z_k z_{k-1}}/\\overline{z^2}$
    (0 for errors white between updates)."""
    out = {}
    for i, name in enumerate(("range", "rate")):
        z = m["z"][..., i]
        out[name] = {
            "normalised_square": float(np.mean(z**2)),
            "lag1_correlation": float(np.mean(z[1:] * z[:-1]) / np.mean(z**2)),
            "samples": int(z.size),
        }
    return out


def range_averaging(m: dict[str, np.ndarray]) -> dict:
    """How the range errors average over the updates, and how they follow the navigator's.

    ``mean_ratio``: per run and channel, $\\bar m = \\sum_k e_k / \\sqrt{\\sum_k \\sigma_k^2}$ over the
    updates; for errors white and as stated $E[\\bar m^2] = 1$; returned is the mean of
    $\\bar m^2$ over runs and channels with its standard error. ``slope``: per run the
    least-squares slope through 0 of the error on the navigator's own range error (true minus
    predicted), $\\sum e x / \\sum x^2$ over updates and channels (0 for a measurement that
    reports the navigator's error in full, −1 for one that reports none); mean and SE over runs.
    """
    e, var, x = m["e"][..., 0], m["var"][..., 0], m["x"][..., 0]
    mbar2 = (e.sum(0) / np.sqrt(var.sum(0))) ** 2  # (runs, ch)
    per_run = np.sum(e * x, axis=(0, 2)) / np.sum(x * x, axis=(0, 2))
    return {
        "seconds": float(m["t"][-1] - m["t"][0] + (m["t"][1] - m["t"][0])),
        "mean_ratio": [float(mbar2.mean()), float(mbar2.std(ddof=1) / np.sqrt(mbar2.size))],
        "slope": list(mean_se(per_run)),
        "slope_per_run": per_run.tolist(),
    }


def summary() -> dict:
    rows = []
    for label, (channel, replace) in ROWS.items():
        m = measure(RUNS, DURATION_S, SETTLE_S, plugins=deep_plugins(**channel), replace=replace)
        row = {"label": label, **{k: m[k].mean(0).tolist() for k in ("nees", "nees_pos", "nees_vel")}}
        row["handed_over"] = handed_over(m)
        row["range_averaging"] = range_averaging(m)
        rows.append(row)
        print(label, {k: round(float(np.mean(row[k])), 3) for k in ("nees", "nees_pos", "nees_vel")}, flush=True)
    return {"runs": RUNS, "duration_s": DURATION_S, "settle_s": SETTLE_S, "seed": SEED, "rows": rows}


def mean_se(v) -> tuple[float, float]:
    """Mean and standard error $s/\\sqrt{n}$ of per-run values."""
    v = np.asarray(v, dtype=float)
    return float(v.mean()), float(v.std(ddof=1) / np.sqrt(len(v)))


def markdown(s: dict) -> str:
    """The page's table from `summary`'s dict (the committed .json)."""
    lines = [
        "<!-- generated by docs/deep_integration_nees_split.py from deep_integration_nees_split.json: do not edit -->",
        "",
        "| straight flight, 45 dB-Hz | NEES (6) | position (3) | velocity (3) | paired NEES difference to `deep` |",
        "| --- | --- | --- | --- | --- |",
    ]
    base = np.asarray(s["rows"][0]["nees"])
    for i, r in enumerate(s["rows"]):
        cells = [f"{m:.2f} ± {se:.2f}" for m, se in (mean_se(r[k]) for k in ("nees", "nees_pos", "nees_vel"))]
        d = "–" if i == 0 else "{:+.2f} ± {:.2f}".format(*mean_se(np.asarray(r["nees"]) - base))
        lines.append(f"| {r['label']} | {' | '.join(cells)} | {d} |")
    h = s["rows"][0]["handed_over"]
    lines += [
        "",
        f"Mean ± SE over the {s['runs']} runs of each run's mean over the updates from {s['settle_s']:g} s "
        f"({s['duration_s']:g} s flight, seed {s['seed']}, the same runs in every row). What `deep` hands over "
        f"(all channels and updates): range normalised square {h['range']['normalised_square']:.2f}, lag-1 "
        f"correlation between updates {h['range']['lag1_correlation']:.3f}; rate "
        f"{h['rate']['normalised_square']:.2f} and {h['rate']['lag1_correlation']:.2f}.",
    ]
    lines += [
        "",
        "| row | range error's mean over the updates: variance / stated | slope of the range error on the "
        "navigator's own |",
        "| --- | --- | --- |",
    ]
    for r in s["rows"]:
        a = r["range_averaging"]
        lines.append(
            f"| {r['label']} | {a['mean_ratio'][0]:.2f} ± {a['mean_ratio'][1]:.2f} | "
            f"{a['slope'][0]:+.3f} ± {a['slope'][1]:.3f} |"
        )
    lines += [
        "",
        f"Variance ratio: per run and channel, the sum of the range errors over the "
        f"{s['rows'][0]['range_averaging']['seconds']:g} s of updates over the square root of the sum of their "
        "stated variances, squared (1 for white errors as stated); mean ± SE over runs × channels. Slope: least "
        "squares through 0 per run (0: the measurement reports the navigator's error in full); mean ± SE over runs.",
    ]
    return "\n".join(lines) + "\n"


def main() -> None:
    s = summary()
    save_summary("deep_integration_nees_split", s, indent=1)
    save("deep_integration_nees_split.md", markdown(s))
    sys.stdout.write(markdown(s))


if __name__ == "__main__":
    main()
