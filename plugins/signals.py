"""Built-in signals (plugin kind ``signal``): each class holds one signal description."""

from __future__ import annotations

from gnssframework.signal.beidou_b1c import BEIDOU_B1C
from gnssframework.signal.gps_l1ca import GPS_L1CA
from gnssframework.signal.gps_l2c import GPS_L2C, QZSS_L2C
from gnssframework.signal.gps_l5 import GPS_L5I, GPS_L5Q, QZSS_L5Q
from gnssframework.signal.qzss_l1ca import QZSS_L1CA
from gnssframework.signal.registered import Signal
from gnssframework.signal.sbas_l1 import SBAS_L1

__all__ = ["GpsL1ca", "QzssL1ca", "SbasL1", "GpsL2c", "QzssL2c", "GpsL5i", "GpsL5q", "QzssL5q", "BeidouB1c"]


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


class GpsL2c(Signal):
    """GPS L2C: L2 CM (data) and L2 CL (pilot) time-multiplexed chip by chip (IS-GPS-200)."""

    name = "gps-l2c"
    spec = GPS_L2C
    description = (
        "GPS L2C: CM (10230 chips, 20 ms, 50 sps) and CL (767250 chips, 1.5 s) alternating at "
        "1.023 Mchip/s on 1227.6 MHz, PRN 1-32"
    )


class QzssL2c(Signal):
    """QZSS L2C, its CM component (IS-QZSS-PNT)."""

    name = "qzss-l2c"
    spec = QZSS_L2C
    description = "QZSS L2C: CM (10230 chips, 20 ms) in its time slot on 1227.6 MHz, PRN 193-202"


class GpsL5i(Signal):
    """GPS L5, its I5 data component tracked: NH10 overlay, 100 sps CNAV (IS-GPS-705)."""

    name = "gps-l5i"
    spec = GPS_L5I
    description = "GPS L5 I5: BPSK(10) at 1176.45 MHz, 10230-chip codes (1 ms), NH10 overlay, 100 sps CNAV, PRN 1-63"


class GpsL5q(Signal):
    """GPS L5, its Q5 pilot tracked: NH20 overlay (IS-GPS-705)."""

    name = "gps-l5q"
    spec = GPS_L5Q
    description = "GPS L5 Q5 pilot: BPSK(10) at 1176.45 MHz, 10230-chip codes (1 ms), NH20 overlay, PRN 1-63"


class QzssL5q(Signal):
    """QZSS L5, its Q5 pilot tracked: GPS L5's codes on PRN 193-202 (IS-QZSS-PNT)."""

    name = "qzss-l5q"
    spec = QZSS_L5Q
    description = "QZSS L5 Q5 pilot: GPS L5's codes and NH20 overlay on 1176.45 MHz, PRN 193-202"


class BeidouB1c(Signal):
    """BeiDou B1C: Weil-code pilot (tracked) and data, BOC(1,1) replica (BDS-SIS-ICD-B1C)."""

    name = "beidou-b1c"
    spec = BEIDOU_B1C
    description = (
        "BeiDou B1C: 10230-chip Weil codes (10 ms) at 1.023 Mchip/s, BOC(1,1) replica, pilot and 100 sps data, PRN 1-63"
    )
