"""GPS L2C (IS-GPS-200) and QZSS L2C (IS-QZSS-PNT): the descriptions of the signals.

L2C at 1227.60 MHz is two codes sent chip by chip in turn at 1.023 Mchip/s: a chip of
L2 CM (10230 chips, 20 ms, carrying the CNAV symbols: 25 bit/s, rate-1/2 encoded to
50 symbols/s, one symbol per CM period), then a chip of L2 CL (767250 chips, 1.5 s, no
data), and so on (IS-GPS-200, sec. 3.2.1.3, 3.3.2.4). Each code alone
runs at 511.5 kchip/s. The description says so with two components at the signal's chip
rate of 511.5 kchip/s, each in one of the two halves of every chip period
(`Component.time_slot`): CM ``(0, 2)``, CL ``(1, 2)``. A block that indexes the spreading
table (`SignalSpec.spreading_table`, two entries a chip) then makes the CM replica with
zeros where CL chips are sent: a CM search ignores the CL half of the power.

RINEX 3.04 names the CM observation ``2S`` (``2L`` for CL, ``2X`` for both).
"""

from __future__ import annotations

from .gps_l2c_codes import (
    L2CL_LENGTH,
    L2CM_INITIAL_STATE,
    L2CM_LENGTH,
    QZSS_L2CM_INITIAL_STATE,
    gps_l2cl_code,
    gps_l2cm_code,
    qzss_l2cm_code,
)
from .spec import BPSK, Component, SignalSpec

__all__ = ["GPS_L2C", "QZSS_L2C", "L2_FREQ_HZ"]

#: The L2 carrier, 120 x 10.23 MHz (IS-GPS-200, sec. 3.3.1.1).
L2_FREQ_HZ = 1227.60e6

#: What GPS and QZSS L2C share: the carrier, the 511.5 kchip/s rate of each code alone, CM's
#: length (the signal's code period) and RINEX code, no sub-carrier.
_L2C_COMMON = dict(
    rinex_code="2S", carrier_freq_hz=L2_FREQ_HZ, chip_rate_hz=511.5e3, code_length_chips=L2CM_LENGTH, subcarrier=BPSK
)
#: CM's component keywords: one CNAV symbol a 20 ms code period, half the power, first time slot.
_CM_COMMON = dict(symbol_period_s=0.02, power_fraction=0.5, time_slot=(0, 2))

#: GPS L2C: CM (data, tracked first) and CL (pilot), time-multiplexed.
GPS_L2C = SignalSpec(
    name="gps-l2c",
    system="G",
    prns=tuple(sorted(L2CM_INITIAL_STATE)),
    components=(
        Component("CM", gps_l2cm_code, **_CM_COMMON),
        Component("CL", gps_l2cl_code, power_fraction=0.5, code_length_chips=L2CL_LENGTH, time_slot=(1, 2)),
    ),
    **_L2C_COMMON,
)

#: QZSS L2C, its CM component (IS-QZSS-PNT; the CL code's initial states are not transcribed
#: here, so the description holds CM only, in its time slot).
QZSS_L2C = SignalSpec(
    name="qzss-l2c",
    system="J",
    prns=tuple(sorted(QZSS_L2CM_INITIAL_STATE)),
    components=(Component("CM", qzss_l2cm_code, **_CM_COMMON),),
    rinex_prn_offset=192,
    **_L2C_COMMON,
)
