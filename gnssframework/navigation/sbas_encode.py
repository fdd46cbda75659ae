r"""SBAS L1 messages written from their contents: the inverse of `sbas_content` for the types
a simulated SBAS stream needs (RTCA DO-229 A.4.4): the PRN mask (1), fast corrections (2-5),
long-term corrections (25, velocity code 0), the IGP mask (18), ionospheric delays (26),
service messages (27) and the clock-ephemeris covariance (28).

Every field sits where `sbas_content`'s table puts it and is quantised to the nearest
integer of its LSB (`bit_fields.encode_fields`); a value out of its field is refused in one
line naming it. Each function returns the message's 250 bits, CRC included
(`sbas_message.message_bits`), ready for the IF generator (`sbas_message.encode_messages`) or
a message file (`sbas_files`). Spare bits are zero; a long-term half with one satellite
leaves the second's mask number 0 ("no satellite").
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..errors import ConfigError
from .bit_fields import Layout, encode_fields
from .sbas_content import DEGRADATION_LAYOUT, DegradationParameters
from .sbas_message import DATA_BITS, message_bits

__all__ = [
    "mask_message",
    "fast_message",
    "long_term_message",
    "igp_mask_message",
    "iono_message",
    "fast_degradation_message",
    "degradation_parameters_message",
    "service_message",
    "covariance_message",
]

_SOURCE = "RTCA DO-229 A.4.4"
_TWO_M31 = 2.0**-31


def _data(layout: Layout, values: dict[str, float], label: str) -> np.ndarray:
    """The 212 data bits of a layout whose first bits are message bits (1-based from the
    preamble, as `bit_fields` counts): bit 15 is the data field's first."""
    shifted = {k: (first - 14, n, scale, signed) for k, (first, n, scale, signed) in layout.items()}
    return encode_fields(DATA_BITS, shifted, values, label, _SOURCE)


def mask_message(slots: Sequence[int], iodp: int, preamble_index: int = 0) -> np.ndarray:
    """Type 1: the mask of slots ``slots`` (1-210, `sbas_content.mask_satellite`) under IODP."""
    data = _data({"iodp": (225, 2, 1.0, False)}, {"iodp": iodp}, "type1")
    for s in slots:
        if not 1 <= int(s) <= 210:
            raise ConfigError("type1.slot", f"mask slots are 1-210, got {s}")
        data[int(s) - 1] = 1
    return message_bits(preamble_index, 1, data)


def fast_message(
    message_type: int, iodf: int, iodp: int, prc_m: Sequence[float], udrei: Sequence[int], preamble_index: int = 0
) -> np.ndarray:
    """Types 2-5: 13 fast corrections (m, 0.125 m LSB, ±256 m) and UDREIs of mask numbers
    ``13 (type - 2)`` on, under IODF and IODP (fewer than 13 are padded with 0 and UDREI 15)."""
    if message_type not in (2, 3, 4, 5):
        raise ConfigError("message_type", f"fast corrections are types 2-5, got {message_type}")
    prc, ui = list(prc_m), list(udrei)
    if len(prc) > 13 or len(prc) != len(ui):
        raise ConfigError("prc_m", f"up to 13 corrections with as many UDREIs, got {len(prc)} and {len(ui)}")
    prc += [0.0] * (13 - len(prc))
    ui += [15] * (13 - len(ui))
    layout: Layout = {"iodf": (15, 2, 1.0, False), "iodp": (17, 2, 1.0, False)}
    values: dict[str, float] = {"iodf": iodf, "iodp": iodp}
    for k in range(13):
        layout[f"prc{k}"] = (19 + 12 * k, 12, 0.125, True)
        layout[f"udrei{k}"] = (175 + 4 * k, 4, 1.0, False)
        values[f"prc{k}"], values[f"udrei{k}"] = prc[k], ui[k]
    return message_bits(preamble_index, message_type, _data(layout, values, f"type{message_type}"))


