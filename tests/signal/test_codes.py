"""C/A codes against IS-GPS-200 and the Gold-code correlation property."""

import numpy as np
import pytest

import gnssframework as gf
from gnssframework.signal.codes import ca_code

# IS-GPS-200 Table 3-Ia, "first 10 chips" in octal (logic 1 = -1 here).
FIRST_10_OCTAL = {
    1: 0o1440,
    2: 0o1620,
    3: 0o1710,
    4: 0o1744,
    5: 0o1133,
    6: 0o1455,
    7: 0o1131,
    8: 0o1454,
    9: 0o1626,
    10: 0o1504,
    11: 0o1642,
    12: 0o1750,
    13: 0o1764,
    14: 0o1772,
    15: 0o1775,
    16: 0o1776,
    17: 0o1156,
    18: 0o1467,
    19: 0o1633,
    20: 0o1715,
    21: 0o1746,
    22: 0o1763,
    23: 0o1063,
    24: 0o1706,
    25: 0o1743,
    26: 0o1761,
    27: 0o1770,
    28: 0o1774,
    29: 0o1127,
    30: 0o1453,
    31: 0o1625,
    32: 0o1712,
}


@pytest.mark.parametrize("prn", range(1, 33))
def test_first_ten_chips_match_is_gps_200(prn):
    bits = (1 - ca_code(prn)[:10]) // 2
    assert int("".join(map(str, bits)), 2) == FIRST_10_OCTAL[prn]


def test_gold_code_correlations_are_three_valued():
    codes = np.array([ca_code(p) for p in range(1, 33)], dtype=float)
    spectra = np.fft.fft(codes, axis=1)
    allowed = {-65, -1, 63}
    for i in range(32):
        cc = np.rint(np.fft.ifft(spectra[i] * np.conj(spectra), axis=1).real).astype(int)
        auto = cc[i]
        assert auto[0] == 1023 and set(auto[1:]) <= allowed
        assert set(np.delete(cc, i, axis=0).ravel()) <= allowed


def test_code_is_int8_balanced_and_bad_prn_is_a_config_error():
    c = ca_code(7)
    assert c.dtype == np.int8 and c.shape == (1023,) and c.sum() in (-1, 1)
    with pytest.raises(gf.ConfigError, match="1-32"):
        ca_code(33)
