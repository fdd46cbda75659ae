"""SBAS L1 ranging codes: GPS C/A Gold codes selected by G2 delay (RTCA DO-229, PRN 120-158).

SBAS L1 (WAAS, EGNOS, MSAS, GAGAN, ...) uses the Gold-code generator of GPS C/A
(IS-GPS-200, sec. 3.3.2.3: G1 = 1 + x^3 + x^10, G2 = 1 + x^2 + x^3 + x^6 + x^8 + x^9 +
x^10, both registers starting all ones) with the satellite's code selected by a *G2
delay*: chip :math:`k` is :math:`G1(k) \\oplus G2(k - d)` (`codes.gold_code_by_g2_delay`,
the rule of `qzss_codes`). The delays of PRN 120-158 are transcribed from RTCA DO-229
(Appendix A, "SBAS PRN code assignments", the "G2 delay (chips)" column; PRN 120-138 in
DO-229C, extended to 158 in later issues) as the GPS Directorate lists them for PRN 120-158
in "L1 C/A PRN code assignments", October 2019,
https://www.gps.gov/technical/prn-codes/L1-CA-PRN-code-assignments-2019-Oct.pdf.
DO-229's table also gives each code's initial G2 register setting (octal), which the tests
use as a truth the generator does not contain (`tests/signal/test_sbas_l1.py`).
"""

from __future__ import annotations

import numpy as np

from .codes import checked_prn, gold_code_by_g2_delay

__all__ = ["SBAS_L1_G2_DELAY", "sbas_l1_code"]

#: G2 delay (chips) per SBAS L1 PRN 120-158 (RTCA DO-229 Appendix A; gps.gov L1 C/A PRN
#: code assignments, 2019).
SBAS_L1_G2_DELAY: dict[int, int] = {
    120: 145,
    121: 175,
    122: 52,
    123: 21,
    124: 237,
    125: 235,
    126: 886,
    127: 657,
    128: 634,
    129: 762,
    130: 355,
    131: 1012,
    132: 176,
    133: 603,
    134: 130,
    135: 359,
    136: 595,
    137: 68,
    138: 386,
    139: 797,
    140: 456,
    141: 499,
    142: 883,
    143: 307,
    144: 127,
    145: 211,
    146: 121,
    147: 118,
    148: 163,
    149: 628,
    150: 853,
    151: 484,
    152: 289,
    153: 811,
    154: 202,
    155: 1021,
    156: 463,
    157: 568,
    158: 904,
}


def sbas_l1_code(prn: int) -> np.ndarray:
    """The SBAS L1 code of ``prn`` (120-158) as ±1 ``int8`` (logic 0 -> +1), 1023 chips.

    Raises
    ------
    ConfigError
        For a PRN outside 120-158.
    """
    return gold_code_by_g2_delay(SBAS_L1_G2_DELAY[checked_prn(prn, SBAS_L1_G2_DELAY, "SBAS L1")])
