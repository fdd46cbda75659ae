r"""GPS L5 ranging codes, I5 and Q5, and their Neuman-Hoffman overlays (IS-GPS-705,
sec. 3.3.2.1-3.3.2.2, Figures 3-1 to 3-5, Tables 3-Ia/3-Ib).

A code is the chip-by-chip sum modulo 2 of two 13-stage register sequences, 10230 chips
(1 ms at 10.23 Mchip/s), both registers reset at every code epoch:

- **XA**: polynomial :math:`1 + x^9 + x^{10} + x^{12} + x^{13}`, loaded with all ones and
  short-cycled: the state after 8190 chips is replaced by all ones, so its 10230 chips are
  its 8190-chip sequence and the first 2040 again;
- **XB**: polynomial :math:`1 + x + x^3 + x^4 + x^6 + x^7 + x^8 + x^{12} + x^{13}`
  (maximal, 8191 states), loaded with all ones; its 10230-chip sequence runs through its
  period and 2039 chips more.

PRN ``i``'s code is :math:`XA(n) \oplus XB(n + r_i)`, :math:`r_i` the *XB code advance* of
Tables 3-Ia/3-Ib (one for I5, one for Q5), with the index taken modulo 10230: XB is reset
every millisecond, so the advanced sequence is the 10230-chip one shifted cyclically. The
register holding the advanced sequence's first chips is the table's *initial XB state*
(the tests check PRN 1 and 2 of I5 against that column). Logic 0 is +1.

A register is a 13-bit integer whose bit ``k - 1`` is stage ``k``; a shift moves every
stage up one, the new stage 1 is the parity of the tapped stages, and the output is stage 13.

Overlays (sec. 3.3.2.2): the 10-chip Neuman-Hoffman code ``0000110101`` on I5 and the
20-chip ``00000100110101001110`` on Q5, one chip a code period (I5 then carries a 100
symbols/s CNAV stream: one symbol every 10 code periods).

Transcription: the XB advances (PRN 1-210: GPS 1-63 of Tables 3-Ia/3-Ib, and the extension
to SBAS and QZSS numbers) were transcribed, data only, from PocketSDR (repository
tomojitakasu/PocketSDR, ``python/sdr_code.py``), under its BSD 2-clause licence:

    Copyright (c) 2021-2026, T. Takasu, All rights reserved.
    Redistribution and use in source and binary forms, with or without modification,
    are permitted provided that the following conditions are met: Redistributions of
    source code must retain the above copyright notice, this list of conditions and the
    following disclaimer. Redistributions in binary form must reproduce the above
    copyright notice, this list of conditions and the following disclaimer in the
    documentation and/or other materials provided with the distribution.
    THIS SOFTWARE IS PROVIDED BY THE COPYRIGHT HOLDERS AND CONTRIBUTORS "AS IS" AND ANY
    EXPRESS OR IMPLIED WARRANTIES ... ARE DISCLAIMED (the full disclaimer is PocketSDR's
    LICENSE.txt).

They were compared, number for number, with a second transcription of the same ICD
tables (GNSS-SDR, ``src/core/system_parameters/GPS_L5.h``; compared, not copied): all 420
agree.
"""

from __future__ import annotations

from functools import cache

import numpy as np

from ..errors import ConfigError
from .codes import bits_to_chips, checked_prn, shift_register_bits

__all__ = [
    "L5_CODE_LENGTH_CHIPS",
    "L5_PRNS",
    "L5I_XB_ADVANCE",
    "L5Q_XB_ADVANCE",
    "L5I_NEUMAN_HOFFMAN",
    "L5Q_NEUMAN_HOFFMAN",
    "l5_xa_chips",
    "l5_xb_chips",
    "l5_xb_state",
    "gps_l5i_code",
    "gps_l5q_code",
]

#: Chips of one code period: 1 ms at 10.23 Mchip/s.
L5_CODE_LENGTH_CHIPS = 10230
#: The PRNs the advance tables cover (IS-GPS-705 Tables 3-Ia/3-Ib and their extension).
L5_PRNS: tuple[int, ...] = tuple(range(1, 211))

