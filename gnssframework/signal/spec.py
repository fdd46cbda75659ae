r"""Signal descriptions: what a receiver needs to know of a ranging signal, in one value.

A `SignalSpec` is handed to generic blocks (acquisition, correlators, synchronisation,
lock detection, observables, writers), as GNSS-SDR hands its signal descriptions to its
generic tracking and acquisition blocks: a block reads the carrier frequency, the code's
length and rate, the sub-carrier, the overlay code and the symbol period from the
description, never from a constant of one signal.

The spreading waveform of a component is

.. math:: s(t) = d(t)\, o(t)\, c(t)\, q(t)

with :math:`c` the primary code (``code_length_chips`` chips at ``chip_rate_hz``,
period ``code_period_s``), :math:`o` the secondary (overlay) code, one chip per primary
period, :math:`d` the data symbols (period ``symbol_period_s``, none on a pilot) and
:math:`q` the sub-carrier: 1 for BPSK, :math:`\mathrm{sign}\,\sin(2\pi f_s t)` with
:math:`f_s = m \cdot 1.023` MHz for BOC(m, n) (whose chip rate is :math:`n \cdot 1.023`
MHz), and a weighted sum of two BOC waveforms for CBOC (Betz, *Engineering Satellite-Based
Navigation and Timing*, 2016, ch. 12; Galileo OS SIS ICD, sec. 2.3).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Literal

import numpy as np

from ..errors import ConfigError

__all__ = ["SignalSpec", "Subcarrier", "Component", "BPSK", "SPEED_OF_LIGHT_M_S", "F0_HZ"]

#: Speed of light in vacuum (m/s), IS-GPS-200 and the Galileo ICD alike.
SPEED_OF_LIGHT_M_S = 299_792_458.0
#: The fundamental frequency every GNSS rate is a multiple of (BOC(m, n) notation), Hz.
F0_HZ = 1.023e6


@dataclass(frozen=True)
class Subcarrier:
    """A component's sub-carrier.

    Attributes
    ----------
    kind
        ``"bpsk"`` (none), ``"boc"`` (sine-phased BOC(m, n)) or ``"cboc"`` (the weighted
        sum ``w1 BOC(m, n) + w2 BOC(m2, n)`` of Galileo E1; the sign of the second term is
        the component's, ``+`` on E1-B and ``-`` on E1-C).
    m, n
        BOC(m, n): sub-carrier frequency ``m * F0_HZ``, chip rate ``n * F0_HZ``.
    m2, weights
        CBOC only: the second sub-carrier's ``m`` and the two amplitudes (sqrt(10/11),
        sqrt(1/11) for CBOC(6,1,1/11)).
    """

    kind: Literal["bpsk", "boc", "cboc"] = "bpsk"
    m: float = 0.0
    n: float = 1.0
    m2: float = 0.0
    weights: tuple[float, float] = (1.0, 0.0)

    @property
    def frequency_hz(self) -> float:
        """Sub-carrier frequency (Hz); 0 for BPSK."""
        return self.m * F0_HZ

    def waveform(self, chip_phase: np.ndarray, sign: float = 1.0) -> np.ndarray:
        """The sub-carrier's value at code phase ``chip_phase`` (chips, any shape).

        A BOC(m, n) chip holds ``2 m / n`` half-periods of the square sub-carrier; its value
        is ``+1`` in the first half-period (sine phasing).
        """
        x = np.asarray(chip_phase, float)
        if self.kind == "bpsk":
            return np.ones_like(x)

        def square(m: float) -> np.ndarray:
            half_periods = np.floor(x * (2.0 * m / self.n))
            return 1.0 - 2.0 * np.mod(half_periods, 2.0)

        if self.kind == "boc":
            return square(self.m)
        w1, w2 = self.weights
        return w1 * square(self.m) + sign * w2 * square(self.m2)


#: No sub-carrier.
BPSK = Subcarrier()


@dataclass(frozen=True)
class Component:
    """One channel of a signal (a data or a pilot component).

    Attributes
    ----------
    name
        ``"data"`` or ``"pilot"`` (or a signal's own name such as ``"I"``/``"Q"``).
    code
        ``code(prn) -> (code_length_chips,) int8`` of ±1 (logic 0 -> +1).
    secondary_code
        Overlay chips (±1), one per primary code period; empty for none.
    symbol_period_s
        Data symbol period (s); ``None`` on a pilot.
    power_fraction
        Share of the signal's power this component carries.
    subcarrier_sign
        Sign of a CBOC's second term on this component.
    """

    name: str
    code: Callable[[int], np.ndarray]
    secondary_code: tuple[int, ...] = ()
    symbol_period_s: float | None = None
    power_fraction: float = 1.0
    subcarrier_sign: float = 1.0


@dataclass(frozen=True)
class SignalSpec:
    """A ranging signal, as the receiver's generic blocks read it.

    Attributes
    ----------
    name
        Registry name (``"gps-l1ca"``).
    system
        RINEX system letter (``"G"`` GPS, ``"E"`` Galileo, ``"C"`` BeiDou, ``"J"`` QZSS,
        ``"S"`` SBAS).
    rinex_code
        RINEX 3 observation code of the tracked component (``"1C"`` for L1 C/A).
    carrier_freq_hz
        Carrier frequency (Hz).
    chip_rate_hz
        Primary code chip rate (chips/s).
    code_length_chips
        Primary code length (chips).
    prns
        The satellite numbers the code generator knows.
    components
        The components, the tracked one first (a pilot where the signal has one).
    subcarrier
        The sub-carrier (`BPSK` for none).
    """

    name: str
    system: str
    rinex_code: str
    carrier_freq_hz: float
    chip_rate_hz: float
    code_length_chips: int
    prns: tuple[int, ...]
    components: tuple[Component, ...]
    subcarrier: Subcarrier = field(default=BPSK)

    def __post_init__(self) -> None:
        for label, value in (("carrier_freq_hz", self.carrier_freq_hz), ("chip_rate_hz", self.chip_rate_hz),
                             ("code_length_chips", self.code_length_chips)):
            if not (math.isfinite(value) and value > 0):
                raise ConfigError(f"signal {self.name!r} {label}", f"must be a positive finite number, got {value!r}")
        if not self.components:
            raise ConfigError(f"signal {self.name!r} components", "a signal needs at least one component")
        if not self.prns:
            raise ConfigError(f"signal {self.name!r} prns", "a signal needs at least one PRN")

    # --- derived quantities -------------------------------------------------------------

    @property
    def code_period_s(self) -> float:
        """Primary code period (s): length over chip rate (1 ms for L1 C/A)."""
        return self.code_length_chips / self.chip_rate_hz

    @property
    def wavelength_m(self) -> float:
        """Carrier wavelength (m)."""
        return SPEED_OF_LIGHT_M_S / self.carrier_freq_hz

    @property
    def chip_length_m(self) -> float:
        """Length of one chip (m)."""
        return SPEED_OF_LIGHT_M_S / self.chip_rate_hz

    @property
    def tracked(self) -> Component:
        """The component the loops track (the first)."""
        return self.components[0]

    @property
    def data(self) -> Component | None:
        """The component carrying navigation data, if any."""
        return next((c for c in self.components if c.symbol_period_s is not None), None)

    @property
    def symbol_period_s(self) -> float | None:
        """Data symbol period (s) of the data component (20 ms for L1 C/A), or None."""
        data = self.data
        return None if data is None else data.symbol_period_s

    @property
    def code_periods_per_symbol(self) -> int | None:
        """Primary code periods per data symbol (20 for L1 C/A), or None without data."""
        sym = self.symbol_period_s
        return None if sym is None else int(round(sym / self.code_period_s))

    @property
    def longest_coherent_s(self) -> float:
        """The longest coherent interval a known symbol or overlay boundary allows without
        wiping off data: the symbol period where the tracked component carries data, the
        whole overlay code's period on a pilot."""
        comp = self.tracked
        if comp.symbol_period_s is not None:
            return comp.symbol_period_s
        return self.code_period_s * max(1, len(comp.secondary_code))

    def code_freq_hz(self, doppler_hz: np.ndarray | float) -> np.ndarray | float:
        """Code NCO rate (chips/s) carrier-aided by ``doppler_hz``: ``f_c (1 + f_D / f_L)``."""
        return self.chip_rate_hz * (1.0 + np.asarray(doppler_hz, float) / self.carrier_freq_hz)

    def code(self, prn: int, component: int = 0) -> np.ndarray:
        """The primary code of ``prn`` (±1 ``int8``) of a component (the tracked one by default).

        Raises
        ------
        ConfigError
            For a PRN the signal does not define.
        """
        self.check_prn(prn)
        return self.components[component].code(int(prn))

    def check_prn(self, prn: int) -> int:
        """``prn`` as an ``int``, or a `ConfigError` naming the signal and its PRN range."""
        if isinstance(prn, bool) or not isinstance(prn, (int, np.integer)) or int(prn) not in self.prns:
            lo, hi = min(self.prns), max(self.prns)
            raise ConfigError("prn", f"{self.name} PRN must be an integer {lo}-{hi}, got {prn!r}")
        return int(prn)

    def samples_per_code(self, sample_rate_hz: float) -> float:
        """Samples in one primary code period at ``sample_rate_hz``."""
        return sample_rate_hz * self.code_period_s
