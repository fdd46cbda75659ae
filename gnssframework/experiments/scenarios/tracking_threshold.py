r"""Scenario ``tracking-threshold``: where each loop lets go, one C/N0 point per case.

One channel per run tracks a GPS L1 C/A signal on the loop engine's analytic correlator
model (`gnssframework.receiver.engine`: a `Channel` started from the acquisition, the
`AnalyticSource`, a `ScalarCloser` around the candidate's ``channel_filter``). A case is a
C/N0 with optional line-of-sight dynamics (Doppler rate, jerk) and its own interval T; a
``[[sweeps]]`` entry over ``cases.cn0_dbhz`` makes the grid, and its ``threshold`` table
(`gnssframework.experiments.threshold`) turns the grid into each candidate's threshold.
Every run draws its correlator noise from its own stream (`gnssframework.random_streams`),
so run ``r`` of every candidate and every C/N0 point sees the same numbers (common random
numbers, paired across candidates and along the sweep).

Every metric is read off the truth: the replica's true errors (truth minus replica) at
every interval, the carrier phase error *unwrapped* (the engine's continuous phases, so
cycle slips are seen as jumps of :math:`\pi` or :math:`2\pi`, not wrapped away).

Loss of lock (per run, absorbing)
    After ``settle_s``, the run is cut into blocks of ``lock_window_s``; a block is *out
    of lock* when the mean of :math:`\cos 2\delta\phi` over it is below ``lock_threshold``
    (0.5: an RMS phase error near 30°, or a spinning phase, whose mean is near 0; a Costas
    loop is blind to half cycles, hence :math:`2\delta\phi`) or the mean absolute code
    error exceeds half the early-late spacing (the DLL has left its linear range). The loss
    is declared at the end of the first such block (the condition held for
    ``lock_window_s``); ``time_to_loss_s`` is that time after ``settle_s``, or the
    observed span (censored) without a loss.

Code and frequency lock (``loss_of_code_freq_lock``, `code_freq_lock_loss`)
    The same blocks judged by the replica's mean :math:`|\delta f|` (above
    ``freq_lock_hz``, default :math:`1/(4T)`) or mean :math:`|\delta\tau|` (above half the
    spacing): the test a frequency-locked vector loop is judged by (scenario
    ``vector-threshold``), reported here beside the phase test.

Filters that estimate instead of commanding
    A ``channel_filter`` that provides no NCO commands but the replica's code, frequency
    and phase errors (``iq-filter``) is closed by `EstimateCloser`: its NCOs move to its
    estimates every interval; its phase error is then the error of its carrier phase
    estimate (the replica's phase is not steered), and it has no equivalent bandwidth.

Cycle slips
    The unwrapped phase error's lock point :math:`n\pi` is tracked with hysteresis: it
    changes only when the error comes within ``slip_capture_rad`` of another multiple
    :math:`m\pi`, counting :math:`|m - n|` half-cycle slips; a whole-cycle slip is counted
    each time the lock point has moved :math:`2\pi` from the last whole-cycle reference
    (`count_slips`). Noise excursions past :math:`\pm\pi/2` that return do not count.
    Rates are slips over the observed span after ``settle_s`` (a loop that lost lock and
    spins keeps slipping: its rate is high).

The receiver's C/N0 estimate
    What the receiver itself would read of the signal as lock goes: after ``settle_s`` the
    prompts are cut into windows of ``cn0_window_s``, each read by the ``cn0_estimator``
    plugin (``m2m4`` by default: bit-blind, on the prompt alone), and
    ``cn0_estimate_error_db`` is the median over a run's windows of the reading minus the
    case's true C/N0 (dB; its mean over runs the estimate's bias). A loop that keeps lock
    reads the estimator's own bias on ideal prompts (`gnssframework.signal.cn0_estimator`);
    one that loses it reads the signal's power smeared over code and frequency errors:
    low, down to the estimator's floor on noise.

A lock test on that reading (``loss_of_lock_by_cn0``)
    What the receiver would decide from its own reading: a run is lost at the first
    ``cn0_lock_consecutive`` windows in a row (default 1: the first window; after
    ``settle_s``) whose readings are below ``cn0_lock_dbhz``, by default the
    estimator's noise-only floor on the window, ``cn0_floor_dbhz`` (the 95th percentile of
    its readings on pure noise, `gnssframework.signal.cn0_estimator.noise_floor_dbhz`: a
    test set lower passes pure noise in more than 5 % of windows). A threshold of this
    metric along a C/N0 sweep is the threshold *read off the estimate*; one of the truth's
    ``loss_of_lock`` below ``cn0_floor_dbhz`` is one the receiver's estimator cannot vouch for.

Jitter
    ``phase_jitter_rad`` and ``code_jitter_chips``: RMS of the phase error (wrapped to
    half a cycle around the lock point) and of the code error over the intervals before
    the loss of lock (NaN when lock is lost in the first block). Beside them the thermal
    formulas at the case's C/N0 and T: the Costas PLL's
    :math:`\sigma^2 = B_L/c\,(1 + 1/(2cT))` with :math:`B_L` the loop's measured
    steady-state noise bandwidth (`loop_bandwidth.equivalent_bandwidth_hz`), and the
    DLL's :math:`2 B_{DLL} T\,\sigma_D^2` with its code discriminator's thermal variance
    (NaN for a channel filter without ``dll_bandwidth_hz`` and ``code_discriminator``).
    The thermal formulas leave out the receiver oscillator (below): its jitter adds to them.

Receiver oscillator
    ``oscillator`` (the scenario's, or a case's own) adds a receiver clock to a case's
    truth (analytic or samples source: on samples the signal follows the truth interval
    by interval): the two-state clock of a preset of `gnssframework.simulation.clock`
    (white and random-walk frequency noise from its Allan-variance h-parameters), drawn
    from each run's own ``"oscillator"`` stream, moving code and carrier together
    (`gnssframework.simulation.clock.oscillator_cycles`). Its phase jitter in a loop of
    noise bandwidth :math:`B_L` grows as :math:`B_L` narrows (the white frequency noise's
    part as :math:`f_c^2 h_0 / B_L`), so it raises the threshold of narrow loops most: the
    realistic curve beside the ideal clock's control (`ClockModel` for the presets).
"""

