"""SBAS streams for tests and validation scripts: a GEO's messages (`navigation.sbas_encode`)
carrying known satellite errors and a plane of vertical ionospheric delay, one message a
second, fast corrections every 6 s."""

from __future__ import annotations

import numpy as np

from gnssframework.navigation import sbas_encode as enc
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


def igp_masks() -> dict[int, np.ndarray]:
    """Per band of `BANDS`, the mask numbers (ascending) of its monitored IGPs."""
    out = {}
    for band, (west, east) in BANDS.items():
        grid = igp_band_grid(band)
        lat, lon = grid[:, 0], grid[:, 1]
        pick = (lat >= IGP_LATS[0]) & (lat <= IGP_LATS[1]) & (lon >= west) & (lon <= east)
        out[band] = np.flatnonzero(pick) + 1
    return out


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
    slots = [int(s[1:]) for s in eph.sv]
    order = np.argsort(slots)  # the mask numbers satellites in slot order
    iodp, iodi = 1, 2
    long_term = [(m + 1, int(eph.iode[k]), dpos_m[k], float(dclock_s[k])) for m, k in enumerate(order)]
    fast_in_mask_order = [float(fast_m[k]) for k in order]
    content = [enc.mask_message(slots, iodp)]
    content += [enc.long_term_message(long_term[i : i + 4], iodp) for i in range(0, len(long_term), 4)]
    masks = igp_masks()
    for band, mask in masks.items():
        content.append(enc.igp_mask_message(len(masks), band, iodi, mask.tolist()))
    for band, mask in masks.items():
        grid = igp_band_grid(band)[mask - 1]
        delay = vertical_delay_m(grid[:, 0], grid[:, 1])
        for block in range(int(np.ceil(mask.size / 15))):
            part = delay[15 * block : 15 * block + 15]
            content.append(enc.iono_message(band, block, iodi, part.tolist(), [5] * part.size))
    records, nxt = [], 0
    for i, tow in enumerate(np.arange(first_tow, last_tow + 0.5)):
        if i % 6 == 0:
            bits = enc.fast_message(2, (i // 6) % 3, iodp, fast_in_mask_order, [4] * eph.sv.size, i % 3)
        else:
            bits = content[nxt % len(content)].copy()
            nxt += 1
        records.append(SbasRecord(week, float(tow), prn, parse_message(bits)[1], bits))
    return records
