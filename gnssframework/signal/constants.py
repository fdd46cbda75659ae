"""Physical and GPS L1 C/A constants, read off the signal description `GPS_L1CA`.

New code reads a `gnssframework.signal.spec.SignalSpec` (the one it was handed) rather
than these names; they remain for the blocks not yet generic over signals.
"""

from .gps_l1ca import GPS_L1CA
from .spec import SPEED_OF_LIGHT_M_S

__all__ = [
    "SPEED_OF_LIGHT_M_S",
    "L1_FREQ_HZ",
    "CA_CHIP_RATE_HZ",
    "CA_CODE_LENGTH",
    "CA_CODE_PERIOD_S",
    "L1_WAVELENGTH_M",
    "CA_CHIP_LENGTH_M",
    "NAV_BIT_RATE_HZ",
]

L1_FREQ_HZ = GPS_L1CA.carrier_freq_hz
CA_CHIP_RATE_HZ = GPS_L1CA.chip_rate_hz
CA_CODE_LENGTH = GPS_L1CA.code_length_chips
CA_CODE_PERIOD_S = GPS_L1CA.code_period_s
L1_WAVELENGTH_M = GPS_L1CA.wavelength_m
CA_CHIP_LENGTH_M = GPS_L1CA.chip_length_m
NAV_BIT_RATE_HZ = 1.0 / GPS_L1CA.symbol_period_s
