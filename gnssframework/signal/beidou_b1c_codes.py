r"""BeiDou B1C ranging codes: Weil codes truncated from a Legendre sequence (BDS-SIS-ICD-B1C-1.0, sec. 5.2).

A Legendre sequence of prime length :math:`N` is :math:`L(0) = 0`, :math:`L(k) = 1` where
:math:`k` is a non-zero quadratic residue modulo :math:`N`, 0 otherwise. The Weil code of
phase difference :math:`w` is :math:`W(k; w) = L(k) \oplus L((k + w) \bmod N)`, and a B1C
code of length :math:`M` with truncation point :math:`p` is

.. math:: c(n; w, p) = W((n + p - 1) \bmod N;\ w), \qquad n = 0 .. M - 1

(ICD sec. 5.2.1, eq. 5-2 to 5-4). The primary codes of the data and pilot components have
:math:`N = 10243`, :math:`M = 10230` (10 ms at 1.023 Mchip/s); the pilot's secondary code has
:math:`N = 3607`, :math:`M = 1800` (one chip a primary period, 18 s). The phase differences
and truncation points of PRN 1-63 are transcribed from the ICD's Table 5-2 (data primary),
Table 5-3 (pilot primary) and Table 5-6 (pilot secondary). Logic 0 is +1.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from .codes import bits_to_chips, checked_prn

__all__ = ["B1C_PRIMARY_LENGTH", "B1C_SECONDARY_LENGTH", "B1C_DATA_PARAMS", "B1C_PILOT_PARAMS",
           "B1C_SECONDARY_PARAMS", "legendre_sequence", "weil_code", "b1c_data_code", "b1c_pilot_code",
           "b1c_pilot_secondary_code"]

B1C_PRIMARY_LENGTH = 10230
B1C_SECONDARY_LENGTH = 1800
_N_PRIMARY, _N_SECONDARY = 10243, 3607


def _table(w: tuple[int, ...], p: tuple[int, ...]) -> dict[int, tuple[int, int]]:
    return {prn: (wi, pi) for prn, (wi, pi) in enumerate(zip(w, p), start=1)}


#: (phase difference w, truncation point p) of the data primary codes, ICD Table 5-2.
B1C_DATA_PARAMS = _table(
    (2678, 4802, 958, 859, 3843, 2232, 124, 4352, 1816, 1126, 1860, 4800, 2267, 424, 4192, 4333, 2656, 4148, 243,
     1330, 1593, 1470, 882, 3202, 5095, 2546, 1733, 4795, 4577, 1627, 3638, 2553, 3646, 1087, 1843, 216, 2245, 726,
     1966, 670, 4130, 53, 4830, 182, 2181, 2006, 1080, 2288, 2027, 271, 915, 497, 139, 3693, 2054, 4342, 3342, 2592,
     1007, 310, 4203, 455, 4318),
    (699, 694, 7318, 2127, 715, 6682, 7850, 5495, 1162, 7682, 6792, 9973, 6596, 2092, 19, 10151, 6297, 5766, 2359,
     7136, 1706, 2128, 6827, 693, 9729, 1620, 6805, 534, 712, 1929, 5355, 6139, 6339, 1470, 6867, 7851, 1162, 7659,
     1156, 2672, 6043, 2862, 180, 2663, 6940, 1645, 1582, 951, 6878, 7701, 1823, 2391, 2606, 822, 6403, 239, 442,
     6769, 2560, 2502, 5072, 7268, 341))

#: (w, p) of the pilot primary codes, ICD Table 5-3.
B1C_PILOT_PARAMS = _table(
    (796, 156, 4198, 3941, 1374, 1338, 1833, 2521, 3175, 168, 2715, 4408, 3160, 2796, 459, 3594, 4813, 586, 1428,
     2371, 2285, 3377, 4965, 3779, 4547, 1646, 1430, 607, 2118, 4709, 1149, 3283, 2473, 1006, 3670, 1817, 771, 2173,
     740, 1433, 2458, 3459, 2155, 1205, 413, 874, 2463, 1106, 1590, 3873, 4026, 4272, 3556, 128, 1200, 130, 4494,
     1871, 3073, 4386, 4098, 1923, 1176),
    (7575, 2369, 5688, 539, 2270, 7306, 6457, 6254, 5644, 7119, 1402, 5557, 5764, 1073, 7001, 5910, 10060, 2710,
     1546, 6887, 1883, 5613, 5062, 1038, 10170, 6484, 1718, 2535, 1158, 526, 7331, 5844, 6423, 6968, 1280, 1838,
     1989, 6468, 2091, 1581, 1453, 6252, 7122, 7711, 7216, 2113, 1095, 1628, 1713, 6102, 6123, 6070, 1115, 8047,
     6795, 2575, 53, 1729, 6388, 682, 5565, 7160, 2277))

#: (w, p) of the pilot secondary codes, ICD Table 5-6.
B1C_SECONDARY_PARAMS = _table(
    (269, 1448, 1028, 1324, 822, 5, 155, 458, 310, 959, 1238, 1180, 1288, 334, 885, 1362, 181, 1648, 838, 313, 750,
     225, 1477, 309, 108, 1457, 149, 322, 271, 576, 1103, 450, 399, 241, 1045, 164, 513, 687, 422, 303, 324, 495,
     725, 780, 367, 882, 631, 37, 647, 1043, 24, 120, 134, 136, 158, 214, 335, 340, 661, 889, 929, 1002, 1149),
    (1889, 1268, 1593, 1186, 1239, 1930, 176, 1696, 26, 1344, 1271, 1182, 1381, 1604, 1333, 1185, 31, 704, 1190,
     1646, 1385, 113, 860, 1656, 1921, 1173, 1928, 57, 150, 1214, 1148, 1458, 1519, 1635, 1257, 1687, 1382, 1514, 1,
     1583, 1806, 1664, 1338, 1111, 1706, 1543, 1813, 228, 2871, 2884, 1823, 75, 11, 63, 1937, 22, 1768, 1526, 1402,
     1445, 1680, 1290, 1245))


@lru_cache(maxsize=2)
def legendre_sequence(n: int) -> np.ndarray:
    """:math:`L(k)`, ``k = 0 .. n - 1`` (0/1 ``uint8``): 1 at the non-zero quadratic residues mod ``n``."""
    seq = np.zeros(n, np.uint8)
    seq[(np.arange(1, n, dtype=np.int64) ** 2) % n] = 1
    return seq


def weil_code(n: int, w: int, p: int, length: int) -> np.ndarray:
    """:math:`c(k; w, p) = W((k + p - 1) \\bmod n; w)` for ``k = 0 .. length - 1``, as ±1 ``int8``."""
    legendre = legendre_sequence(n)
    k = (np.arange(length) + p - 1) % n
    return bits_to_chips(legendre[k] ^ legendre[(k + w) % n])


def _params(prn, table: dict[int, tuple[int, int]]) -> tuple[int, int]:
    return table[checked_prn(prn, table, "BeiDou B1C")]


def b1c_data_code(prn: int) -> np.ndarray:
    """The 10230-chip data primary code of ``prn`` (1-63), ±1 ``int8``."""
    return weil_code(_N_PRIMARY, *_params(prn, B1C_DATA_PARAMS), B1C_PRIMARY_LENGTH)


def b1c_pilot_code(prn: int) -> np.ndarray:
    """The 10230-chip pilot primary code of ``prn`` (1-63), ±1 ``int8``."""
    return weil_code(_N_PRIMARY, *_params(prn, B1C_PILOT_PARAMS), B1C_PRIMARY_LENGTH)


def b1c_pilot_secondary_code(prn: int) -> tuple[int, ...]:
    """The 1800-chip pilot secondary code of ``prn`` (1-63), ±1."""
    return tuple(int(c) for c in weil_code(_N_SECONDARY, *_params(prn, B1C_SECONDARY_PARAMS), B1C_SECONDARY_LENGTH))
