"""Several satellites' signals in one noise: the project's own recordings for tests and docs.

Each satellite is `gnssframework.signal.if_samples.generate_if_samples` without noise;
the sum gets one white noise of unit variance per real dimension, so each satellite has
the C/N0 it was given (the generator's amplitude law with ``sigma = 1``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...signal.if_samples import generate_if_samples

__all__ = ["SatelliteSignal", "synthesize_samples"]


@dataclass(frozen=True)
class SatelliteSignal:
    """One satellite of a synthetic recording (values at the first sample)."""

    prn: int
    cn0_dbhz: float
    doppler_hz: float = 0.0
    code_phase_chips: float = 0.0
    carrier_phase_rad: float = 0.0


def synthesize_samples(satellites: list[SatelliteSignal], duration_s: float, sample_rate_hz: float, if_hz: float,
                       rng: np.random.Generator, *, complex_samples: bool = True) -> np.ndarray:
    """Samples (``float64`` or ``complex128``) of ``satellites`` in unit-variance white noise."""
    n = int(round(duration_s * sample_rate_hz))
    x = np.zeros(n, complex if complex_samples else float)
    for sat in satellites:
        x += generate_if_samples(sat.prn, duration_s, sample_rate_hz, if_hz, sat.cn0_dbhz, rng,
                                 doppler_hz=sat.doppler_hz, code_phase_chips=sat.code_phase_chips,
                                 carrier_phase_rad=sat.carrier_phase_rad, complex_samples=complex_samples,
                                 noise=False).samples
    if complex_samples:
        return x + rng.standard_normal(n) + 1j * rng.standard_normal(n)
    return x + rng.standard_normal(n)
