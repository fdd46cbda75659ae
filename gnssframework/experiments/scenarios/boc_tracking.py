r"""Scenario ``boc-tracking``: side-peak lock and code error of BOC(1,1) code loops.

One channel per run tracks Galileo E1-C with a BOC(1,1) replica (``galileo-e1c-boc11``,
a pilot: no data) on the loop engine's analytic correlator model, whose taps see the BOC
autocorrelation (a train of triangles, `SignalSpec.autocorrelation`; checked against the
numerical correlation of the sampled replica in ``tests/signal/test_boc_tracking.py``). The
candidate's code discriminator declares the taps it needs beyond early, prompt and late
(`Discriminator.extra_taps`: very-early and very-late for the side-peak detectors); the
source draws them with their noise correlated as :math:`R(o_i - o_j)`.

Every run starts with the true Doppler and a code error drawn uniformly in
:math:`\pm` ``initial_code_error_chips`` (0.5 by default: some starts sit near a side
peak, at :math:`\pm 1/2` chip for BOC(1,1)), from the run's own stream: run ``r`` of every
candidate and C/N0 starts from the same error and sees the same noise (paired).

Metrics, read off the true code error (truth minus replica):

``side_peak_lock``
    1 when the mean :math:`|\delta\tau|` over the last ``lock_window_s`` exceeds
    ``side_peak_chips`` / 2 (a quarter chip for BOC(1,1): nearer the side peak than the
    main one), else 0; its mean over runs is the probability of side-peak lock.
``code_rms_main_chips``
    RMS code error after ``settle_s`` on the runs that end on the main peak (undefined on
    a side-peak lock).
``phase_lock_lost``
    1 when the mean :math:`\cos 2\delta\phi` over the last ``lock_window_s`` is below
    ``lock_threshold`` (the carrier loop let go: the code results are then not the code
    loop's), else 0.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar, Literal

import numpy as np
from pydantic import Field

from ... import random_streams as draw
from ...receiver.engine.channel import Channel
from ...receiver.engine.closers import ScalarCloser
from ...receiver.engine.sources import AnalyticSource
from ...receiver.engine.truth import LoopTruth
from ...receiver.tracking.loop_bandwidth import at_interval
from ...signal.correlator_model import CorrelatorSimulator, amplitude_from_cn0
from ...signal.galileo_e1 import GALILEO_E1C_BOC11
from ...signal.spec import SignalSpec
from ..metric_components import SeriesMetric, evaluate, units
from ..metrics import MetricValue
from . import BatchResult, register_scenario
from .tracking_threshold import TrackingThresholdCase, TrackingThresholdParams, TrackingThresholdScenario

__all__ = ["BocTrackingScenario", "boc_scores", "METRICS"]


class BocTrackingParams(TrackingThresholdParams):
    #: T counts its code periods (`SignalCoherentTime`): 4 ms to the 100 ms of E1-C's overlay.
    signal: ClassVar[SignalSpec] = GALILEO_E1C_BOC11
    duration_s: float = Field(2.0, gt=0, le=3600, description="duration of every case (s)")
    coherent_time_s: float = Field(0.004, description="interval T (s): whole 4 ms E1-C code periods")
    early_late_spacing_chips: float = Field(0.2, gt=0, le=1.0, description="early-late spacing D (chips)")
    settle_s: float = Field(1.0, ge=0, description="time not scored by code_rms_main_chips (s)")
    lock_window_s: float = Field(0.2, gt=0, description="the last this many seconds decide side-peak lock")
    initial_code_error_chips: float = Field(
        0.5, ge=0, le=1.0, description="initial code error drawn uniformly in +- this (chips)"
    )
    side_peak_chips: float = Field(
        0.5,
        gt=0,
        le=1.0,
        description="distance of the first side peak (chips; "
        "n/(2m), 0.5 for BOC(1,1)): a run ending more than half of it off is side-locked",
    )


class BocTrackingCase(TrackingThresholdCase):
    signal: ClassVar[SignalSpec] = GALILEO_E1C_BOC11
    source: Literal["analytic"] = Field(
        "analytic", description="correlators from the analytic model (the only source of this scenario)"
    )


def boc_scores(code_err: np.ndarray, phase_err: np.ndarray, T: float, p: BocTrackingParams) -> dict:
    """Per-run scores of one batch from its true errors ``(K, runs)`` (module docstring)."""
    K = code_err.shape[0]
    window = min(K, max(1, int(round(p.lock_window_s / T))))
    side = np.mean(np.abs(code_err[-window:]), axis=0) > p.side_peak_chips / 2
    lost = np.mean(np.cos(2 * phase_err[-window:]), axis=0) < p.lock_threshold
    first = min(K - 1, int(math.ceil(p.settle_s / T - 1e-9)))
    rms = np.sqrt(np.mean(code_err[first:] ** 2, axis=0))
    return {
        "side_peak_lock": side.astype(float),
        "code_rms_main_chips": np.where(side, np.nan, rms),
        "phase_lock_lost": lost.astype(float),
    }


class BocScore(SeriesMetric):
    """One of `boc_scores` as a metric component (reads ``code_error_chips`` and
    ``phase_error_rad``). Each computes the batch's scores itself (a few means over the
    ``(K, runs)`` errors): no state is kept between calls, so no scorer can hand another
    scenario's or batch's scores on."""

    def __init__(self, name: str, unit: str, *, undefined: str = "", description: str = "") -> None:
        super().__init__(name, unit, of="code_error_chips", undefined=undefined, description=description)
        self.requires = ("code_error_chips", "phase_error_rad")  # type: ignore[misc]  # per instance, as SeriesMetric's

    def compute(self, series: dict[str, np.ndarray], time_s: np.ndarray | None, scenario: Any) -> MetricValue:
        assert time_s is not None  # the scenario's series have a time axis
        T = float(time_s[1] - time_s[0]) if len(time_s) > 1 else 2 * float(time_s[0])
        scores = boc_scores(series["code_error_chips"], series["phase_error_rad"], T, scenario.params)
        return MetricValue(scores[self.name])


#: The scenario's metrics.
METRICS = (
    BocScore(
        "side_peak_lock",
        "",
        description="1 if the mean |code error| over the last lock_window_s exceeds "
        "side_peak_chips / 2 (locked on a side peak), else 0; its mean is the probability of side-peak lock",
    ),
    BocScore(
        "code_rms_main_chips",
        "chips",
        undefined="side-peak lock",
        description="RMS code error after settle_s on a run that ends on the main peak",
    ),
    BocScore(
        "phase_lock_lost",
        "",
        description="1 if the mean cos(2 phase error) over the last lock_window_s is below lock_threshold, else 0",
    ),
)


@register_scenario
class BocTrackingScenario(TrackingThresholdScenario):
    """Side-peak lock probability and main-peak code error of BOC(1,1) code loops."""

    kind = "boc-tracking"
    signal: ClassVar[SignalSpec] = GALILEO_E1C_BOC11
    Params = BocTrackingParams
    params: BocTrackingParams  # self.params, as validated
    CaseParams = BocTrackingCase
    outputs = {"phase_error_rad": "rad", "code_error_chips": "chips"}

    @staticmethod
    def taps_of(channel) -> dict[str, float]:
        """The taps beyond E/P/L the channel filter's code discriminator reads
        (`Discriminator.extra_taps`), none for a filter without one."""
        disc = getattr(channel.params, "code_discriminator", None)
        return {} if disc is None else disc.create().extra_taps()

    def track(
        self, case: dict, channel, runs: int, rng, code_error0: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray, float]:
        """Close ``channel`` over ``runs`` runs of the case from the drawn code errors (or
        ``code_error0``, chips, when given): the unwrapped mid-interval phase error and the
        code error ``(K, runs)``, and T."""
        rng = draw.as_run_streams(rng, runs)
        p = self.params
        c = self._case(case)
        T, d = c["T"], p.early_late_spacing_chips
        a = p.initial_code_error_chips
        if code_error0 is None:
            code_error0 = draw.uniform(draw.child(rng, "initial code error"), -a, a, (runs,))
        truth = LoopTruth.from_dynamics(
            c["duration_s"],
            T,
            c["cn0_dbhz"],
            doppler_hz=np.full(runs, p.doppler_hz),
            doppler_rate_hz_s=c["rate"],
            doppler_jerk_hz_s2=c["jerk"],
            signal=self.signal,
        )
        simulator = CorrelatorSimulator(T, d, extra_taps=self.taps_of(channel) or None, signal=self.signal)
        source = AnalyticSource(simulator, amplitude_from_cn0(c["cn0_dbhz"], T), rng)
        closer = ScalarCloser(channel)
        assert truth.code_phase_chips is not None  # from_dynamics sets it
        replica = Channel.start(
            (runs,), truth.code_phase_chips[0] - code_error0, p.doppler_hz + p.initial_freq_error_hz, signal=self.signal
        )
        closer.reset(replica, T, early_late_spacing_chips=d, cn0_dbhz=c["cn0_dbhz"])
        code, carrier = truth.code_phase_chips, truth.carrier_phase_rad
        assert code is not None and carrier is not None  # from_dynamics sets both
        phase_err, code_err = np.empty((truth.epochs, runs)), np.empty((truth.epochs, runs))
        for k in range(truth.epochs):
            err = replica.errors(code[k], code[k + 1], carrier[k], carrier[k + 1], T)
            closer.step(replica, source.correlate(replica, k, err))
            phase_err[k] = err.phase_rad + np.pi * err.freq_hz * T
            code_err[k] = err.code_chips
        return phase_err, code_err, T

    def run_batch(self, case, plugins, runs, rng) -> BatchResult:
        c = self._case(case)
        channel = at_interval(plugins["channel_filter"], c["T"])
        phase_err, code_err, T = self.track(case, channel, runs, rng)
        K = phase_err.shape[0]
        series = {"phase_error_rad": phase_err, "code_error_chips": code_err}
        return evaluate(METRICS, series, (np.arange(K) + 0.5) * T, self)


BocTrackingScenario.metrics = units(METRICS)
