"""Galileo E5a (Galileo OS SIS ICD Issue 2.1, sec. 2.3, 3.4, 3.5): the descriptions.

E5a sits on 1176.45 MHz (GPS L5's carrier) with BPSK(10) codes of 10230 chips (1 ms at
10.23 Mchip/s; `galileo_e5a_codes`), a data and a pilot component of half the power each,
in phase quadrature. E5a-I carries F/NAV at 50 symbols/s (one symbol every 20 code
periods) overlaid by CS20_1; E5a-Q is the pilot, PRN ``i`` overlaid by its own CS100_i
(`Component.secondary_code_of`). RINEX 3.04: ``5I``, ``5Q``. The E5 AltBOC signal's E5a
part is what a receiver with a 20 MHz front end at 1176.45 MHz takes; E5b is not
described here. As for GPS L5 (`gps_l5`), one description per tracked component; the
quadrature is stated, not used by a block.
"""

from __future__ import annotations

from typing import Any

from .galileo_e5a_codes import (
    E5A_CODE_LENGTH_CHIPS,
    E5A_PRNS,
    E5AI_SECONDARY_CS20,
    galileo_e5ai_code,
    galileo_e5aq_code,
    galileo_e5aq_secondary_code,
)
from .gps_l5 import L5_FREQ_HZ
from .spec import Component, SignalSpec

__all__ = ["GALILEO_E5AI", "GALILEO_E5AQ", "E5AI_DATA", "E5AQ_PILOT"]

#: E5a-I: F/NAV at 50 symbols/s (20 ms, 20 code periods), CS20_1 overlay.
E5AI_DATA = Component(
    "I", galileo_e5ai_code, secondary_code=E5AI_SECONDARY_CS20, symbol_period_s=0.02, power_fraction=0.5
)
#: E5a-Q: the pilot, CS100_i overlay (one per PRN).
E5AQ_PILOT = Component("Q", galileo_e5aq_code, secondary_code_of=galileo_e5aq_secondary_code, power_fraction=0.5)

_E5A: dict[str, Any] = dict(
    system="E",
    carrier_freq_hz=L5_FREQ_HZ,
    chip_rate_hz=10.23e6,
    code_length_chips=E5A_CODE_LENGTH_CHIPS,
    prns=E5A_PRNS,
)
#: Galileo E5a with E5a-I (data) tracked.
GALILEO_E5AI = SignalSpec(name="galileo-e5ai", rinex_code="5I", components=(E5AI_DATA, E5AQ_PILOT), **_E5A)
#: Galileo E5a with E5a-Q (pilot) tracked.
GALILEO_E5AQ = SignalSpec(name="galileo-e5aq", rinex_code="5Q", components=(E5AQ_PILOT, E5AI_DATA), **_E5A)
