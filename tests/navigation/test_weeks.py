"""Full weeks from the low bits a message sends (`navigation.weeks.full_week`), and GPS
weeks and times of week as calendar times (`gps_calendar`, `gps_week_tow`)."""

from __future__ import annotations

import datetime as dt

from hypothesis import given
from hypothesis import strategies as st

from gnssframework.navigation.weeks import full_week, gps_calendar, gps_week_tow


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


def test_gps_weeks_begin_on_the_published_sundays():
    # The two rollovers of the 10-bit week (1999-08-22, 2019-04-07: the US Naval Observatory's
    # and IS-GPS-200's dates) and week 2000 (2018-05-06).
    assert gps_calendar(1024, 0.0) == dt.datetime(1999, 8, 22)
    assert gps_calendar(2048, 0.0) == dt.datetime(2019, 4, 7)
    assert gps_calendar(2000, 86_400.0 * 3 + 3600.25) == dt.datetime(2018, 5, 9, 1, 0, 0, 250_000)
    assert gps_week_tow(dt.datetime(2019, 4, 6, 23, 59, 59)) == (2047, 604_799.0)
    assert gps_calendar(2048, -1.0) == dt.datetime(2019, 4, 6, 23, 59, 59)  # a negative tow rolls back


@given(week=st.integers(0, 4000), tow_ms=st.integers(0, 604_800_000 - 1))
def test_week_and_tow_survive_the_calendar(week, tow_ms):
    got_week, got_tow = gps_week_tow(gps_calendar(week, tow_ms / 1000))
    assert got_week == week and abs(got_tow - tow_ms / 1000) < 1e-6
