"""Run the four reference comparisons (and the sweep demo) and copy their figures into docs/img/experiments/.

    python docs/make_experiment_plots.py            # what CI runs
    python docs/make_experiment_plots.py --slow     # also the reference-000 C/N0 sweep (~6 min on 2 cores)
    python docs/make_experiment_plots.py --retune   # tune the tuned examples again, rewrite their records
    python docs/make_experiment_plots.py --all-figures   # every figure of every report, not only the docs'
    python docs/make_experiment_plots.py NAME ...   # these examples only
    python docs/make_experiment_plots.py --part 1/2 # the first of two parts of equal cost (CI's lanes)
    python docs/make_experiment_plots.py --ci-stores # those CI's comparisons made (after them)
    python docs/make_experiment_plots.py --replicate # every claim also on a second, disjoint seed set

Only the figures a docs page shows (``img/experiments/<name>-<plot>.png`` named in a page
under docs/) are drawn and copied: drawing is most of this script's time once the stores
are finished (constrained layouts, log axes), and most report figures are read in
``results/<name>/report.md``, not on a page. ``--all-figures`` draws them all.

Each comparison writes to results/<name>/ and resumes from its store, so a run that
the README's main job already made is not repeated. A tuned example with a record of its
tuning (examples/trials/<name>.json, `gnssframework.experiments.trial_record`) is evaluated
at the values that tuning selected, its trials not rerun: CI checks its claims without paying
for its tuning. ``--retune`` runs every tuning whole and writes the records anew (a tuned
example without a record gets one on its first run); tests/experiments/test_committed_trial_records.py
says when a record has gone stale.
"""

from __future__ import annotations

import pathlib
import shutil
import sys
import time

from gnssframework.experiments import load_config, run_comparison
from gnssframework.experiments.trial_record import TRIALS_FILE

