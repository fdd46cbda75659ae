"""Built-in signals (plugin kind ``signal``): each class holds one signal description."""

from __future__ import annotations

from gnssframework.signal.gps_l1ca import GPS_L1CA
from gnssframework.signal.qzss_l1ca import QZSS_L1CA
from gnssframework.signal.registered import Signal
from gnssframework.signal.sbas_l1 import SBAS_L1

__all__ = ["GpsL1ca", "QzssL1ca", "SbasL1"]


class GpsL1ca(Signal):
    """GPS L1 C/A: BPSK(1) at 1575.42 MHz, 1023-chip Gold codes, 50 bit/s LNAV (IS-GPS-200)."""

    name = "gps-l1ca"
    spec = GPS_L1CA
    description = "GPS L1 C/A: BPSK(1) at 1575.42 MHz, 1023-chip Gold codes, PRN 1-32, 50 bit/s LNAV"


class QzssL1ca(Signal):
    """QZSS L1 C/A: GPS L1 C/A's structure on PRN 193-202 (IS-QZSS-PNT)."""

    name = "qzss-l1ca"
    spec = QZSS_L1CA
    description = "QZSS L1 C/A: BPSK(1) at 1575.42 MHz, C/A-family Gold codes by G2 delay, PRN 193-202, LNAV"


class SbasL1(Signal):
    """SBAS L1: C/A-family Gold codes by G2 delay on PRN 120-158, 500 symbols/s (RTCA DO-229)."""

    name = "sbas-l1"
    spec = SBAS_L1
    description = "SBAS L1: BPSK(1) at 1575.42 MHz, C/A-family Gold codes by G2 delay, PRN 120-158, 500 sps"
