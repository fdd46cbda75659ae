"""One scalar loop on the engine's two correlator sources, side by side (docs/receiver/loop-engine.md).

    python docs/engine_sources.py

The same ``channel_filter`` (the registry's ``scalar`` loop, defaults) closes the same
`ScalarCloser` over a `Channel` on (1) the analytic correlator model, (2) IF samples of
the same simulated signal (`generate_if_samples`, complex, 4 MHz) correlated by the
compiled kernels. Every run draws its own noise (seeded); the table gives, over the runs,
the mean of each run's mean and standard deviation of the replica's true errors after
the pull-in, and their standard errors from the spread across runs. Writes
``docs/experiments/generated/engine_sources.{json,md}``. `tests/receiver/test_engine_sources.py`
runs the same comparison on fewer runs.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from gnssframework import registry
from gnssframework.receiver.engine.channel import Channel
from gnssframework.receiver.engine.closers import ScalarCloser
from gnssframework.receiver.engine.loops import TrackingRecord, run_scalar
from gnssframework.receiver.engine.samples import SampleSource
from gnssframework.receiver.engine.sources import AnalyticSource
from gnssframework.receiver.engine.truth import LoopTruth
from gnssframework.signal.correlator_model import CorrelatorSimulator, amplitude_from_cn0
from gnssframework.signal.gps_l1ca import GPS_L1CA
from gnssframework.signal.if_samples import generate_if_samples

#: The simulated signal and the loop's start (an acquisition's errors).
SIGNAL = dict(prn=1, cn0_dbhz=45.0, doppler_hz=1200.0, code_phase_chips=100.3, carrier_phase_rad=0.7)
START_ERRORS = dict(code_chips=0.05, doppler_hz=3.0)
T_S, SAMPLE_RATE_HZ, IF_HZ = 1e-3, 4e6, 0.0
#: Errors: code (chips), phase (rad, modulo pi: the Costas loop's ambiguity) and frequency (Hz).
ERRORS = ("code_chips", "phase_rad", "freq_hz")


def _truth(duration_s: float, runs: int) -> LoopTruth:
    s = SIGNAL
    return LoopTruth.from_dynamics(
        duration_s,
        T_S,
        s["cn0_dbhz"],
        doppler_hz=np.full(runs, s["doppler_hz"]),
        code_phase0_chips=s["code_phase_chips"],
        carrier_phase0_rad=s["carrier_phase_rad"],
    )


def _track(truth: LoopTruth, source_of) -> TrackingRecord:
    """The one loop: the registry's ``scalar`` channel filter closing a `ScalarCloser` over a
    `Channel` started with `START_ERRORS`, on the source ``source_of(channel)`` gives."""
    batch = truth.code_phase_chips.shape[1:]
    channel = Channel.start(
        batch,
        truth.code_phase_chips[0] + START_ERRORS["code_chips"],
        SIGNAL["doppler_hz"] + START_ERRORS["doppler_hz"],
        signal=GPS_L1CA,
    )
    closer = ScalarCloser(registry.create("channel_filter", "scalar"))
    closer.reset(channel, T_S, cn0_dbhz=truth.cn0_dbhz)
    return run_scalar(closer, source_of(channel), channel, truth)


def analytic_runs(runs: int, duration_s: float, seed: int) -> TrackingRecord:
    """All runs at once on the analytic model: ``(K, runs)`` errors."""
    truth = _truth(duration_s, runs)
    rng = np.random.default_rng(seed)
    return _track(
        truth, lambda ch: AnalyticSource(CorrelatorSimulator(T_S), amplitude_from_cn0(truth.cn0_dbhz, T_S), rng)
    )


def sample_runs(runs: int, duration_s: float, seed: int) -> list[TrackingRecord]:
    """Run by run on IF samples of the same signal (each run its own noise): ``(K, 1)`` errors each."""
    out = []
    code = GPS_L1CA.code(SIGNAL["prn"])[None, :]
    for r in range(runs):
        rng = np.random.default_rng([seed, r])
        x = generate_if_samples(
            SIGNAL["prn"],
            duration_s + 2 * T_S,
            SAMPLE_RATE_HZ,
            IF_HZ,
            SIGNAL["cn0_dbhz"],
            rng,
            doppler_hz=SIGNAL["doppler_hz"],
            code_phase_chips=SIGNAL["code_phase_chips"],
            carrier_phase_rad=SIGNAL["carrier_phase_rad"],
            complex_samples=True,
            sample_type="float32",
        )
        out.append(
            _track(
                _truth(duration_s, 1),
                lambda ch, x=x: SampleSource(x.samples, SAMPLE_RATE_HZ, IF_HZ, code, T_S, noise_std=x.noise_std),
            )
        )
    return out


def run_statistics(code: np.ndarray, phase: np.ndarray, freq: np.ndarray, settle: int) -> dict[str, np.ndarray]:
    """Each run's mean and standard deviation of its errors after ``settle`` intervals: arrays ``(runs,)``."""
    phase = np.angle(np.exp(2j * phase)) / 2  # modulo pi
    out = {}
    for name, e in zip(ERRORS, (code, phase, freq)):
        e = e[settle:]
        out[f"{name}_mean"], out[f"{name}_std"] = e.mean(axis=0), e.std(axis=0, ddof=1)
    return out