ROOT = pathlib.Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "img" / "experiments"
#: The tuned examples' trial records (what their full tuning ran and selected).
RECORDS = ROOT / "examples" / "trials"
#: Tuned by the README's main job in CI (its store reused here): no record. Empty since CI
#: evaluates the main job from its record too (examples/trials/vector_tracking.json).
TUNED_BY_MAIN_JOB: tuple[str, ...] = ()
EXAMPLES = (
    "vector_tracking",
    "carrier_smoothing",
    "scintillation",
    "multipath",
    "sweep_demo",
    "carrier_smoothing_sweep",
    "scintillation_sweep",
    "deep_integration_ci",
    "deep_integration_elevation_ci",
    "deep_integration_lock_ci",
    "deep_integration_lock_control_ci",
    "sample_receiver",
    "deep_integration_nees_ci",
    "deep_integration_error_sources_ci",
    "vector_tracking_spacing",
    "vector_tracking_fade_ci",
    "deep_integration_error_sources",
    "deep_integration_lock_bandwidth",
    "tracking_threshold",
    "tracking_threshold_oscillator",
    "tracking_threshold_oscillator_tuned",
    "tracking_threshold_cn0_lock",
    "vector_tracking_realistic",
    "deep_integration_realistic_ci",
    "deep_integration_threshold_ci",
    "scintillation_rate_lock",
    "deep_integration_budget_ins_straight_ci",
)
#: The examples whose stores CI's comparisons make first (``.ci/run`` compares each into
#: results/<name>/): this script only draws their figures and writes their tables, after those
#: comparisons (``--ci-stores``); ``--part`` splits the others, which CI runs beside them.
CI_STORES = (
    "vector_tracking",
    "vector_tracking_realistic",
    "vector_tracking_fade_ci",
    "deep_integration_realistic_ci",
    "deep_integration_ci",
    "deep_integration_elevation_ci",
    "deep_integration_lock_ci",
    "deep_integration_lock_control_ci",
    "sample_receiver",
)
#: Seconds each example not in `CI_STORES` cost this script in CI (its run of dfcaeba on
#: 2 cores), for ``--part``'s balance. An example missing here counts as 0; a stale number only
#: unbalances the lanes, it changes no result.
CI_COST_S = {
    "deep_integration_nees_ci": 259,
    "scintillation": 224,
    "multipath": 116,
    "deep_integration_lock_bandwidth": 68,
    "deep_integration_error_sources": 55,
    "scintillation_sweep": 51,
    "scintillation_rate_lock": 40,
    "tracking_threshold": 43,
    "tracking_threshold_cn0_lock": 42,
    "deep_integration_budget_ins_straight_ci": 35,
    "deep_integration_threshold_ci": 70,
    "tracking_threshold_oscillator": 70,
    "tracking_threshold_oscillator_tuned": 40,
    "carrier_smoothing_sweep": 29,
    "deep_integration_error_sources_ci": 29,
    "vector_tracking_spacing": 22,
    "carrier_smoothing": 20,
    "sweep_demo": 9,
}
#: Examples whose claims this script always re-checks on the replicate runs (a second,
#: disjoint seed set, as ``compare --check --replicate``): those cheap enough for CI's budget.
#: ``--replicate`` does it for every example selected (the pages give what that found).
REPLICATED = ("carrier_smoothing",)
#: Too slow for CI; their committed figures are regenerated with --slow.
SLOW_EXAMPLES = ("vector_tracking_sweep", "deep_integration", "vector_tracking_static", "vector_tracking_moving")
#: Examples whose page includes tables generated from the run (docs/experiment_tables.py), with the
#: metrics their results tables list (None: every metric of the example, in its order).
#: The main example's metrics, in its order (the slow one-motion tunings share them).
_VECTOR_TRACKING_TABLE = [
    "code_phase_error_rmse",
    "carrier_freq_error_rmse",
    "position_error_rmse",
    "velocity_error_rmse",
    "position_steady_error_rmse",
    "nees",
    "nees_position",
    "nees_velocity",
    "code_output_rmse",
    "freq_output_rmse",
]
TABLES = {
    "vector_tracking": _VECTOR_TRACKING_TABLE,
    "vector_tracking_realistic": _VECTOR_TRACKING_TABLE,
    "vector_tracking_static": _VECTOR_TRACKING_TABLE,
    "vector_tracking_moving": _VECTOR_TRACKING_TABLE,
    # The full reference-002 run (--slow): every metric of the example (None).
    "deep_integration": None,
}
#: Sweep examples whose page includes their sweep tables (docs/sweep_tables.py).
SWEEP_TABLES = {
    "vector_tracking_sweep": [
        "carrier_freq_error_rmse",
        "velocity_error_rmse",
        "position_error_rmse",
        "nees_position",
        "nees_velocity",
        "freq_output_rmse",
        "pcrb_position",
        "pcrb_velocity",
    ]
}
#: Sweeps of the correlator spacing whose page includes the theory table (docs/spacing_tables.py).
SPACING_TABLES = ("vector_tracking_spacing",)
#: Examples whose page includes the paper's values beside theirs (docs/published_tables.py).
PUBLISHED_TABLES = {"vector_tracking": ["ackf-literal", "discriminator-fixed-r"]}
TABLES["deep_integration_ci"] = [
    "horizontal_position_error_rmse",
    "height_error_rmse",
    "horizontal_velocity_error_rmse",
    "vertical_velocity_error_rmse",
    "attitude_error_rmse",
    "loss_of_lock_fraction",
    "nees",
]
TABLES["deep_integration_elevation_ci"] = TABLES["deep_integration_ci"]
TABLES["deep_integration_realistic_ci"] = TABLES["deep_integration_ci"]
TABLES["deep_integration_lock_ci"] = [
    "loss_of_lock_fraction",
    "phase_lock_loss_fraction",
    "cycle_slip_rate",
    "phase_tracking_error_rmse",
    "freq_tracking_error_rmse",
    "code_tracking_error_rmse",
]
TABLES["deep_integration_lock_control_ci"] = TABLES["deep_integration_lock_ci"]
TABLES["deep_integration_lock_bandwidth"] = TABLES["deep_integration_lock_ci"]
TABLES["sample_receiver"] = [
    "horizontal_error_rms",
    "vertical_error_rms",
    "time_to_first_fix_s",
    "fix_fraction",
    "channels_locked",
    "false_channels_locked",
    "cn0_error_rms_db",
]
TABLES["deep_integration_nees_ci"] = [
    "horizontal_position_error_rmse",
    "height_error_rmse",
    "horizontal_velocity_error_rmse",
    "vertical_velocity_error_rmse",
    "code_tracking_error_rmse",
    "loss_of_lock_fraction",
    "nees",
]
TABLES["deep_integration_error_sources_ci"] = [
    "horizontal_position_error_rmse",
    "height_error_rmse",
    "horizontal_velocity_error_rmse",
    "vertical_velocity_error_rmse",
    "attitude_error_rmse",
    "freq_tracking_error_rmse",
    "code_tracking_error_rmse",
    "loss_of_lock_fraction",
    "nees",
]
TABLES["deep_integration_error_sources"] = TABLES["deep_integration_error_sources_ci"]
# Issue 42: the IMU's calibration states in a straight flight.
TABLES["deep_integration_budget_ins_straight_ci"] = [
    "horizontal_position_error_rmse",
    "height_error_rmse",
    "horizontal_velocity_error_rmse",
    "vertical_velocity_error_rmse",
    "nees",
]
# Reference 004 (docs/experiments/multipath.md): its cases' tables and its psi sweep's
# (written to multipath_sweep.md: an example in both lists gets <name>_sweep.md for its sweeps).
_MULTIPATH_TABLE = [
    "horizontal_error_rmse",
    "lat_error_mean",
    "lat_error_rmse",
    "lon_error_mean",
    "lon_error_rmse",
    "convergence_epoch",
]
TABLES["multipath"] = _MULTIPATH_TABLE
SWEEP_TABLES["multipath"] = ["horizontal_error_rmse"]
# Reference 003 (scintillation): the main example and its sweeps.
TABLES["scintillation"] = ["phase_error_rmse", "loss_of_lock_fraction", "discriminator_std", "equivalent_bandwidth_hz"]
SWEEP_TABLES["scintillation_sweep"] = ["phase_error_rmse", "loss_of_lock_fraction"]
TABLES["scintillation_rate_lock"] = ["phase_error_rmse", "loss_of_lock_fraction"]
# Reference 001 (carrier smoothing): the main example's metrics and its slip-rate sweep's.
TABLES["carrier_smoothing"] = ["error_rmse", "slip_recovery_epochs", "censored_slips", "false_reset_rate"]
SWEEP_TABLES["carrier_smoothing_sweep"] = ["error_rmse", "slip_recovery_epochs", "false_reset_rate"]
# Issue 40 (tracking thresholds): lock along the C/N0 sweep and the receiver's own C/N0 reading there.
# Issues 40 and 42: the same loops with a receiver oscillator (the ideal clock its control).
SWEEP_TABLES["tracking_threshold_oscillator"] = ["loss_of_lock", "phase_jitter_rad"]
# ... and each loop tuned for its threshold under the GNSS-grade TCXO by the same rule.
SWEEP_TABLES["tracking_threshold_oscillator_tuned"] = ["loss_of_lock", "phase_jitter_rad"]
SWEEP_TABLES["deep_integration_threshold_ci"] = ["loss_of_lock_fraction", "phase_lock_loss_fraction"]
# ... and the threshold the receiver reads off its own C/N0 test, per declare rule and estimator.
SWEEP_TABLES["tracking_threshold_cn0_lock"] = ["loss_of_lock_by_cn0", "cn0_estimate_error_db"]
SWEEP_TABLES["tracking_threshold"] = [
    "loss_of_lock",
    "loss_of_code_freq_lock",
    "cn0_estimate_error_db",
    "loss_of_lock_by_cn0",
]


