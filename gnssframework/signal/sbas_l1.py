"""SBAS L1 (RTCA DO-229, ICAO Annex 10 Vol. I Appendix B): the description of the signal, one value.

SBAS L1 is GPS L1 C/A's ranging structure (BPSK(1) at 1575.42 MHz, 1023-chip Gold codes
at 1.023 Mchip/s, 1 ms) on PRN 120-158, with codes of the C/A family selected by G2 delay
(`sbas_codes`). Its data differ from GPS's: 250 bit/s messages of 250 bits, rate-1/2
convolutionally encoded (constraint length 7) to 500 symbols/s, so one symbol lasts
2 ms = 2 code periods (DO-229 Appendix A, sec. A.3). RINEX 3.04 (sec. 3.5) names the
system ``S``, the observation ``1C`` and PRN 120 ``S20`` (PRN minus 100).
"""

from __future__ import annotations

from .sbas_codes import SBAS_L1_G2_DELAY, sbas_l1_code
from .spec import BPSK, Component, SignalSpec

__all__ = ["SBAS_L1"]

SBAS_L1 = SignalSpec(
    name="sbas-l1",
    system="S",
    rinex_code="1C",
    carrier_freq_hz=1575.42e6,
    chip_rate_hz=1.023e6,
    code_length_chips=1023,
    prns=tuple(sorted(SBAS_L1_G2_DELAY)),
    components=(Component("data", sbas_l1_code, symbol_period_s=0.002),),
    subcarrier=BPSK,
    rinex_prn_offset=100,
)
