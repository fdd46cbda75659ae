"""Several satellites' signals in one noise: the project's own recordings for tests and docs.

Each satellite is `gnssframework.signal.if_samples.generate_if_samples` without noise;
the sum gets one white noise of unit variance per real dimension, so each satellite has
the C/N0 it was given (the generator's amplitude law with ``sigma = 1``). A satellite's
signal is any `SignalSpec` (GPS L1 C/A by default; BPSK or BOC alike).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...errors import ConfigError
from ...signal.gps_l1ca import GPS_L1CA
from ...signal.if_samples import generate_if_samples
from ...signal.navdata import random_nav_bits
from ...signal.spec import SignalSpec

__all__ = ["SatelliteSignal", "synthesize_samples"]


@dataclass(frozen=True)
class SatelliteSignal:
    """One satellite of a synthetic recording (values at the first sample)."""

    prn: int
    cn0_dbhz: float
    doppler_hz: float = 0.0
    code_phase_chips: float = 0.0
    carrier_phase_rad: float = 0.0
    #: Random navigation data (50 bit/s on L1 C/A; drawn from the generator's rng) whose
    #: first bit edge is at the start of this code period (0: the first code epoch after
    #: t = 0); bit edges fall on code epochs, as the satellites send them. ``None``: no data.
    first_bit_code_period: int | None = None
    #: The signal the satellite sends.
    signal: SignalSpec = GPS_L1CA
    #: The ±1 data symbols sent from ``first_bit_code_period`` on (e.g. `inav.inav_symbols`,
    #: `lnav.lnav_symbols`, `sbas_message.sbas_symbols`) instead of random ones; at least one
    #: per symbol period of the recording after the first edge.
    symbols: np.ndarray | None = field(default=None, compare=False, repr=False)

    def __post_init__(self) -> None:
        if self.first_bit_code_period is not None and self.signal.symbol_period_s is None:
            raise ConfigError(
                "first_bit_code_period", f"{self.signal.name} carries no data symbols (a pilot): leave it None"
            )
        if self.symbols is not None and self.first_bit_code_period is None:
            raise ConfigError("symbols", "give first_bit_code_period too: the code period the first symbol starts")

    def first_bit_edge_s(self) -> float:
        """Time of the first bit edge: a code epoch (chip 0) after t = 0."""
        length = self.signal.code_length_chips
        rate = float(self.signal.code_freq_hz(self.doppler_hz))
        first_epoch = ((-self.code_phase_chips) % length) / rate
        return first_epoch + (self.first_bit_code_period or 0) * length / rate


def synthesize_samples(
    satellites: list[SatelliteSignal],
    duration_s: float,
    sample_rate_hz: float,
    if_hz: float,
    rng: np.random.Generator,
    *,
    complex_samples: bool = True,
) -> np.ndarray:
    """Samples (``float64`` or ``complex128``) of ``satellites`` in unit-variance white noise."""
    n = int(round(duration_s * sample_rate_hz))
    x = np.zeros(n, complex if complex_samples else float)
    for sat in satellites:
        bits = None
        if sat.symbols is not None:
            need = int(np.ceil((duration_s - sat.first_bit_edge_s()) / sat.signal.symbol_period_s))
            bits = np.asarray(sat.symbols, dtype=float)
            if bits.ndim != 1 or bits.size < need:
                raise ConfigError(
                    "symbols", f"PRN {sat.prn}: {need} symbols cover the recording, got shape {bits.shape}"
                )
        elif sat.first_bit_code_period is not None:
            bits = random_nav_bits(int(np.ceil(duration_s * (1.0 / sat.signal.symbol_period_s))) + 2, rng)
        x += generate_if_samples(
            sat.prn,
            duration_s,
            sample_rate_hz,
            if_hz,
            sat.cn0_dbhz,
            rng,
            doppler_hz=sat.doppler_hz,
            code_phase_chips=sat.code_phase_chips,
            carrier_phase_rad=sat.carrier_phase_rad,
            complex_samples=complex_samples,
            data_bits=bits,
            first_bit_edge_s=sat.first_bit_edge_s() if bits is not None else 0.0,
            noise=False,
            signal=sat.signal,
        ).samples
    if complex_samples:
        return x + rng.standard_normal(n) + 1j * rng.standard_normal(n)
    return x + rng.standard_normal(n)
