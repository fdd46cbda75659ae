"""BeiDou B1C (BDS-SIS-ICD-B1C-1.0): the description of the signal, one value.

B1C at 1575.42 MHz has a data component (B-CNAV1 at 100 symbols/s: one symbol a 10 ms
primary period; BOC(1,1), a quarter of the power) and a pilot (three quarters, QMBOC(6,1,4/33):
BOC(1,1) with a BOC(6,1) part of 4/33 of the pilot's power), each with a 10230-chip Weil code
at 1.023 Mchip/s (`beidou_b1c_codes`). The receiver's replica is BOC(1,1) on both (the
narrow-band replica the ICD allows; the BOC(6,1) part is outside a 4 MHz front end anyway).
The pilot is tracked first. Its 1800-chip secondary code differs from PRN to PRN, which a
`Component` (one overlay for every PRN) cannot hold: it is left out of the description
(`beidou_b1c_codes.b1c_pilot_secondary_code` gives it), so the description allows 10 ms of
coherent integration on the pilot. RINEX 3.04 names the pilot observation ``1P``.
"""

from __future__ import annotations

from .beidou_b1c_codes import B1C_PILOT_PARAMS, B1C_PRIMARY_LENGTH, b1c_data_code, b1c_pilot_code
from .spec import Component, SignalSpec, Subcarrier

__all__ = ["BEIDOU_B1C"]

BEIDOU_B1C = SignalSpec(
    name="beidou-b1c",
    system="C",
    rinex_code="1P",
    carrier_freq_hz=1575.42e6,
    chip_rate_hz=1.023e6,
    code_length_chips=B1C_PRIMARY_LENGTH,
    prns=tuple(sorted(B1C_PILOT_PARAMS)),
    components=(
        Component("pilot", b1c_pilot_code, power_fraction=0.75),
        Component("data", b1c_data_code, symbol_period_s=0.01, power_fraction=0.25),
    ),
    subcarrier=Subcarrier("boc", 1.0, 1.0),
)
