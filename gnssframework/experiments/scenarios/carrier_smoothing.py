"""Scenario ``carrier-smoothing``: carrier-smoothed code with cycle slips (CN105068097 patent 2015).

One satellite of the nominal constellation seen from a static receiver, epochs of 1 s.
Pseudorange = range + white thermal noise + AR(1) code multipath; carrier phase (m) =
range + integer ambiguity + white noise + random cycle slips. No ionosphere, so
code-carrier divergence is zero: a smoother can average indefinitely between slips.
A candidate composes a ``channel_filter`` (``hatch``, ``kf-smoother``), or nothing for
the raw pseudorange. A case may set its own slip probability. Slip recovery is measured
on isolated slips only, and slips whose recovery the next slip cuts off are counted
(``censored_slips``), not averaged.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
import pymap3d
from pydantic import Field, ValidationInfo, field_validator

from ... import random_streams as draw
from ...errors import ConfigError
from ...interfaces import RunContext
from ...navigation.geometry import geometric_range
from ...signal.gps_l1ca import GPS_L1CA
from ...signal.spec import SignalSpec
from ...simulation.constellation import nominal_constellation
from ...simulation.impairments import ar1_noise, cycle_slips
from ..metric_components import FalseResets, Rmse, SlipRecovery, evaluate, false_resets, slip_recovery, units
from ..metric_components import undefined_reasons as _undefined_reasons
from . import BatchResult, Scenario, ScenarioParams, register_scenario

__all__ = [
    "CarrierSmoothingScenario",
    "METRICS",
    "slip_recovery",
    "slip_recovery_epochs",
    "false_resets",
    "BYTES_PER_EPOCH_RUN",
]

#: Peak memory of one run's epoch (the simulated observables and the smoother's outputs;
#: an upper bound over the candidates: tests/experiments/test_limits.py holds it above the measured peak).
BYTES_PER_EPOCH_RUN = 256


class CarrierSmoothingParams(ScenarioParams):
    epochs: int = Field(721, ge=50, le=100_000)
    dt_s: float = Field(1.0, gt=0)
    start_time_s: float = Field(37800.0, ge=0)
    lat_deg: float = 34.23
    lon_deg: float = 108.3576
    height_m: float = 590.6
    code_noise_std_m: float = Field(1.0, ge=0, description="white thermal code noise")
    multipath_std_m: float = Field(0.5, ge=0, description="stationary std of the AR(1) code multipath")
    multipath_psi: float = Field(0.98, gt=-1, lt=1)
    carrier_noise_std_m: float = Field(0.003, ge=0)
    slip_probability: float = Field(0.01, ge=0, le=1, description="chance of a slip at each epoch")
    slip_min_cycles: int = Field(10, ge=1)
    slip_max_cycles: int = Field(50, ge=1)
    settle_epochs: int = Field(50, ge=0, description="error_rmse ignores the first epochs")
    recovery_isolation_epochs: int = Field(
        400,
        ge=0,
        description="slip_recovery_epochs measures only slips with no "
        "earlier slip within this many epochs (a clean reference level)",
    )

    @field_validator("slip_max_cycles")
    @classmethod
    def _max_not_below_min(cls, value: int, info: ValidationInfo) -> int:
        if value < info.data.get("slip_min_cycles", 1):
            raise ValueError(f"must be >= slip_min_cycles ({info.data.get('slip_min_cycles')})")
        return value


class CarrierSmoothingCase(ScenarioParams):
    name: str | None = None
    slip_probability: float | None = Field(
        None, ge=0, le=1, description="chance of a slip at each epoch in this case (default: the scenario's)"
    )


def slip_recovery_epochs(err: np.ndarray, slips: np.ndarray, **kwargs) -> np.ndarray:
    """Mean epochs, per run, to recover from isolated, uncensored slips (see ``slip_recovery``)."""
    return slip_recovery(err, slips, **kwargs)[0]


#: The scenario's metrics, each declared once as a component (name, unit, the series it
#: reduces); ``run_batch`` computes them all once with `evaluate`.
METRICS = (
    Rmse(
        "error_rmse",
        "m",
        of="range_error_m",
        skip_epochs="settle_epochs",
        description="RMS range error of the (smoothed) pseudorange after settle_epochs",
    ),
    SlipRecovery(
        "slip_recovery_epochs",
        of="range_error_m",
        slips="slip",
        output="mean",
        isolation="recovery_isolation_epochs",
        start="settle_epochs",
        description="mean epochs to recover (2 sigma) from isolated, uncensored slips",
    ),
    SlipRecovery(
        "censored_slips",
        of="range_error_m",
        slips="slip",
        output="censored",
        isolation="recovery_isolation_epochs",
        start="settle_epochs",
        description="isolated slips not recovered before the next slip or the end",
    ),
    FalseResets(
        "false_reset_rate",
        of="slip_detected",
        slips="slip",
        description="slip detections with no slip since the previous detection",
    ),
)


@register_scenario
class CarrierSmoothingScenario(Scenario):
    """Carrier-smoothed code with random cycle slips (CN105068097 patent 2015)."""

    kind = "carrier-smoothing"
    #: The simulated signal (its carrier wavelength).
    signal: ClassVar[SignalSpec] = GPS_L1CA
    Params = CarrierSmoothingParams
    params: CarrierSmoothingParams  # self.params, as validated
    CaseParams = CarrierSmoothingCase
    components = {"channel_filter": False}
    metrics = units(METRICS)
    #: The raw per-epoch series the metrics reduce (metric components of other packages
    #: may read them too): signed range error, true slip epochs, slip detections.
    outputs = {"range_error_m": "m", "slip": "-", "slip_detected": "-"}
    #: Why a metric can be undefined (NaN) in a run; summary.json and report.md say it.
    undefined_reasons = _undefined_reasons(METRICS)

    def batch_memory(self, case: dict, runs: int, where: str, candidates=()) -> tuple[float, str, str]:
        epochs = self.params.epochs
        return (
            BYTES_PER_EPOCH_RUN * epochs * runs,
            "scenario.epochs",
            f"a batch of {runs} runs of {where} ({epochs} epochs)",
        )

    def check_composition(self, plugins, where: str) -> None:
        ch = plugins.get("channel_filter")
        if ch is not None and (
            not set(ch.requires) <= {"pseudorange_m", "carrier_m"} or "smoothed_m" not in ch.provides
        ):
            raise ConfigError(
                f"{where}.channel_filter.name",
                f"{ch.name!r} does not smooth code with carrier "
                "(needs pseudorange_m and carrier_m, provides smoothed_m); use 'hatch' or 'kf-smoother'",
            )

    def simulate(self, runs: int, rng: np.random.Generator, slip_probability: float | None = None):
        """True range, pseudorange, carrier (m) and slip epochs, each ``(K, runs)``."""
        p = self.params
        slip_probability = p.slip_probability if slip_probability is None else slip_probability
        const = nominal_constellation()
        sat = const.subset(const.visible(p.start_time_s, p.lat_deg, p.lon_deg, p.height_m, 10.0, 1))
        t = p.start_time_s + np.arange(p.epochs) * p.dt_s
        pos, _, _ = sat.state(t)
        rx = np.array(pymap3d.geodetic2ecef(p.lat_deg, p.lon_deg, p.height_m))
        truth = np.broadcast_to(geometric_range(pos[:, 0], rx)[:, None], (p.epochs, runs))
        mp_xi = p.multipath_std_m * np.sqrt(1 - p.multipath_psi**2)
        code = (
            truth
            + p.code_noise_std_m * draw.standard_normal(rng, (p.epochs, runs), 1)
            + ar1_noise(p.multipath_psi, mp_xi, p.epochs, rng, batch_shape=(runs,))
        )
        ambiguity = draw.integers(rng, -(10**6), 10**6, runs, 0) * self.signal.wavelength_m
        slips_cycles = cycle_slips(
            p.epochs, slip_probability, rng, p.slip_max_cycles, (runs,), min_cycles=p.slip_min_cycles
        )
        happens = np.diff(slips_cycles, axis=0, prepend=0) != 0
        carrier = (
            truth
            + ambiguity
            + p.carrier_noise_std_m * draw.standard_normal(rng, (p.epochs, runs), 1)
            + slips_cycles * self.signal.wavelength_m
        )
        return truth, code, carrier, happens

    def assumption_context(self, case: dict) -> dict:
        """The epoch interval, the code noise variance (white noise plus the AR(1)
        multipath's stationary variance, $\\sigma_w^2 + \\sigma_{mp}^2$) and the true
        code-minus-carrier drift PSD (0: this scenario has no ionosphere)."""
        p = self.params
        return {
            "epoch_interval_s": p.dt_s,
            "code_noise_variance_m2": p.code_noise_std_m**2 + p.multipath_std_m**2,
            "code_minus_carrier_drift_psd_m2_s": 0.0,
        }

    def run_batch(self, case, plugins, runs, rng) -> BatchResult:
        rng = draw.as_run_streams(rng, runs)  # one stream per run: numbers independent of batching
        p = self.params
        truth, code, carrier, slips = self.simulate(runs, rng, case.get("slip_probability"))
        ch = plugins.get("channel_filter")
        if ch is None:
            smoothed, detected = code, np.zeros_like(slips)
        else:
            ch.reset((runs,), RunContext(epoch_interval_s=p.dt_s))
            outs = [ch.checked_step({"pseudorange_m": code[k], "carrier_m": carrier[k]}) for k in range(p.epochs)]
            smoothed = np.stack([o["smoothed_m"] for o in outs])
            detected = np.stack([np.broadcast_to(o.get("slip_detected", False), (runs,)) for o in outs])
        return evaluate(
            METRICS,
            {"range_error_m": smoothed - truth, "slip": slips, "slip_detected": detected},
            np.arange(p.epochs) * p.dt_s,
            self,
        )