def both_sources(runs: int, duration_s: float, settle_s: float, seed: int = 1) -> dict[str, dict[str, np.ndarray]]:
    """Per-run statistics (`run_statistics`) of the loop on each source."""
    settle = int(round(settle_s / T_S))
    a = analytic_runs(runs, duration_s, seed)
    s = sample_runs(runs, duration_s, seed + 1)
    stack = lambda f: np.concatenate([getattr(r, f) for r in s], axis=1)  # noqa: E731
    return {
        "analytic": run_statistics(a.code_error_chips, a.phase_error_rad, a.freq_error_hz, settle),
        "samples": run_statistics(stack("code_error_chips"), stack("phase_error_rad"), stack("freq_error_hz"), settle),
    }


def summary(stats: dict[str, dict[str, np.ndarray]]) -> dict[str, dict[str, list[float]]]:
    """Mean over the runs and its standard error, per statistic and source: ``[mean, se]``."""
    return {
        src: {k: [float(np.mean(v)), float(np.std(v, ddof=1) / np.sqrt(v.size))] for k, v in st.items()}
        for src, st in stats.items()
    }


def table(summ: dict, runs: int, duration_s: float, settle_s: float) -> str:
    units = {"code_chips": "chips", "phase_rad": "rad", "freq_hz": "Hz"}
    lines = [
        f"<!-- generated by docs/engine_sources.py: {runs} runs per source, {duration_s} s, "
        f"statistics after {settle_s} s -->",
        "| error statistic | analytic source | IF-samples source | difference / combined SE |",
        "| --- | --- | --- | --- |",
    ]
    for key in summ["analytic"]:
        (ma, sa), (ms, ss) = summ["analytic"][key], summ["samples"][key]
        name, stat = key.rsplit("_", 1)
        z = (ms - ma) / np.hypot(sa, ss)
        lines.append(
            f"| {stat} of {name.split('_')[0]} error ({units[name]}) | {ma:.4g} ± {sa:.2g} | "
            f"{ms:.4g} ± {ss:.2g} | {z:+.2f} |"
        )
    return "\n".join(lines) + "\n"


def main(runs: int = 24, duration_s: float = 0.6, settle_s: float = 0.2) -> None:
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import experiment_tables

    summ = summary(both_sources(runs, duration_s, settle_s))
    experiment_tables.save_summary("engine_sources", summ)
    print(experiment_tables.save("engine_sources.md", table(summ, runs, duration_s, settle_s)))


if __name__ == "__main__":
    main()
