"""Scenario ``carrier-smoothing``: carrier-smoothed code with cycle slips (CN105068097 patent 2015).

One satellite of the nominal constellation seen from a static receiver, epochs of 1 s.
Pseudorange = range + white thermal noise + AR(1) code multipath; carrier phase (m) =
range + integer ambiguity + white noise + random cycle slips. No ionosphere, so
code-carrier divergence is zero: a smoother can average indefinitely between slips.
A candidate composes a ``channel_filter`` (``hatch``, ``kf-smoother``), or nothing for
the raw pseudorange.
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

__all__ = ["CarrierSmoothingScenario", "slip_recovery_epochs"]


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

    @field_validator("slip_max_cycles")
    @classmethod
    def _max_not_below_min(cls, value: int, info: ValidationInfo) -> int:
        if value < info.data.get("slip_min_cycles", 1):
            raise ValueError(f"must be >= slip_min_cycles ({info.data.get('slip_min_cycles')})")
        return value


class CarrierSmoothingCase(ScenarioParams):
    name: str | None = None


def slip_recovery_epochs(err: np.ndarray, slips: np.ndarray, before: int = 30, window: int = 5) -> np.ndarray:
    """Mean epochs, per run, until the error is back within 2 sigma of its level before a slip.

    For each slip at epoch s with ``before`` slip-free epochs before it, sigma is the RMS
    error over those epochs; recovery is the first j where the RMS over
    ``[s+j, s+j+window)`` is at most 2 sigma. A slip that does not recover before the next
    one counts the epochs until then. Runs without such a slip give NaN.

    ``err`` and ``slips`` (boolean, True at a slip epoch) are ``(K, runs)``.
    """
    K, runs = err.shape
    out = np.full(runs, np.nan)
    for r in range(runs):  # slips are rare events: a loop over runs and slips, not over epochs
        at = np.flatnonzero(slips[:, r])
        rec = []
        for i, s in enumerate(at):
            prev_slip = at[i - 1] if i else -10**9
            if s - before < 0 or s - prev_slip <= before:
                continue
            sigma = np.sqrt(np.mean(err[s - before:s, r] ** 2))
            end = at[i + 1] if i + 1 < at.size else K
            sq = err[s:end, r] ** 2
            if sq.size < window:
                continue
            run_rms = np.sqrt(np.convolve(sq, np.ones(window) / window, mode="valid"))
            ok = np.flatnonzero(run_rms <= 2 * sigma)
            rec.append(ok[0] if ok.size else end - s)
        if rec:
            out[r] = float(np.mean(rec))
    return out


@register_scenario
class CarrierSmoothingScenario(Scenario):
    """Carrier-smoothed code with random cycle slips (CN105068097 patent 2015)."""

    kind = "carrier-smoothing"
    Params = CarrierSmoothingParams
    CaseParams = CarrierSmoothingCase
    components = {"channel_filter": False}
    metrics = {"error_rmse": "m", "slip_recovery_epochs": "epochs"}

    def check_composition(self, plugins, where: str) -> None:
        ch = plugins.get("channel_filter")
        if ch is not None and (not set(ch.requires) <= {"pseudorange_m", "carrier_m"} or "smoothed_m" not in ch.provides):
            raise ConfigError(f"{where}.channel_filter.name", f"{ch.name!r} does not smooth code with carrier "
                              "(needs pseudorange_m and carrier_m, provides smoothed_m); use 'hatch' or 'kf-smoother'")

    def simulate(self, runs: int, rng: np.random.Generator):
        """True range, pseudorange, carrier (m) and slip epochs, each ``(K, runs)``."""
        p = self.params
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
        slips_cycles = cycle_slips(p.epochs, p.slip_probability, rng, p.slip_max_cycles, (runs,),
                                   min_cycles=p.slip_min_cycles)
        happens = np.diff(slips_cycles, axis=0, prepend=0) != 0
        carrier = truth + ambiguity + p.carrier_noise_std_m * rng.standard_normal((p.epochs, runs)) \
            + slips_cycles * L1_WAVELENGTH_M
        return truth, code, carrier, happens

    def run_batch(self, case, plugins, runs, rng) -> BatchResult:
        p = self.params
        truth, code, carrier, slips = self.simulate(runs, rng)
        ch = plugins.get("channel_filter")
        if ch is None:
            smoothed = code
        else:
            ch.reset((runs,), RunContext(epoch_interval_s=p.dt_s))
            smoothed = np.stack([ch.checked_step({"pseudorange_m": code[k], "carrier_m": carrier[k]})["smoothed_m"]
                                 for k in range(p.epochs)])
        err = smoothed - truth
        s = slice(p.settle_epochs, None)
        metrics = {"error_rmse": np.sqrt(np.mean(err[s] ** 2, axis=0)),
                   "slip_recovery_epochs": slip_recovery_epochs(err, slips)}
        return BatchResult(metrics, {"error_rmse": np.abs(err), "slip_recovery_epochs": slips.astype(float)},
                           np.arange(p.epochs) * p.dt_s)