from __future__ import annotations

import functools
import math
from typing import Any, ClassVar, Literal

import numpy as np
from pydantic import Field, field_validator

from ... import random_streams as draw
from ...errors import ConfigError
from ...interfaces import RunContext
from ...receiver.engine.channel import Channel
from ...receiver.engine.closers import (
    ESTIMATE_OUTPUTS,
    NCO_COMMANDS,
    EstimateCloser,
    ScalarCloser,
    check_closed_loop,
    check_estimate_loop,
)
from ...receiver.engine.sources import AnalyticSource
from ...receiver.engine.truth import LoopTruth
from ...receiver.tracking.jitter import code_thermal_std_chips, pll_thermal_variance_rad2
from ...receiver.tracking.loop_bandwidth import at_interval, equivalent_bandwidth_hz
from ...signal.gps_l1ca import GPS_L1CA
from ...signal.spec import SignalSpec
from ...signal.correlator_model import CorrelatorSimulator, amplitude_from_cn0
from ...simulation.clock import Oscillator, oscillator_cycles
from ..limits import SignalCoherentTime
from ..metric_components import Mean, SeriesMetric, evaluate, units
from ..metrics import MetricValue
from . import BatchResult, Scenario, ScenarioParams, register_scenario

__all__ = [
    "TrackingThresholdScenario",
    "lock_loss",
    "code_freq_lock_loss",
    "count_slips",
    "lock_scores",
    "code_freq_lock_scores",
    "cn0_estimate_error_db",
    "cn0_readings_dbhz",
    "median_error_db",
    "cn0_floor_dbhz",
    "cn0_lock_loss",
    "METRICS",
    "BYTES_PER_EPOCH_RUN",
]

#: Peak memory of one run's interval (truth, the record; a generous round number).
BYTES_PER_EPOCH_RUN = 512


class TrackingThresholdParams(SignalCoherentTime, ScenarioParams):
    duration_s: float = Field(10.0, gt=0, le=3600, description="duration of every case (s)")
    coherent_time_s: float = Field(0.01, description="interval T (s): whole 1 ms code periods, 1 to 20 ms")
    cn0_dbhz: float = Field(30.0, ge=5, le=60, description="C/N0 of a case that sets none (dB-Hz)")
    doppler_hz: float = Field(1500.0, description="constant Doppler at start (known to the receiver)")
    initial_freq_error_hz: float = Field(0.0, ge=-50, le=50, description="acquisition's Doppler error (Hz)")
    early_late_spacing_chips: float = Field(1.0, gt=0, le=1.0, description="early-late spacing d (chips)")
    settle_s: float = Field(1.0, ge=0, description="pull-in time not scored (s)")
    lock_window_s: float = Field(
        0.1, gt=0, description="block length of the lock test: how long the out-of-lock condition must hold (s)"
    )
    lock_threshold: float = Field(
        0.5, gt=-1, lt=1, description="a block whose mean cos(2 phase error) is below is out of lock"
    )
    freq_lock_hz: float | None = Field(
        None,
        gt=0,
        description="code-and-frequency lock test (loss_of_code_freq_lock): "
        "a block whose mean |frequency error| exceeds it is out of lock (Hz); "
        "null: 1/(4T), a two-quadrant arctangent FLL's pull-in range",
    )
    oscillator: Oscillator = Field(
        "none",
        description="receiver oscillator of every case that sets none: 'none' (an ideal clock) or a preset of "
        "gnssframework.simulation.clock (tcxo, tcxo-hq, ocxo: its Allan-variance h-parameters), whose clock "
        "bias moves code and carrier together (analytic and samples cases)",
    )
    sample_rate_hz: float = Field(
        2.046e6,
        ge=1.1e6,
        le=40e6,
        description="sample rate of a samples case (complex baseband, IF 0; T times it must be a whole number)",
    )
    prn: int = Field(1, ge=1, le=32, description="PRN of a samples case's signal")
    slip_capture_rad: float = Field(
        math.pi / 4,
        gt=0,
        lt=math.pi / 2,
        description="the phase error must come this close (rad) to a new multiple of pi to count a slip",
    )
    cn0_estimator: str = Field(
        "m2m4",
        description="the cn0_estimator plugin reading the prompts "
        "(cn0_estimate_bias_db); one that reads the prompt alone",
    )
    cn0_window_s: float = Field(0.2, gt=0, le=60, description="window of one C/N0 estimate (s; whole intervals T)")
    cn0_lock_dbhz: float | None = Field(
        None,
        ge=0,
        le=60,
        description="the receiver's C/N0 lock test "
        "(loss_of_lock_by_cn0): a window whose reading is below it declares loss "
        "(dB-Hz); null: the cn0_estimator's noise-only floor on the window (95th "
        "percentile on pure noise, cn0_floor_dbhz), the lowest C/N0 it can vouch for",
    )
    cn0_lock_consecutive: int = Field(
        1,
        ge=1,
        le=100,
        description="windows in a row that must read below cn0_lock_dbhz before the C/N0 lock test "
        "declares loss (loss_of_lock_by_cn0; a receiver's declare rule: 1, the first window below)",
    )

    @field_validator("cn0_estimator")
    @classmethod
    def _prompt_only(cls, name: str) -> str:
        return prompt_only_estimator(name)


