"""GPS L5 (IS-GPS-705) and QZSS L5 (IS-QZSS-PNT): the descriptions of the signals.

L5 sits on 1176.45 MHz (115 x 10.23 MHz) with BPSK(10) codes of 10230 chips (1 ms at
10.23 Mchip/s; `gps_l5_codes`), a data and a pilot component of half the power each, in
phase quadrature (IS-GPS-705 sec. 3.2.1, 3.3.2): I5 carries CNAV at 100 symbols/s (50 bit/s,
rate 1/2; one symbol every 10 code periods) overlaid by the 10-chip Neuman-Hoffman code
NH10; Q5 is the pilot, overlaid by NH20. RINEX 3.04: ``5I``, ``5Q``.

One description per tracked component, each registered as a ``signal`` plugin: the pilot
first where a receiver wants the longest coherent time (``gps-l5q``), the data component
first where it wants the symbols (``gps-l5i``). A description's other component is named
with its code and overlay; the quadrature between the two is stated here and not used by
any block (the generator writes the tracked component alone, and a replica correlates one
component). QZSS L5 uses GPS L5's codes and overlays on PRN 193-202 (``qzss-l5q``).
Galileo E5a, on the same carrier, is `galileo_e5a`.
"""

from __future__ import annotations

from typing import Any

from .gps_l5_codes import (
    L5_CODE_LENGTH_CHIPS,
    L5I_NEUMAN_HOFFMAN,
    L5Q_NEUMAN_HOFFMAN,
    gps_l5i_code,
    gps_l5q_code,
)
from .spec import Component, SignalSpec

__all__ = [
    "L5_FREQ_HZ",
    "GPS_L5I",
    "GPS_L5Q",
    "QZSS_L5Q",
    "L5I_DATA",
    "L5Q_PILOT",
]

#: The L5 / E5a carrier, 115 x 10.23 MHz (IS-GPS-705 sec. 3.3.1.1; OS SIS ICD sec. 2.1).
L5_FREQ_HZ = 1176.45e6

#: I5: CNAV at 100 symbols/s (10 ms, 10 code periods), NH10 overlay, half the power.
L5I_DATA = Component("I", gps_l5i_code, secondary_code=L5I_NEUMAN_HOFFMAN, symbol_period_s=0.01, power_fraction=0.5)
#: Q5: the pilot, NH20 overlay, half the power.
L5Q_PILOT = Component("Q", gps_l5q_code, secondary_code=L5Q_NEUMAN_HOFFMAN, power_fraction=0.5)

_L5: dict[str, Any] = dict(carrier_freq_hz=L5_FREQ_HZ, chip_rate_hz=10.23e6, code_length_chips=L5_CODE_LENGTH_CHIPS)
#: GPS PRNs of IS-GPS-705 Tables 3-Ia/3-Ib (1-63); QZSS's 193-202.
_GPS_PRNS = tuple(range(1, 64))
_QZSS_PRNS = tuple(range(193, 203))

#: GPS L5 with I5 (data) tracked.
GPS_L5I = SignalSpec(
    name="gps-l5i", system="G", rinex_code="5I", prns=_GPS_PRNS, components=(L5I_DATA, L5Q_PILOT), **_L5
)
#: GPS L5 with Q5 (pilot) tracked.
GPS_L5Q = SignalSpec(
    name="gps-l5q", system="G", rinex_code="5Q", prns=_GPS_PRNS, components=(L5Q_PILOT, L5I_DATA), **_L5
)
#: QZSS L5 with its Q5 pilot tracked (IS-QZSS-PNT: GPS L5's codes, PRN 193-202).
QZSS_L5Q = SignalSpec(
    name="qzss-l5q",
    system="J",
    rinex_code="5Q",
    prns=_QZSS_PRNS,
    components=(L5Q_PILOT, L5I_DATA),
    rinex_prn_offset=192,
    **_L5,
)
