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
from functools import cached_property
from typing import Literal
from collections.abc import Callable

import numpy as np

from ..errors import ConfigError
from .codes import checked_prn

__all__ = ["SignalSpec", "Subcarrier", "Component", "BPSK", "SPEED_OF_LIGHT_M_S", "F0_HZ", "pulse_autocorrelation"]

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

    @property
    def subchips_per_chip(self) -> int:
        """Equal-length pieces of one chip on each of which the sub-carrier is constant:
        1 for BPSK, ``2 m / n`` for BOC(m, n), the least common multiple of ``2 m / n``
        and ``2 m2 / n`` for CBOC (12 for CBOC(6, 1, 1/11)).

        Raises
        ------
        ConfigError
            For a sub-carrier whose half-periods do not divide a chip (``2 m / n`` not an
            integer).
        """
        if self.kind == "bpsk":
            return 1
        ms = (self.m,) if self.kind == "boc" else (self.m, self.m2)
        counts = []
        for m in ms:
            k = 2.0 * m / self.n
            if not (k >= 1 and abs(k - round(k)) < 1e-9):
                raise ConfigError(
                    "subcarrier",
                    f"2 m / n = {k:g} half-periods per chip is not a positive integer (m = {m:g}, n = {self.n:g})",
                )
            counts.append(int(round(k)))
        return math.lcm(*counts)

    def chip_pulse(self, sign: float = 1.0) -> np.ndarray:
        """The sub-carrier's value on each of the `subchips_per_chip` pieces of one chip
        (sampled at the pieces' centres, where it is constant)."""
        s = self.subchips_per_chip
        return self.waveform((np.arange(s) + 0.5) / s, sign)

    def autocorrelation(self, tau_chips: np.ndarray, sign: float = 1.0) -> np.ndarray:
        r"""Normalised autocorrelation of a spreading waveform of this sub-carrier with random
        (or long) codes, at lags ``tau_chips``, infinite bandwidth.

        With the chip pulse :math:`p` constant on :math:`S` pieces of width
        :math:`\Delta = 1/S` chip (values :math:`v_0 .. v_{S-1}`), the waveform's
        autocorrelation :math:`R(\tau) = \int p(t) p(t + \tau) dt / \int p^2` is linear
        between the lags :math:`k\Delta`, where it is the discrete autocorrelation
        :math:`R_k = \sum_j v_j v_{j+k} / \sum_j v_j^2`: a train of triangles (Betz 2016,
        ch. 12: BOC(1,1) gives :math:`1 - 3|\tau|` up to half a chip, then
        :math:`|\tau| - 1`). BPSK gives the triangle :math:`\max(0, 1 - |\tau|)`.
        """
        return pulse_autocorrelation(self.chip_pulse(sign), tau_chips)

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


