"""SBAS streams for tests and validation scripts: a GEO's messages (`navigation.sbas_encode`)
carrying known satellite errors and a plane of vertical ionospheric delay, one message a
second, fast corrections every 6 s."""

from __future__ import annotations

import numpy as np
import pymap3d

from gnssframework.navigation import sbas_encode as enc
from gnssframework.navigation.ephemeris import satellite_state
from gnssframework.navigation.sbas_iono import mops_troposphere, sbas_pierce_point
from gnssframework.navigation.sbas_content import igp_band_grid
from gnssframework.navigation.sbas_files import SbasRecord
from gnssframework.navigation.sbas_message import parse_message

#: The monitored IGP columns (longitudes, deg) of bands 7 and 8, and their latitudes (deg):
#: every pierce point of a receiver in Japan above 5 degrees.
BANDS = {7: (110, 135), 8: (140, 170)}
IGP_LATS = (15, 55)


def vertical_delay_m(lat_deg, lon_deg):
    """A plane of vertical delay (m at L1), a multiple of 0.125 m at every IGP: 1.9-4.1 m."""
    return 3.0 + 0.025 * (np.asarray(lat_deg) - 35.0) - 0.025 * (np.asarray(lon_deg) - 140.0)


def receive_sbas(path, rinex, sbas):
    """`receive` of the LNAV recording at ``path`` (5 Hz fixes, default tracking, ``rinex``'s
    records) with the SBAS options ``sbas`` (`sbas_fixes.SbasOptions`)."""
    from gnssframework import registry
    from gnssframework.receiver.channels import tracking_config
    from gnssframework.receiver.frontend import open_recording
    from gnssframework.receiver.navigation.receive import receive

    acquisition = registry.create("acquisition", "pcps")
    return receive(open_recording(path), acquisition, tracking_config(), rate_hz=5.0, rinex=rinex, sbas=sbas)


def range_delays(sats, station_ecef_m, tow_s: float, day_of_year: float, clock_errors_m: np.ndarray):
    """Each satellite's code delay (m) seen from ``station_ecef_m`` at ``tow_s`` (its geometry
    held): its clock error, the slant delay of the plane `vertical_delay_m` at its pierce
    point and DO-229's MOPS troposphere; and the fast corrections that take the clock part
    out (the stream's ``fast_m``)."""
    lat, lon, h = pymap3d.ecef2geodetic(*station_ecef_m)
    az, el, _ = pymap3d.ecef2aer(*satellite_state(sats, tow_s).position_m.T, lat, lon, h)
    lat_pp, lon_pp, slant = sbas_pierce_point(lat, lon, np.asarray(az), np.asarray(el))
    tropo, _ = mops_troposphere(lat, h, np.asarray(el), day_of_year)
    return clock_errors_m + slant * vertical_delay_m(lat_pp, lon_pp) + tropo, -clock_errors_m


def igp_masks(bands: dict[int, tuple[int, int]] = BANDS, lats: tuple[int, int] = IGP_LATS) -> dict[int, np.ndarray]:
    """Per band of ``bands`` (band: its westmost and eastmost monitored longitudes), the mask
    numbers (ascending) of its IGPs within ``lats`` (deg, both ends in)."""
    out = {}
    for band, (west, east) in bands.items():
        grid = igp_band_grid(band)
        lat, lon = grid[:, 0], grid[:, 1]
        pick = (lat >= lats[0]) & (lat <= lats[1]) & (lon >= west) & (lon <= east)
        out[band] = np.flatnonzero(pick) + 1
    return out


