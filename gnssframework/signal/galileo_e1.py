r"""Galileo E1 OS (Galileo OS SIS ICD Issue 2.1, 2023): the descriptions of E1-B and E1-C.

E1 OS is two components on one carrier at 1575.42 MHz, each a 4092-chip memory code at
1.023 Mchip/s (4 ms, `galileo_codes`) on a CBOC(6,1,1/11) sub-carrier (ICD sec. 2.3.3):

.. math:: s_{E1}(t) = \tfrac{1}{\sqrt 2}\big[e_B(t)\,(\alpha\, sc_a(t) + \beta\, sc_b(t))
          - e_C(t)\,(\alpha\, sc_a(t) - \beta\, sc_b(t))\big]

with :math:`sc_a` the sine-phased BOC(1,1) and :math:`sc_b` the BOC(6,1) square
sub-carriers, :math:`\alpha = \sqrt{10/11}`, :math:`\beta = \sqrt{1/11}`. E1-B carries the
I/NAV data at 250 symbols/s (one symbol a code period, 4 ms); E1-C is the pilot, its
primary code overlaid by the 25-chip secondary code CS25_1 (one chip a code period,
100 ms). Each component holds half the power; the BOC(6,1) term has the sign ``+`` on
E1-B and ``-`` on E1-C (`Component.subcarrier_sign`).

Four descriptions, each registered as a ``signal`` plugin:

- `GALILEO_E1B` (``galileo-e1b``, RINEX ``1B``): the data component tracked, CBOC;
- `GALILEO_E1C` (``galileo-e1c``, RINEX ``1C``): the pilot tracked, CBOC;
- `GALILEO_E1B_BOC11`, `GALILEO_E1C_BOC11` (``galileo-e1b-boc11``, ``galileo-e1c-boc11``):
  the same with a BOC(1,1) replica. A receiver whose front end passes a few MHz (the
  PocketSDR recordings: 4 and 12 MHz sampling) sees little of the BOC(6,1) term (1/11 of
  the power, at +-6.1 MHz) and correlates with BOC(1,1), as PocketSDR and GNSS-SDR's
  narrow-band option do: the loss is :math:`10\log_{10}(\alpha^2)` = 0.41 dB
  against a matched CBOC replica (ICD's 10/11 power split), and the replica is ±1 (what
  the compiled correlators take).
"""

from __future__ import annotations

import math
from dataclasses import replace

from .galileo_codes import (
    GALILEO_E1_CODE_LENGTH_CHIPS,
    GALILEO_E1_PRNS,
    GALILEO_E1C_SECONDARY_CS25,
    galileo_e1b_code,
    galileo_e1c_code,
)
from .spec import Component, SignalSpec, Subcarrier

__all__ = [
    "GALILEO_E1B",
    "GALILEO_E1C",
    "GALILEO_E1B_BOC11",
    "GALILEO_E1C_BOC11",
    "CBOC_6_1_1_11",
    "BOC_1_1",
    "E1B_DATA",
    "E1C_PILOT",
    "boc11_replica",
]

#: CBOC(6,1,1/11): sqrt(10/11) BOC(1,1) + (or -) sqrt(1/11) BOC(6,1) (ICD sec. 2.3.3).
CBOC_6_1_1_11 = Subcarrier("cboc", 1.0, 1.0, 6.0, (math.sqrt(10.0 / 11.0), math.sqrt(1.0 / 11.0)))
#: BOC(1,1), sine-phased: the narrow-band replica of E1.
BOC_1_1 = Subcarrier("boc", 1.0, 1.0)

#: E1-B: the data component, 250 symbols/s (4 ms, one code period), BOC(6,1) term ``+``.
E1B_DATA = Component("data", galileo_e1b_code, symbol_period_s=0.004, power_fraction=0.5, subcarrier_sign=1.0)
#: E1-C: the pilot, secondary code CS25_1 (100 ms), BOC(6,1) term ``-``.
E1C_PILOT = Component(
    "pilot", galileo_e1c_code, secondary_code=GALILEO_E1C_SECONDARY_CS25, power_fraction=0.5, subcarrier_sign=-1.0
)

_COMMON = dict(
    system="E",
    carrier_freq_hz=1575.42e6,
    chip_rate_hz=1.023e6,
    code_length_chips=GALILEO_E1_CODE_LENGTH_CHIPS,
    prns=GALILEO_E1_PRNS,
    subcarrier=CBOC_6_1_1_11,
)

#: Galileo E1-B tracked (data; E1-C the second component), CBOC(6,1,1/11).
GALILEO_E1B = SignalSpec(name="galileo-e1b", rinex_code="1B", components=(E1B_DATA, E1C_PILOT), **_COMMON)
#: Galileo E1-C tracked (pilot; E1-B the second component), CBOC(6,1,1/11).
GALILEO_E1C = SignalSpec(name="galileo-e1c", rinex_code="1C", components=(E1C_PILOT, E1B_DATA), **_COMMON)


def boc11_replica(spec: SignalSpec) -> SignalSpec:
    """``spec`` with a BOC(1,1) sub-carrier instead of CBOC, named ``<name>-boc11``: the
    replica a narrow-band receiver correlates with (module docstring)."""
    return replace(spec, name=f"{spec.name}-boc11", subcarrier=BOC_1_1)


#: Galileo E1-B with a BOC(1,1) replica.
GALILEO_E1B_BOC11 = boc11_replica(GALILEO_E1B)
#: Galileo E1-C with a BOC(1,1) replica.
GALILEO_E1C_BOC11 = boc11_replica(GALILEO_E1C)
