"""Reference 001 (patent CN105068097) on real data: every GPS arc of a day of CEBR.

Runs the Hatch filter, the Kalman smoother, the adaptive (ml-q) Kalman smoother and the two
slip-reset smoothers on every GPS L1 C/A arc of a Septentrio PolaRx4's 24 h file (30 s),
restarting each at the receiver's loss-of-lock flags and at gaps, and reports what can be
measured without a truth:

- ``error_rmse``: the RMS of the code error left after smoothing, measured as code minus
  carrier minus twice the ionospheric delay (which the L1/L2 carriers give up to a
  constant, 2 (phi1 - phi2) / (gamma - 1), gamma = (f1/f2)^2), minus each arc's mean: code
  noise and multipath plus what the smoother adds (its ionospheric lag); after the first
  ``SETTLE`` epochs of each arc.
- ``settle_epochs``: after an arc starts at a flagged loss of lock, the epochs until the
  5-epoch RMS of that error is within twice the RMS of the arc's settled part.
- ``false_resets``: restarts of the slip-reset smoothers (code-minus-carrier test, 4 m)
  inside an arc where the dual-frequency carriers show no jump (the geometry-free
  combination phi1 - phi2 steps by less than ``JUMP_M`` against its neighbours).

Arcs with a carrier jump the receiver did not flag are measured too: the smoothers run
through the jump (nothing restarts them but their own slip test), while the measure's
reference, which contains the carriers, restarts there: between detected jumps its
constant is the raw code's mean of the measure over that segment (the code does not slip),
so a smoother's transient after an L1 slip stays in its error.

Beside the hand-set settings of the simulated page, ``kf-tuned`` and ``adaptive-kf-tuned``
run the values examples/carrier_smoothing.toml's ``[tuning]`` found on the simulation (1 s
epochs; not tuned on this file, which has no truth and no disjoint data to tune on).

Arcs are the unit of the statistics: a candidate's value is the mean over arcs, with its
standard error, and differences between candidates are paired over the same arcs.

Run: python examples/carrier_smoothing_real.py [--file CEBR...crx.gz] [--out DIR] [--docs]
(writes ``DIR/carrier_smoothing_real.md`` and ``.json``; the default file is
``../shared/data/rinex/`` beside the repository). ``--docs`` also writes both into
``docs/experiments/generated/``, where the reference-001 page includes the table (CI runs
it so: the page's real-data numbers are this script's, never pasted).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

import gnssframework as gf
from gnssframework.experiments.stats import paired_difference
from gnssframework.io.observations import LLI_LOST_LOCK, read_observations
from gnssframework.io.smoothing import smooth_observations

ROOT = Path(__file__).resolve().parents[1]
GENERATED = ROOT / "docs" / "experiments" / "generated"
DEFAULT_FILE = ROOT.parent / "shared" / "data" / "rinex" / "CEBR00ESP_R_20182000000_01D_30S_MO.crx.gz"
F1_HZ, F2_HZ = 1575.42e6, 1227.60e6  # IS-GPS-200: L1, L2
GAMMA = (F1_HZ / F2_HZ) ** 2
SETTLE = 50  # epochs left out at each arc start (as on the simulated page)
MIN_ARC = 80  # shortest arc measured: SETTLE plus 30 settled epochs
JUMP_M = 0.10  # a geometry-free step this large against its neighbours is a real carrier jump (~0.5 L1 cycle)
SLIP_THRESHOLD_M = 4.0  # the reset smoothers' code-minus-carrier test, as on the simulated page

#: The simulated page's candidates and settings (docs/experiments/carrier-smoothing.md).
CANDIDATES = {
    "raw": None,
    "hatch": ("hatch", {"window": 100}),
    "kf": ("kf-smoother", {"q": 1e-3, "r": 1.25}),
    "adaptive-kf": (
        "kf-smoother",
        {"q": 1e-3, "r": 1.25, "adapter": "ml-q", "adapter_params": {"window": 10, "warmup": 20}},
    ),
    "hatch-slip-reset": ("hatch", {"window": 100, "slip_threshold_m": SLIP_THRESHOLD_M}),
    "kf-slip-reset": ("kf-smoother", {"q": 1e-3, "r": 1.25, "slip_threshold_m": SLIP_THRESHOLD_M}),
    # Tuned on the simulation (docs/experiments/carrier-smoothing.md, "Fair tuning"; seed 1, 24 trials).
    "kf-tuned": ("kf-smoother", {"q": 0.233, "r": 1.25}),
    "adaptive-kf-tuned": (
        "kf-smoother",
        {"q": 0.248, "r": 1.68, "adapter": "ml-q", "adapter_params": {"window": 3, "warmup": 20}},
    ),
}
#: Paired differences reported (candidate, reference), over the same arcs.
PAIRS = [(name, "kf") for name in CANDIDATES if name != "kf"] + [
    ("adaptive-kf-tuned", "kf-tuned"),
    ("adaptive-kf", "kf-tuned"),
    ("kf-tuned", "raw"),
    ("adaptive-kf-tuned", "raw"),
]


def iono_free_code_error(code_m: np.ndarray, phase1_m: np.ndarray, phase2_m: np.ndarray) -> np.ndarray:
    """Code minus carrier minus twice the L1 ionospheric delay, up to a constant per arc.

    With phi_i = r - gamma_i I + const (gamma_1 = 1, gamma_2 = gamma) and rho = r + I + e:
    rho - phi1 - 2 (phi1 - phi2) / (gamma - 1) = e + const.
    """
    return code_m - phase1_m - 2.0 * (phase1_m - phase2_m) / (GAMMA - 1.0)


def carrier_jumps(phase1_m: np.ndarray, phase2_m: np.ndarray) -> np.ndarray:
    """True where the geometry-free phase steps by more than JUMP_M against the median of
    the two steps either side (the ionosphere changes smoothly at 30 s; one jump among the
    four neighbours cannot move their median)."""
    step = np.diff(phase1_m - phase2_m)
    out = np.zeros(phase1_m.shape, bool)
    if step.size < 5:
        return out
    pad = np.concatenate([step[:1], step[:1], step, step[-1:], step[-1:]])
    n = step.size
    trend = np.median(np.stack([pad[0:n], pad[1 : n + 1], pad[3 : n + 3], pad[4 : n + 4]]), axis=0)
    out[1:] = np.abs(step - trend) > JUMP_M
    return out


def arcs_of(starts: np.ndarray, valid: np.ndarray) -> list[tuple[int, np.ndarray]]:
    """``(satellite column, epoch rows)`` of every arc."""
    out = []
    for j in range(valid.shape[1]):
        rows = np.flatnonzero(valid[:, j])
        if not rows.size:
            continue
        cuts = np.flatnonzero(starts[rows, j])
        for a, b in zip(cuts, list(cuts[1:]) + [rows.size]):
            out.append((j, rows[a:b]))
    return out


def segment_reference(raw_measure: np.ndarray, jumps: np.ndarray) -> np.ndarray:
    """Per epoch, the raw code's mean of the measure over its segment between carrier
    jumps: the measure's constant, which steps at every jump of the carriers it contains
    (the code has no slips, so its mean per segment is the constant plus its mean error)."""
    segment = np.cumsum(jumps)
    means = np.bincount(segment, weights=raw_measure) / np.bincount(segment)
    return means[segment]


def settle_epochs(error_m: np.ndarray) -> float:
    """Epochs until the 5-epoch RMS is within twice the RMS of the settled part (NaN if never)."""
    band = 2.0 * np.sqrt(np.mean(error_m[SETTLE:] ** 2))
    rms5 = np.sqrt(np.convolve(error_m**2, np.ones(5) / 5, mode="valid"))
    inside = np.flatnonzero(rms5 <= band)
    return float(inside[0]) if inside.size else np.nan


def mean_se(x) -> tuple[float, float, int]:
    x = np.asarray([v for v in x if np.isfinite(v)], float)
    if x.size < 2:
        return (float(x.mean()) if x.size else np.nan), np.nan, int(x.size)
    return float(x.mean()), float(x.std(ddof=1) / np.sqrt(x.size)), int(x.size)


def run(path: Path) -> dict:
    obs = read_observations(path, "G")
    valid = obs.valid & np.isfinite(obs.second_carrier_m)  # dual frequency needed for the metric
    obs_l1 = obs
    smoothed, resets = {}, {}
    for name, spec in CANDIDATES.items():
        if spec is None:
            continue
        kind, params = spec
        res = smooth_observations(
            obs_l1, lambda kind=kind, params=params: gf.registry.create("channel_filter", kind, **params)
        )
        smoothed[name], resets[name] = res.smoothed_m, res.slip_detected
        starts = res.arc_start  # the same for every candidate: flags and gaps
    smoothed["raw"] = obs.pseudorange_m
    flagged = (obs.lli & LLI_LOST_LOCK) != 0
    per_arc: dict[str, dict[str, list[float]]] = {n: {"error_rmse": [], "settle_epochs": []} for n in CANDIDATES}
    false_resets = {n: 0 for n in CANDIDATES}
    true_jumps_reset = {n: 0 for n in CANDIDATES}
    measured, short, jumps_total, flagged_arcs, jump_arcs = 0, 0, 0, 0, 0
    for j, rows in arcs_of(starts, obs.valid):
        rows = rows[valid[rows, j]]
        jumps = carrier_jumps(obs.carrier_m[rows, j], obs.second_carrier_m[rows, j])
        jumps_total += int(jumps.sum())
        for name in resets:
            inside = resets[name][rows, j]
            false_resets[name] += int((inside & ~jumps).sum())
            true_jumps_reset[name] += int((inside & jumps).sum())
        if rows.size < MIN_ARC:
            short += 1
            continue
        measured += 1
        jump_arcs += bool(jumps.any())
        first_flagged = bool(flagged[rows[0], j])
        flagged_arcs += first_flagged
        p1, p2 = obs.carrier_m[rows, j], obs.second_carrier_m[rows, j]
        steps = segment_reference(iono_free_code_error(obs.pseudorange_m[rows, j], p1, p2), jumps)
        for name, x in smoothed.items():
            err = iono_free_code_error(x[rows, j], p1, p2) - steps  # no jump: steps is one constant
            err = err - np.mean(err[SETTLE:])
            per_arc[name]["error_rmse"].append(float(np.sqrt(np.mean(err[SETTLE:] ** 2))))
            per_arc[name]["settle_epochs"].append(settle_epochs(err) if first_flagged else np.nan)
    summary = {
        "file": path.name,
        "satellites": int(obs.sv.size),
        "epochs": int(obs.epoch.size),
        "interval_s": obs.interval_s,
        "arcs": int(starts.sum()),
        "arcs_measured": measured,
        "arcs_not_measured": short,
        "arcs_measured_with_unflagged_jumps": jump_arcs,
        "arcs_starting_at_a_flag": flagged_arcs,
        "lli_flags": int((flagged & obs.valid).sum()),
        "lli_flags_at_gaps_or_first_epochs": int((flagged & starts & obs.valid).sum()),
        "dual_frequency_jumps_inside_arcs": jumps_total,
        "candidates": {},
        "paired": {},
    }
    for name in CANDIDATES:
        m, se, n = mean_se(per_arc[name]["error_rmse"])
        s, sse, sn = mean_se(per_arc[name]["settle_epochs"])
        summary["candidates"][name] = {
            "error_rmse_m": [m, se, n],
            "settle_epochs": [s, sse, sn],
            "false_resets": false_resets[name] if name in resets else None,
            "resets_at_carrier_jumps": true_jumps_reset[name] if name in resets else None,
        }
    for name, ref in PAIRS:
        d = np.array(per_arc[name]["error_rmse"]) - np.array(per_arc[ref]["error_rmse"])
        ds = np.array(per_arc[name]["settle_epochs"]) - np.array(per_arc[ref]["settle_epochs"])
        summary["paired"][f"{name} − {ref}"] = {
            "error_rmse_m": list(mean_se(d)),
            "settle_epochs": list(mean_se(ds)),
            "significant": {
                key: bool(paired_difference(np.array(per_arc[name][key]), np.array(per_arc[ref][key])).significant)
                for key in ("error_rmse", "settle_epochs")
            },
        }
    return summary


def _fmt(v: list, digits: int) -> str:
    m, se, n = v
    if not np.isfinite(m):
        return "-"
    return f"{m:.{digits}f} ± {se:.{digits}f}" if np.isfinite(se) else f"{m:.{digits}f}"


def _paired(d: dict, key: str, digits: int) -> str:
    """``diff ± SE (n)``, marked ``n.s.`` where the paired 95 % t-interval contains 0."""
    v = d["error_rmse_m" if key == "error_rmse" else key]
    return f"{_fmt(v, digits)} ({v[2]}{'' if d['significant'][key] else ', n.s.'})"


def markdown(s: dict) -> str:
    lines = [
        f"<!-- generated by examples/carrier_smoothing_real.py --docs from {s['file']}: do not edit -->",
        "",
        f"`{s['file']}`: {s['satellites']} GPS satellites, {s['epochs']} epochs at {s['interval_s']:g} s, "
        f"{s['arcs']} arcs ({s['lli_flags']} loss-of-lock flags, {s['lli_flags_at_gaps_or_first_epochs']} of "
        f"them at a gap or a first epoch); {s['arcs_measured']} arcs of {MIN_ARC} epochs or more with L1 and L2 "
        f"measured ({s['arcs_starting_at_a_flag']} start at a flag, "
        f"{s['arcs_measured_with_unflagged_jumps']} hold a carrier jump the receiver did not flag); "
        f"{s['dual_frequency_jumps_inside_arcs']} dual-frequency carrier jumps inside arcs.",
        "",
        "| candidate | error_rmse (m) | settle_epochs after a flag | false resets | resets at carrier jumps |",
        "| --- | --- | --- | --- | --- |",
    ]
    for name, c in s["candidates"].items():
        fr = "-" if c["false_resets"] is None else str(c["false_resets"])
        tr = "-" if c["resets_at_carrier_jumps"] is None else str(c["resets_at_carrier_jumps"])
        lines.append(f"| {name} | {_fmt(c['error_rmse_m'], 3)} | {_fmt(c['settle_epochs'], 1)} | {fr} | {tr} |")
    lines += ["", "| paired difference (same arcs) | error_rmse (m) | settle_epochs |", "| --- | --- | --- |"]
    for label, d in s["paired"].items():
        lines.append(f"| {label} | {_paired(d, 'error_rmse', 3)} | {_paired(d, 'settle_epochs', 1)} |")
    lines += [
        "",
        "Mean over arcs ± standard error (number of arcs in brackets; n.s.: the paired 95 % t-interval contains 0).",
    ]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--file", type=Path, default=DEFAULT_FILE)
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "carrier_smoothing_real")
    parser.add_argument(
        "--docs",
        action="store_true",
        help="also write the table and summary into docs/experiments/generated/ (the page includes the table)",
    )
    args = parser.parse_args(argv)
    start = time.perf_counter()
    summary = run(args.file)
    args.out.mkdir(parents=True, exist_ok=True)
    text = markdown(summary)
    for folder in (args.out, GENERATED) if args.docs else (args.out,):
        (folder / "carrier_smoothing_real.json").write_text(json.dumps(summary, indent=2) + "\n")
        (folder / "carrier_smoothing_real.md").write_text(text)
    print(text)
    print(f"wrote {args.out}/carrier_smoothing_real.md and .json ({time.perf_counter() - start:.0f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
