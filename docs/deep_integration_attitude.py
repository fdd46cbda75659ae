"""Evidence for the attitude maximum of docs/experiments/deep-integration.md (about 2 min on one core).

Run: ``python docs/deep_integration_attitude.py``; it writes
``docs/experiments/generated/deep_integration_attitude.json`` (the numbers) and ``.md`` (the
page's table, `markdown` of the json). Not in CI (over 1.5 CPU-minutes). Re-runs the ``deep`` candidate of
``examples/deep_integration.toml``, case ``45dBHz``, with the runner's own random numbers
(so its runs are the example's), and prints per run: the post-settle maximum of the attitude
error, the axis (roll, pitch, yaw) and the time where it falls, the filter's own 1-sigma
uncertainty of the down-axis misalignment (heading) at that time, and the largest error
from the boost (10 s) on. Then the same runs (same draws, common random numbers) with the
initial attitude error scaled from 0.5 to 0.1 deg per axis, and the paired difference.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from gnssframework.experiments.config import load_config
from gnssframework.random_streams import name_key, run_streams
from gnssframework.experiments.scenarios import get_scenario
from gnssframework.inertial.frames import ned_to_ecef_matrix
from gnssframework.experiments.scenarios.deep_integration_metrics import attitude_errors_deg
from gnssframework.experiments.scenarios.deep_integration_runs import run_deep
from experiment_tables import save, save_summary  # noqa: E402  (docs/: the generated files' writer)

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "deep_integration.toml"
AXES = ("roll", "pitch", "yaw")


STORE = Path(__file__).resolve().parents[1] / "results" / "deep_integration_attitude" / "tuning.sqlite"


def tuned_deep(config):
    """``config``'s ``deep`` candidate at the values the example's ``[tuning]`` gives it.

    The tuner seeds each candidate's sampler by (seed, candidate, trial) and runs each trial as
    the candidate alone (`gnssframework.experiments.tuning.trial_config`), so tuning ``deep``
    alone reproduces the example's tuned ``deep`` (its summary's tuning table). Returns the
    candidate and its tuning result; the trials are kept in ``STORE`` (resumes).
    """
    from gnssframework.experiments.runner import _execute
    from gnssframework.experiments.store import ResultStore
    from gnssframework.experiments.tuning import tune, tuned_config

    data = config.model_dump(mode="json", exclude={"sweeps", "claims", "published"}, exclude_none=True)
    data["candidates"] = [c for c in data["candidates"] if c["name"] == "deep"]
    data["tuning"]["free"] = [f for f in data["tuning"]["free"] if f["path"].split(".")[1] == "deep"]
    data["reference"] = None
    alone = type(config).model_validate(data)
    result = tune(alone, ResultStore(STORE), STORE.parent, lambda jobs: _execute(jobs, alone.executor))
    return next(c for c in tuned_config(alone, result).candidates if c.name == "deep"), result["deep"]


def deep_attitude(initial_attitude_std_deg: float | None = None, cand=None) -> dict[str, np.ndarray]:
    config = load_config(EXAMPLE)
    params = dict(config.scenario)
    if initial_attitude_std_deg is not None:
        params["initial_attitude_std_deg"] = initial_attitude_std_deg
    scenario = get_scenario(params)
    cand = cand or tuned_deep(config)[0]
    plugins = scenario.build(cand.components())
    case_index = next(i for i, c in enumerate(config.cases) if c.name == "45dBHz")
    runs = config.runs
    rng = run_streams(config.seed, name_key("45dBHz"), range(runs))  # the runner's streams of runs 0..runs-1
    flight = scenario.flight()
    truth = scenario._truth(flight, config.cases[case_index].params()["cn0_dbhz"], runs, rng)
    out = run_deep(scenario, plugins, flight, truth, runs, rng)
    t = out["time_s"]
    truth_dcm = np.broadcast_to(flight.body_to_ned(t)[:, None], out["body_to_ned"].shape)
    err = attitude_errors_deg(out["body_to_ned"], truth_dcm)  # (U, runs, 3)
    lat, lon, _ = _geodetic(out["position_m"])
    c_n_e = np.swapaxes(ned_to_ecef_matrix(lat, lon), -1, -2)
    p_ned = c_n_e @ out["attitude_cov_ecef"] @ np.swapaxes(c_n_e, -1, -2)
    sigma_deg = np.degrees(np.sqrt(np.diagonal(p_ned, axis1=-2, axis2=-1)))  # (U, runs, 3): N, E, D
    return {"time_s": t, "error_deg": err, "sigma_ned_deg": sigma_deg, "settle_s": scenario.params.settle_s}


def _geodetic(r):
    import pymap3d

    return pymap3d.ecef2geodetic(r[..., 0], r[..., 1], r[..., 2])


def summarise(res: dict[str, np.ndarray]) -> dict:
    """Per run: the post-settle maximum of max(|roll|, |pitch|, |yaw|) error, its axis and time,
    the filter's heading (down-axis) 1-sigma there, and the maxima from 10 s and 15 s on."""
    t, err, sig = res["time_s"], res["error_deg"], res["sigma_ned_deg"]
    keep = t >= res["settle_s"]
    worst = np.max(np.abs(err), axis=-1)  # the metric's series: largest of |roll|, |pitch|, |yaw|
    runs = []
    for r in range(err.shape[1]):
        k = np.flatnonzero(keep)[np.argmax(worst[keep, r])]
        axis = int(np.argmax(np.abs(err[k, r])))
        runs.append(
            {
                "max_deg": float(worst[k, r]),
                "axis": AXES[axis],
                "time_s": float(t[k]),
                "heading_sigma_deg": float(sig[k, r, 2]),
                "roll_pitch_sigma_deg": [float(sig[k, r, 0]), float(sig[k, r, 1])],
                "max_from_10s_deg": float(np.max(worst[t >= 10.0, r])),
                "max_from_15s_deg": float(np.max(worst[t >= 15.0, r])),
            }
        )
    before = t < 10.0
    return {
        "runs": runs,
        "heading_sigma_5_10s_deg": float(np.mean(sig[keep & before][..., 2])),
        "heading_sigma_from_15s_deg": float(np.mean(sig[t >= 15.0][..., 2])),
    }


