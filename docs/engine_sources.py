"""One scalar loop and one vector loop on the engine's two correlator sources, side by side
(docs/receiver/loop-engine.md).

    python docs/engine_sources.py

The same ``channel_filter`` (the registry's ``scalar`` loop, defaults) closes the same
`ScalarCloser` over a `Channel` on (1) the analytic correlator model, (2) IF samples of
the same simulated signal (`generate_if_samples`, complex, 4 MHz) correlated by the
compiled kernels. Every run draws its own noise (seeded); the table gives, over the runs,
the mean of each run's mean and standard deviation of the replica's true errors after
the pull-in, and their standard errors from the spread across runs. Writes
``docs/experiments/generated/engine_sources.{json,md}``.

The vector loop (`run_vector_loop`: the ``discriminator`` channel filters and the ``ekf-pv``
navigation filter of `VECTOR_CANDIDATE`, one `VectorCloser`) runs on the analytic model
and on IF samples of the same truth (`VECTOR_SCENARIO`: the vector-tracking scenario's
satellites, static receiver and OCXO clock; `truth_samples`); the statistics of each run
(position and velocity errors, the replicas' code and frequency errors) after the
settling are compared the same way. Writes ``engine_sources_vector.{json,md}``.
`tests/receiver/test_engine_sources.py` runs both comparisons on fewer runs.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from gnssframework import registry
from gnssframework.experiments import get_scenario
from gnssframework.receiver.engine.channel import Channel
from gnssframework.receiver.engine.closers import ScalarCloser
from gnssframework.receiver.engine.loops import TrackingRecord, run_scalar
from gnssframework.receiver.engine.samples import SampleSource
from gnssframework.receiver.engine.sources import AnalyticSource
from gnssframework.receiver.engine.truth import LoopTruth
from gnssframework.receiver.engine.truth_samples import truth_samples
from gnssframework.receiver.tracking.vector import VectorRecord, run_vector_loop
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


# --- the vector loop -------------------------------------------------------------------

#: The vector loop's truth: the vector-tracking scenario's geometry (nominal constellation,
#: the page's site), static receiver, OCXO clock, 10 ms intervals, no data bits.
VECTOR_SCENARIO = {
    "kind": "vector-tracking",
    "channels": 6,
    "data_bits": "none",
    "coherent_time_s": 0.01,
    "settle_s": 0.0,
}
#: Its loop: the reference-000 example's discriminator candidate.
VECTOR_CANDIDATE = {
    "channel_filter": ("discriminator", {"code_discriminator": "eml-envelope", "freq_discriminator": "cross-product"}),
    "nav_filter": ("ekf-pv", {"clock": "ocxo"}),
}
#: The channels' codes: PRNs whose half-chip code correlation is the model's 1/2 (see the page).
VECTOR_PRNS = (1, 2, 3, 4, 5, 6)
VECTOR_CN0_DBHZ = 45.0
#: Per-run statistics of the vector loop (after the settling).
VECTOR_STATISTICS = (
    "position_rms_m",
    "velocity_rms_m_s",
    "code_mean_chips",
    "code_std_chips",
    "freq_mean_hz",
    "freq_std_hz",
)


def _vector_loop():
    ch, nav = (registry.create(kind, name, **params) for kind, (name, params) in VECTOR_CANDIDATE.items())
    return ch, nav


def vector_analytic_runs(runs: int, duration_s: float, seed: int) -> VectorRecord:
    """All runs at once on the analytic model."""
    scen = get_scenario({**VECTOR_SCENARIO, "duration_s": duration_s})
    rng = np.random.default_rng(seed)
    truth, x0, P0 = scen.truth(VECTOR_CN0_DBHZ, runs, rng)
    return run_vector_loop(*_vector_loop(), truth, x0, P0, rng, data_bits="none")


def vector_sample_runs(
    runs: int, duration_s: float, seed: int, streams: str = "per-channel", sample_rate_hz: float = SAMPLE_RATE_HZ
) -> list:
    """Run by run on complex IF samples of the same truth (`truth_samples`, each run its own
    clock, initial estimate, carrier phases and noise); ``streams`` as `truth_samples`'s."""
    scen = get_scenario({**VECTOR_SCENARIO, "duration_s": duration_s})
    T = scen.params.coherent_time_s
    codes = np.stack([GPS_L1CA.code(p) for p in VECTOR_PRNS]).astype(np.float32)
    out = []
    for r in range(runs):
        rng = np.random.default_rng([seed, r])
        truth, x0, P0 = scen.truth(VECTOR_CN0_DBHZ, 1, rng)
        theta0 = rng.uniform(-np.pi, np.pi, (1, len(VECTOR_PRNS)))
        x = truth_samples(truth, sample_rate_hz, codes, theta0[0], rng, streams=streams)
        source = SampleSource(x, sample_rate_hz, 0.0, codes, T)
        out.append(
            run_vector_loop(
                *_vector_loop(), truth, x0, P0, rng, data_bits="none", source=source, initial_carrier_phase_rad=theta0
            )
        )
    return out


