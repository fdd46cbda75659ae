"""Scenario ``scintillation``: carrier tracking under ionospheric scintillation (Xia et al.).

One channel per run tracks a GPS L1 C/A signal whose amplitude and phase are modulated by
a scintillation process (AJ-Stanford or Cornell). The candidate is a ``channel_filter``
that closes the carrier loop (``scalar`` PLL, ``kf-carrier-loop``), run in closed loop
on the correlator model. A case may set its own C/N0, interval T and duration; with its
own T, every candidate's loop is re-created at that T with its other parameters as given
(Q and R per interval, bandwidths in Hz). ``equivalent_bandwidth_hz`` is each loop's
steady-state noise bandwidth (``gnssframework.receiver.tracking.loop_bandwidth``).
"""

from __future__ import annotations

from typing import ClassVar, Literal

import numpy as np
from pydantic import Field

from ... import random_streams as draw
from ...errors import ConfigError
from ...interfaces import RunContext
from ...receiver.tracking.loop_bandwidth import at_interval, equivalent_bandwidth_hz
from ...receiver.tracking.scalar import NCO_COMMANDS, SignalTruth, check_closed_loop, run_closed_loop
from ...signal.gps_l1ca import GPS_L1CA
from ...signal.spec import SignalSpec
from ...simulation import scintillation as scint
from ...simulation.clock import Oscillator, oscillator_cycles
from ..limits import SignalCoherentTime
from ..metric_components import LockLossFraction, Mean, Rmse, Std, evaluate, units
from . import BatchResult, Scenario, ScenarioParams, register_scenario

__all__ = ["ScintillationScenario", "METRICS", "BYTES_PER_EPOCH_RUN"]

#: Peak memory of one run's epoch (the scintillation process, the truth and the closed
#: loop's record), an upper bound: tests/experiments/test_limits.py holds it above the measured peak.
BYTES_PER_EPOCH_RUN = 512


class ScintillationParams(SignalCoherentTime, ScenarioParams):
    duration_s: float = Field(60.0, gt=0, le=3600)
    coherent_time_s: float = Field(0.01, description="interval T (s): whole 1 ms code periods, 1 to 20 ms")
    cn0_dbhz: float = Field(45.0, ge=20, le=60, description="C/N0 without scintillation")
    doppler_hz: float = Field(1500.0, description="constant Doppler (known at start)")
    doppler_rate_hz_s: float = Field(0.0, description="line-of-sight dynamics")
    settle_s: float = Field(2.0, ge=0)
    lock_window_s: float = Field(0.2, gt=0, description="block length of the lock test")
    lock_threshold: float = Field(0.5, description="a block whose mean cos(2 phase error) is below is out of lock")
    oscillator: Oscillator = Field(
        "none",
        description="receiver oscillator phase noise of every case that sets none: 'none' (an ideal "
        "clock), or a preset of gnssframework.simulation.clock (tcxo, tcxo-hq, ocxo: its Allan-variance "
        "h-parameters)",
    )