def paired(a: list[float], b: list[float]) -> tuple[float, float]:
    """Mean and standard error of the paired differences a - b: ``(mean(d), std(d, ddof=1)/sqrt(n))``."""
    d = np.asarray(a) - np.asarray(b)
    return float(d.mean()), float(d.std(ddof=1) / np.sqrt(len(d)))


def half_normal_mean_sd(sigma: float) -> tuple[float, float]:
    """Mean and standard deviation of $|N(0, \\sigma^2)|$: $\\sigma\\sqrt{2/\\pi}$ and
    $\\sigma\\sqrt{1 - 2/\\pi}$ (the half-normal distribution)."""
    return sigma * float(np.sqrt(2 / np.pi)), sigma * float(np.sqrt(1 - 2 / np.pi))


def markdown(s: dict) -> str:
    """The page's table from the summary `main` writes (its .json)."""
    lines = [
        "<!-- generated by docs/deep_integration_attitude.py from deep_integration_attitude.json: do not edit -->",
        "",
        f"`deep`, case `45dBHz` of `examples/deep_integration.toml`, its {len(s['nominal']['runs'])} runs "
        f"(the runner's random numbers), initial attitude error {s['nominal_std_deg']:g} deg per axis, at its tuned "
        + ", ".join(f"`{k}` = {v:.3g}" for k, v in s["tuned"].items())
        + ":",
        "",
        "| run | post-settle max (deg) | axis, time | filter 1-sigma heading there (deg) | max from 15 s (deg) |",
        "| --- | --- | --- | --- | --- |",
    ]
    for i, r in enumerate(s["nominal"]["runs"]):
        lines.append(
            f"| {i} | {r['max_deg']:.2f} | {r['axis']}, {r['time_s']:.1f} s | {r['heading_sigma_deg']:.2f} "
            f"| {r['max_from_15s_deg']:.3f} |"
        )
    a = [r["max_deg"] for r in s["nominal"]["runs"]]
    b = [r["max_deg"] for r in s["scaled"]["runs"]]
    m, se = paired(a, b)
    lines += [
        "",
        f"Mean of the maxima {np.mean(a):.2f} deg; filter heading 1-sigma {s['nominal']['heading_sigma_5_10s_deg']:.2f} "
        f"deg on average at 5-10 s, {s['nominal']['heading_sigma_from_15s_deg']:.4f} deg from 15 s. The same draws "
        f"scaled to {s['scaled_std_deg']:g} deg per axis: mean maximum {np.mean(b):.2f} deg; paired difference "
        f"{m:.2f} ± {se:.2f} deg (mean ± SE over the {len(a)} runs).",
    ]
    hm, hs = half_normal_mean_sd(s["nominal_std_deg"])
    lines += [
        "",
        f"A maximum equal to the initial heading error would be a draw of |N(0, {s['nominal_std_deg']:g} deg)|: "
        f"mean {hm:.2f} deg, standard deviation {hs:.2f} deg; the {len(a)} runs' mean is "
        f"{(np.mean(a) - hm) / (hs / np.sqrt(len(a))):.1f} standard errors from it. Roll and pitch 1-sigma at the "
        f"maxima: {min(min(r['roll_pitch_sigma_deg']) for r in s['nominal']['runs']):.3f}-"
        f"{max(max(r['roll_pitch_sigma_deg']) for r in s['nominal']['runs']):.3f} deg.",
    ]
    return "\n".join(lines) + "\n"


def main() -> None:
    """Tune ``deep`` as the example does, run both initial errors, write the .json and the .md."""
    nominal = float(get_scenario(dict(load_config(EXAMPLE).scenario)).params.initial_attitude_std_deg)
    cand, tuning = tuned_deep(load_config(EXAMPLE))
    summary = {
        "nominal_std_deg": nominal,
        "scaled_std_deg": 0.1,
        "tuned": tuning["best"],
        "nominal": summarise(deep_attitude(cand=cand)),
        "scaled": summarise(deep_attitude(0.1, cand=cand)),
    }
    save_summary("deep_integration_attitude", summary)
    text = markdown(summary)
    save("deep_integration_attitude.md", text)
    sys.stdout.write(text)


if __name__ == "__main__":
    main()
