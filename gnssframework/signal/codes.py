"""GPS L1 C/A Gold codes (IS-GPS-200, section 3.3.2.3)."""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..errors import ConfigError

__all__ = [
    "ca_code",
    "G2_TAPS",
    "CA_CODE_LENGTH",
    "gold_code_by_taps",
    "gold_code_by_g2_delay",
    "bits_to_chips",
    "shift_register_bits",
    "checked_prn",
    "register_states",
]

#: Chips in one C/A code period (IS-GPS-200, 3.3.2.3).
CA_CODE_LENGTH = 1023

#: G2 phase-selector taps (1-based register stages) per PRN, IS-GPS-200 Table 3-Ia.
G2_TAPS: dict[int, tuple[int, int]] = {
    1: (2, 6),
    2: (3, 7),
    3: (4, 8),
    4: (5, 9),
    5: (1, 9),
    6: (2, 10),
    7: (1, 8),
    8: (2, 9),
    9: (3, 10),
    10: (2, 3),
    11: (3, 4),
    12: (5, 6),
    13: (6, 7),
    14: (7, 8),
    15: (8, 9),
    16: (9, 10),
    17: (1, 4),
    18: (2, 5),
    19: (3, 6),
    20: (4, 7),
    21: (5, 8),
    22: (6, 9),
    23: (1, 3),
    24: (4, 6),
    25: (5, 7),
    26: (6, 8),
    27: (7, 9),
    28: (8, 10),
    29: (1, 6),
    30: (2, 7),
    31: (3, 8),
    32: (4, 9),
}


def register_states(
    feedback_stages: tuple[int, ...], n: int = CA_CODE_LENGTH, stages: int = 10, start: tuple[int, ...] | None = None
) -> np.ndarray:
    """The ``(n, stages)`` states (stages 1 to ``stages``, before each shift) of a register
    starting at ``start`` (stage 1 first; all ones by default) whose new stage 1 is the XOR
    of ``feedback_stages`` (1-based): the C/A code's G1 and G2 (IS-GPS-200 fig. 3-10) and
    BeiDou B1I's (BDS-SIS-ICD-B1I 3.0 fig. 5-2). Run once per code and cached by its
    callers: not a hot path."""
    reg = list(start) if start is not None else [1] * stages
    if len(reg) != stages:
        raise ConfigError("start", f"a {stages}-stage register needs {stages} initial bits, got {len(reg)}")
    out = np.empty((n, stages), np.uint8)
    for i in range(n):
        out[i] = reg
        fb = 0
        for stage in feedback_stages:
            fb ^= reg[stage - 1]
        reg = [fb] + reg[:-1]
    return out


@lru_cache(maxsize=1)
def _g1_g2_states() -> tuple[np.ndarray, np.ndarray]:
    # G1 = 1 + x^3 + x^10, G2 = 1 + x^2 + x^3 + x^6 + x^8 + x^9 + x^10, both start all ones.
    return register_states((3, 10)), register_states((2, 3, 6, 8, 9, 10))


def bits_to_chips(bits: np.ndarray) -> np.ndarray:
    """Logic bits (0/1, any integer or bool dtype) as ±1 ``int8`` chips: logic 0 -> +1, 1 -> -1
    (IS-GPS-200 and the Galileo and BeiDou ICDs alike)."""
    return (1 - 2 * bits.astype(np.int8)).astype(np.int8)


def gold_code_by_taps(tap1: int, tap2: int) -> np.ndarray:
    """The 1023-chip C/A-family Gold code :math:`G1 \\oplus G2_{t_1} \\oplus G2_{t_2}`
    (G2 phase selector on 1-based stages ``tap1``, ``tap2``; IS-GPS-200 fig. 3-10), ±1 ``int8``."""
    g1, g2 = _g1_g2_states()
    return bits_to_chips(g1[:, 9] ^ g2[:, tap1 - 1] ^ g2[:, tap2 - 1])


def gold_code_by_g2_delay(delay_chips: int) -> np.ndarray:
    """The 1023-chip C/A-family Gold code whose G2 sequence is delayed by ``delay_chips``
    (chip :math:`k` is :math:`G1(k) \\oplus G2(k - d)`), as ±1 ``int8`` (logic 0 -> +1, 1 -> -1)."""
    g1, g2 = _g1_g2_states()
    return bits_to_chips(g1[:, 9] ^ np.roll(g2[:, 9], int(delay_chips)))


def shift_register_bits(start: int, taps: int, n: int, stages: int, *, short_cycle: int | None = None) -> np.ndarray:
    """``n`` output bits (0/1) of a Fibonacci shift register held as a ``stages``-bit integer
    whose most significant bit is the output stage: each shift moves every bit one place up
    and the new least significant bit is the parity of the bits under ``taps``. With
    ``short_cycle``, the state after that one is all ones again (GPS L5's XA, IS-GPS-705
    3.3.2.1). Run once per code and cached by its callers: not a hot path."""
    mask = (1 << stages) - 1
    state = start & mask
    out = np.empty(n, np.uint8)
    for i in range(n):
        out[i] = state >> (stages - 1)
        state = mask if state == short_cycle else ((state << 1) & mask) | (int(state & taps).bit_count() & 1)
    return out


def checked_prn(prn: object, prns, label: str) -> int:
    """``prn`` as an ``int`` when it is an integer in ``prns`` (any container of PRNs), else a
    `ConfigError` on ``prn`` naming ``label`` and the range (``"<label> PRN must be an integer
    lo-hi, got ..."``); the one PRN check of every code generator and `SignalSpec.check_prn`."""
    if isinstance(prn, bool) or not isinstance(prn, (int, np.integer)) or int(prn) not in prns:
        raise ConfigError("prn", f"{label} PRN must be an integer {min(prns)}-{max(prns)}, got {prn!r}")
    return int(prn)


def ca_code(prn: int) -> np.ndarray:
    """The 1023-chip C/A code of ``prn`` (1-32) as ±1 ``int8`` (logic 0 -> +1, 1 -> -1).

    Raises
    ------
    ConfigError
        For a PRN outside 1-32.
    """
    return gold_code_by_taps(*G2_TAPS[checked_prn(prn, G2_TAPS, "GPS C/A")])
