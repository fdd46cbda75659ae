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

import numpy as np
import pymap3d
from pydantic import Field, ValidationInfo, field_validator

from ...errors import ConfigError
from ...interfaces import RunContext
from ...signal.constants import L1_WAVELENGTH_M
from ...simulation.constellation import nominal_constellation
from ...simulation.impairments import ar1_noise, cycle_slips
from . import BatchResult, Scenario, ScenarioParams, register_scenario

__all__ = ["CarrierSmoothingScenario", "slip_recovery", "slip_recovery_epochs", "false_resets"]


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
    recovery_isolation_epochs: int = Field(400, ge=0, description="slip_recovery_epochs measures only slips with no "
                                           "earlier slip within this many epochs (a clean reference level)")

    @field_validator("slip_max_cycles")
    @classmethod
    def _max_not_below_min(cls, value: int, info: ValidationInfo) -> int:
        if value < info.data.get("slip_min_cycles", 1):
            raise ValueError(f"must be >= slip_min_cycles ({info.data.get('slip_min_cycles')})")
        return value


class CarrierSmoothingCase(ScenarioParams):
    name: str | None = None
    slip_probability: float | None = Field(None, ge=0, le=1, description="chance of a slip at each epoch in this "
                                           "case (default: the scenario's)")


def slip_recovery(err: np.ndarray, slips: np.ndarray, before: int = 30, window: int = 5, band: float = 2.0,
                  isolation: int = 400, start: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Recovery after isolated cycle slips, per run: (mean epochs to recover, censored slips).

    A slip at epoch s is *measured* if its ``before`` epochs of reference start at or
    after ``start`` and no earlier slip lies within ``isolation`` epochs before s (so the
    reference level is not the tail of an earlier slip). Its reference sigma is the RMS
    error over ``[s - before, s)``; it has recovered at the first j where the RMS over
    ``[s+j, s+j+window)`` is at most ``band`` sigma. A measured slip that has not
    recovered before the next slip or the end of the run is *censored*: it is left out
    of the mean (counting the epochs until the next slip would bias the mean low) and
    counted in the second output. The mean is NaN for a run without an uncensored
    measured slip.

    For a Hatch filter of window tau, a slip of N cycles leaves an error
    N lambda a^(j+1), a = 1 - 1/tau, on top of the smoothing noise sigma; with the 2-sigma
    band it recovers after about tau ln(N lambda / (sqrt(3) sigma)) epochs (the noise
    takes sigma^2 of the 4 sigma^2 budget), which the tests check.

    ``err`` and ``slips`` (boolean, True at a slip epoch) are ``(K, runs)``.
    """
    K, runs = err.shape
    mean = np.full(runs, np.nan)
    censored = np.zeros(runs)
    for r in range(runs):  # slips are rare events: a loop over runs and slips, not over epochs
        at = np.flatnonzero(slips[:, r])
        rec = []
        for i, s in enumerate(at):
            prev_slip = at[i - 1] if i else -10**9
            if s - before < start or s - prev_slip <= isolation:
                continue
            sigma = np.sqrt(np.mean(err[s - before:s, r] ** 2))
            end = at[i + 1] if i + 1 < at.size else K
            sq = err[s:end, r] ** 2
            run_rms = np.sqrt(np.convolve(sq, np.ones(window) / window, mode="valid")) if sq.size >= window else sq[:0]
            ok = np.flatnonzero(run_rms <= band * sigma)
            if ok.size:
                rec.append(ok[0])
            else:
                censored[r] += 1
        if rec:
            mean[r] = float(np.mean(rec))
    return mean, censored


def slip_recovery_epochs(err: np.ndarray, slips: np.ndarray, **kwargs) -> np.ndarray:
    """Mean epochs, per run, to recover from isolated, uncensored slips (see ``slip_recovery``)."""
    return slip_recovery(err, slips, **kwargs)[0]


def false_resets(detected: np.ndarray, slips: np.ndarray) -> np.ndarray:
    """False resets per run, ``(runs,)``, from ``(K, runs)`` booleans (detections, true slips).

    A detection is true if a slip happened since the previous detection (or the start),
    which counts a slip caught a few epochs late (a slip below the threshold whose
    decaying error later crosses it) as caught, not as a false alarm.
    """
    pending = np.zeros(slips.shape[1], bool)
    false = np.zeros(slips.shape[1])
    for k in range(slips.shape[0]):  # a scan over epochs, vectorised over runs
        pending |= slips[k]
        false += detected[k] & ~pending
        pending &= ~detected[k]
    return false


@register_scenario
class CarrierSmoothingScenario(Scenario):
    """Carrier-smoothed code with random cycle slips (CN105068097 patent 2015)."""

    kind = "carrier-smoothing"
    Params = CarrierSmoothingParams
    CaseParams = CarrierSmoothingCase
    components = {"channel_filter": False}
    metrics = {"error_rmse": "m", "slip_recovery_epochs": "epochs", "censored_slips": "slips/run",
               "false_reset_rate": "resets/run"}
    #: Why a metric can be undefined (NaN) in a run; summary.json and report.md say it.
    undefined_reasons = {"slip_recovery_epochs": "no isolated slips"}

    def check_composition(self, plugins, where: str) -> None:
        ch = plugins.get("channel_filter")
        if ch is not None and (not set(ch.requires) <= {"pseudorange_m", "carrier_m"} or "smoothed_m" not in ch.provides):
            raise ConfigError(f"{where}.channel_filter.name", f"{ch.name!r} does not smooth code with carrier "
                              "(needs pseudorange_m and carrier_m, provides smoothed_m); use 'hatch' or 'kf-smoother'")

    def simulate(self, runs: int, rng: np.random.Generator, slip_probability: float | None = None):
        """True range, pseudorange, carrier (m) and slip epochs, each ``(K, runs)``."""
        p = self.params
        slip_probability = p.slip_probability if slip_probability is None else slip_probability
        const = nominal_constellation()
        sat = const.subset(const.visible(p.start_time_s, p.lat_deg, p.lon_deg, p.height_m, 10.0, 1))
        t = p.start_time_s + np.arange(p.epochs) * p.dt_s
        pos, _, _ = sat.state(t)
        rx = np.array(pymap3d.geodetic2ecef(p.lat_deg, p.lon_deg, p.height_m))
        truth = np.broadcast_to(np.linalg.norm(pos[:, 0] - rx, axis=-1)[:, None], (p.epochs, runs))
        mp_xi = p.multipath_std_m * np.sqrt(1 - p.multipath_psi**2)
        code = truth + p.code_noise_std_m * rng.standard_normal((p.epochs, runs)) \
            + ar1_noise(p.multipath_psi, mp_xi, p.epochs, rng, batch_shape=(runs,))
        ambiguity = rng.integers(-10**6, 10**6, runs) * L1_WAVELENGTH_M
        slips_cycles = cycle_slips(p.epochs, slip_probability, rng, p.slip_max_cycles, (runs,),
                                   min_cycles=p.slip_min_cycles)
        happens = np.diff(slips_cycles, axis=0, prepend=0) != 0
        carrier = truth + ambiguity + p.carrier_noise_std_m * rng.standard_normal((p.epochs, runs)) \
            + slips_cycles * L1_WAVELENGTH_M
        return truth, code, carrier, happens

    def run_batch(self, case, plugins, runs, rng) -> BatchResult:
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
        err = smoothed - truth
        s = slice(p.settle_epochs, None)
        recovery, censored = slip_recovery(err, slips, isolation=p.recovery_isolation_epochs, start=p.settle_epochs)
        metrics = {"error_rmse": np.sqrt(np.mean(err[s] ** 2, axis=0)), "slip_recovery_epochs": recovery,
                   "censored_slips": censored, "false_reset_rate": false_resets(detected, slips)}
        series = {"error_rmse": np.abs(err), "slip_recovery_epochs": slips.astype(float),
                  "censored_slips": slips.astype(float), "false_reset_rate": (detected & ~slips).astype(float)}
        return BatchResult(metrics, series, np.arange(p.epochs) * p.dt_s)