def prompt_only_estimator(name: str | None) -> str | None:
    """``name`` if it is a cn0_estimator of the prompt alone (the one output the scenario
    simulates); else a one-line error naming the field."""
    from ... import registry

    if name is None:
        return None
    estimator = registry.get("cn0_estimator", name)  # an unknown name: the registry's error, with the names
    if tuple(estimator.needs) != ("prompt",):
        raise ConfigError(
            "cn0_estimator",
            f"{name!r} reads {', '.join(estimator.needs)}; the scenario simulates "
            "the prompt only: choose an estimator of the prompt alone (m2m4, narrow-wide, snv, "
            "beaulieu)",
        )
    return name


class TrackingThresholdCase(SignalCoherentTime, ScenarioParams):
    name: str | None = None
    cn0_dbhz: float | None = Field(None, ge=5, le=60, description="C/N0 of this case (dB-Hz; default the scenario's)")
    coherent_time_s: float | None = Field(
        None, description="interval T of this case (default the scenario's); the candidates' loops are re-created at it"
    )
    duration_s: float | None = Field(None, gt=0, le=3600, description="duration of this case (default the scenario's)")
    doppler_rate_hz_s: float = Field(
        0.0,
        ge=-1000,
        le=1000,
        description="constant Doppler rate (Hz/s; line-of-sight acceleration / L1 wavelength: 1 Hz/s = 0.19 m/s^2)",
    )
    doppler_jerk_hz_s2: float = Field(
        0.0, ge=-100, le=100, description="constant Doppler jerk (Hz/s^2; line-of-sight jerk / L1 wavelength)"
    )
    oscillator: Oscillator | None = Field(
        None, description="receiver oscillator of this case (default: the scenario's)"
    )
    source: Literal["analytic", "samples"] = Field(
        "analytic",
        description="correlators from the analytic model (all runs at once) or from IF samples "
        "(complex, generated per run, correlated by the compiled kernels; static cases only)",
    )
    cn0_estimator: str | None = Field(
        None, description="this case's receiver C/N0 estimator (default: the scenario's cn0_estimator)"
    )
    cn0_window_s: float | None = Field(
        None, gt=0, le=60, description="this case's C/N0 estimation window (s; default the scenario's)"
    )
    cn0_lock_dbhz: float | None = Field(
        None, ge=0, le=60, description="this case's C/N0 lock test limit (dB-Hz; default the scenario's)"
    )
    cn0_lock_consecutive: int | None = Field(
        None,
        ge=1,
        le=100,
        description="this case's declare rule: windows in a row below the limit (default the scenario's)",
    )

    @field_validator("cn0_estimator")
    @classmethod
    def _prompt_only(cls, name: str | None) -> str | None:
        try:
            return prompt_only_estimator(name)
        except ConfigError as exc:  # a value error: the config loader names the case's field
            raise ValueError(exc.detail) from None


def lock_loss(
    phase_error_rad: np.ndarray,
    code_error_chips: np.ndarray,
    first: int,
    window: int,
    threshold: float,
    half_spacing_chips: float,
) -> tuple[np.ndarray, np.ndarray, int]:
    """First out-of-lock block of every run (see the module docstring).

    Parameters
    ----------
    phase_error_rad, code_error_chips
        ``(K, runs)`` true errors per interval.
    first
        First scored interval (after settling).
    window
        Intervals per block.

    Returns
    -------
    lost, end, blocks
        ``lost (runs,)`` bool; ``end (runs,)`` the number of scored intervals up to the end
        of the first out-of-lock block (``blocks * window`` when not lost); ``blocks`` the
        number of whole blocks scored.
    """
    K, runs = phase_error_rad.shape
    blocks = (K - first) // window
    if blocks < 1:
        raise ValueError(f"no whole lock-test block of {window} intervals after interval {first} of {K}")
    stop = first + blocks * window
    c2 = np.cos(2 * phase_error_rad[first:stop]).reshape(blocks, window, runs).mean(axis=1)
    code = np.abs(code_error_chips[first:stop]).reshape(blocks, window, runs).mean(axis=1)
    bad = (c2 < threshold) | (code > half_spacing_chips)
    lost = bad.any(axis=0)
    j = np.where(lost, np.argmax(bad, axis=0), blocks - 1)
    return lost, (j + 1) * window, blocks


def code_freq_lock_loss(
    freq_error_hz: np.ndarray,
    code_error_chips: np.ndarray,
    first: int,
    window: int,
    freq_limit_hz: float,
    half_spacing_chips: float,
) -> tuple[np.ndarray, np.ndarray, int]:
    r"""First block out of *code and frequency* lock of every run (or channel): the criterion
    that a frequency-locked loop (a vector delay/frequency lock loop, whose replica phase is
    not locked) can be judged by, and a phase-locked loop beside it.

    A block of ``window`` intervals after interval ``first`` is out of lock when its mean
    :math:`|\delta f|` exceeds ``freq_limit_hz`` (the scenarios' default :math:`1/(4T)`:
    the pull-in range of a two-quadrant arctangent FLL discriminator, Kaplan & Hegarty, 3rd
    ed., section 8.4; beyond it the frequency discriminator wraps) or its mean
    :math:`|\delta\tau|` exceeds ``half_spacing_chips`` (the DLL has left its linear range).

    Parameters
    ----------
    freq_error_hz, code_error_chips
        ``(K, ...)`` true errors of the replica per interval (any batch dimensions).
    first, window
        First scored interval; intervals per block.

    Returns
    -------
    lost, end, blocks
        ``lost (...)`` bool; ``end (...)`` scored intervals up to the end of the first
        out-of-lock block (``blocks * window`` when not lost); ``blocks`` whole blocks scored.
    """
    K = freq_error_hz.shape[0]
    batch = freq_error_hz.shape[1:]
    blocks = (K - first) // window
    if blocks < 1:
        raise ValueError(f"no whole lock-test block of {window} intervals after interval {first} of {K}")
    stop = first + blocks * window
    freq = np.abs(freq_error_hz[first:stop]).reshape((blocks, window) + batch).mean(axis=1)
    code = np.abs(code_error_chips[first:stop]).reshape((blocks, window) + batch).mean(axis=1)
    bad = (freq > freq_limit_hz) | (code > half_spacing_chips)
    lost = bad.any(axis=0)
    j = np.where(lost, np.argmax(bad, axis=0), blocks - 1)
    return lost, (j + 1) * window, blocks