def pulse_autocorrelation(pulse: np.ndarray, tau_chips: np.ndarray) -> np.ndarray:
    """Normalised autocorrelation at lags ``tau_chips`` of a spreading waveform with random
    (or long) codes whose chip pulse is ``pulse`` (its constant values on equal pieces of one
    chip): the discrete autocorrelation of the pieces, linear between them
    (`Subcarrier.autocorrelation`)."""
    tau = np.abs(np.asarray(tau_chips, float))
    v = np.asarray(pulse, float)
    s = v.size
    rk = np.array([np.dot(v[: s - k], v[k:]) for k in range(s)] + [0.0]) / np.dot(v, v)
    x = np.minimum(tau * s, float(s))
    k = np.minimum(np.floor(x).astype(int), s - 1)
    f = x - k
    return (1.0 - f) * rk[k] + f * rk[k + 1]


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
    secondary_code_of
        ``secondary_code_of(prn) -> tuple`` of ±1: an overlay that differs from PRN to PRN
        (Galileo E5a-Q's CS100_i), every PRN's of one length; None: ``secondary_code``
        serves every PRN. `SignalSpec.overlay` reads whichever the component has.
    symbol_period_s
        Data symbol period (s); ``None`` on a pilot.
    power_fraction
        Share of the signal's power this component carries.
    subcarrier_sign
        Sign of a CBOC's second term on this component.
    code_length_chips
        This component's primary code length where it differs from the signal's (GPS L2 CL:
        767250 chips beside CM's 10230); ``None``: the signal's ``code_length_chips``.
    time_slot
        ``(slot, slots)`` of a time-multiplexed component: each chip period (at the
        signal's ``chip_rate_hz``) is cut into ``slots`` equal parts, and this component is
        sent in part ``slot`` only (its waveform is 0 in the others). GPS L2C alternates CM
        and CL chip by chip at 1.023 Mchip/s: CM is ``(0, 2)``, CL ``(1, 2)`` of each
        511.5 kHz chip period (IS-GPS-200, sec. 3.2.1.3 and 3.3.2.4). ``(0, 1)``: not multiplexed.
    """

    name: str
    code: Callable[[int], np.ndarray]
    secondary_code: tuple[int, ...] = ()
    symbol_period_s: float | None = None
    secondary_code_of: Callable[[int], tuple[int, ...]] | None = None
    power_fraction: float = 1.0
    subcarrier_sign: float = 1.0
    code_length_chips: int | None = None
    time_slot: tuple[int, int] = (0, 1)


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
    rinex_prn_offset
        What a PRN loses to become its RINEX satellite number (0 for GPS; 192 for QZSS,
        PRN 193 being ``J01``; RINEX 3.04 section 3.5).
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
    rinex_prn_offset: int = 0

    def __post_init__(self) -> None:
        for label, value in (
            ("carrier_freq_hz", self.carrier_freq_hz),
            ("chip_rate_hz", self.chip_rate_hz),
            ("code_length_chips", self.code_length_chips),
        ):
            if not (math.isfinite(value) and value > 0):
                raise ConfigError(f"signal {self.name!r} {label}", f"must be a positive finite number, got {value!r}")
        if not self.components:
            raise ConfigError(f"signal {self.name!r} components", "a signal needs at least one component")
        if not self.prns:
            raise ConfigError(f"signal {self.name!r} prns", "a signal needs at least one PRN")
        for comp in self.components:
            slot, slots = comp.time_slot
            if not (isinstance(slots, int) and slots >= 1 and isinstance(slot, int) and 0 <= slot < slots):
                raise ConfigError(
                    f"signal {self.name!r} component {comp.name!r} time_slot",
                    f"must be (slot, slots) with 0 <= slot < slots, got {comp.time_slot!r}",
                )
            sym = comp.symbol_period_s
            if sym is None:
                continue
            periods = sym / self.code_period_s
            if not (math.isfinite(periods) and periods >= 1 - 1e-9 and abs(periods - round(periods)) < 1e-6):
                raise ConfigError(
                    f"signal {self.name!r} component {comp.name!r} symbol_period_s",
                    f"must be a whole number of code periods ({self.code_period_s:g} s), got {sym!r}",
                )

    # --- derived quantities -------------------------------------------------------------
    # Computed once per description (``cached_property``: the description is frozen): the
    # sample tracker reads several of them per channel and coherent interval.

    @cached_property
    def code_period_s(self) -> float:
        """Primary code period (s): length over chip rate (1 ms for L1 C/A)."""
        return self.code_length_chips / self.chip_rate_hz

    @cached_property
    def wavelength_m(self) -> float:
        """Carrier wavelength (m)."""
        return SPEED_OF_LIGHT_M_S / self.carrier_freq_hz

    @cached_property
    def chip_length_m(self) -> float:
        """Length of one chip (m)."""
        return SPEED_OF_LIGHT_M_S / self.chip_rate_hz

    @property
    def tracked(self) -> Component:
        """The component the loops track (the first)."""
        return self.components[0]

    @cached_property
    def data(self) -> Component | None:
        """The component carrying navigation data, if any."""
        return next((c for c in self.components if c.symbol_period_s is not None), None)

    @cached_property
    def symbol_period_s(self) -> float | None:
        """Data symbol period (s) of the data component (20 ms for L1 C/A), or None."""
        data = self.data
        return None if data is None else data.symbol_period_s

    @cached_property
    def code_periods_per_symbol(self) -> int | None:
        """Primary code periods per data symbol (20 for L1 C/A), or None without data."""
        sym = self.symbol_period_s
        return None if sym is None else int(round(sym / self.code_period_s))

    @cached_property
    def longest_coherent_s(self) -> float:
        """The longest coherent interval a known symbol or overlay boundary allows without
        wiping off data: the symbol period where the tracked component carries data, the
        whole overlay code's period on a pilot."""
        comp = self.tracked
        if comp.symbol_period_s is not None:
            return comp.symbol_period_s
        return self.code_period_s * max(1, self.overlay_length(0))

    def overlay(self, prn: int, component: int = 0) -> tuple[int, ...]:
        """A component's overlay (secondary) code for ``prn``, ±1 chips one a primary period
        (the per-PRN one where the component has it; empty for none)."""
        comp = self.components[component]
        if comp.secondary_code_of is None:
            return comp.secondary_code
        return tuple(comp.secondary_code_of(self.check_prn(prn)))

    def overlay_length(self, component: int = 0) -> int:
        """Chips of a component's overlay (the first PRN's, for a per-PRN overlay; 0: none)."""
        return len(self.overlay(self.prns[0], component))

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
        code = np.asarray(self.components[component].code(int(prn)))
        length = self.component_code_length(component)
        if code.shape != (length,):
            raise ConfigError(
                f"signal {self.name!r} code",
                f"the generator gave {code.shape} chips for PRN {prn}, the description says {length}",
            )
        return code

    def component_code_length(self, component: int = 0) -> int:
        """Primary code length (chips) of a component: its own, else the signal's."""
        own = self.components[component].code_length_chips
        return self.code_length_chips if own is None else int(own)

    def check_prn(self, prn: int) -> int:
        """``prn`` as an ``int``, or a `ConfigError` naming the signal and its PRN range."""
        return checked_prn(prn, self.prns, self.name)

    @cached_property
    def subchips_per_chip(self) -> int:
        """Pieces of a chip on which the spreading waveform is constant (1 for BPSK): the
        sub-carrier's, times what the components' time slots need (2 for GPS L2C)."""
        return math.lcm(self.subcarrier.subchips_per_chip, *(c.time_slot[1] for c in self.components))

    @cached_property
    def is_bpsk(self) -> bool:
        """Whether the chip pulse is BPSK's full-chip rectangle: no sub-carrier and no time
        multiplexing (the BPSK triangle is then the code's autocorrelation)."""
        return self.subcarrier.kind == "bpsk" and self.subchips_per_chip == 1

    def chip_pulse(self, component: int = 0) -> np.ndarray:
        """A component's value on each of the `subchips_per_chip` pieces of one chip: the
        sub-carrier (`Subcarrier.waveform` at the pieces' centres) times its time slot
        (1 inside, 0 outside; all ones when not multiplexed)."""
        comp = self.components[component]
        s = self.subchips_per_chip
        centres = (np.arange(s) + 0.5) / s
        slot, slots = comp.time_slot
        inside = np.floor(centres * slots) == slot
        return self.subcarrier.waveform(centres, comp.subcarrier_sign) * inside

    @cached_property
    def replica_duty(self) -> float:
        """The tracked component's mean squared `chip_pulse`: its share of time sent (1; 1/2
        for a component in one of two time slots, GPS L2 CM). A coherent block of T s holds
        the component's energy over :math:`T \\cdot` duty, which the acquisitions' C/N0
        from :math:`E[S] = K(2 + 2cT\\,\\mathrm{duty})` divides out."""
        return float(np.mean(self.chip_pulse(0) ** 2))

    def spreading_table(self, prn: int, component: int = 0) -> np.ndarray:
        r"""One code period of the spreading waveform (code times sub-carrier) as a table of
        sub-chips, ``(code_length_chips * subchips_per_chip,)`` ``float64``.

        Entry :math:`k` is :math:`c(\lfloor k / S \rfloor)\, q((k + 1/2) / S)`, with
        :math:`S` = `subchips_per_chip`: a generic block that indexes a code table by
        :math:`\lfloor S x \rfloor \bmod (L S)` at code phase :math:`x` chips (the compiled
        correlators, the acquisition replica, the IF generator) then produces the BOC or
        CBOC waveform exactly, and for BPSK (:math:`S = 1`) the code itself. The values are
        ±1 except for CBOC (weighted sums) and time-multiplexed components (0 outside
        their slot).
        """
        code = self.code(prn, component).astype(float)
        return (code[:, None] * self.chip_pulse(component)[None, :]).reshape(-1)

    def spreading_at(self, table: np.ndarray, chip_phase: np.ndarray) -> np.ndarray:
        """The spreading waveform ``table`` (`spreading_table`) at code phases
        ``chip_phase`` (chips, any shape, any real value: taken modulo the code period)."""
        s = self.subchips_per_chip
        return table[np.floor(np.asarray(chip_phase, float) * s).astype(np.int64) % table.size]

    def autocorrelation(self, tau_chips: np.ndarray) -> np.ndarray:
        """The tracked component's normalised code autocorrelation at ``tau_chips``
        (`pulse_autocorrelation` of `chip_pulse`: the BPSK triangle, the BOC triangle train,
        a triangle of half a chip for a component in one of two time slots)."""
        return pulse_autocorrelation(self.chip_pulse(0), tau_chips)

    def rinex_satellite(self, prn: int) -> str:
        """The RINEX 3 satellite name of ``prn`` (``"G05"``, ``"J01"`` for QZSS PRN 193)."""
        return f"{self.system}{int(prn) - self.rinex_prn_offset:02d}"

    @cached_property
    def rinex_obs_types(self) -> tuple[str, str, str, str]:
        """The RINEX 3 observation types of the tracked component: pseudorange, carrier
        phase, Doppler, signal strength (``C1C L1C D1C S1C`` for L1 C/A)."""
        return tuple(f"{kind}{self.rinex_code}" for kind in "CLDS")  # type: ignore[return-value]

    def samples_per_code(self, sample_rate_hz: float) -> float:
        """Samples in one primary code period at ``sample_rate_hz``."""
        return sample_rate_hz * self.code_period_s
