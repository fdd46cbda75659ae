"""Message fields by position (`navigation.bit_fields`): written by `encode_fields`, read back
by `decode_fields` (1-based layouts) and `read_fields` / `read_field` (0-based first bits)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from gnssframework.errors import ConfigError
from gnssframework.navigation.bit_fields import decode_fields, encode_fields, read_field, read_fields


def test_fields_are_read_where_they_were_written_msb_first_twos_complement():
    bits = np.zeros(24, np.uint8)
    bits[3:8] = [1, 0, 1, 1, 0]  # 0b10110 = 22 from bit 3 (0-based)
    bits[8:12] = [1, 1, 1, 0]  # 0b1110: -2 signed, 14 unsigned
    assert read_field(bits, 3, 5) == 22.0 and read_field(bits, 3, 5, scale=0.5) == 11.0
    assert read_field(bits, 8, 4, signed=True) == -2.0 and read_field(bits, 8, 4) == 14.0
    np.testing.assert_array_equal(read_fields(bits, 8, 2, 2), [3.0, 2.0])  # 0b11, 0b10
    assert decode_fields(bits, {"a": (4, 5, 1.0, False)}) == {"a": 22}  # the same field, 1-based


@given(values=st.lists(st.integers(-512, 511), min_size=1, max_size=6))
def test_signed_fields_survive_a_round_trip(values):
    layout = {f"v{k}": (1 + 10 * k, 10, 0.25, True) for k in range(len(values))}
    bits = encode_fields(60, layout, {f"v{k}": v * 0.25 for k, v in enumerate(values)}, "test", "here")
    np.testing.assert_array_equal(read_fields(bits, 0, 10, len(values), 0.25, signed=True), np.array(values) * 0.25)


def test_a_value_outside_its_field_is_refused_by_name():
    with pytest.raises(ConfigError, match="test.v0"):
        encode_fields(10, {"v0": (1, 10, 1.0, True)}, {"v0": 512}, "test", "here")
