r"""Galileo E5a ranging codes: the E5a-I and E5a-Q primary codes, their secondary codes
CS20_1 (E5a-I) and CS100_1..CS100_50 (E5a-Q, one per PRN).

Source of truth: *Galileo OS SIS ICD*, Issue 2.1 (2023), sec. 3.4 ("Primary codes":
register-generated codes of 10230 chips, 1 ms at 10.23 Mchip/s; Table "E5 primary code
generator" and its start values) and sec. 3.5 (secondary codes, in hexadecimal).

Each primary code is the sum modulo 2 of two 14-stage register sequences of 10230 chips
(the registers run free over the period, 16383 > 10230, and are reset at every code epoch):
register 1 with the polynomial octal ``40503`` (:math:`x^{14} + x^8 + x^6 + x + 1`) loaded
with all ones, register 2 with octal ``50661`` (:math:`x^{14} + x^{12} + x^9 + x^5 + x^4 +
x^2 + x + 1`) loaded with the PRN's start value. A register is held here as the ICD writes a
start value: a 14-bit integer whose most significant bit is the output; a shift moves the
bits one place up, and the new least significant bit is the parity of the register's bits
at the polynomial's terms :math:`x^1 .. x^{14}` (bit ``k - 1`` for :math:`x^k`). Logic 0 is
+1. A secondary code in hexadecimal is read most significant bit first (CS20_1 is
``842E9``, 20 bits; a CS100 is 25 digits, 100 bits).

E5a-I carries F/NAV at 50 symbols/s (20 code periods a symbol, CS20_1 over the same 20 ms);
E5a-Q is the pilot, PRN ``i`` overlaid by CS100_i (100 ms).

Transcription: the start values (octal) and the CS100 codes were transcribed, data only,
from PocketSDR (repository tomojitakasu/PocketSDR, ``python/sdr_code.py`` and
``python/sdr_code_gal.py``), under its BSD 2-clause licence:

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

The codes this module makes from them were compared, chip for chip, with a second and
differently made transcription of the ICD (GNSS-SDR, ``src/core/system_parameters/
Galileo_E5a.h``, which holds every primary code written out in hexadecimal, and the 50
E5a-Q secondary codes; compared, not copied): all 100 primary codes and CS20_1 agree.
Of the secondary codes, GNSS-SDR's table holds 47 strings for its 50 places: CS100_1-36 and
CS100_40-50 agree with these, and CS100_37-39 are missing there, so its PRN 37-47 take the
codes of PRN 40-50 (a defect of that table, found by this comparison; Galileo has flown no
PRN above 36 so far). Four other public transcriptions hold CS100_37-39 as here. The tests
keep the first and last 24 chips of a few primary codes, from the ICD's hexadecimal, as
their truth.
"""

from __future__ import annotations

from functools import cache

import numpy as np

from .codes import bits_to_chips, checked_prn, shift_register_bits
from .galileo_codes import hex_to_chips

__all__ = [
    "E5A_CODE_LENGTH_CHIPS",
    "E5A_PRNS",
    "E5AI_START_VALUES",
    "E5AQ_START_VALUES",
    "E5AI_SECONDARY_CS20",
    "E5AQ_SECONDARY_CS100",
    "galileo_e5ai_code",
    "galileo_e5aq_code",
    "galileo_e5aq_secondary_code",
]

#: Chips of one primary period: 1 ms at 10.23 Mchip/s.
E5A_CODE_LENGTH_CHIPS = 10230
#: Satellites of the E5a tables.
E5A_PRNS: tuple[int, ...] = tuple(range(1, 51))

_STAGES = 14
_MASK = (1 << _STAGES) - 1
#: The register polynomials (octal, ICD): register 1 and register 2 of E5a.
_POLY_1 = 0o40503
_POLY_2 = 0o50661

# fmt: off
#: E5a-I register 2 start values (octal), PRN 1-50.
E5AI_START_VALUES: tuple[int, ...] = (
    0o30305, 0o14234, 0o27213, 0o20577, 0o23312, 0o33463, 0o15614, 0o12537,
    0o01527, 0o30236, 0o27344, 0o07272, 0o36377, 0o17046, 0o06434, 0o15405,
    0o24252, 0o11631, 0o24776, 0o00630, 0o11560, 0o17272, 0o27445, 0o31702,
    0o13012, 0o14401, 0o34727, 0o22627, 0o30623, 0o27256, 0o01520, 0o14211,
    0o31465, 0o22164, 0o33516, 0o02737, 0o21316, 0o35425, 0o35633, 0o24655,
    0o14054, 0o27027, 0o06604, 0o31455, 0o34465, 0o25273, 0o20763, 0o31721,
    0o17312, 0o13277,
)
# fmt: on
# fmt: off
#: E5a-Q register 2 start values (octal), PRN 1-50.
E5AQ_START_VALUES: tuple[int, ...] = (
    0o25652, 0o05142, 0o24723, 0o31751, 0o27366, 0o24660, 0o33655, 0o27450,
    0o07626, 0o01705, 0o12717, 0o32122, 0o16075, 0o16644, 0o37556, 0o02477,
    0o02265, 0o06430, 0o25046, 0o12735, 0o04262, 0o11230, 0o00037, 0o06137,
    0o04312, 0o20606, 0o11162, 0o22252, 0o30533, 0o24614, 0o07767, 0o32705,
    0o05052, 0o27553, 0o03711, 0o02041, 0o34775, 0o05274, 0o37356, 0o16205,
    0o36270, 0o06600, 0o26773, 0o17375, 0o35267, 0o36255, 0o12044, 0o26442,
    0o21621, 0o25411,
)
# fmt: on