def docs_figures() -> str:
    """Every docs page's text, where a figure this script copies is looked up by name."""
    return "\n".join(page.read_text(encoding="utf-8") for page in sorted((ROOT / "docs").rglob("*.md")))


def selected(argv: list[str]) -> tuple[str, ...]:
    """The examples to run: those named on the command line (each must be one of the
    lists above), else every CI example (and the slow ones with ``--slow``). With
    ``--part K/N``, the K-th of N parts of about equal cost (`balanced_parts`) of those not
    in `CI_STORES`; with ``--ci-stores``, those in it. CI runs ``--part 1/2`` and
    ``--part 2/2`` beside its comparisons, ``--ci-stores`` after them: together, the whole
    list, and no two processes on one store."""
    known = EXAMPLES + SLOW_EXAMPLES
    names = tuple(a for i, a in enumerate(argv) if not a.startswith("--") and (i == 0 or argv[i - 1] != "--part"))
    unknown = [n for n in names if n not in known]
    if unknown:
        raise SystemExit(
            f"make_experiment_plots.py: unknown example(s) {', '.join(unknown)}; known: {', '.join(known)}"
        )
    names = names or EXAMPLES + (SLOW_EXAMPLES if "--slow" in argv else ())
    if "--ci-stores" in argv:
        return tuple(n for n in names if n in CI_STORES)
    if "--part" not in argv:
        return names
    names = tuple(n for n in names if n not in CI_STORES)
    part = argv[argv.index("--part") + 1] if argv.index("--part") + 1 < len(argv) else ""
    k, _, n = part.partition("/")
    if not (k.isdigit() and n.isdigit() and 1 <= int(k) <= int(n)):
        raise SystemExit(f"make_experiment_plots.py: --part takes K/N with 1 <= K <= N, got {part!r}")
    return balanced_parts(names, int(n))[int(k) - 1]


