"""GPS L1 C/A (IS-GPS-200): the one place its description lives.

A receiver block that needs the carrier frequency, the chip rate, the code length or the
bit period reads them from `GPS_L1CA` (or from whichever `SignalSpec` it was handed),
never from a constant of its own.
"""

from __future__ import annotations

from .codes import ca_code
from .spec import BPSK, Component, SignalSpec

__all__ = ["GPS_L1CA"]

#: GPS L1 C/A: BPSK(1) at 1575.42 MHz, 1023-chip Gold codes at 1.023 Mchip/s (1 ms),
#: 50 bit/s LNAV data (20 code periods per bit), no pilot, no overlay code
#: (IS-GPS-200, sections 3.2.1 and 3.3.2).
GPS_L1CA = SignalSpec(
    name="gps-l1ca",
    system="G",
    rinex_code="1C",
    carrier_freq_hz=1575.42e6,
    chip_rate_hz=1.023e6,
    code_length_chips=1023,
    prns=tuple(range(1, 33)),
    components=(Component("data", ca_code, symbol_period_s=0.02),),
    subcarrier=BPSK,
)