_STAGES = 13
_MASK = (1 << _STAGES) - 1
#: Tapped stages of XA (1 + x^9 + x^10 + x^12 + x^13) and XB (1 + x + x^3 + ... + x^13).
_XA_TAPS = sum(1 << (k - 1) for k in (9, 10, 12, 13))
_XB_TAPS = sum(1 << (k - 1) for k in (1, 3, 4, 6, 7, 8, 12, 13))
#: XA's state after 8190 chips (stages 1-13: 1111111111101), replaced by all ones.
_XA_LAST = _MASK & ~(1 << 11)

# fmt: off
#: IS-GPS-705 Tables 3-Ia/3-Ib: XB code advance (chips) of I5, PRN 1-210.
L5I_XB_ADVANCE: tuple[int, ...] = (
     266,  365,  804, 1138, 1509, 1559, 1756, 2084, 2170, 2303, 2527, 2687,
    2930, 3471, 3940, 4132, 4332, 4924, 5343, 5443, 5641, 5816, 5898, 5918,
    5955, 6243, 6345, 6477, 6518, 6875, 7168, 7187, 7329, 7577, 7720, 7777,
    8057, 5358, 3550, 3412,  819, 4608, 3698,  962, 3001, 4441, 4937, 3717,
    4730, 7291, 2279, 7613, 5723, 7030, 1475, 2593, 2904, 2056, 2757, 3756,
    6205, 5053, 6437, 7789, 2311, 7432, 5155, 1593, 5841, 5014, 1545, 3016,
    4875, 2119,  229, 7634, 1406, 4506, 1819, 7580, 5446, 6053, 7958, 5267,
    2956, 3544, 1277, 2996, 1758, 3360, 2718, 3754, 7440, 2781, 6756, 7314,
     208, 5252,  696,  527, 1399, 5879, 6868,  217, 7681, 3788, 1337, 2424,
    4243, 5686, 1955, 4791,  492, 1518, 6566, 5349,  506,  113, 1953, 2797,
     934, 3023, 3632, 1330, 4909, 4867, 1183, 3990, 6217, 1224, 1733, 2319,
    3928, 2380,  841, 5049, 7027, 1197, 7208, 8000,  152, 6762, 3745, 4723,
    5502, 4796,  123, 8142, 5091, 7875,  330, 5272, 4912,  374, 2045, 6616,
    6321, 7605, 2570, 2419, 1234, 1922, 4317, 5110,  825,  958, 1089, 7813,
    6058, 7703, 6702, 1714, 6371, 2281, 1986, 6282, 3201, 3760, 1056, 6233,
    1150, 2823, 6250,  645, 2401, 1639, 2946, 7091,  923, 7045, 6493, 1706,
    5836,  926, 6086,  950, 5905, 3240, 6675, 3197, 1555, 3589, 4555, 5671,
    6948, 4664, 2086, 5950, 5521, 1515,
)
# fmt: on
# fmt: off
#: IS-GPS-705 Tables 3-Ia/3-Ib: XB code advance (chips) of Q5, PRN 1-210.
L5Q_XB_ADVANCE: tuple[int, ...] = (
    1701,  323, 5292, 2020, 5429, 7136, 1041, 5947, 4315,  148,  535, 1939,
    5206, 5910, 3595, 5135, 6082, 6990, 3546, 1523, 4548, 4484, 1893, 3961,
    7106, 5299, 4660,  276, 4389, 3783, 1591, 1601,  749, 1387, 1661, 3210,
     708, 4226, 5604, 6375, 3056, 1772, 3662, 4401, 5218, 2838, 6913, 1685,
    1194, 6963, 5001, 6694,  991, 7489, 2441,  639, 2097, 2498, 6470, 2399,
     242, 3768, 1186, 5246, 4259, 5907, 3870, 3262, 7387, 3069, 2999, 7993,
    7849, 4157, 5031, 5986, 4833, 5739, 7846,  898, 2022, 7446, 6404,  155,
    7862, 7795, 6121, 4840, 6585,  429, 6020,  200, 1664, 1499, 7298, 1305,
    7323, 7544, 4438, 2485, 3387, 7319, 1853, 5781, 1874, 7555, 2132, 6441,
    6722, 1192, 2588, 2188,  297, 1540, 4138, 5231, 4789,  659,  871, 6837,
    1393, 7383,  611, 4920, 5416, 1611, 2474,  118, 1382, 1092, 7950, 7223,
    1769, 4721, 1252, 5147, 2165, 7897, 4054, 3498, 6571, 2858, 8126, 7017,
    1901,  181, 1114, 5195, 7479, 4186, 3904, 7128, 1396, 4513, 5967, 2580,
    2575, 7961, 2598, 4508, 2090, 3685, 7748,  684,  913, 5558, 2894, 5858,
    6432, 3813, 3573, 7523, 5280, 3376, 7424, 2918, 5793, 1747, 7079, 2921,
    2490, 4119, 3373,  977,  681, 4273, 5419, 5626, 1266, 5804, 2414, 6444,
    4757,  427, 5452, 5182, 6606, 6531, 4268, 3115, 6835,  862, 4856, 2765,
      37, 1943, 7977, 2512, 4451, 4071,
)
# fmt: on

