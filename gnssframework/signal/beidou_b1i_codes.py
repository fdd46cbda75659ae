r"""BeiDou B1I ranging codes and the D1 Neumann-Hoffman overlay (BDS-SIS-ICD-B1I 3.0,
sec. 5.1.1-5.1.2 and 5.2.2, Table 5-1).

A code is 2046 chips (1 ms at 2.046 Mchip/s): the chip-by-chip sum modulo 2 of two
11-stage register sequences, both loaded with ``01010101010`` (stage 1 first) at every code
epoch, each 2047 chips long and truncated by its last chip:

- **G1**: polynomial :math:`1 + x + x^7 + x^8 + x^9 + x^{10} + x^{11}`, its output stage 11;
- **G2**: polynomial :math:`1 + x + x^2 + x^3 + x^4 + x^5 + x^8 + x^9 + x^{11}`, its output
  the sum modulo 2 of two or three stages, the *phase assignment* of the PRN (Table 5-1:
  PRN 1-37 two stages, PRN 38-63 three).

Logic 0 is +1. PRN 1-5 and 59-63 are GEO satellites, which send the D2 message at 500
bit/s with no overlay; the others (MEO and IGSO, PRN 6-58) send D1 at 50 bit/s, each bit
overlaid by the 20-chip Neumann-Hoffman code ``00000100110101001110`` at one chip a code
period (sec. 5.1.2; the code of GPS L5 Q5's overlay).

The phase assignments are Table 5-1's; two public transcriptions of the table (PocketSDR's
``sdr_code.py`` and GNSS-DSP-tools' ``gnsstools/beidou/b1i.py``) were compared with it entry
for entry (compared, not copied) and agree.
"""

from __future__ import annotations

from functools import cache

import numpy as np

from .codes import bits_to_chips, checked_prn, register_states

__all__ = [
    "B1I_CODE_LENGTH_CHIPS",
    "B1I_PRNS",
    "B1I_GEO_PRNS",
    "B1I_D1_PRNS",
    "B1I_G2_PHASE",
    "B1I_NEUMANN_HOFFMAN",
    "B1I_START",
    "beidou_b1i_code",
]

#: Chips of one B1I code period (sec. 5.1.1: 2047-chip Gold codes truncated by one chip).
B1I_CODE_LENGTH_CHIPS = 2046
#: PRNs of the ICD (Table 5-1).
B1I_PRNS = tuple(range(1, 64))
#: GEO satellites (D2 at 500 bit/s, no overlay: sec. 5.1.2).
B1I_GEO_PRNS = (1, 2, 3, 4, 5, 59, 60, 61, 62, 63)
#: MEO and IGSO satellites (D1 at 50 bit/s under NH20).
B1I_D1_PRNS = tuple(p for p in B1I_PRNS if p not in B1I_GEO_PRNS)
#: Initial phase of G1 and G2, stage 1 first (sec. 5.1.1).
B1I_START = (0, 1, 0, 1, 0, 1, 0, 1, 0, 1, 0)
#: Feedback stages of G1 and G2 (the polynomials' powers, 1-based stages).
_G1_FEEDBACK = (1, 7, 8, 9, 10, 11)
_G2_FEEDBACK = (1, 2, 3, 4, 5, 8, 9, 11)
#: The 20-chip Neumann-Hoffman code of D1 (sec. 5.1.2), as ±1 (logic 0 -> +1).
B1I_NEUMANN_HOFFMAN = tuple(
    int(c) for c in bits_to_chips(np.array([0, 0, 0, 0, 0, 1, 0, 0, 1, 1, 0, 1, 0, 1, 0, 0, 1, 1, 1, 0]))
)

#: G2 phase assignment (1-based stages summed modulo 2 for the output), PRN 1-63 in order.
# fmt: off
_PHASES = (
    (1, 3), (1, 4), (1, 5), (1, 6), (1, 8), (1, 9), (1, 10), (1, 11), (2, 7), (3, 4),
    (3, 5), (3, 6), (3, 8), (3, 9), (3, 10), (3, 11), (4, 5), (4, 6), (4, 8), (4, 9),
    (4, 10), (4, 11), (5, 6), (5, 8), (5, 9), (5, 10), (5, 11), (6, 8), (6, 9), (6, 10),
    (6, 11), (8, 9), (8, 10), (8, 11), (9, 10), (9, 11), (10, 11),
    (1, 2, 7), (1, 3, 4), (1, 3, 6), (1, 3, 8), (1, 3, 10), (1, 3, 11), (1, 4, 5),
    (1, 4, 9), (1, 5, 6), (1, 5, 8), (1, 5, 10), (1, 5, 11), (1, 6, 9), (1, 8, 9),
    (1, 9, 10), (1, 9, 11), (2, 3, 7), (2, 5, 7), (2, 7, 9), (3, 4, 5), (3, 4, 9),
    (3, 5, 6), (3, 5, 8), (3, 5, 10), (3, 5, 11), (3, 6, 9),
)
# fmt: on
#: G2 phase assignment per PRN (Table 5-1).
B1I_G2_PHASE: dict[int, tuple[int, ...]] = dict(enumerate(_PHASES, start=1))


@cache
def _g1_g2_states() -> tuple[np.ndarray, np.ndarray]:
    return (
        register_states(_G1_FEEDBACK, B1I_CODE_LENGTH_CHIPS, 11, B1I_START),
        register_states(_G2_FEEDBACK, B1I_CODE_LENGTH_CHIPS, 11, B1I_START),
    )


@cache
def _code(prn: int) -> np.ndarray:
    g1, g2 = _g1_g2_states()
    g2_out = np.bitwise_xor.reduce(g2[:, [s - 1 for s in B1I_G2_PHASE[prn]]], axis=1)
    chips = bits_to_chips(g1[:, 10] ^ g2_out)
    chips.flags.writeable = False
    return chips


def beidou_b1i_code(prn: int) -> np.ndarray:
    """The 2046-chip B1I code of ``prn`` (1-63) as ±1 ``int8`` (module text); a read-only
    cached array.

    Raises
    ------
    ConfigError
        For a PRN outside 1-63.
    """
    return _code(checked_prn(prn, B1I_PRNS, "BeiDou B1I"))
