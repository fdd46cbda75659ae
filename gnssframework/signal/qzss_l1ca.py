"""QZSS L1 C/A (IS-QZSS-PNT): the description of the signal, one value.

QZSS L1 C/A is GPS L1 C/A's signal structure (BPSK(1) at 1575.42 MHz, 1023-chip Gold
codes at 1.023 Mchip/s, 50 bit/s data in the LNAV format) on PRN 193-202, with codes of
the same Gold family selected by G2 delay (`qzss_codes`). RINEX names the system ``J``,
the observation ``1C`` and PRN 193 ``J01``.
"""

from __future__ import annotations

from .qzss_codes import QZSS_L1CA_G2_DELAY, qzss_l1ca_code
from .spec import BPSK, Component, SignalSpec

__all__ = ["QZSS_L1CA"]

QZSS_L1CA = SignalSpec(
    name="qzss-l1ca",
    system="J",
    rinex_code="1C",
    carrier_freq_hz=1575.42e6,
    chip_rate_hz=1.023e6,
    code_length_chips=1023,
    prns=tuple(sorted(QZSS_L1CA_G2_DELAY)),
    components=(Component("data", qzss_l1ca_code, symbol_period_s=0.02),),
    subcarrier=BPSK,
    rinex_prn_offset=192,
)