def count_slips(phase_error_rad: np.ndarray, capture_rad: float) -> tuple[np.ndarray, np.ndarray]:
    r"""Half- and whole-cycle slips of the unwrapped phase error ``(K, runs)``, with hysteresis.

    The lock point :math:`n\pi` moves to :math:`m\pi` only when the error comes within
    ``capture_rad`` of it, adding :math:`|m - n|` half-cycle slips. A whole-cycle slip is
    counted each time the lock point has moved two half cycles from the last whole-cycle
    reference (which then moves by :math:`2\pi` towards it): a half cycle out and back is
    two half-cycle slips and no whole one; :math:`0 \to \pi \to 3\pi` is three half-cycle
    slips and one whole one.

    Returns
    -------
    half, whole
        ``(runs,)`` counts.
    """
    e = np.asarray(phase_error_rad, float)
    level = np.round(e[0] / np.pi)
    reference = level.copy()
    half = np.zeros(e.shape[1:])
    whole = np.zeros(e.shape[1:])
    for k in range(1, e.shape[0]):
        m = np.round(e[k] / np.pi)
        move = (np.abs(e[k] - m * np.pi) < capture_rad) & (m != level)
        half += np.where(move, np.abs(m - level), 0.0)
        level = np.where(move, m, level)
        cycles = np.trunc((level - reference) / 2)
        whole += np.abs(cycles)
        reference = reference + 2 * cycles
    return half, whole


def _rms_before(x: np.ndarray, end: np.ndarray) -> np.ndarray:
    """RMS over axis 0 of ``x (n, runs)`` of each run's first ``end`` rows (NaN for none)."""
    keep = np.arange(x.shape[0])[:, None] < end[None, :]
    n = keep.sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > 0, np.sqrt(np.sum(np.where(keep, x**2, 0.0), axis=0) / n), np.nan)