def long_term_message(
    corrections: Sequence[tuple[int, int, Sequence[float], float]], iodp: int, preamble_index: int = 0
) -> np.ndarray:
    """Type 25 with velocity code 0 in both halves: up to four satellites' ``(mask number
    1-51, IODE, (δx, δy, δz) m at 0.125 m LSB, δa_f0 s at 2⁻³¹ s LSB)``."""
    if not 1 <= len(corrections) <= 4:
        raise ConfigError("corrections", f"type 25 with velocity code 0 carries 1-4 satellites, got {len(corrections)}")
    layout: Layout = {}
    values: dict[str, float] = {}
    for half in (0, 1):
        p = 15 + 106 * half  # the half's velocity code (0), 1-based
        layout[f"iodp{half}"] = (p + 103, 2, 1.0, False)
        values[f"iodp{half}"] = iodp
        for j in (0, 1):
            k = 2 * half + j
            if k >= len(corrections):
                continue
            slot, iode, dpos, daf0 = corrections[k]
            q = p + 1 + 51 * j
            layout.update(
                {
                    f"slot{k}": (q, 6, 1.0, False),
                    f"iode{k}": (q + 6, 8, 1.0, False),
                    f"dx{k}": (q + 14, 9, 0.125, True),
                    f"dy{k}": (q + 23, 9, 0.125, True),
                    f"dz{k}": (q + 32, 9, 0.125, True),
                    f"daf0{k}": (q + 41, 10, _TWO_M31, True),
                }
            )
            values.update(
                {
                    f"slot{k}": slot,
                    f"iode{k}": iode,
                    f"dx{k}": dpos[0],
                    f"dy{k}": dpos[1],
                    f"dz{k}": dpos[2],
                    f"daf0{k}": daf0,
                }
            )
    return message_bits(preamble_index, 25, _data(layout, values, "type25"))


def igp_mask_message(n_bands: int, band: int, iodi: int, igps: Sequence[int], preamble_index: int = 0) -> np.ndarray:
    """Type 18: band ``band``'s monitored IGPs (mask numbers 1-201, `sbas_content.igp_band_grid`
    order) of ``n_bands`` bands, under IODI."""
    values: dict[str, float] = {"n_bands": n_bands, "band": band, "iodi": iodi}
    layout: Layout = {"n_bands": (15, 4, 1.0, False), "band": (19, 4, 1.0, False), "iodi": (23, 2, 1.0, False)}
    data = _data(layout, values, "type18")
    for g in igps:
        if not 1 <= int(g) <= 201:
            raise ConfigError("type18.igp", f"IGP mask numbers are 1-201, got {g}")
        data[24 - 14 + int(g) - 1] = 1
    return message_bits(preamble_index, 18, data)


def iono_message(
    band: int,
    block: int,
    iodi: int,
    delay_m: Sequence[float],
    givei: Sequence[int],
    preamble_index: int = 0,
) -> np.ndarray:
    """Type 26: vertical delays (m, 0.125 m LSB, 0-63.750 m; NaN: not monitored, sent as 511
    with GIVEI 15) and GIVEIs of IGPs ``15 block`` to ``15 block + 14`` of the band's mask."""
    delay, gi = list(delay_m), list(givei)
    if len(delay) > 15 or len(delay) != len(gi):
        raise ConfigError("delay_m", f"up to 15 delays with as many GIVEIs, got {len(delay)} and {len(gi)}")
    delay += [float("nan")] * (15 - len(delay))
    gi += [15] * (15 - len(gi))
    layout: Layout = {"band": (15, 4, 1.0, False), "block": (19, 4, 1.0, False), "iodi": (218, 2, 1.0, False)}
    values: dict[str, float] = {"band": band, "block": block, "iodi": iodi}
    for k in range(15):
        layout[f"delay{k}"] = (23 + 13 * k, 9, 0.125, False)
        layout[f"givei{k}"] = (32 + 13 * k, 4, 1.0, False)
        monitored = np.isfinite(delay[k])
        if monitored and not 0.0 <= delay[k] <= 63.75:
            raise ConfigError(f"type26.delay{k}", f"{delay[k]!r} m is outside 0-63.750 m ({_SOURCE})")
        values[f"delay{k}"] = delay[k] if monitored else 511 * 0.125
        values[f"givei{k}"] = gi[k] if monitored else 15
    return message_bits(preamble_index, 26, _data(layout, values, "type26"))


def fast_degradation_message(latency_s: int, iodp: int, ai: Sequence[int], preamble_index: int = 0) -> np.ndarray:
    """Type 7: the system latency (s), IODP and the degradation factor indicators a_i of mask
    numbers 0-50 (fewer are padded with 0)."""
    values = list(ai) + [0] * (51 - len(ai))
    if len(values) > 51:
        raise ConfigError("ai", f"type 7 carries 51 indicators, got {len(ai)}")
    layout: Layout = {"latency": (15, 4, 1.0, False), "iodp": (19, 2, 1.0, False)}
    fields: dict[str, float] = {"latency": latency_s, "iodp": iodp}
    for k, v in enumerate(values):
        layout[f"ai{k}"] = (23 + 4 * k, 4, 1.0, False)
        fields[f"ai{k}"] = v
    return message_bits(preamble_index, 7, _data(layout, fields, "type7"))


