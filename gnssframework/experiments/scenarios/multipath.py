"""Scenario ``multipath``: position-domain filtering with AR(1) colored noise (Liu et al. 2020).

A static receiver's latitude and longitude (local metres) are measured every epoch with
AR(1) colored multipath noise plus white noise. Candidates compose a ``nav_filter``
(``position-ca``), an ``estimator``, and optionally a ``colored-ar1`` augmentation and a
``noise_adapter``.
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from ...errors import ConfigError
from ...simulation.impairments import ar1_noise
from . import BatchResult, Scenario, ScenarioParams, register_scenario

__all__ = ["MultipathScenario", "convergence_epoch"]


class MultipathParams(ScenarioParams):
    epochs: int = Field(500, ge=20, le=100_000)
    dt_s: float = Field(1.0, gt=0)
    psi: float = Field(0.95, gt=-1, lt=1, description="AR(1) coefficient of the multipath noise")
    multipath_std_m: float = Field(3.0, ge=0, description="stationary std of the colored part")
    white_std_m: float = Field(0.5, ge=0, description="std of the white part")
    convergence_window: int = Field(10, ge=1, description="epochs of the running RMS in the convergence test")


class MultipathCase(ScenarioParams):
    name: str | None = None


def convergence_epoch(err: np.ndarray, window: int) -> np.ndarray:
    """First epoch after which the running RMS error (``window`` epochs) stays below twice
    the RMS error of the second half of the run. ``err`` is ``(K, runs)``; returns ``(runs,)``."""
    K = err.shape[0]
    # Trailing sum of the last `window` squared errors (fewer at the start), over all runs at once.
    cs = np.cumsum(err**2, axis=0)
    lagged = np.concatenate([np.zeros((min(window, K),) + err.shape[1:]), cs[: max(K - window, 0)]], axis=0)
    running = np.sqrt((cs - lagged) / window)
    bound = 2 * np.sqrt(np.mean(err[K // 2:] ** 2, axis=0))
    above = running > bound
    last = np.where(above.any(axis=0), K - 1 - np.argmax(above[::-1], axis=0), -1)
    return (last + 1).astype(float)


@register_scenario
class MultipathScenario(Scenario):
    """Position filtering with AR(1) colored multipath noise (Liu et al. 2020)."""

    kind = "multipath"
    Params = MultipathParams
    CaseParams = MultipathCase
    components = {"nav_filter": True, "estimator": True, "augmentation": False, "noise_adapter": False}
    metrics = {"lat_error_mean": "m", "lat_error_rmse": "m", "lon_error_mean": "m", "lon_error_rmse": "m",
               "convergence_epoch": "epochs"}

    def check_composition(self, plugins, where: str) -> None:
        if not hasattr(plugins["nav_filter"], "filter"):
            raise ConfigError(f"{where}.nav_filter.name", f"{plugins['nav_filter'].name!r} cannot filter a position "
                              "sequence; use 'position-ca'")

    def simulate(self, runs: int, rng: np.random.Generator) -> np.ndarray:
        """Measured (lat, lon) errors in metres, ``(K, runs, 2)``; the truth is 0."""
        p = self.params
        xi_std = p.multipath_std_m * np.sqrt(1 - p.psi**2)
        colored = ar1_noise(p.psi, xi_std, p.epochs, rng, batch_shape=(runs, 2))
        return colored + p.white_std_m * rng.standard_normal((p.epochs, runs, 2))

    def run_batch(self, case, plugins, runs, rng) -> BatchResult:
        p = self.params
        zs = self.simulate(runs, rng)
        res = plugins["nav_filter"].filter(zs, plugins["estimator"], adapter=plugins.get("noise_adapter"),
                                           augmentation=plugins.get("augmentation"))
        err = res.mean[..., 0]  # (K', runs, 2): the truth is the origin
        lat, lon = err[..., 0], err[..., 1]
        metrics = {
            "lat_error_mean": np.mean(np.abs(lat), axis=0),
            "lat_error_rmse": np.sqrt(np.mean(lat**2, axis=0)),
            "lon_error_mean": np.mean(np.abs(lon), axis=0),
            "lon_error_rmse": np.sqrt(np.mean(lon**2, axis=0)),
            "convergence_epoch": convergence_epoch(np.hypot(lat, lon), p.convergence_window),
        }
        t = res.epochs * p.dt_s
        series = {"lat_error_mean": np.abs(lat), "lat_error_rmse": np.abs(lat), "lon_error_mean": np.abs(lon),
                  "lon_error_rmse": np.abs(lon), "convergence_epoch": np.hypot(lat, lon)}
        return BatchResult(metrics, series, t)