@register_scenario
class TrackingThresholdScenario(Scenario):
    """Loss of lock, time to it, cycle slips and jitter of closed loops at one C/N0 per case."""

    kind = "tracking-threshold"
    #: The tracked signal (its wavelength for the assumptions, its code for a samples case).
    signal: ClassVar[SignalSpec] = GPS_L1CA
    Params = TrackingThresholdParams
    params: TrackingThresholdParams  # self.params, as validated
    CaseParams = TrackingThresholdCase
    components = {"channel_filter": True}
    outputs = {
        "phase_error_rad": "rad",
        "code_error_chips": "chips",
        "freq_error_hz": "Hz",
        "phase_thermal_std_rad": "rad",
        "code_thermal_std_chips": "chips",
        "loop_noise_bandwidth_hz": "Hz",
        "cn0_error_db": "dB",
        "cn0_lost": "",
        "cn0_floor": "dB-Hz",
    }

    def _case(self, case: dict) -> dict:
        c = self.CaseParams.model_validate(case)
        p = self.params
        return {
            "T": c.coherent_time_s or p.coherent_time_s,
            "duration_s": c.duration_s or p.duration_s,
            "cn0_dbhz": p.cn0_dbhz if c.cn0_dbhz is None else c.cn0_dbhz,
            "rate": c.doppler_rate_hz_s,
            "jerk": c.doppler_jerk_hz_s2,
            "oscillator": c.oscillator or p.oscillator,
            "source": c.source,
        }

    def cn0_params(self, case: dict) -> TrackingThresholdParams:
        """The scenario's parameters with the case's own C/N0 estimator, window, lock limit and
        declare rule where it sets them (what the C/N0 lock test of the case reads)."""
        c = self.CaseParams.model_validate(case)
        update = {
            k: getattr(c, k)
            for k in ("cn0_estimator", "cn0_window_s", "cn0_lock_dbhz", "cn0_lock_consecutive")
            if getattr(c, k) is not None
        }
        return self.params.model_copy(update=update) if update else self.params

    def check_case(self, case: dict, where: str) -> None:
        """The case's own checks, and its duration against settling and one lock-test block."""
        super().check_case(case, where)
        c = self._case(case)
        p = self.params
        field = f"{where}.duration_s" if case.get("duration_s") else "scenario.duration_s"
        if c["source"] == "samples":
            for key, name in (("rate", "doppler_rate_hz_s"), ("jerk", "doppler_jerk_hz_s2")):
                if c[key] != 0:
                    raise ConfigError(
                        f"{where}.{name}",
                        "the samples source simulates a constant Doppler only; "
                        f'set it to 0 or use source = "analytic" (got {c[key]!r})',
                    )
            n = c["T"] * p.sample_rate_hz
            if abs(n - round(n)) > 1e-6:
                raise ConfigError(
                    "scenario.sample_rate_hz",
                    f"T = {c['T']} s times the sample rate must be a whole number of samples (got {n:g})",
                )
        if c["duration_s"] - p.settle_s < max(p.lock_window_s, c["T"]):
            raise ConfigError(
                field,
                f"must leave one lock-test block of lock_window_s = {p.lock_window_s!r} s "
                f"after settle_s = {p.settle_s!r} s (got {c['duration_s']!r})",
            )

    def assumption_context(self, case: dict) -> dict:
        c = self._case(case)
        return {"coherent_time_s": c["T"], "cn0_dbhz": c["cn0_dbhz"], "wavelength_m": self.signal.wavelength_m}

    def batch_memory(self, case: dict, runs: int, where: str, candidates=()) -> tuple[float, str, str]:
        c = self._case(case)
        epochs = int(round(c["duration_s"] / c["T"]))
        return BYTES_PER_EPOCH_RUN * epochs * runs, f"{where}.duration_s", f"a batch of {runs} runs ({epochs} epochs)"

    def run_contexts(self, cases: list[dict]) -> list[RunContext]:
        intervals = sorted({self._case(c)["T"] for c in cases} | {self.params.coherent_time_s})
        d = self.params.early_late_spacing_chips
        return [RunContext(coherent_time_s=T, early_late_spacing_chips=d, epoch_interval_s=T) for T in intervals]

    def in_context(self, plugin, context: RunContext):
        return at_interval(plugin, context.coherent_time_s)

    def check_composition(self, plugins, where: str) -> None:
        channel = plugins["channel_filter"]
        try:
            if all(n in channel.provides for n in NCO_COMMANDS):
                check_closed_loop(channel)
            else:
                check_estimate_loop(channel)
        except ConfigError as exc:
            raise self.refuse(exc, where, NCO_COMMANDS + ESTIMATE_OUTPUTS) from None

    def track(self, case: dict, channel, runs: int, rng) -> tuple[np.ndarray, np.ndarray, float]:
        """Close ``channel`` (at the case's T) over ``runs`` runs of the case: the unwrapped
        mid-interval phase error ``(K, runs)`` (rad), the code error (chips), and T."""
        phase, code, _, T = self.track_errors(case, channel, runs, rng)
        return phase, code, T

    def track_errors(self, case: dict, channel, runs: int, rng) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        """`track`, with the replica's true frequency error ``(K, runs)`` (Hz) before T."""
        series, T = self.track_series(case, channel, runs, rng)
        return series["phase_error_rad"], series["code_error_chips"], series["freq_error_hz"], T

    def track_series(self, case: dict, channel, runs: int, rng) -> tuple[dict[str, np.ndarray], float]:
        """Close ``channel`` over ``runs`` runs of the case: the series of `_close` and T."""
        rng = draw.as_run_streams(rng, runs)  # one stream per run: numbers independent of batching
        p = self.params
        c = self._case(case)
        T, d = c["T"], p.early_late_spacing_chips
        if c["source"] == "samples":
            # the samples span two intervals more than the loop (the correlators read ahead)
            K_span = int(round(c["duration_s"] / T)) + 2
            clocks = oscillator_cycles(
                c["oscillator"], K_span, T, draw.child(rng, "oscillator"), runs, self.signal.carrier_freq_hz
            )
            parts = [
                self._track_samples(c, channel, stream, None if clocks is None else clocks[:, r])
                for r, stream in enumerate(rng.generators)
            ]
            return {name: np.concatenate([q[name] for q in parts], axis=1) for name in parts[0]}, T
        K = int(round(c["duration_s"] / T))
        clock = oscillator_cycles(
            c["oscillator"], K, T, draw.child(rng, "oscillator"), runs, self.signal.carrier_freq_hz
        )
        truth = LoopTruth.from_dynamics(
            c["duration_s"],
            T,
            c["cn0_dbhz"],
            doppler_hz=np.full(runs, p.doppler_hz),
            doppler_rate_hz_s=c["rate"],
            doppler_jerk_hz_s2=c["jerk"],
            extra_cycles=clock,
        )
        source = AnalyticSource(CorrelatorSimulator(T, d), amplitude_from_cn0(c["cn0_dbhz"], T), rng)
        return self._close(channel, truth, c, source), T

    def _track_samples(
        self, c: dict, channel, rng: np.random.Generator, clock_cycles: np.ndarray | None = None
    ) -> dict[str, np.ndarray]:
        """One run on IF samples drawn from the run's own stream ``rng`` (complex baseband
        at ``sample_rate_hz``; the signal's code phase and carrier phase 0 at t = 0). With
        ``clock_cycles`` ``(K + 3,)`` (the receiver oscillator's carrier cycles at the edges
        of the samples' intervals, `oscillator_cycles`) the signal follows the truth's code
        and carrier interval by interval (`_samples_following`), the oscillator's motion in
        both."""
        from ...signal.if_samples import generate_if_samples
        from ...receiver.engine.samples import SampleSource

        p = self.params
        T, fs = c["T"], p.sample_rate_hz
        doppler = np.full(1, p.doppler_hz)
        if clock_cycles is None:
            x = generate_if_samples(
                p.prn,
                c["duration_s"] + 2 * T,
                fs,
                0.0,
                c["cn0_dbhz"],
                rng,
                doppler_hz=p.doppler_hz,
                complex_samples=True,
                sample_type="float32",
            )
            samples, noise_std = x.samples, x.noise_std
            truth = LoopTruth.from_dynamics(c["duration_s"], T, c["cn0_dbhz"], doppler_hz=doppler)
        else:
            span = LoopTruth.from_dynamics(
                c["duration_s"] + 2 * T, T, c["cn0_dbhz"], doppler_hz=doppler, extra_cycles=clock_cycles[:, None]
            )
            samples, noise_std = _samples_following(span, p.prn, fs, c["cn0_dbhz"], rng)
            K = int(round(c["duration_s"] / T))
            truth = LoopTruth.from_dynamics(
                c["duration_s"], T, c["cn0_dbhz"], doppler_hz=doppler, extra_cycles=clock_cycles[: K + 1, None]
            )
        source = SampleSource(
            samples,
            fs,
            0.0,
            self.signal.code(p.prn)[None, :],
            T,
            early_late_spacing_chips=p.early_late_spacing_chips,
            noise_std=noise_std,
        )
        return self._close(channel, truth, c, source)  # the closer resets the filter

    def _close(self, channel, truth: LoopTruth, c: dict, source) -> dict[str, np.ndarray]:
        """Close ``channel`` over ``truth`` on ``source``: the unwrapped mid-interval phase
        error, the code error, the replica's frequency error and the prompt correlator,
        ``(K, runs)`` each (``phase_error_rad``, ``code_error_chips``, ``freq_error_hz``,
        ``prompt``). A channel
        filter that commands NCOs is closed by `ScalarCloser`; one that estimates the
        replica's errors (``iq-filter``) by `EstimateCloser`, its phase error then the
        error of its carrier phase estimate (its replica's phase is not steered)."""
        p = self.params
        T, d = truth.coherent_time_s, p.early_late_spacing_chips
        runs = truth.code_phase_chips.shape[1]
        estimate = not all(n in channel.provides for n in NCO_COMMANDS)
        closer = EstimateCloser(channel) if estimate else ScalarCloser(channel)
        replica = Channel.start(
            (runs,), truth.code_phase_chips[0], p.doppler_hz + p.initial_freq_error_hz, signal=truth.signal
        )
        closer.reset(replica, T, early_late_spacing_chips=d, cn0_dbhz=c["cn0_dbhz"])
        code, carrier = truth.code_phase_chips, truth.carrier_phase_rad
        phase_err, code_err, freq_err = (np.empty((truth.epochs, runs)) for _ in range(3))
        prompt = np.empty((truth.epochs, runs), complex)
        for k in range(truth.epochs):
            err = replica.errors(code[k], code[k + 1], carrier[k], carrier[k + 1], T)
            correlators = source.correlate(replica, k, err)
            prompt[k] = correlators.prompt
            out = closer.step(replica, correlators)
            phase_err[k] = err.phase_rad + np.pi * err.freq_hz * T  # mid-interval, not wrapped
            if estimate:  # the replica's phase is not steered: the loop's phase is its estimate
                phase_err[k] = EstimateCloser.phase_estimate_error(phase_err[k], out, T)
            code_err[k] = err.code_chips
            freq_err[k] = err.freq_hz
        return {"phase_error_rad": phase_err, "code_error_chips": code_err, "freq_error_hz": freq_err, "prompt": prompt}

    def run_batch(self, case, plugins, runs, rng) -> BatchResult:
        c = self._case(case)
        channel = at_interval(plugins["channel_filter"], c["T"])
        tracked, T = self.track_series(case, channel, runs, rng)
        phase_err = tracked["phase_error_rad"]
        bandwidth = float("nan")  # a loop closed by its estimates has no NCO loop to probe
        if all(n in channel.provides for n in NCO_COMMANDS):
            try:
                bandwidth = equivalent_bandwidth_hz(channel, T)
            except ConfigError:  # the bandwidth probe did not settle: no thermal formula to compare with
                pass
        thermal_phase = float(np.sqrt(pll_thermal_variance_rad2(c["cn0_dbhz"], bandwidth, T)))
        thermal_code = code_thermal_std_chips(channel, c["cn0_dbhz"], T, self.params.early_late_spacing_chips)
        K = phase_err.shape[0]
        cn0 = self.cn0_params(case)  # the scenario's C/N0 test, or the case's own
        reading_db = cn0_readings_dbhz(tracked.pop("prompt"), T, cn0)
        cn0_error_db = median_error_db(reading_db, c["cn0_dbhz"])
        floor_dbhz = cn0_floor_dbhz(T, cn0)
        limit = floor_dbhz if cn0.cn0_lock_dbhz is None else cn0.cn0_lock_dbhz
        lost_by_cn0 = cn0_lock_loss(reading_db, limit, cn0.cn0_lock_consecutive)
        series = {
            **tracked,
            "cn0_error_db": np.broadcast_to(cn0_error_db, (K, runs)),
            "cn0_lost": np.broadcast_to(lost_by_cn0, (K, runs)),
            "cn0_floor": np.full((K, runs), floor_dbhz),
            "phase_thermal_std_rad": np.full((K, runs), thermal_phase),
            "code_thermal_std_chips": np.full((K, runs), thermal_code),
            "loop_noise_bandwidth_hz": np.full((K, runs), bandwidth),
        }
        return evaluate(METRICS, series, (np.arange(K) + 0.5) * T, self)