def degradation_parameters_message(params: DegradationParameters, preamble_index: int = 0) -> np.ndarray:
    """Type 10 from its parameters (`sbas_content.DEGRADATION_LAYOUT`)."""
    values = {name: float(getattr(params, name)) for name in DEGRADATION_LAYOUT}
    return message_bits(preamble_index, 10, _data(DEGRADATION_LAYOUT, values, "type10"))


def covariance_message(
    iodp: int, satellites: Sequence[tuple[int, int, np.ndarray]], preamble_index: int = 0
) -> np.ndarray:
    """Type 28: IODP and up to two satellites, each ``(mask number, scale exponent, E)`` with
    ``E`` the 4 × 4 upper-triangular integers of the Cholesky factor (diagonal 0-511,
    above it -512 to 511; `sbas_content.CovarianceMatrices`); a missing second satellite
    is mask number 0."""
    if len(satellites) > 2:
        raise ConfigError("type28.satellites", f"a type 28 carries two satellites, got {len(satellites)}")
    layout: Layout = {"iodp": (15, 2, 1.0, False)}
    values: dict[str, float] = {"iodp": iodp}
    for k, (slot, exponent, e) in enumerate(satellites):
        m = np.asarray(e, float)
        if m.shape != (4, 4) or np.any(np.tril(m, -1) != 0):
            raise ConfigError(f"type28.E{k}", "E is a 4 x 4 upper-triangular matrix")
        first = 17 + 105 * k
        layout[f"slot{k}"] = (first, 6, 1.0, False)
        layout[f"exponent{k}"] = (first + 6, 3, 1.0, False)
        values[f"slot{k}"], values[f"exponent{k}"] = slot, exponent
        for j, (r, c) in enumerate(zip(*np.diag_indices(4))):
            layout[f"e{r + 1}{c + 1}_{k}"] = (first + 9 + 9 * j, 9, 1.0, False)
            values[f"e{r + 1}{c + 1}_{k}"] = m[r, c]
        for j, (r, c) in enumerate(zip(*np.triu_indices(4, 1))):
            layout[f"e{r + 1}{c + 1}_{k}"] = (first + 45 + 10 * j, 10, 1.0, True)
            values[f"e{r + 1}{c + 1}_{k}"] = m[r, c]
    return message_bits(preamble_index, 28, _data(layout, values, "type28"))


def service_message(
    iods: int,
    count: int,
    number: int,
    priority: int,
    inside: int,
    outside: int,
    regions: Sequence[tuple[int, int, int, int, bool]],
    preamble_index: int = 0,
) -> np.ndarray:
    """Type 27: service message ``number`` (0-based) of ``count`` of set ``iods``, its
    priority, δUDRE indicators inside and outside, and up to five regions ``(lat1, lon1,
    lat2, lon2, quadrangle)`` in whole degrees (`sbas_content.ServiceMessage`)."""
    if not 1 <= count <= 8 or len(regions) > 5:
        raise ConfigError("type27.regions", f"1-8 messages of up to 5 regions, got {count} and {len(regions)}")
    layout: Layout = {
        "iods": (15, 3, 1.0, False),
        "count": (18, 3, 1.0, False),
        "number": (21, 3, 1.0, False),
        "regions": (24, 3, 1.0, False),
        "priority": (27, 2, 1.0, False),
        "inside": (29, 4, 1.0, False),
        "outside": (33, 4, 1.0, False),
    }
    values: dict[str, float] = {
        "iods": iods,
        "count": count - 1,
        "number": number,
        "regions": len(regions),
        "priority": priority,
        "inside": inside,
        "outside": outside,
    }
    for k, (lat1, lon1, lat2, lon2, quadrangle) in enumerate(regions):
        first = 37 + 35 * k
        for name, offset, n, v in (
            ("lat1", 0, 8, lat1),
            ("lon1", 8, 9, lon1),
            ("lat2", 17, 8, lat2),
            ("lon2", 25, 9, lon2),
            ("shape", 34, 1, int(quadrangle)),
        ):
            layout[f"{name}_{k}"] = (first + offset, n, 1.0, name != "shape")
            values[f"{name}_{k}"] = v
    return message_bits(preamble_index, 27, _data(layout, values, "type27"))
