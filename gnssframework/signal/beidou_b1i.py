"""BeiDou B1I (BDS-SIS-ICD-B1I 3.0): the descriptions of the signal.

B1I sits on 1561.098 MHz (152.6 x 10.23 MHz) with BPSK(2) codes of 2046 chips (1 ms at
2.046 Mchip/s; `beidou_b1i_codes`), one component. What it carries depends on the
satellite (sec. 5.1.2): MEO and IGSO satellites (PRN 6-58) the D1 message at 50 bit/s, each
bit's twenty code periods overlaid by the Neumann-Hoffman code NH20; GEO satellites (PRN
1-5, 59-63) the D2 message at 500 bit/s with no overlay. A description holds one symbol
period and one overlay, so there are two: ``beidou-b1i`` (D1 satellites) and
``beidou-b1i-geo`` (GEO satellites). The D1 message is decoded by
:mod:`gnssframework.navigation.d1nav`; D2 is not. RINEX 3.04: ``2I``.
"""

from __future__ import annotations

from typing import Any

from .beidou_b1i_codes import (
    B1I_CODE_LENGTH_CHIPS,
    B1I_D1_PRNS,
    B1I_GEO_PRNS,
    B1I_NEUMANN_HOFFMAN,
    beidou_b1i_code,
)
from .spec import Component, SignalSpec

__all__ = ["B1I_FREQ_HZ", "BEIDOU_B1I", "BEIDOU_B1I_GEO", "B1I_D1", "B1I_D2"]

#: The B1I carrier (sec. 4.2: 1561.098 MHz).
B1I_FREQ_HZ = 1561.098e6

#: D1: 50 bit/s (20 ms, 20 code periods) under NH20.
B1I_D1 = Component("I", beidou_b1i_code, secondary_code=B1I_NEUMANN_HOFFMAN, symbol_period_s=0.02)
#: D2: 500 bit/s (2 ms, 2 code periods), no overlay.
B1I_D2 = Component("I", beidou_b1i_code, symbol_period_s=0.002)

_B1I: dict[str, Any] = dict(
    system="C",
    rinex_code="2I",
    carrier_freq_hz=B1I_FREQ_HZ,
    chip_rate_hz=2.046e6,
    code_length_chips=B1I_CODE_LENGTH_CHIPS,
)
#: BeiDou B1I of the MEO and IGSO satellites (D1).
BEIDOU_B1I = SignalSpec(name="beidou-b1i", prns=B1I_D1_PRNS, components=(B1I_D1,), **_B1I)
#: BeiDou B1I of the GEO satellites (D2).
BEIDOU_B1I_GEO = SignalSpec(name="beidou-b1i-geo", prns=B1I_GEO_PRNS, components=(B1I_D2,), **_B1I)