#: Neuman-Hoffman overlays (IS-GPS-705 sec. 3.3.2.2; logic 0 -> +1): 10 chips on I5.
L5I_NEUMAN_HOFFMAN: tuple[int, ...] = tuple(1 - 2 * int(b) for b in "0000110101")
#: The 20-chip Neuman-Hoffman overlay of Q5.
L5Q_NEUMAN_HOFFMAN: tuple[int, ...] = tuple(1 - 2 * int(b) for b in "00000100110101001110")


@cache
def l5_xa_chips() -> np.ndarray:
    """XA's 10230 output bits (0/1) of one code period (all-ones start, short-cycled)."""
    out = shift_register_bits(_MASK, _XA_TAPS, L5_CODE_LENGTH_CHIPS, _STAGES, short_cycle=_XA_LAST)
    out.flags.writeable = False
    return out


@cache
def l5_xb_chips() -> np.ndarray:
    """XB's 10230 output bits (0/1) of one code period from the all-ones state."""
    out = shift_register_bits(_MASK, _XB_TAPS, L5_CODE_LENGTH_CHIPS, _STAGES)
    out.flags.writeable = False
    return out


def l5_xb_state(advance_chips: int) -> str:
    """The XB register after ``advance_chips`` shifts from all ones, as stages 1-13 (the
    ICD's *initial XB code state* column, e.g. ``0101011100100`` for I5 PRN 1)."""
    # The state after r shifts holds the outputs r .. r + 12 with stage 13 (the MSB) first.
    ahead = shift_register_bits(_MASK, _XB_TAPS, int(advance_chips) + _STAGES, _STAGES)[int(advance_chips) :]
    return "".join(str(int(b)) for b in ahead[::-1])


def _code(advance: tuple[int, ...], prn: int, name: str) -> np.ndarray:
    p = checked_prn(prn, L5_PRNS, name)
    r = advance[p - 1]
    if not 0 <= r < L5_CODE_LENGTH_CHIPS:
        raise ConfigError(f"{name} PRN {p}", f"XB advance {r} outside one code period")
    xb = np.roll(l5_xb_chips(), -r)  # XB(n + r), n + r modulo 10230
    return bits_to_chips(l5_xa_chips() ^ xb)


@cache
def gps_l5i_code(prn: int) -> np.ndarray:
    """The I5 code of ``prn`` (±1 ``int8``, 10230 chips, logic 0 -> +1)."""
    return _code(L5I_XB_ADVANCE, prn, "GPS L5 I5")


@cache
def gps_l5q_code(prn: int) -> np.ndarray:
    """The Q5 code of ``prn`` (±1 ``int8``, 10230 chips, logic 0 -> +1)."""
    return _code(L5Q_XB_ADVANCE, prn, "GPS L5 Q5")
