r"""GPS L2C ranging codes, L2 CM and L2 CL (IS-GPS-200, sec. 3.3.2.4, Figure 3-9, Table 3-IIa).

Both codes come from one 27-stage linear shift register of the modular (Galois) kind with
the polynomial

.. math:: 1 + x^3 + x^4 + x^5 + x^6 + x^9 + x^{11} + x^{13} + x^{16} + x^{19} + x^{21}
          + x^{24} + x^{27}

(IS-GPS-200, sec. 3.3.2.4), loaded with a PRN's initial state and reset to it every code
period: after 10230 chips for CM (20 ms at 511.5 kchip/s), after 767250 for CL (1.5 s). A
chip is the register's output stage; logic 0 is +1. Here the register is a 27-bit integer
whose bit 0 is the output stage: a shift moves every bit one place toward bit 0 and, when
the bit shifted out is 1, XORs the feedback mask into the register (bit ``k - 1`` for each
:math:`x^k` above, bit 26 for :math:`x^{27}`).

The initial states (octal, read as that integer) are transcribed from IS-GPS-200
(revision N, Table 3-IIa "Code phase assignments (IIR-M, IIF, and subsequent blocks only)",
PRN 1-32 for CM and CL) and, for QZSS PRN 193-202 (CM), from IS-QZSS-PNT (Table "L2C code
PRN numbers and initial register values", the same values as IS-GPS-200's extension of
Table 3-IIa to PRN 159-210). The ICD's table also gives each code's *end state* (the register
at the period's last chip), which the tests use as the truth the generator must reach.
"""

from __future__ import annotations

from functools import lru_cache, cache

import numpy as np

from ..errors import ConfigError
from .codes import bits_to_chips, checked_prn

__all__ = [
    "L2CM_LENGTH",
    "L2CL_LENGTH",
    "L2CM_INITIAL_STATE",
    "L2CL_INITIAL_STATE",
    "QZSS_L2CM_INITIAL_STATE",
    "l2c_register_chips",
    "gps_l2cm_code",
    "gps_l2cl_code",
    "qzss_l2cm_code",
]

#: Chips of one CM period (20 ms at 511.5 kchip/s) and of one CL period (1.5 s).
L2CM_LENGTH = 10230
L2CL_LENGTH = 767250

#: The feedback mask of the register (bit k-1 for each x^k of the polynomial, bit 26 for x^27).
_FEEDBACK = sum(1 << (k - 1) for k in (3, 4, 5, 6, 9, 11, 13, 16, 19, 21, 24, 27))

#: IS-GPS-200 Table 3-IIa, L2 CM initial shift-register state (octal), PRN 1-32.
L2CM_INITIAL_STATE: dict[int, int] = {
    1: 0o742417664,
    2: 0o756014035,
    3: 0o002747144,
    4: 0o066265724,
    5: 0o601403471,
    6: 0o703232733,
    7: 0o124510070,
    8: 0o617316361,
    9: 0o047541621,
    10: 0o733031046,
    11: 0o713512145,
    12: 0o024437606,
    13: 0o021264003,
    14: 0o230655351,
    15: 0o001314400,
    16: 0o222021506,
    17: 0o540264026,
    18: 0o205521705,
    19: 0o064022144,
    20: 0o120161274,
    21: 0o044023533,
    22: 0o724744327,
    23: 0o045743577,
    24: 0o741201660,
    25: 0o700274134,
    26: 0o010247261,
    27: 0o713433445,
    28: 0o737324162,
    29: 0o311627434,
    30: 0o710452007,
    31: 0o722462133,
    32: 0o050172213,
}

#: IS-GPS-200 Table 3-IIa, L2 CL initial shift-register state (octal), PRN 1-32.
L2CL_INITIAL_STATE: dict[int, int] = {
    1: 0o624145772,
    2: 0o506610362,
    3: 0o220360016,
    4: 0o710406104,
    5: 0o001143345,
    6: 0o053023326,
    7: 0o652521276,
    8: 0o206124777,
    9: 0o015563374,
    10: 0o561522076,
    11: 0o023163525,
    12: 0o117776450,
    13: 0o606516355,
    14: 0o003037343,
    15: 0o046515565,
    16: 0o671511621,
    17: 0o605402220,
    18: 0o002576207,
    19: 0o525163451,
    20: 0o266527765,
    21: 0o006760703,
    22: 0o501474556,
    23: 0o743747443,
    24: 0o615534726,
    25: 0o763621420,
    26: 0o720727474,
    27: 0o700521043,
    28: 0o222567263,
    29: 0o132765304,
    30: 0o746332245,
    31: 0o102300466,
    32: 0o255231716,
}

#: IS-QZSS-PNT, L2 CM initial shift-register state (octal), QZSS PRN 193-202.
QZSS_L2CM_INITIAL_STATE: dict[int, int] = {
    193: 0o204244652,
    194: 0o202133131,
    195: 0o714351204,
    196: 0o657127260,
    197: 0o130567507,
    198: 0o670517677,
    199: 0o607275514,
    200: 0o045413633,
    201: 0o212645405,
    202: 0o613700455,
}


def l2c_register_chips(initial_state: int, n_chips: int) -> tuple[np.ndarray, int]:
    """``n_chips`` outputs of the L2C register started at ``initial_state`` (logic 0/1,
    ``uint8``) and the register's state at the last of them (the ICD's "end state" when
    ``n_chips`` is a code period).

    Raises
    ------
    ConfigError
        For a state that is not a non-zero 27-bit integer.
    """
    if not 0 < int(initial_state) < (1 << 27):
        raise ConfigError("initial_state", f"must be a non-zero 27-bit register state, got {initial_state!r}")
    out = bytearray(n_chips)
    state, mask = int(initial_state), _FEEDBACK
    last = state
    for i in range(n_chips):  # once per code and process (cached by the callers): not a hot path
        last = state
        bit = state & 1
        out[i] = bit
        state >>= 1
        if bit:
            state ^= mask
    return np.frombuffer(bytes(out), np.uint8), last


@cache
def _cm(state: int) -> np.ndarray:
    code = bits_to_chips(l2c_register_chips(state, L2CM_LENGTH)[0])
    code.flags.writeable = False
    return code


@lru_cache(maxsize=4)
def _cl(state: int) -> np.ndarray:
    code = bits_to_chips(l2c_register_chips(state, L2CL_LENGTH)[0])
    code.flags.writeable = False
    return code


def gps_l2cm_code(prn: int) -> np.ndarray:
    """The 10230-chip L2 CM code of GPS ``prn`` (1-32), ±1 ``int8`` (read-only, cached)."""
    return _cm(L2CM_INITIAL_STATE[checked_prn(prn, L2CM_INITIAL_STATE, "GPS L2C")])


def gps_l2cl_code(prn: int) -> np.ndarray:
    """The 767250-chip L2 CL code of GPS ``prn`` (1-32), ±1 ``int8`` (read-only, cached;
    about a second to generate)."""
    return _cl(L2CL_INITIAL_STATE[checked_prn(prn, L2CL_INITIAL_STATE, "GPS L2C")])


def qzss_l2cm_code(prn: int) -> np.ndarray:
    """The 10230-chip L2 CM code of QZSS ``prn`` (193-202), ±1 ``int8`` (read-only, cached)."""
    return _cm(QZSS_L2CM_INITIAL_STATE[checked_prn(prn, QZSS_L2CM_INITIAL_STATE, "QZSS L2C")])