def _contents(eph, dpos_m, dclock_s, iodp, iodi, bands, lats) -> tuple[list, list, list, list]:
    """The mask, long-term, IGP-mask and ionospheric messages of a stream (`sbas_stream`)."""
    slots = [int(s[1:]) for s in eph.sv]
    order = np.argsort(slots)  # the mask numbers satellites in slot order
    long_term = [(m + 1, int(eph.iode[k]), dpos_m[k], float(dclock_s[k])) for m, k in enumerate(order)]
    masks = igp_masks(bands, lats)
    igp = [enc.igp_mask_message(len(masks), band, iodi, mask.tolist()) for band, mask in masks.items()]
    iono = []
    for band, mask in masks.items():
        grid = igp_band_grid(band)[mask - 1]
        delay = vertical_delay_m(grid[:, 0], grid[:, 1])
        for block in range(int(np.ceil(mask.size / 15))):
            part = delay[15 * block : 15 * block + 15]
            iono.append(enc.iono_message(band, block, iodi, part.tolist(), [5] * part.size))
    long_msgs = [enc.long_term_message(long_term[i : i + 4], iodp) for i in range(0, len(long_term), 4)]
    return [enc.mask_message(slots, iodp)], long_msgs, igp, iono


def _fast(eph, fast_m, iodp, i):
    order = np.argsort([int(s[1:]) for s in eph.sv])
    return enc.fast_message(2, (i // 6) % 3, iodp, [float(fast_m[k]) for k in order], [4] * eph.sv.size, i % 3)


def sbas_stream(
    eph,
    dpos_m: np.ndarray,
    dclock_s: np.ndarray,
    fast_m: np.ndarray,
    week: int,
    first_tow: float,
    last_tow: float,
    prn: int,
) -> list[SbasRecord]:
    """GEO ``prn``'s messages each second from ``first_tow`` to ``last_tow``: the mask of
    ``eph``'s GPS satellites (slot = PRN; mask numbers in slot order, whatever ``eph``'s),
    fast corrections ``fast_m`` (UDREI 4) every 6 s,
    long-term corrections ``dpos_m``, ``dclock_s`` (velocity code 0, the records' IODEs), the
    IGP masks of `igp_masks` and their delays (`vertical_delay_m`, GIVEI 5) in turn."""
    iodp, iodi = 1, 2
    content = sum(_contents(eph, dpos_m, dclock_s, iodp, iodi, BANDS, IGP_LATS), [])
    records, nxt = [], 0
    for i, tow in enumerate(np.arange(first_tow, last_tow + 0.5)):
        if i % 6 == 0:
            bits = _fast(eph, fast_m, iodp, i)
        else:
            bits = content[nxt % len(content)].copy()
            nxt += 1
        records.append(SbasRecord(week, float(tow), prn, parse_message(bits)[1], bits))
    return records


def compact_stream(
    eph,
    fast_m: np.ndarray,
    week: int,
    first_tow: float,
    count: int,
    prn: int,
    bands: dict[int, tuple[int, int]],
    lats: tuple[int, int],
) -> list[SbasRecord]:
    """``count`` messages of GEO ``prn``, one a second from ``first_tow`` (the GEO's send
    times), that make a whole set as soon as they can: two fast corrections ``fast_m`` (IODP
    1, UDREI 4: ignored before the mask), the mask, fast corrections again, zero long-term
    corrections (the records' IODEs), the IGP masks of ``bands`` within ``lats`` and their
    delays (`vertical_delay_m`, GIVEI 5); then fast corrections every 6 s and the rest again
    in turn."""
    iodp, iodi = 1, 2
    n = eph.sv.size
    mask, long_msgs, igp, iono = _contents(eph, np.zeros((n, 3)), np.zeros(n), iodp, iodi, bands, lats)
    sent = [_fast(eph, fast_m, iodp, 0), _fast(eph, fast_m, iodp, 1)] + mask + [_fast(eph, fast_m, iodp, 3)]
    sent += long_msgs + igp + iono
    cycle = mask + long_msgs + igp + iono
    k = 0
    while len(sent) < count:  # then fast corrections every 6 s between the rest in turn
        if len(sent) % 6 == 3:
            sent.append(_fast(eph, fast_m, iodp, len(sent)))
        else:
            sent.append(cycle[k % len(cycle)].copy())
            k += 1
    return [
        SbasRecord(week, float(first_tow + i), prn, parse_message(bits)[1], bits) for i, bits in enumerate(sent[:count])
    ]
