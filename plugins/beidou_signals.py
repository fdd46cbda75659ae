"""Built-in BeiDou B1I signals (plugin kind ``signal``): D1 and GEO satellites."""

from __future__ import annotations

from gnssframework.signal.beidou_b1i import BEIDOU_B1I, BEIDOU_B1I_GEO
from gnssframework.signal.registered import Signal

__all__ = ["BeidouB1i", "BeidouB1iGeo"]


class BeidouB1i(Signal):
    """BeiDou B1I of the MEO and IGSO satellites: NH20 overlay, 50 bit/s D1 (BDS-SIS-ICD-B1I)."""

    name = "beidou-b1i"
    spec = BEIDOU_B1I
    description = "BeiDou B1I (D1): BPSK(2) at 1561.098 MHz, 2046-chip codes (1 ms), NH20 overlay, 50 bit/s, PRN 6-58"


class BeidouB1iGeo(Signal):
    """BeiDou B1I of the GEO satellites: 500 bit/s D2, no overlay (BDS-SIS-ICD-B1I)."""

    name = "beidou-b1i-geo"
    spec = BEIDOU_B1I_GEO
    description = "BeiDou B1I (GEO, D2): BPSK(2) at 1561.098 MHz, 2046-chip codes (1 ms), 500 bit/s, PRN 1-5, 59-63"
