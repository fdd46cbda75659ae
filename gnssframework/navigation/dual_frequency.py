r"""The ionosphere-free combination of two signals of one satellite on two carriers.

A pseudorange on carrier :math:`f_j` carries the first-order ionospheric delay
:math:`I_j \propto 1/f_j^2`, so with :math:`\gamma = (f_1/f_2)^2` (1.6469 for GPS L1 and
L2, IS-GPS-200 20.3.3.3.3.2) :math:`I_2 = \gamma I_1` and

.. math:: P_{IF} = \frac{\gamma P_1 - P_2}{\gamma - 1}

holds no first-order ionosphere. Its satellite clock is the same combination of the two
single-frequency users' clocks (`ephemeris.single_frequency_clock_s`),

.. math:: \Delta t_{IF} = \frac{\gamma\,\Delta t_1 - \Delta t_2}{\gamma - 1},

which is :math:`\Delta t_{SV}` itself for an LNAV record (L1 C/A takes
:math:`\Delta t_{SV} - T_{GD}`, L2 :math:`\Delta t_{SV} - \gamma T_{GD}`: IS-GPS-200
20.3.3.3.3.3), and with a CNAV record's inter-signal corrections IS-GPS-200
30.3.3.3.1.1.2's
:math:`\Delta t_{SV} - T_{GD} + (ISC_2 - \gamma ISC_1)/(1 - \gamma)`. The combination's noise
is :math:`\sqrt{\gamma^2 + 1}/(\gamma - 1)` times one signal's (2.98 for L1 and L2, equal
noise on each): the price of removing the ionosphere.

GPS and QZSS signals only: their records' clocks are defined per signal by T_GD (and the
ISCs). A Galileo record's clock is already that of a dual-frequency pair, which this module
does not model.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError
from ..signal.spec import SignalSpec
from .ephemeris import Ephemerides, SatelliteState, single_frequency_clock_s

__all__ = ["DualFrequency", "DUAL_FREQUENCY_SYSTEMS"]

#: RINEX letters of the systems whose signals combine here (GPS, QZSS).
DUAL_FREQUENCY_SYSTEMS = ("G", "J")


@dataclass(frozen=True)
class DualFrequency:
    """Two signals of one system on two carriers, ``first`` the higher (L1), whose
    ionosphere-free combination a solution takes (module text).

    Raises
    ------
    ConfigError
        For signals of another system than GPS or QZSS, of two systems, or on one carrier.
    """

    first: SignalSpec
    second: SignalSpec

    def __post_init__(self) -> None:
        for s in (self.first, self.second):
            if s.system not in DUAL_FREQUENCY_SYSTEMS:
                raise ConfigError(
                    "signal",
                    f"{s.name}: the ionosphere-free combination takes GPS or QZSS signals "
                    f"(systems {', '.join(DUAL_FREQUENCY_SYSTEMS)}), not system {s.system!r}",
                )
        if self.first.system != self.second.system:
            raise ConfigError("signal", f"{self.first.name} and {self.second.name} are of two systems")
        if not self.first.carrier_freq_hz > self.second.carrier_freq_hz * (1 + 1e-6):
            raise ConfigError(
                "signal",
                f"{self.first.name} ({self.first.carrier_freq_hz / 1e6:.2f} MHz) must be on a higher carrier "
                f"than {self.second.name} ({self.second.carrier_freq_hz / 1e6:.2f} MHz)",
            )

    @property
    def gamma(self) -> float:
        """:math:`(f_1/f_2)^2`."""
        return (self.first.carrier_freq_hz / self.second.carrier_freq_hz) ** 2

    @property
    def noise_factor(self) -> float:
        """The combination's standard deviation over one signal's, for equal noise on both."""
        g = self.gamma
        return float(np.sqrt(g**2 + 1.0) / (g - 1.0))

    def combine(self, first_m: np.ndarray, second_m: np.ndarray) -> np.ndarray:
        """:math:`(\\gamma P_1 - P_2) / (\\gamma - 1)` of pseudoranges (m), NaN where either is."""
        g = self.gamma
        return (g * np.asarray(first_m, float) - np.asarray(second_m, float)) / (g - 1.0)

    def clock_s(self, eph: Ephemerides, state: SatelliteState) -> np.ndarray:
        """The satellite clock (s) of the combination: that of the two single-frequency
        users' clocks (module text)."""
        g = self.gamma
        first = single_frequency_clock_s(eph, state, self.first.carrier_freq_hz)
        second = single_frequency_clock_s(eph, state, self.second.carrier_freq_hz)
        return (g * first - second) / (g - 1.0)