def vector_statistics(rec: VectorRecord, settle: int) -> dict[str, np.ndarray]:
    """Each run's statistics after ``settle`` intervals, arrays ``(runs,)``: RMS 3-D position
    and velocity errors, and the mean and standard deviation of the replicas' code and
    frequency errors over the channels and intervals."""
    pos, vel = rec.position_error_m[settle:], rec.velocity_error_m_s[settle:]
    code, freq = rec.code_error_chips[settle:], rec.freq_error_hz[settle:]
    runs = pos.shape[1]
    flat = lambda e: np.moveaxis(e, 1, 0).reshape(runs, -1)  # noqa: E731
    return {
        "position_rms_m": np.sqrt(np.mean(np.sum(pos**2, axis=-1), axis=0)),
        "velocity_rms_m_s": np.sqrt(np.mean(np.sum(vel**2, axis=-1), axis=0)),
        "code_mean_chips": flat(code).mean(axis=1),
        "code_std_chips": flat(code).std(axis=1, ddof=1),
        "freq_mean_hz": flat(freq).mean(axis=1),
        "freq_std_hz": flat(freq).std(axis=1, ddof=1),
    }


#: The sample sources of the vector comparison: each channel alone in its noise (the
#: analytic model's assumption), and every satellite in one stream (a receiver's input).
VECTOR_STREAMS = {"samples": "per-channel", "samples-one-stream": "one"}


def vector_both_sources(
    runs: int, duration_s: float, settle_s: float, seed: int = 1, streams: tuple[str, ...] = tuple(VECTOR_STREAMS)
) -> dict[str, dict[str, np.ndarray]]:
    """Per-run statistics (`vector_statistics`) of the vector loop on the analytic source and
    on the sample sources ``streams`` (keys of `VECTOR_STREAMS`)."""
    T = VECTOR_SCENARIO["coherent_time_s"]
    settle = int(round(settle_s / T))
    out = {"analytic": vector_statistics(vector_analytic_runs(runs, duration_s, seed), settle)}
    for i, name in enumerate(streams):
        s = [
            vector_statistics(r, settle)
            for r in vector_sample_runs(runs, duration_s, seed + 1 + i, VECTOR_STREAMS[name])
        ]
        out[name] = {k: np.concatenate([st[k] for st in s]) for k in VECTOR_STATISTICS}
    return out


def vector_table(summ: dict, runs: int, duration_s: float, settle_s: float) -> str:
    labels = {
        "position_rms_m": "RMS position error (m)",
        "velocity_rms_m_s": "RMS velocity error (m/s)",
        "code_mean_chips": "mean of replica code error (chips)",
        "code_std_chips": "std of replica code error (chips)",
        "freq_mean_hz": "mean of replica frequency error (Hz)",
        "freq_std_hz": "std of replica frequency error (Hz)",
    }
    lines = [
        f"<!-- generated by docs/engine_sources.py: {runs} runs per source, {duration_s} s, "
        f"statistics after {settle_s} s -->",
        "| per-run statistic | analytic source | IF samples, a stream per channel | difference / combined SE "
        "| IF samples, one stream | difference / combined SE |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for key in VECTOR_STATISTICS:
        ma, sa = summ["analytic"][key]
        row = f"| {labels[key]} | {ma:.4g} ± {sa:.2g} "
        for name in VECTOR_STREAMS:
            ms, ss = summ[name][key]
            row += f"| {ms:.4g} ± {ss:.2g} | {(ms - ma) / np.hypot(sa, ss):+.2f} "
        lines.append(row + "|")
    return "\n".join(lines) + "\n"


def main(
    runs: int = 24,
    duration_s: float = 0.6,
    settle_s: float = 0.2,
    vector_runs: int = 24,
    vector_duration_s: float = 2.0,
    vector_settle_s: float = 0.5,
) -> None:
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import experiment_tables

    summ = summary(both_sources(runs, duration_s, settle_s))
    experiment_tables.save_summary("engine_sources", summ)
    print(experiment_tables.save("engine_sources.md", table(summ, runs, duration_s, settle_s)))
    summ = summary(vector_both_sources(vector_runs, vector_duration_s, vector_settle_s))
    experiment_tables.save_summary("engine_sources_vector", summ)
    print(
        experiment_tables.save(
            "engine_sources_vector.md", vector_table(summ, vector_runs, vector_duration_s, vector_settle_s)
        )
    )


if __name__ == "__main__":
    main()