def balanced_parts(names: tuple[str, ...], n: int) -> list[tuple[str, ...]]:
    """Split ``names`` into ``n`` parts of about equal `CI_COST_S` (longest first, each to
    the part with the least cost so far: Graham's LPT rule, within a third of the optimum
    makespan); each part keeps the list's order."""
    totals = [0.0] * n
    owner: dict[str, int] = {}
    for name in sorted(names, key=lambda m: -CI_COST_S.get(m, 0)):  # stable: ties in list order
        owner[name] = totals.index(min(totals))
        totals[owner[name]] += CI_COST_S.get(name, 0)
    return [tuple(m for m in names if owner[m] == k) for k in range(n)]


def main() -> int:
    """Run the examples, copy their figures, and check every example's claims (exit 1 if
    one does not hold: the pages state them)."""
    from gnssframework.experiments.claims import claim_line, replication_failed, small_n_refusal, unstated_small_n
    from gnssframework.io.files import loads_strict

    OUT.mkdir(parents=True, exist_ok=True)
    pages = None if "--all-figures" in sys.argv[1:] else docs_figures()
    failed = []
    for name in selected(sys.argv[1:]):
        started = time.monotonic()
        config = load_config(ROOT / "examples" / f"{name}.toml")
        record = RECORDS / f"{name}.json"
        recorded = config.tuning is not None and name not in TUNED_BY_MAIN_JOB
        seeded = recorded and record.exists() and "--retune" not in sys.argv[1:]

        def wanted(png: str, name: str = name) -> bool:
            return pages is None or f"{name}-{png}" in pages

        summary = run_comparison(
            config,
            ROOT / "results" / name,
            progress=False,
            trials_from=record if seeded else None,
            figures=wanted,
            replicate=name in REPLICATED or "--replicate" in sys.argv[1:],
        )
        if recorded and not seeded:
            RECORDS.mkdir(exist_ok=True)
            shutil.copy(summary.parent / TRIALS_FILE, record)
            print(f"{name}: tuning record written to {record}")
        copied = [png for png in sorted((summary.parent / "plots").glob("*.png")) if wanted(png.name)]
        for png in copied:
            shutil.copy(png, OUT / f"{name}-{png.name}")
        print(f"{name}: {len(copied)} figures copied ({time.monotonic() - started:.0f} s)")
        claims = loads_strict(summary.read_text()).get("claims", [])
        failed += [f"{name}: {claim_line(c)}" for c in claims if c["outcome"] != "holds" or replication_failed(c)]
        failed += [small_n_refusal(name, c["claim"], c["statement"], c["n"]) for c in unstated_small_n(claims)]
        if claims:
            both = " (re-checked on the replicate runs)" if any("replicate_outcome" in c for c in claims) else ""
            print(f"{name}: {sum(c['outcome'] == 'holds' for c in claims)} of {len(claims)} claims hold{both}")
        if name in TABLES:
            sys.path.insert(0, str(ROOT / "docs"))
            from experiment_tables import write

            print(f"{name}: tables written to {write(summary.parent, name, TABLES[name])}")
        if name in PUBLISHED_TABLES:
            sys.path.insert(0, str(ROOT / "docs"))
            from published_tables import write as write_published

            print(
                f"{name}: published values written to {write_published(summary.parent, name, PUBLISHED_TABLES[name])}"
            )
        if name in SWEEP_TABLES:
            sys.path.insert(0, str(ROOT / "docs"))
            from sweep_tables import write as write_sweep

            sweep_file = f"{name}_sweep" if name in TABLES else name
            print(f"{name}: sweep tables written to {write_sweep(summary.parent, sweep_file, SWEEP_TABLES[name])}")
        if name in SPACING_TABLES:
            sys.path.insert(0, str(ROOT / "docs"))
            from spacing_tables import write as write_spacing

            print(f"{name}: spacing tables written to {write_spacing(summary.parent, name)}")

    for line in failed:
        print("claim does not hold: " + line, file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