def _samples_following(
    truth: LoopTruth, prn: int, sample_rate_hz: float, cn0_dbhz: float, rng: np.random.Generator
) -> tuple[np.ndarray, float]:
    """Complex baseband samples (``complex64``) of one run's signal following ``truth``
    (one run) interval by interval: in each interval the code phase and carrier phase start
    at the truth's values at its first edge and move linearly to its next (the analytic
    model's interval edges), then unit-variance-per-dimension white noise from ``rng``
    (the amplitude law of `generate_if_samples`). Returns the samples and the noise sigma."""
    from ...signal.if_samples import SAMPLE_TYPES, signal_samples

    T = truth.coherent_time_s
    n = int(round(T * sample_rate_hz))
    code, carrier = truth.code_phase_chips[:, 0], truth.carrier_phase_rad[:, 0]
    sigma = SAMPLE_TYPES["float32"]
    amplitude = np.sqrt(2.0 * sigma**2 * 10.0 ** (cn0_dbhz / 10.0) / sample_rate_hz)
    out = np.empty(truth.epochs * n, np.complex64)
    for k in range(truth.epochs):  # a loop over intervals (600 in 6 s), each one vectorised call
        out[k * n : (k + 1) * n] = signal_samples(
            truth.signal,
            prn,
            n,
            sample_rate_hz,
            float(amplitude),
            float(code[k]),
            float(code[k + 1] - code[k]) / T,
            float(carrier[k]),
            float(carrier[k + 1] - carrier[k]) / n,
            None,
            0.0,
            True,
        )
    noise = rng.standard_normal(out.size) + 1j * rng.standard_normal(out.size)
    return (out + sigma * noise).astype(np.complex64), sigma


