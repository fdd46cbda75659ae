"""QZSS L1 C/A ranging codes: GPS C/A Gold codes selected by G2 delay (IS-QZSS-PNT).

QZSS L1 C/A uses the Gold-code generator of GPS C/A (IS-GPS-200, sec. 3.3.2.3: G1 =
1 + x^3 + x^10, G2 = 1 + x^2 + x^3 + x^6 + x^8 + x^9 + x^10, both registers starting all
ones) with the satellite's code selected by a *G2 delay* instead of two phase-selector
taps: chip :math:`k` is :math:`G1(k) \\oplus G2(k - d)` with :math:`d` the delay in chips
(IS-QZSS-PNT, "L1C/A code" PRN assignment table: PRN 193-202; the same delays are listed
for PRN 193-202 in the GPS Directorate's "L1 C/A PRN code assignments", October 2019,
https://www.gps.gov/technical/prn-codes/L1-CA-PRN-code-assignments-2019-Oct.pdf, which
extends IS-GPS-200's table to PRN 210). The same rule with the
delays of IS-GPS-200 Table 3-Ia (5, 6, 7, ... for PRN 1, 2, 3, ...) gives GPS C/A, which
is how the tests check the delay convention. The generator is the one of `codes`
(`gold_code_by_g2_delay`), shared with GPS C/A.
"""

from __future__ import annotations

import numpy as np

from .codes import checked_prn, gold_code_by_g2_delay

__all__ = ["QZSS_L1CA_G2_DELAY", "gold_code_by_g2_delay", "qzss_l1ca_code"]

#: G2 delay (chips) per QZSS L1 C/A PRN (IS-QZSS-PNT, L1C/A PRN assignment table).
QZSS_L1CA_G2_DELAY: dict[int, int] = {
    193: 339,
    194: 208,
    195: 711,
    196: 189,
    197: 263,
    198: 537,
    199: 663,
    200: 942,
    201: 173,
    202: 900,
}


def qzss_l1ca_code(prn: int) -> np.ndarray:
    """The QZSS L1 C/A code of ``prn`` (193-202) as ±1 ``int8``.

    Raises
    ------
    ConfigError
        For a PRN outside 193-202.
    """
    return gold_code_by_g2_delay(QZSS_L1CA_G2_DELAY[checked_prn(prn, QZSS_L1CA_G2_DELAY, "QZSS L1 C/A")])