class ScintillationCase(SignalCoherentTime, ScenarioParams):
    name: str | None = None
    model: Literal["aj-stanford", "cornell"] = "aj-stanford"
    s4: float = Field(..., gt=0, le=1.0)
    sigma_phi_rad: float = Field(0.1, ge=0, description="AJ-Stanford phase standard deviation")
    tau0_s: float = Field(0.8, gt=0, description="Cornell decorrelation time")
    p: float = Field(2.5, ge=1.5, le=4.0, description="AJ-Stanford spectral slope")
    corner_hz: float = Field(0.1, gt=0, description="AJ-Stanford corner frequency")
    cn0_dbhz: float | None = Field(None, ge=20, le=60, description="C/N0 of this case (default: the scenario's)")
    coherent_time_s: float | None = Field(
        None,
        description="interval T of this case (s; whole 1 ms code "
        "periods, 1 to 20 ms; default: the scenario's); the candidates' "
        "loops are re-created at this T",
    )
    duration_s: float | None = Field(None, gt=0, le=3600, description="duration of this case (default: the scenario's)")
    # Line-of-sight dynamics in the truth's carrier (and code) phase; all off by default,
    # so a case without them is the static receiver of the reference.
    doppler_rate_hz_s: float | None = Field(
        None,
        ge=-1000,
        le=1000,
        description="constant Doppler rate of this case in Hz/s (line-of-sight acceleration / L1 wavelength; "
        "1 Hz/s = 0.19 m/s^2); default: the scenario's doppler_rate_hz_s (0). A 2nd-order loop lags it by "
        "2 pi fdot / omega_n^2 rad (Kaplan & Hegarty, Understanding GPS/GNSS, 3rd ed., PLL steady-state errors)",
    )
    doppler_jerk_hz_s2: float = Field(
        0.0,
        ge=-100,
        le=100,
        description="constant rate of change of the Doppler rate in Hz/s^2 (line-of-sight jerk / L1 wavelength); "
        "default 0; the carrier gains fddot t^3 / 6 cycles, a ramp error for a 2nd-order loop",
    )
    los_sine_amplitude_m: float = Field(
        0.0,
        ge=0,
        le=100,
        description="amplitude in metres of a sinusoidal platform motion along the line of sight, default 0 "
        "(none); the carrier gains (A / lambda_L1) sin(2 pi f t) cycles",
    )
    los_sine_frequency_hz: float = Field(
        0.5,
        gt=0,
        le=20,
        description="frequency in Hz of that sinusoidal motion, default 0.5 Hz (a vibration or a sway)",
    )
    oscillator: Oscillator | None = Field(
        None,
        description="receiver oscillator of this case (default: the scenario's): its clock bias b(t) "
        "moves carrier and code together by -f_L1 b cycles (gnssframework.simulation.clock.ClockModel)",
    )


#: The scenario's metrics, each declared once as a component (name, unit, the series it
#: reduces); ``run_batch`` computes them all once with `evaluate`.
METRICS = (
    Rmse(
        "phase_error_rmse",
        "rad",
        of="phase_error_rad",
        settle="settle_s",
        description="RMS carrier phase error (wrapped to half a cycle) after settle_s",
    ),
    Std(
        "discriminator_std",
        "rad",
        of="phase_disc_rad",
        settle="settle_s",
        description="standard deviation of the phase discriminator's output after settle_s",
    ),
    LockLossFraction(
        "loss_of_lock_fraction",
        of="phase_error_rad",
        window="lock_window_s",
        threshold="lock_threshold",
        settle="settle_s",
        description="fraction of lock_window_s blocks whose mean cos(2 phase error) is below lock_threshold",
    ),
    Mean(
        "equivalent_bandwidth_hz",
        "Hz",
        of="loop_noise_bandwidth_hz",
        description="the loop's steady-state noise bandwidth (gnssframework.receiver.tracking.loop_bandwidth)",
    ),
)