#: CS20_1, the E5a-I secondary code (``842E9``), ±1.
E5AI_SECONDARY_CS20: tuple[int, ...] = tuple(int(c) for c in hex_to_chips("842E9", 20))
#: CS100_1 .. CS100_50 in hexadecimal: the E5a-Q secondary code of PRN 1-50.
E5AQ_SECONDARY_CS100: tuple[str, ...] = (
    "83F6F69D8F6E15411FB8C9B1C",
    "66558BD3CE0C7792E83350525",
    "59A025A9C1AF0651B779A8381",
    "D3A32640782F7B18E4DF754B7",
    "B91FCAD7760C218FA59348A93",
    "BAC77E933A779140F094FBF98",
    "537785DE280927C6B58BA6776",
    "EFCAB4B65F38531ECA22257E2",
    "79F8CAE838475EA5584BEFC9B",
    "CA5170FEA3A810EC606B66494",
    "1FC32410652A2C49BD845E567",
    "FE0A9A7AFDAC44E42CB95D261",
    "B03062DC2B71995D5AD8B7DBE",
    "F6C398993F598E2DF4235D3D5",
    "1BB2FB8B5BF24395C2EF3C5A1",
    "2F920687D238CC7046EF6AFC9",
    "34163886FC4ED7F2A92EFDBB8",
    "66A872CE47833FB2DFD5625AD",
    "99D5A70162C920A4BB9DE1CA8",
    "81D71BD6E069A7ACCBEDC66CA",
    "A654524074A9E6780DB9D3EC6",
    "C3396A101BEDAF623CFC5BB37",
    "C3D4AB211DF36F2111F2141CD",
    "3DFF25EAE761739265AF145C1",
    "994909E0757D70CDE389102B5",
    "B938535522D119F40C25FDAEC",
    "C71AB549C0491537026B390B7",
    "0CDB8C9E7B53F55F5B0A0597B",
    "61C5FA252F1AF81144766494F",
    "626027778FD3C6BB4BAA7A59D",
    "E745412FF53DEBD03F1C9A633",
    "3592AC083F3175FA724639098",
    "52284D941C3DCAF2721DDB1FD",
    "73B3D8F0AD55DF4FE814ED890",
    "94BF16C83BD7462F6498E0282",
    "A8C3DE1AC668089B0B45B3579",
    "E23FFC2DD2C14388AD8D6BEC8",
    "F2AC871CDF89DDC06B5960D2B",
    "06191EC1F622A77A526868BA1",
    "22D6E2A768E5F35FFC8E01796",
    "25310A06675EB271F2A09EA1D",
    "9F7993C621D4BEC81A0535703",
    "D62999EACF1C99083C0B4A417",
    "F665A7EA441BAA4EA0D01078C",
    "46F3D3043F24CDEABD6F79543",
    "E2E3E8254616BD96CEFCA651A",
    "E548231A82F9A01A19DB5E1B2",
    "265C7F90A16F49EDE2AA706C8",
    "364A3A9EB0F0481DA0199D7EA",
    "9810A7A898961263A0F749F56",
)


def _register_bits(start: int, poly: int, n: int) -> np.ndarray:
    """``n`` output bits (0/1) of a 14-stage register from ``start`` (module text): the taps
    are the polynomial's terms x^1 .. x^14 as bits 0 .. 13."""
    return shift_register_bits(start, poly >> 1, n, _STAGES)


@cache
def _register_1() -> np.ndarray:
    return _register_bits(_MASK, _POLY_1, E5A_CODE_LENGTH_CHIPS)


def _code(starts: tuple[int, ...], prn: int, name: str) -> np.ndarray:
    p = checked_prn(prn, E5A_PRNS, name)
    return bits_to_chips(_register_1() ^ _register_bits(starts[p - 1], _POLY_2, E5A_CODE_LENGTH_CHIPS))


@cache
def galileo_e5ai_code(prn: int) -> np.ndarray:
    """The E5a-I primary code of ``prn`` (±1 ``int8``, 10230 chips)."""
    return _code(E5AI_START_VALUES, prn, "Galileo E5a-I")


@cache
def galileo_e5aq_code(prn: int) -> np.ndarray:
    """The E5a-Q primary code of ``prn`` (±1 ``int8``, 10230 chips)."""
    return _code(E5AQ_START_VALUES, prn, "Galileo E5a-Q")


@cache
def galileo_e5aq_secondary_code(prn: int) -> tuple[int, ...]:
    """CS100_``prn``: the E5a-Q secondary code of ``prn`` (100 chips, ±1)."""
    p = checked_prn(prn, E5A_PRNS, "Galileo E5a-Q")
    return tuple(int(c) for c in hex_to_chips(E5AQ_SECONDARY_CS100[p - 1], 100))
