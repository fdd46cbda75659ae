"""What a channel's navigation message gives, per kind of message: its transmit times and what the reports show.

Each message a ``receive`` run decodes (GPS/QZSS LNAV, Galileo I/NAV) is a `NavMessage`: the
signals that carry it, how a channel's rows are dated from it (its transmit times), whether
vector tracking and the assisted start hand over from it, the columns it fills in the
no-position report's satellite table, the function giving one channel's row of them, and its
words for a channel or a run without a transmit time. `navigation_message` looks up a
signal's, so the receiver and its reports ask one interface and never which system they read.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...errors import ConfigError
from ...navigation.cnav_records import cnav_records
from ...signal.spec import SignalSpec
from ..channels.records import STAGES
from .cnav_stream import carries_cnav, channel_cnav, cnav_channel_timing
from .inav_stream import (
    carries_d1,
    carries_d2,
    carries_fnav,
    carries_inav,
    carries_lnav,
    channel_inav,
    inav_channel_timing,
)
from .observables import ChannelTiming, channel_timing

__all__ = [
    "NavMessage",
    "LNAV",
    "INAV",
    "CNAV",
    "FNAV",
    "MESSAGES",
    "navigation_message",
    "lnav_decoded",
    "inav_decoded",
    "cnav_decoded",
    "require_positioning",
]

#: Indices in receiver.channels.STAGES of the bit-aligned stages.
_BIT_ALIGNED = tuple(STAGES.index(stage) for stage in ("extended", "vector"))


@dataclass(frozen=True)
class NavMessage:
    """One kind of navigation message as the reports see it.

    Attributes
    ----------
    name
        ``"LNAV"``, ``"I/NAV"``.
    carried_by
        Whether a signal carries it on its tracked component.
    timing
        ``(channel record, signal) -> ChannelTiming | None``: the channel's rows dated from
        the message (`observables.channel_timing` from LNAV subframes,
        `inav_stream.inav_channel_timing` from the I/NAV GST); None without a transmit time.
    hands_over
        Whether vector tracking and the assisted start (`vector_tracking`) can take over
        from it: they are dated from LNAV.
    columns
        The headers of the satellite table's five decoded cells, in the order of
        ``decoded``'s keys ``subframes``, ``first_tow_s``, ``ephemeris``, ``iono``, ``week``.
    decoded
        ``(channel record, signal) -> row``: the count of subframes or pages, the first (or
        last) TOW (s, None without one), whether a complete ephemeris was decoded, the
        ionosphere (bool, or None where the message's is not used) and the week (None).
    no_transmit_time
        ``channel record -> reason``: why a locked channel has no transmit time.
    none_decoded
        ``(locked, found) -> reason``: why no satellite of a run has a transmit time, with
        ``locked`` of the ``found`` satellites locked.
    """

    name: str
    carried_by: Callable[[SignalSpec], bool]
    timing: Callable[[Any, SignalSpec], ChannelTiming | None]
    hands_over: bool
    columns: tuple[str, str, str, str, str]
    decoded: Callable[[Any, SignalSpec], dict]
    no_transmit_time: Callable[[Any], str]
    none_decoded: Callable[[int, int], str]


def lnav_decoded(ch, signal: SignalSpec) -> dict:
    """What one channel's LNAV gave: ``subframes`` (count), ``first_tow_s`` (of the first
    subframe, None without one), ``ephemeris`` (a complete one decoded), ``iono`` (page 18)
    and ``week`` (10-bit, subframe 1; None)."""
    tm = channel_timing(ch, signal=signal) if ch.rows else None
    msg = tm.message if tm is not None else None
    subframes = list(msg.subframes) if msg is not None else []
    return {
        "subframes": len(subframes),
        "first_tow_s": subframes[0].tow_s if subframes else None,
        "ephemeris": bool(tm is not None and tm.ephemerides),
        "iono": msg is not None and msg.iono_utc is not None,
        "week": msg.week if msg is not None else None,
    }


def inav_decoded(ch, signal: SignalSpec) -> dict:
    """What one E1-B channel's I/NAV gave (`channel_inav`): ``subframes`` the pages decoded,
    ``first_tow_s`` and ``week`` the last GST's TOW and week, ``ephemeris`` (a complete one
    decoded), ``iono`` None (word 5's NeQuick coefficients are not used)."""
    timing = channel_inav(ch, signal)
    gst = timing.gst
    return {
        "subframes": timing.pages,
        "first_tow_s": None if gst is None else gst[2],
        "ephemeris": timing.ephemeris is not None,
        "iono": None,
        "week": None if gst is None else gst[1],
    }


def cnav_decoded(ch, signal: SignalSpec) -> dict:
    """What one L2 CM channel's CNAV gave (`channel_cnav`, decoded once): ``subframes`` the
    CRC-checked messages, ``first_tow_s`` the first one's (s), ``ephemeris`` whether a
    record was completed (types 10, 11, a clock and a type 30: `cnav_records.cnav_records`),
    ``iono`` whether a type 30's Klobuchar coefficients came and ``week`` the type 10 week
    (13 bits, the full week until 2137; None)."""
    messages = channel_cnav(ch, signal).messages
    good = [m for m in messages if m.crc_ok]
    decoded = cnav_records(messages)
    return {
        "subframes": len(good),
        "first_tow_s": good[0].tow_s if good else None,
        "ephemeris": bool(decoded.records),
        "iono": decoded.iono is not None,
        "week": decoded.week,
    }


def _lnav_no_transmit_time(ch) -> str:
    if not np.isin(ch.column("stage"), _BIT_ALIGNED).any():
        return "never bit-synchronised (no LNAV bits, no transmit time)"
    return "no LNAV subframe decoded (no transmit time)"


LNAV = NavMessage(
    "LNAV",
    carries_lnav,
    lambda ch, signal: channel_timing(ch, signal=signal),
    True,
    ("LNAV subframes", "first TOW (s)", "ephemeris decoded", "page 18", "week (10-bit)"),
    lnav_decoded,
    _lnav_no_transmit_time,
    lambda locked, found: (
        f"no LNAV subframe decoded ({locked} of {found} satellites found locked; a subframe takes 6 s "
        "once a channel is locked and bit-synchronised)"
    ),
)
INAV = NavMessage(
    "I/NAV",
    carries_inav,
    inav_channel_timing,
    False,
    ("I/NAV pages", "GST TOW (s)", "ephemeris decoded", "iono", "GST week"),
    inav_decoded,
    lambda ch: "no I/NAV page with a GST decoded (no transmit time)",
    lambda locked, found: (
        f"no I/NAV page with a GST decoded ({locked} of {found} satellites found locked; the GST "
        "comes in word type 0, 5 or 6, one every few 2 s pages once a channel is locked)"
    ),
)
CNAV = NavMessage(
    "CNAV",
    carries_cnav,
    cnav_channel_timing,
    False,
    ("CNAV messages", "first TOW (s)", "ephemeris decoded", "type 30", "week"),
    cnav_decoded,
    lambda ch: "no CNAV message with a good CRC decoded (no transmit time)",
    lambda locked, found: (
        f"no CNAV message with a good CRC decoded ({locked} of {found} satellites found locked; a "
        "message takes 12 s of a locked L2C channel (6 s on L5), on multiples of 12 s (6 s) of GPS time)"
    ),
)
FNAV = NavMessage(
    "F/NAV",
    carries_fnav,
    inav_channel_timing,
    False,
    ("F/NAV pages", "GST TOW (s)", "ephemeris decoded", "iono", "GST week"),
    inav_decoded,
    lambda ch: "no F/NAV page with a GST decoded (no transmit time)",
    lambda locked, found: (
        f"no F/NAV page with a GST decoded ({locked} of {found} satellites found locked; a page takes "
        "10 s of a locked channel, on multiples of 10 s of GST)"
    ),
)
D1 = NavMessage(
    "D1",
    carries_d1,
    inav_channel_timing,
    False,
    ("D1 subframes", "SOW + 14 s (GPS s)", "ephemeris decoded", "iono", "GPS week"),
    inav_decoded,
    lambda ch: "no D1 subframe decoded (no transmit time)",
    lambda locked, found: (
        f"no D1 subframe decoded ({locked} of {found} satellites found locked; a subframe takes 6 s "
        "of a locked channel, on multiples of 6 s of BDT, and an ephemeris subframes 1-3 of a 30 s frame)"
    ),
)
D2 = NavMessage(
    "D2",
    carries_d2,
    inav_channel_timing,
    False,
    ("D2 subframes", "SOW + 14 s (GPS s)", "ephemeris decoded", "iono", "GPS week"),
    inav_decoded,
    lambda ch: "no D2 subframe decoded (no transmit time)",
    lambda locked, found: (
        f"no D2 subframe decoded ({locked} of {found} satellites found locked; a subframe takes 0.6 s of "
        "a locked, bit-synchronised channel, and an ephemeris the ten pages of subframe 1, 30 s)"
    ),
)
#: The messages the receiver decodes.
MESSAGES = (LNAV, INAV, CNAV, FNAV, D1, D2)


def navigation_message(signal: SignalSpec) -> NavMessage:
    """The message ``signal`` carries (`MESSAGES`); LNAV for a signal that carries none of
    them (its channels then report no subframes)."""
    return next((m for m in MESSAGES if m.carried_by(signal)), LNAV)


def require_positioning(signal: SignalSpec) -> None:
    """Refuse, in one line, a signal the ``receive`` command cannot position with: one whose
    tracked component carries none of `MESSAGES` (GPS/QZSS L1 C/A's LNAV, Galileo E1-B's
    I/NAV, GPS/QZSS L2C's and GPS L5 I5's CNAV, Galileo E5a-I's F/NAV, BeiDou B1I's D1 and D2)."""
    if not any(m.carried_by(signal) for m in MESSAGES):
        raise ConfigError(
            "signal",
            f"{signal.name}: the receive command positions from GPS/QZSS L1 C/A (LNAV: "
            "gps-l1ca, qzss-l1ca), Galileo E1-B (I/NAV: galileo-e1b-boc11, galileo-e1b), "
            "GPS/QZSS L2C and GPS L5 I5 (CNAV: gps-l2c, qzss-l2c, gps-l5i), Galileo E5a-I (F/NAV: "
            "galileo-e5ai) and BeiDou B1I (D1: beidou-b1i; D2 of GEO satellites: beidou-b1i-geo) only",
        )
