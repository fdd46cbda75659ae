"""Full weeks from the low bits a message sends (`navigation.weeks.full_week`)."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from gnssframework.navigation.weeks import full_week


def test_full_week_places_the_low_bits_nearest():
    assert full_week(2198 % 64, 6, 2198) == 2198
    assert full_week(2198 % 64, 6, 2198 + 31) == 2198
    assert full_week(2198 % 64, 6, 2198 - 31) == 2198
    assert full_week(2198 % 64, 6, 2198 + 33) == 2198 + 64
    assert full_week(0, 8, 1023) == 1024
    # LNAV's 10-bit week of 2 Dec 2026 (GPS week 2447) near a file of the same day.
    assert full_week(2447 % 1024, 10, 2447) == 2447


@given(
    week=st.integers(0, 5000),
    bits=st.sampled_from([6, 8, 10]),
    offset=st.integers(-511, 511),
)
def test_the_week_is_recovered_from_any_reference_within_half_a_cycle(week, bits, offset):
    half = 1 << (bits - 1)
    if abs(offset) < half:  # within half a cycle: the sent week itself
        assert full_week(week % (1 << bits), bits, week + offset) == week
    # Whatever the reference, the result has the sent low bits and lies within half a cycle.
    got = full_week(week % (1 << bits), bits, week + offset)
    assert got % (1 << bits) == week % (1 << bits) and -half <= got - (week + offset) < half
