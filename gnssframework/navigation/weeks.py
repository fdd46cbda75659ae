"""Full week numbers from the low bits a navigation message sends.

A message sends its week modulo ``2**bits``: LNAV's WN in 10 bits (IS-GPS-200 20.3.3.3.1.1),
its WNt and WN_LSF in 8 (20.3.3.5.1.6), I/NAV's WN0G in 6 and WN0t in 8 (Galileo OS SIS ICD
5.1.7-5.1.8). The full week is the one with those low bits nearest a reference week known
otherwise (a navigation file's record, the receiver's assistance), within half a cycle.
"""

from __future__ import annotations

import datetime as _dt

__all__ = ["GPS_EPOCH", "WEEK_S", "full_week", "gps_calendar", "gps_week_tow"]

#: GPS time's origin, 1980-01-06 00:00:00 (IS-GPS-200 20.3.3.3.1.1): the calendar of a GPS
#: week and time of week, without leap seconds (subtract them for UTC).
GPS_EPOCH = _dt.datetime(1980, 1, 6)
#: Seconds in a GPS week.
WEEK_S = 604_800


def full_week(low_bits: int, bits: int, near_week: int) -> int:
    """The full week whose low ``bits`` bits are ``low_bits``, within half a ``2**bits``-week
    cycle of ``near_week``:

        week = near + ((low - near + 2**(bits-1)) mod 2**bits) - 2**(bits-1)

    (e.g. WN0G's 6 bits placed near a record's GPS week; LNAV's 10-bit week near the
    week of an ephemeris file)."""
    cycle = 1 << bits
    return int(near_week + ((int(low_bits) - near_week + cycle // 2) % cycle) - cycle // 2)


def gps_calendar(week: int, tow_s: float) -> _dt.datetime:
    """Calendar time (GPS time scale, naive ``datetime``) of a GPS week and time of week:
    ``GPS_EPOCH + week weeks + tow_s`` (a negative or over-long ``tow_s`` rolls the week)."""
    return GPS_EPOCH + _dt.timedelta(weeks=int(week), seconds=float(tow_s))


def gps_week_tow(t: _dt.datetime) -> tuple[int, float]:
    """GPS week and seconds of week of a calendar time given in the GPS time scale (naive)."""
    seconds = (t - GPS_EPOCH).total_seconds()
    week = int(seconds // WEEK_S)
    return week, seconds - week * WEEK_S