def cn0_readings_dbhz(prompt: np.ndarray, T: float, p: Any) -> np.ndarray:
    """The receiver's C/N0 readings (dB-Hz), ``(windows, runs)``: ``prompt (K, runs)`` cut
    after ``p.settle_s`` into whole windows of ``p.cn0_window_s`` (at least the estimator's
    fewest intervals), each read by the ``p.cn0_estimator`` plugin; ``-inf`` where it reads
    0 or below (the estimator saw no signal: M2M4's :math:`2M_2^2 - M_4 < 0`). No whole
    window: ``(0, runs)``."""
    from ... import registry

    estimator = registry.create("cn0_estimator", p.cn0_estimator)
    K, runs = prompt.shape
    first = int(math.ceil(p.settle_s / T - 1e-9))
    width = max(int(round(p.cn0_window_s / T)), estimator.required_intervals())
    windows = max((K - first) // width, 0)
    blocks = prompt[first : first + windows * width].reshape(windows, width, runs)
    estimate_hz = estimator.estimate_hz(np.moveaxis(blocks, 1, -1), T)  # (windows, runs)
    with np.errstate(divide="ignore"):
        return np.where(estimate_hz > 0, 10.0 * np.log10(np.maximum(estimate_hz, 1e-300)), -np.inf)


def median_error_db(reading_db: np.ndarray, cn0_dbhz: float) -> np.ndarray:
    """Per run, the median over windows of ``reading_db (windows, runs)`` minus the truth
    (dB); a reading of ``-inf`` ranks lowest, and the median is NaN when more than half the
    windows have none (or there is no window)."""
    if reading_db.shape[0] == 0:
        return np.full(reading_db.shape[1], np.nan)
    error_db = np.median(reading_db, axis=0) - cn0_dbhz
    return np.where(np.isfinite(error_db), error_db, np.nan)


def cn0_estimate_error_db(prompt: np.ndarray, T: float, cn0_dbhz: float, p: Any) -> np.ndarray:
    """The receiver's C/N0 estimate against the truth, per run: the median over the run's
    windows of ``10 log10(estimate) - cn0_dbhz`` (dB; `cn0_readings_dbhz`, `median_error_db`)."""
    return median_error_db(cn0_readings_dbhz(prompt, T, p), cn0_dbhz)


def cn0_floor_dbhz(T: float, p: Any) -> float:
    """The ``p.cn0_estimator``'s noise-only floor (dB-Hz) on the scenario's window
    (``p.cn0_window_s`` at interval ``T``): the 95th percentile of its readings on pure noise
    (`gnssframework.signal.cn0_estimator.noise_floor_dbhz`, 2000 windows, a fixed seed;
    computed once per estimator, T and window: every batch of a case reads the same)."""
    from ... import registry

    estimator = registry.create("cn0_estimator", p.cn0_estimator)
    width = max(int(round(p.cn0_window_s / T)), estimator.required_intervals())
    return _noise_floor_dbhz(p.cn0_estimator, float(T), width)


@functools.lru_cache(maxsize=64)
def _noise_floor_dbhz(name: str, T: float, width: int) -> float:
    from ... import registry
    from ...signal.cn0_estimator import noise_floor_dbhz

    return noise_floor_dbhz(registry.create("cn0_estimator", name), T, width)


def cn0_lock_loss(reading_db: np.ndarray, limit_dbhz: float, consecutive: int = 1) -> np.ndarray:
    """Per run, 1.0 if ``consecutive`` windows in a row of ``reading_db (windows, runs)``
    read below ``limit_dbhz`` (the receiver's C/N0 lock test declares loss), else 0.0
    (also with fewer windows than ``consecutive``); NaN without a window."""
    if reading_db.shape[0] == 0:
        return np.full(reading_db.shape[1], np.nan)
    below = reading_db < limit_dbhz
    if below.shape[0] < consecutive:
        return np.zeros(below.shape[1])
    runs_below = np.lib.stride_tricks.sliding_window_view(below, consecutive, axis=0)  # (W - n + 1, runs, n)
    return runs_below.all(axis=-1).any(axis=0).astype(float)


def lock_scores(phase_err: np.ndarray, code_err: np.ndarray, T: float, p: TrackingThresholdParams) -> dict:
    """The per-run lock statistics of one batch from its true errors ``(K, runs)`` (see the
    module docstring): ``loss_of_lock``, ``time_to_loss_s``, the slip rates and jitters."""
    K, runs = phase_err.shape
    first = int(math.ceil(p.settle_s / T - 1e-9))
    window = max(1, int(round(p.lock_window_s / T)))
    lost, end, blocks = lock_loss(phase_err, code_err, first, window, p.lock_threshold, p.early_late_spacing_chips / 2)
    span_s = (K - first) * T
    scored = phase_err[first:]
    half_slips, whole_slips = count_slips(scored, p.slip_capture_rad)
    wrapped = (scored + np.pi / 2) % np.pi - np.pi / 2
    in_lock = np.where(lost, end - window, end)  # intervals before the first out-of-lock block
    return {
        "loss_of_lock": lost.astype(float),
        "time_to_loss_s": end * T,
        "half_cycle_slip_rate": half_slips / span_s,
        "cycle_slip_rate": whole_slips / span_s,
        "phase_jitter_rad": _rms_before(wrapped, in_lock),
        "code_jitter_chips": _rms_before(code_err[first:], in_lock),
    }


def code_freq_lock_scores(freq_err: np.ndarray, code_err: np.ndarray, T: float, p: Any) -> dict:
    """``loss_of_code_freq_lock`` and ``time_to_code_freq_loss_s`` of every run (or channel:
    any trailing dimensions) from the replica's true errors ``(K, ...)``, with the lock-test
    settings of ``p`` (``settle_s``, ``lock_window_s``, ``freq_lock_hz``,
    ``early_late_spacing_chips``; `code_freq_lock_loss`)."""
    first = int(math.ceil(p.settle_s / T - 1e-9))
    window = max(1, int(round(p.lock_window_s / T)))
    limit = p.freq_lock_hz if p.freq_lock_hz is not None else 1.0 / (4.0 * T)
    lost, end, _ = code_freq_lock_loss(freq_err, code_err, first, window, limit, p.early_late_spacing_chips / 2)
    return {"loss_of_code_freq_lock": lost.astype(float), "time_to_code_freq_loss_s": end * T}


class CodeFreqLockScore(SeriesMetric):
    """One of `code_freq_lock_scores` as a metric component (reads ``freq_error_hz`` and
    ``code_error_chips``)."""

    def __init__(self, name: str, unit: str, *, description: str = "") -> None:
        super().__init__(name, unit, of="freq_error_hz", description=description)
        self.requires = ("freq_error_hz", "code_error_chips")

    def compute(self, series: dict[str, np.ndarray], time_s: np.ndarray | None, scenario: Any) -> MetricValue:
        T = float(time_s[1] - time_s[0]) if len(time_s) > 1 else 2 * float(time_s[0])
        scores = code_freq_lock_scores(series["freq_error_hz"], series["code_error_chips"], T, scenario.params)
        return MetricValue(scores[self.name])


class LockScore(SeriesMetric):
    """One of `lock_scores` as a metric component (reads ``phase_error_rad`` and
    ``code_error_chips``). Each computes the batch's scores itself (a few passes over the
    ``(K, runs)`` errors): no state is kept between calls, so no scorer can hand another
    scenario's or batch's scores on."""

    def __init__(self, name: str, unit: str, *, undefined: str = "", description: str = "") -> None:
        super().__init__(name, unit, of="phase_error_rad", undefined=undefined, description=description)
        self.requires = ("phase_error_rad", "code_error_chips")

    def compute(self, series: dict[str, np.ndarray], time_s: np.ndarray | None, scenario: Any) -> MetricValue:
        assert time_s is not None  # the scenario's series have a time axis
        T = float(time_s[1] - time_s[0]) if len(time_s) > 1 else 2 * float(time_s[0])
        scores = lock_scores(series["phase_error_rad"], series["code_error_chips"], T, scenario.params)
        return MetricValue(scores[self.name])


#: The scenario's metrics, each declared once as a component.
METRICS = (
    LockScore(
        "loss_of_lock",
        "",
        description="1 if lock was lost after settle_s (a lock_window_s block with mean "
        "cos(2 phase error) below lock_threshold, or mean |code error| above d/2), else 0; its mean is the "
        "probability of loss of lock within the case",
    ),
    LockScore(
        "time_to_loss_s",
        "s",
        description="time after settle_s to the end of the first out-of-lock block, "
        "or the observed span (censored); its mean is the Kaplan-Meier restricted mean time to loss of lock",
    ),
    CodeFreqLockScore(
        "loss_of_code_freq_lock",
        "",
        description="1 if code or frequency lock was lost after "
        "settle_s (a lock_window_s block with mean |frequency error| above freq_lock_hz, default "
        "1/(4T), or mean |code error| above d/2), else 0: the criterion a frequency-locked vector "
        "loop is judged by too",
    ),
    CodeFreqLockScore(
        "time_to_code_freq_loss_s",
        "s",
        description="time after settle_s to the end of the first "
        "block out of code or frequency lock, or the observed span (censored)",
    ),
    LockScore(
        "half_cycle_slip_rate", "1/s", description="half-cycle slips of the true phase error per second after settle_s"
    ),
    LockScore(
        "cycle_slip_rate", "1/s", description="whole-cycle slips of the true phase error per second after settle_s"
    ),
    LockScore(
        "phase_jitter_rad",
        "rad",
        undefined="lock lost in the first block",
        description="RMS phase error (wrapped to half a cycle) while in lock",
    ),
    Mean(
        "phase_jitter_thermal_rad",
        "rad",
        of="phase_thermal_std_rad",
        description="Costas PLL thermal jitter B_L/c (1 + 1/(2cT)) at the loop's measured noise bandwidth",
    ),
    LockScore(
        "code_jitter_chips",
        "chips",
        undefined="lock lost in the first block",
        description="RMS code error while in lock",
    ),
    Mean(
        "code_jitter_thermal_chips",
        "chips",
        of="code_thermal_std_chips",
        description="DLL thermal jitter sqrt(2 B T sigma_D^2) (NaN without dll_bandwidth_hz)",
    ),
    Mean(
        "cn0_estimate_error_db",
        "dB",
        of="cn0_error_db",
        undefined="no reading in most windows (or no whole cn0_window_s after settle_s)",
        description="median over the run's windows (cn0_window_s, after settle_s) of the cn0_estimator's reading "
        "minus the true C/N0; its mean over runs is the estimate's bias: the receiver's own view of the signal "
        "as lock goes",
    ),
    Mean(
        "loss_of_lock_by_cn0",
        "",
        of="cn0_lost",
        undefined="no whole cn0_window_s after settle_s",
        description="1 if a window's C/N0 reading (cn0_window_s, after settle_s) is below cn0_lock_dbhz (default "
        "cn0_floor_dbhz), else 0: the receiver's own lock test on its estimate",
    ),
    Mean(
        "cn0_floor_dbhz",
        "dB-Hz",
        of="cn0_floor",
        description="the cn0_estimator's noise-only floor on the window (95th percentile of its readings on pure "
        "noise): a threshold below it cannot be read off the estimate",
    ),
    Mean(
        "equivalent_bandwidth_hz",
        "Hz",
        of="loop_noise_bandwidth_hz",
        description="the carrier loop's steady-state noise bandwidth (loop_bandwidth.equivalent_bandwidth_hz)",
    ),
)
TrackingThresholdScenario.metrics = units(METRICS)
