"""GPS L1 C/A Gold codes (IS-GPS-200, section 3.3.2.3)."""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..errors import ConfigError

__all__ = ["ca_code", "G2_TAPS", "CA_CODE_LENGTH"]

#: Chips in one C/A code period (IS-GPS-200, 3.3.2.3).
CA_CODE_LENGTH = 1023

#: G2 phase-selector taps (1-based register stages) per PRN, IS-GPS-200 Table 3-Ia.
G2_TAPS: dict[int, tuple[int, int]] = {
    1: (2, 6), 2: (3, 7), 3: (4, 8), 4: (5, 9), 5: (1, 9), 6: (2, 10), 7: (1, 8), 8: (2, 9),
    9: (3, 10), 10: (2, 3), 11: (3, 4), 12: (5, 6), 13: (6, 7), 14: (7, 8), 15: (8, 9),
    16: (9, 10), 17: (1, 4), 18: (2, 5), 19: (3, 6), 20: (4, 7), 21: (5, 8), 22: (6, 9),
    23: (1, 3), 24: (4, 6), 25: (5, 7), 26: (6, 8), 27: (7, 9), 28: (8, 10), 29: (1, 6),
    30: (2, 7), 31: (3, 8), 32: (4, 9),
}


@lru_cache(maxsize=None)
def _code_bits(prn: int) -> bytes:
    # G1 = 1 + x^3 + x^10, G2 = 1 + x^2 + x^3 + x^6 + x^8 + x^9 + x^10, both start all ones.
    g1 = [1] * 10
    g2 = [1] * 10
    t1, t2 = G2_TAPS[prn]
    out = bytearray(CA_CODE_LENGTH)
    for i in range(CA_CODE_LENGTH):  # once per PRN, cached: not a hot path
        out[i] = g1[9] ^ g2[t1 - 1] ^ g2[t2 - 1]
        fb1 = g1[2] ^ g1[9]
        fb2 = g2[1] ^ g2[2] ^ g2[5] ^ g2[7] ^ g2[8] ^ g2[9]
        g1 = [fb1] + g1[:9]
        g2 = [fb2] + g2[:9]
    return bytes(out)


def ca_code(prn: int) -> np.ndarray:
    """The 1023-chip C/A code of ``prn`` (1-32) as ±1 ``int8`` (logic 0 -> +1, 1 -> -1).

    Raises
    ------
    ConfigError
        For a PRN outside 1-32.
    """
    if not isinstance(prn, (int, np.integer)) or int(prn) not in G2_TAPS:
        raise ConfigError("prn", f"GPS C/A PRN must be an integer 1-32, got {prn!r}")
    bits = np.frombuffer(_code_bits(int(prn)), dtype=np.uint8)
    return (1 - 2 * bits.astype(np.int8)).astype(np.int8)