@register_scenario
class ScintillationScenario(Scenario):
    """Carrier tracking under amplitude and phase scintillation (Xia et al.)."""

    kind = "scintillation"
    #: The simulated signal (its carrier wavelength).
    signal: ClassVar[SignalSpec] = GPS_L1CA
    Params = ScintillationParams
    params: ScintillationParams  # self.params, as validated
    CaseParams = ScintillationCase
    components = {"channel_filter": True}
    metrics = units(METRICS)
    #: The raw per-epoch series the metrics reduce (metric components of other packages
    #: may read them too).
    outputs = {"phase_error_rad": "rad", "phase_disc_rad": "rad", "loop_noise_bandwidth_hz": "Hz"}

    def check_case(self, case: dict, where: str) -> None:
        """The case's own checks, and its duration against the intervals it must hold: one
        interval, the settling time and, after it, one whole lock-test block."""
        super().check_case(case, where)
        c = self.CaseParams.model_validate(case)
        p = self.params
        T = c.coherent_time_s or p.coherent_time_s
        duration_s = c.duration_s or p.duration_s
        field = f"{where}.duration_s" if c.duration_s else "scenario.duration_s"
        for limit, name in ((T, "the interval coherent_time_s"), (p.settle_s, "settle_s")):
            if duration_s <= limit:
                raise ConfigError(field, f"must be longer than {name} = {limit!r} s (got {duration_s!r})")
        if p.lock_window_s > duration_s - p.settle_s:
            raise ConfigError(
                "scenario.lock_window_s",
                f"must be at most duration_s - settle_s = "
                f"{duration_s - p.settle_s:g} s of {where} (one whole lock-test block after "
                f"settling; got {p.lock_window_s!r})",
            )

    def assumption_context(self, case: dict) -> dict:
        """The case's interval T (the loops are re-created at it), its C/N0 and the L1
        wavelength, for the candidates' ``assumptions``."""
        c = self.CaseParams.model_validate({k: v for k, v in case.items() if k != "name"} | {"name": case.get("name")})
        p = self.params
        return {
            "coherent_time_s": c.coherent_time_s or p.coherent_time_s,
            "cn0_dbhz": p.cn0_dbhz if c.cn0_dbhz is None else c.cn0_dbhz,
            "wavelength_m": self.signal.wavelength_m,
        }

    def batch_memory(self, case: dict, runs: int, where: str, candidates=()) -> tuple[float, str, str]:
        T = case["coherent_time_s"] or self.params.coherent_time_s
        epochs = int(round((case["duration_s"] or self.params.duration_s) / T))
        field = f"{where}.coherent_time_s" if case["coherent_time_s"] else "scenario.coherent_time_s"
        return BYTES_PER_EPOCH_RUN * epochs * runs, field, f"a batch of {runs} runs of {where} ({epochs} epochs)"

    def run_contexts(self, cases: list[dict]) -> list[RunContext]:
        """One context per interval T of the scenario and its cases (loops are re-created at each)."""
        own = {self.CaseParams.model_validate(c).coherent_time_s for c in cases}
        intervals = sorted({self.params.coherent_time_s} | {T for T in own if T is not None})
        return [RunContext(coherent_time_s=T, early_late_spacing_chips=1.0, epoch_interval_s=T) for T in intervals]

    def in_context(self, plugin, context: RunContext):
        return self.at_interval(plugin, context.coherent_time_s)

    def case_parameters(self, kind: str, spec, case: dict) -> dict:
        """The channel filter of a task is built at its case's interval T (the loop
        `at_interval` would re-create in `run_batch`): ``coherent_time_s = T`` when its own
        interval is another, nothing when it has none (it takes the harness's)."""
        field = spec.cls.Params.model_fields.get("coherent_time_s") if kind == "channel_filter" else None
        if field is None:
            return {}
        own_s = spec.params.get("coherent_time_s", field.get_default(call_default_factory=True))
        T = self.CaseParams.model_validate(case).coherent_time_s or self.params.coherent_time_s
        return {} if own_s is None or abs(own_s - T) < 1e-12 else {"coherent_time_s": T}

    def check_composition(self, plugins, where: str) -> None:
        ch = plugins["channel_filter"]
        try:
            check_closed_loop(ch, record=("phase_disc_rad",))
        except ConfigError as exc:
            raise self.refuse(exc, where, NCO_COMMANDS + ("phase_disc_rad",)) from None
        T = getattr(ch.params, "coherent_time_s", None)
        if T is not None and abs(T - self.params.coherent_time_s) > 1e-12:
            raise ConfigError(
                f"{where}.channel_filter.params.coherent_time_s",
                f"is {T} but the scenario integrates over {self.params.coherent_time_s} s; make them equal",
            )

    def _scintillation(
        self, case: dict, runs: int, rng: np.random.Generator, T: float, duration_s: float
    ) -> np.ndarray:
        fs = 1.0 / T
        duration = duration_s + T  # K+1 boundary samples
        if case.get("model", "aj-stanford") == "cornell":
            return scint.cornell(case["s4"], case.get("tau0_s", 0.8), duration, fs, rng, batch_shape=(runs,))
        return scint.aj_stanford(
            case["s4"],
            case.get("sigma_phi_rad", 0.1),
            duration,
            fs,
            rng,
            p=case.get("p", 2.5),
            corner_hz=case.get("corner_hz", 0.1),
            batch_shape=(runs,),
        )

    at_interval = staticmethod(at_interval)  # the loop at the case's T (loop_bandwidth.at_interval)

    def truth(self, case: dict, runs: int, rng) -> tuple[SignalTruth, np.ndarray]:
        """The case's signal truth and its scintillation phase ``(K+1, runs)`` (rad).

        The carrier phase is the line-of-sight dynamics (constant Doppler, the case's
        Doppler rate and jerk, its sinusoidal motion; ``SignalTruth.from_dynamics``) plus
        the scintillation phase; the amplitude is the scintillation's.
        """
        rng = draw.as_run_streams(rng, runs)
        p = self.params
        c = self.CaseParams.model_validate(case).model_dump()
        T = c["coherent_time_s"] or p.coherent_time_s
        duration_s = c["duration_s"] or p.duration_s
        cn0_dbhz = p.cn0_dbhz if c["cn0_dbhz"] is None else c["cn0_dbhz"]
        K = int(round(duration_s / T))
        z = self._scintillation(c, runs, rng, T, duration_s)[: K + 1]
        phase = np.unwrap(np.angle(z), axis=0)
        phase = phase - phase[0]
        rate = p.doppler_rate_hz_s if c["doppler_rate_hz_s"] is None else c["doppler_rate_hz_s"]
        sway = None
        if c["los_sine_amplitude_m"] > 0:
            t = np.arange(K + 1)[:, None] * T
            sway = (
                c["los_sine_amplitude_m"]
                / self.signal.wavelength_m
                * np.sin(2 * np.pi * c["los_sine_frequency_hz"] * t)
            )
        oscillator = c["oscillator"] or p.oscillator
        clock = oscillator_cycles(oscillator, K, T, draw.child(rng, "oscillator"), runs, self.signal.carrier_freq_hz)
        if clock is not None:
            sway = clock if sway is None else sway + clock
        truth = SignalTruth.from_dynamics(
            duration_s,
            T,
            cn0_dbhz,
            doppler_hz=np.full(runs, p.doppler_hz),
            doppler_rate_hz_s=rate,
            doppler_jerk_hz_s2=c["doppler_jerk_hz_s2"],
            extra_cycles=sway,
            extra_phase_rad=phase,
            amplitude_scale=np.abs(z[:K]),
        )
        return truth, phase

    def run_batch(self, case, plugins, runs, rng) -> BatchResult:
        rng = draw.as_run_streams(rng, runs)  # one stream per run: numbers independent of batching
        p = self.params
        c = self.CaseParams.model_validate(case).model_dump()
        T = c["coherent_time_s"] or p.coherent_time_s
        channel = self.at_interval(plugins["channel_filter"], T)
        truth, _ = self.truth(case, runs, rng)
        K = truth.epochs
        # The receiver knows the initial Doppler only (acquisition), not the dynamics.
        rec = run_closed_loop(channel, truth, rng, initial_doppler_hz=p.doppler_hz, record=("phase_disc_rad",))
        t = (np.arange(K) + 0.5) * T
        # Costas loops are blind to half cycles: wrap errors to (-pi/2, pi/2].
        err = (rec.phase_error_rad + np.pi / 2) % np.pi - np.pi / 2
        return evaluate(
            METRICS,
            {
                "phase_error_rad": err,
                "phase_disc_rad": rec.outputs["phase_disc_rad"],
                "loop_noise_bandwidth_hz": np.full((K, runs), equivalent_bandwidth_hz(channel, T)),
            },
            t,
            self,
        )
