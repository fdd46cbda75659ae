r"""What SBAS L1 messages say: the contents of the message types a user needs for corrected
ranging (RTCA DO-229 Appendix A, A.4.4; ICAO Annex 10 Vol. I Appendix B, 3.5.4), read from a
message's 250 bits (`sbas_message`).

Bits are numbered from 0, the first bit of the preamble; every field is an integer, most
significant bit first, two's complement where signed, times its scale:

========= ====================================================================================
type      fields (first bit, bits, scale)
========= ====================================================================================
1         PRN mask: 210 one-bit slots (14; slot ``i`` at bit ``13 + i``), IODP (224, 2)
2-5 (0)   fast corrections: IODF (14, 2), IODP (16, 2), 13 PRC (18 + 12 k, 12, 0.125 m),
          13 UDREI (174 + 4 k, 4); type ``t`` holds mask slots ``13 (t - 2)`` on (type 0,
          a test message, is read as type 2 where it carries one)
6         integrity: IODF of types 2-5 (14 + 2 k, 2), 51 UDREI (22 + 4 k, 4)
7         fast-correction degradation: system latency (14, 4, 1 s), IODP (18, 2), 51 degradation
          factor indicators a_i (22 + 4 k, 4)
10        degradation parameters (1-based bits as DO-229 A.4.4.6 numbers them, ``Layout`` of
          `DEGRADATION_LAYOUT`): B_rrc, C_ltc_lsb, C_ltc_v1, I_ltc_v1, C_ltc_v0, I_ltc_v0,
          C_geo_lsb, C_geo_v, I_geo, C_er, C_iono_step, I_iono, C_iono_ramp, RSS_UDRE,
          RSS_iono, C_covariance
9         GEO navigation: IODN (14, 8), t0 (22, 13, 16 s of day), URA (35, 4), X, Y (39, 69:
          30, 0.08 m), Z (99, 25, 0.4 m), Ẋ, Ẏ (124, 141: 17, 0.000625 m/s), Ż (158, 18, 0.004
          m/s), Ẍ, Ÿ (176, 186: 10, 0.0000125 m/s²), Z̈ (196, 10, 0.0000625 m/s²), a_Gf0 (206,
          12, 2⁻³¹ s), a_Gf1 (218, 8, 2⁻⁴⁰ s/s)
17        GEO almanacs: three of 67 bits from 14 (data ID 2, PRN 8, health 8, X and Y 15 bits of
          2600 m, Z 9 of 26 000 m, Ẋ and Ẏ 3 bits of 10 m/s, Ż 4 of 40.96 m/s), t0 (215, 11, 64
          s of day)
18        IGP mask: number of bands (14, 4), band (18, 4), IODI (22, 2), 201 one-bit IGPs from 24
24        six fast corrections (14 + 12 k, 12, 0.125 m; UDREI 86 + 4 k), IODP (110, 2), block
          (112, 2), IODF (114, 2), and one half of long-term corrections from 120
25        two halves of long-term corrections, from 14 and 120 (106 bits each; below)
26        ionospheric delays: band (14, 4), block (18, 4), 15 IGPs of delay (22 + 13 k, 9, 0.125
          m; 511: not monitored) and GIVEI (31 + 13 k, 4), IODI (217, 2)
27        service message (A.4.4.13): IODS (14, 3), number of service messages less one (17,
          3), service message number (20, 3), number of regions (23, 3), priority code (26,
          2), δUDREI inside (28, 4) and outside (32, 4), then up to five regions from 36 + 35 k:
          corner 1 latitude (8, 1°, signed), longitude (9, 1°, signed), corner 2 latitude,
          longitude, shape (1: quadrangle, 0: triangle)
28        clock-ephemeris covariance (A.4.4.16): IODP (14, 2), two satellites from 16 + 105 k:
          mask number (6; 0: none), scale exponent (3), E_11 E_22 E_33 E_44 (9 each), E_12 E_13
          E_14 E_23 E_24 E_34 (10 each, signed): the Cholesky factor R = 2^(exponent - 5) E
          (upper triangular) of the relative covariance C = RᵀR of (x, y, z, clock)
========= ====================================================================================

A half of long-term corrections opens with its velocity code. Code 0: two satellites, each
mask number (6), IODE (8), δx, δy, δz (9, 0.125 m), δa_f0 (10, 2⁻³¹ s), then IODP (2) and a
spare bit. Code 1: one satellite, mask number (6), IODE (8), δx, δy, δz (11, 0.125 m), δa_f0
(11, 2⁻³¹ s), δẋ, δẏ, δż (8, 2⁻¹¹ m/s), δa_f1 (8, 2⁻³⁹ s/s), t0 (13, 16 s of day), IODP (2).

A mask slot names a satellite (DO-229 A.4.4.2): 1-37 GPS, 38-61 GLONASS slots 1-24, 120-158
SBAS (``S20``-``S58``, RINEX names), 183-192 QZSS L1S (PRN 183-192) and 193-202 QZSS
(``J01``-``J10``). The IGPs of a band are a fixed grid (A.4.4.9): bands 0-8 each 40° of
longitude in 5° columns, a column's latitudes every 5° between ±55° plus ±65° and ±75° on
10° columns and +85° (or -85°) on four columns 90° apart; bands 9 and 10 the caps, 60°-85°
north and south. Each is generated here by that rule and numbered as the mask numbers it.

`SbasCorrections.from_messages` gathers a stream's messages into what a user would apply at
its end: each masked satellite's latest fast correction and UDREI, its long-term correction
and each monitored IGP's delay, where the message's IODP or IODI matches the mask's.
Types 27 and 28 are read by `sbas_udre`; type 12 and the rest are not interpreted here
(`decode_content` returns None).
The field positions follow DO-229 as RTKLIB's ``sbas.c`` reads them (learned from, not
copied); the checks are in `tests/navigation/test_sbas_content.py`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .bit_fields import decode_fields
from .bit_fields import read_field as _field
from .bit_fields import read_fields as _fields
from .sbas_message import MESSAGE_BITS, parse_message
from .sbas_udre import DELTA_UDRE, CovarianceMatrices, ServiceMessage, covariance_content, service_content

__all__ = [
    "PrnMask",
    "FastCorrections",
    "Integrity",
    "FastDegradation",
    "DegradationParameters",
    "DEGRADATION_LAYOUT",
    "GeoNavigation",
    "GeoAlmanac",
    "IgpMask",
    "LongTermCorrection",
    "IonoDelays",
    "CovarianceMatrices",
    "ServiceMessage",
    "DELTA_UDRE",
    "SbasContent",
    "decode_content",
    "describe",
    "mask_satellite",
    "igp_band_grid",
    "SbasCorrections",
]

_TWO_M31 = 2.0**-31


def mask_satellite(slot: int) -> str:
    """The satellite a PRN-mask slot (1-210) names: ``G05``, ``R03``, ``S29``, ``J01``; ``"L1S 185"``
    for a QZSS L1S PRN, ``"slot 70"`` for a reserved slot."""
    if 1 <= slot <= 37:
        return f"G{slot:02d}"
    if 38 <= slot <= 61:
        return f"R{slot - 37:02d}"
    if 120 <= slot <= 158:
        return f"S{slot - 100:02d}"
    if 183 <= slot <= 192:
        return f"L1S {slot}"
    if 193 <= slot <= 202:
        return f"J{slot - 192:02d}"
    return f"slot {slot}"


def _lat_column(lon: int) -> list[int]:
    """The latitudes (deg) of a 5-degree IGP column of bands 0-8 at longitude ``lon``."""
    middle = list(range(-55, 56, 5))
    if lon % 10:
        return middle
    column = [-75, -65, *middle, 65, 75]
    if (lon + 180) % 90 == 0:  # -180, -90, 0, 90: +85 too
        return column + [85]
    if (lon + 140) % 90 == 0:  # -140, -50, 40, 130: -85 too
        return [-85, *column]
    return column


def igp_band_grid(band: int) -> np.ndarray:
    """``(N, 2)`` latitude and longitude (deg) of the IGPs of ``band`` (0-10), in mask order
    (column by column, south to north; bands 9-10 ring by ring, west to east)."""
    if 0 <= band <= 8:
        lons = range(-180 + 40 * band, -180 + 40 * band + 40, 5)
        return np.array([(lat, lon) for lon in lons for lat in _lat_column(lon)], dtype=float)
    if band in (9, 10):
        sign = 1 if band == 9 else -1
        rings = [(60, range(-180, 180, 5)), (65, range(-180, 180, 10)), (70, range(-180, 180, 10))]
        rings += [(75, range(-180, 180, 10)), (85, range(-180, 180, 30) if band == 9 else range(-170, 180, 30))]
        return np.array([(sign * lat, lon) for lat, lons in rings for lon in lons], dtype=float)
    raise ValueError(f"IGP band {band}: bands are 0-10")


@dataclass(frozen=True)
class PrnMask:
    """Type 1: the masked satellites in slot order and the mask's issue of data (IODP)."""

    iodp: int
    slots: tuple[int, ...]

    @property
    def satellites(self) -> tuple[str, ...]:
        return tuple(mask_satellite(s) for s in self.slots)


@dataclass(frozen=True)
class FastCorrections:
    """Types 2-5 (and 24's six): pseudorange corrections (m) and UDRE indicators of mask
    numbers ``first + k`` (0-based), under IODF and the mask's IODP."""

    message_type: int
    iodf: int
    iodp: int
    first: int
    prc_m: np.ndarray = field(repr=False)
    udrei: np.ndarray = field(repr=False)


@dataclass(frozen=True)
class Integrity:
    """Type 6: the IODF of types 2-5 and the UDREI of mask numbers 0-50."""

    iodf: tuple[int, int, int, int]
    udrei: np.ndarray = field(repr=False)


@dataclass(frozen=True)
class FastDegradation:
    """Type 7: the system latency (s), IODP and the degradation factor indicator of mask
    numbers 0-50."""

    latency_s: int
    iodp: int
    ai: np.ndarray = field(repr=False)


#: Type 10's fields: name -> (first bit, 1-based from the preamble; bits; scale; signed).
DEGRADATION_LAYOUT = {
    "brrc_m": (15, 10, 0.002, False),
    "cltc_lsb_m": (25, 10, 0.002, False),
    "cltc_v1_mps": (35, 10, 0.00005, False),
    "iltc_v1_s": (45, 9, 1.0, False),
    "cltc_v0_m": (54, 10, 0.002, False),
    "iltc_v0_s": (64, 9, 1.0, False),
    "cgeo_lsb_m": (73, 10, 0.0005, False),
    "cgeo_v_mps": (83, 10, 0.00005, False),
    "igeo_s": (93, 9, 1.0, False),
    "cer_m": (102, 6, 0.5, False),
    "ciono_step_m": (108, 10, 0.001, False),
    "iiono_s": (118, 9, 1.0, False),
    "ciono_ramp_mps": (127, 10, 0.000005, False),
    "rss_udre": (137, 1, 1.0, False),
    "rss_iono": (138, 1, 1.0, False),
    "ccovariance": (139, 7, 0.1, False),
}


@dataclass(frozen=True)
class DegradationParameters:
    """Type 10: the parameters of DO-229 A.4.5's degradation terms (names of
    `DEGRADATION_LAYOUT`: metres, seconds, m/s; the two RSS flags 0 or 1)."""

    brrc_m: float
    cltc_lsb_m: float
    cltc_v1_mps: float
    iltc_v1_s: float
    cltc_v0_m: float
    iltc_v0_s: float
    cgeo_lsb_m: float
    cgeo_v_mps: float
    igeo_s: float
    cer_m: float
    ciono_step_m: float
    iiono_s: float
    ciono_ramp_mps: float
    rss_udre: int
    rss_iono: int
    ccovariance: float


@dataclass(frozen=True)
class GeoNavigation:
    """Type 9: the sending GEO's ECEF state at ``t0_s`` (seconds of the day) and clock."""

    iodn: int
    t0_s: float
    ura_index: int
    position_m: np.ndarray
    velocity_mps: np.ndarray
    acceleration_mps2: np.ndarray
    af0_s: float
    af1_s_s: float


@dataclass(frozen=True)
class GeoAlmanac:
    """Type 17: up to three GEOs' almanacs (PRN 0 entries left out) at ``t0_s`` (seconds of
    the day): ``(data ID, PRN, health, position (m), velocity (m/s))`` each."""

    t0_s: float
    entries: tuple[tuple[int, int, int, np.ndarray, np.ndarray], ...]


@dataclass(frozen=True)
class IgpMask:
    """Type 18: one band's monitored IGPs (mask numbers 1-201), with IODI."""

    n_bands: int
    band: int
    iodi: int
    igps: tuple[int, ...]

    def grid(self) -> np.ndarray:
        """``(N, 2)`` latitude and longitude (deg) of the masked IGPs, in mask order."""
        return igp_band_grid(self.band)[np.asarray(self.igps, int) - 1]


@dataclass(frozen=True)
class LongTermCorrection:
    """One satellite's long-term correction (types 24, 25) of mask number ``slot`` (1-51):
    ECEF position and clock offsets, rates (0 with velocity code 0) and their time of day
    (None with code 0: the message's time)."""

    slot: int
    iode: int
    iodp: int
    dpos_m: np.ndarray
    dvel_mps: np.ndarray
    daf0_s: float
    daf1_s_s: float
    t0_s: float | None


@dataclass(frozen=True)
class IonoDelays:
    """Type 26: vertical delays (m; NaN where not monitored) and GIVEI of IGPs ``15 block +
    k`` of the band's mask, under IODI."""

    band: int
    block: int
    iodi: int
    delay_m: np.ndarray = field(repr=False)
    givei: np.ndarray = field(repr=False)


def _long_term_half(bits: np.ndarray, p: int) -> list[LongTermCorrection]:
    """The corrections of the half message from bit ``p`` (its velocity code)."""
    if not int(bits[p]):
        iodp = int(_field(bits, p + 103, 2))
        out = []
        for q in (p + 1, p + 52):
            slot = int(_field(bits, q, 6))
            if slot:
                out.append(
                    LongTermCorrection(
                        slot,
                        int(_field(bits, q + 6, 8)),
                        iodp,
                        _fields(bits, q + 14, 9, 3, 0.125, True),
                        np.zeros(3),
                        _field(bits, q + 41, 10, _TWO_M31, True),
                        0.0,
                        None,
                    )
                )
        return out
    q = p + 1
    slot = int(_field(bits, q, 6))
    if not slot:
        return []
    return [
        LongTermCorrection(
            slot,
            int(_field(bits, q + 6, 8)),
            int(_field(bits, q + 103, 2)),
            _fields(bits, q + 14, 11, 3, 0.125, True),
            _fields(bits, q + 58, 8, 3, 2.0**-11, True),
            _field(bits, q + 47, 11, _TWO_M31, True),
            _field(bits, q + 82, 8, 2.0**-39, True),
            _field(bits, q + 90, 13, 16.0),
        )
    ]


def _fast(bits: np.ndarray, mtype: int) -> FastCorrections:
    block = 2 if mtype == 0 else mtype
    return FastCorrections(
        mtype,
        int(_field(bits, 14, 2)),
        int(_field(bits, 16, 2)),
        13 * (block - 2),
        _fields(bits, 18, 12, 13, 0.125, True),
        _fields(bits, 174, 4, 13).astype(int),
    )


def _geo_navigation(bits: np.ndarray) -> GeoNavigation:
    return GeoNavigation(
        int(_field(bits, 14, 8)),
        _field(bits, 22, 13, 16.0),
        int(_field(bits, 35, 4)),
        np.array([_field(bits, 39, 30, 0.08, True), _field(bits, 69, 30, 0.08, True), _field(bits, 99, 25, 0.4, True)]),
        np.array(
            [
                _field(bits, 124, 17, 0.000625, True),
                _field(bits, 141, 17, 0.000625, True),
                _field(bits, 158, 18, 0.004, True),
            ]
        ),
        np.array(
            [
                _field(bits, 176, 10, 0.0000125, True),
                _field(bits, 186, 10, 0.0000125, True),
                _field(bits, 196, 10, 0.0000625, True),
            ]
        ),
        _field(bits, 206, 12, _TWO_M31, True),
        _field(bits, 218, 8, 2.0**-40, True),
    )


def _geo_almanac(bits: np.ndarray) -> GeoAlmanac:
    entries = []
    for k in range(3):
        p = 14 + 67 * k
        prn = int(_field(bits, p + 2, 8))
        if prn:
            position = np.array([_field(bits, p + 18, 15, 2600.0, True), _field(bits, p + 33, 15, 2600.0, True)])
            position = np.r_[position, _field(bits, p + 48, 9, 26000.0, True)]
            velocity = np.array(
                [
                    _field(bits, p + 57, 3, 10.0, True),
                    _field(bits, p + 60, 3, 10.0, True),
                    _field(bits, p + 63, 4, 40.96, True),
                ]
            )
            entries.append((int(_field(bits, p, 2)), prn, int(_field(bits, p + 10, 8)), position, velocity))
    return GeoAlmanac(_field(bits, 215, 11, 64.0), tuple(entries))


#: What `decode_content` returns (see there).
SbasContent = (
    PrnMask
    | FastCorrections
    | Integrity
    | FastDegradation
    | DegradationParameters
    | GeoNavigation
    | GeoAlmanac
    | IgpMask
    | IonoDelays
    | CovarianceMatrices
    | ServiceMessage
    | list[LongTermCorrection]
    | tuple[FastCorrections, list[LongTermCorrection]]
    | None
)


def decode_content(bits: np.ndarray) -> SbasContent:
    """The contents of one message's 250 bits (0/1) whose CRC holds: a `PrnMask`,
    `FastCorrections`, `Integrity`, `FastDegradation`, `GeoNavigation`, `GeoAlmanac`,
    `IgpMask`, `IonoDelays`, a list of `LongTermCorrection` (type 25), a pair (`FastCorrections`,
    list of `LongTermCorrection`) for type 24, or None for a type not interpreted here (and for
    type 0 sent as all zeros or 63, the null message).

    Raises
    ------
    ValueError
        For bits that are not one message whose CRC holds (`sbas_message.parse_message`).
    """
    b = np.asarray(bits)
    _, mtype, ok = parse_message(b)
    if not ok:
        raise ValueError(f"not an SBAS message whose CRC holds ({MESSAGE_BITS} bits, preamble, CRC-24Q)")
    b = b.astype(np.uint8)
    if mtype == 1:
        return PrnMask(int(_field(b, 224, 2)), tuple(int(i) for i in np.flatnonzero(b[14:224]) + 1))
    if mtype in (2, 3, 4, 5) or (mtype == 0 and b[14:226].any()):
        return _fast(b, mtype)
    if mtype == 6:
        iodf = tuple(int(_field(b, 14 + 2 * k, 2)) for k in range(4))
        return Integrity(iodf, _fields(b, 22, 4, 51).astype(int))  # type: ignore[arg-type]
    if mtype == 7:
        return FastDegradation(int(_field(b, 14, 4)), int(_field(b, 18, 2)), _fields(b, 22, 4, 51).astype(int))
    if mtype == 9:
        return _geo_navigation(b)
    if mtype == 10:
        v = decode_fields(b, DEGRADATION_LAYOUT)
        scaled = {k: float(x) for k, x in v.items() if not k.startswith("rss")}
        return DegradationParameters(**scaled, rss_udre=int(v["rss_udre"]), rss_iono=int(v["rss_iono"]))
    if mtype == 17:
        return _geo_almanac(b)
    if mtype == 18:
        igps = tuple(int(i) for i in np.flatnonzero(b[24:225]) + 1)
        return IgpMask(int(_field(b, 14, 4)), int(_field(b, 18, 4)), int(_field(b, 22, 2)), igps)
    if mtype == 24:
        fast = FastCorrections(
            24,
            int(_field(b, 114, 2)),
            int(_field(b, 110, 2)),
            13 * int(_field(b, 112, 2)),
            _fields(b, 14, 12, 6, 0.125, True),
            _fields(b, 86, 4, 6).astype(int),
        )
        return fast, _long_term_half(b, 120)
    if mtype == 25:
        return _long_term_half(b, 14) + _long_term_half(b, 120)
    if mtype == 26:
        raw = _fields(b, 22, 13, 15)
        delay = np.floor(raw / 16)  # the 9-bit delay, then the 4-bit GIVEI
        return IonoDelays(
            int(_field(b, 14, 4)),
            int(_field(b, 18, 4)),
            int(_field(b, 217, 2)),
            np.where(delay == 511, np.nan, delay * 0.125),
            (raw % 16).astype(int),
        )
    if mtype == 27:
        return service_content(b)
    if mtype == 28:
        return covariance_content(b)
    return None


def describe(content: SbasContent) -> str:
    """One line saying what a decoded message holds (``sbas.csv``'s ``content`` column), e.g.
    ``"mask IODP 3: 33 satellites"``; ``""`` for a type not interpreted."""
    if isinstance(content, PrnMask):
        return f"mask IODP {content.iodp}: {len(content.slots)} satellites"
    if isinstance(content, FastCorrections):
        last = content.first + len(content.prc_m)
        return f"fast corrections IODF {content.iodf} IODP {content.iodp}: mask numbers {content.first + 1}-{last}"
    if isinstance(content, Integrity):
        return f"integrity IODF {' '.join(map(str, content.iodf))}"
    if isinstance(content, FastDegradation):
        return f"degradation factors IODP {content.iodp}, latency {content.latency_s} s"
    if isinstance(content, DegradationParameters):
        return (
            f"degradation parameters: B_rrc {content.brrc_m:.3f} m, C_ltc_v0 {content.cltc_v0_m:.3f} m, "
            f"C_iono_step {content.ciono_step_m:.3f} m, RSS_UDRE {content.rss_udre}, RSS_iono {content.rss_iono}"
        )
    if isinstance(content, GeoNavigation):
        x, y, z = content.position_m
        return f"GEO navigation t0 {content.t0_s:.0f} s: {x:.2f} {y:.2f} {z:.1f} m"
    if isinstance(content, GeoAlmanac):
        return f"GEO almanac t0 {content.t0_s:.0f} s: PRN {' '.join(str(e[1]) for e in content.entries)}"
    if isinstance(content, IgpMask):
        return f"IGP mask band {content.band} IODI {content.iodi}: {len(content.igps)} IGPs"
    if isinstance(content, IonoDelays):
        return f"ionospheric delays band {content.band} block {content.block} IODI {content.iodi}"
    if isinstance(content, ServiceMessage):
        return (
            f"service message {content.number + 1} of {content.count} IODS {content.iods}: "
            f"{len(content.regions)} regions, priority {content.priority}, δUDREI {content.inside} in, "
            f"{content.outside} out"
        )
    if isinstance(content, CovarianceMatrices):
        return f"clock-ephemeris covariance IODP {content.iodp}: mask numbers {' '.join(map(str, content.slots))}"
    if isinstance(content, tuple):
        return f"mixed corrections IODP {content[0].iodp}: {len(content[1])} long-term"
    if isinstance(content, list):
        return f"long-term corrections: mask numbers {' '.join(str(c.slot) for c in content)}"
    return ""


@dataclass
class SbasCorrections:
    """What a stream's messages add up to at its end (module text): the mask, each masked
    satellite's latest fast correction (m), UDREI and the time of its message (and in
    ``fast_previous`` the correction it replaced, for the range-rate correction; in
    ``fast_iodf`` the IODF of both), its long-term correction (and in ``long_term_time`` its
    message's time), each band's monitored IGPs with their latest delays (m) and GIVEI, and
    the latest type 7 and type 10 with their times (``degradation``, ``parameters``), and
    per satellite its latest type 28 (``covariance``: time, scale exponent, C), and the
    latest type 27 of each service message number with its time (``service``).
    ``ignored`` counts messages whose IODP or IODI did not match the mask they need (or that
    came before it)."""

    mask: PrnMask | None = None
    fast: dict[str, tuple[float, int, float]] = field(default_factory=dict)
    fast_previous: dict[str, tuple[float, int, float]] = field(default_factory=dict)
    fast_iodf: dict[str, tuple[int, int | None]] = field(default_factory=dict)
    long_term_time: dict[str, float] = field(default_factory=dict)
    degradation: tuple[float, FastDegradation] | None = None
    parameters: tuple[float, DegradationParameters] | None = None
    long_term: dict[str, LongTermCorrection] = field(default_factory=dict)
    igp_masks: dict[int, IgpMask] = field(default_factory=dict)
    iono: dict[tuple[int, float, float], tuple[float, int, float]] = field(default_factory=dict)
    geo: dict[int, tuple[float, GeoNavigation]] = field(default_factory=dict)
    covariance: dict[str, tuple[float, int, np.ndarray]] = field(default_factory=dict)
    service: dict[int, tuple[float, ServiceMessage]] = field(default_factory=dict)
    ignored: int = 0

    @classmethod
    def from_messages(cls, messages: list[tuple[float, int, np.ndarray]]) -> SbasCorrections:
        """Gather ``(time s, GEO PRN, bits)`` messages in time order (one GEO's stream: a
        mask's IODP is its sender's)."""
        out = cls()
        for t, prn, bits in sorted(messages, key=lambda m: m[0]):
            out.add(t, prn, decode_content(bits))
        return out

    def _named(self, first: int, values: np.ndarray, udrei: np.ndarray, t: float, iodf: int) -> None:
        assert self.mask is not None
        for k, (prc, u) in enumerate(zip(values, udrei)):
            if first + k < len(self.mask.slots):
                sat = self.mask.satellites[first + k]
                before = None
                if sat in self.fast and self.fast[sat][2] < t:
                    self.fast_previous[sat] = self.fast[sat]
                    before = self.fast_iodf.get(sat, (None, None))[0]
                self.fast[sat] = (float(prc), int(u), t)
                self.fast_iodf[sat] = (iodf, before)

    def _long(self, corrections: list[LongTermCorrection], t: float) -> None:
        for c in corrections:
            if self.mask is None or c.iodp != self.mask.iodp or c.slot > len(self.mask.slots):
                self.ignored += 1
                continue
            self.long_term[self.mask.satellites[c.slot - 1]] = c
            self.long_term_time[self.mask.satellites[c.slot - 1]] = t

    def add(self, t: float, prn: int, content: SbasContent) -> None:
        """Take one decoded message (`decode_content`) sent at ``t`` by GEO ``prn``."""
        if isinstance(content, PrnMask):
            self.mask = content
        elif isinstance(content, FastCorrections):
            if self.mask is None or content.iodp != self.mask.iodp:
                self.ignored += 1
            else:
                self._named(content.first, content.prc_m, content.udrei, t, content.iodf)
        elif isinstance(content, tuple):  # type 24
            self.add(t, prn, content[0])
            self._long(content[1], t)
        elif isinstance(content, list):
            self._long(content, t)
        elif isinstance(content, FastDegradation):
            if self.mask is None or content.iodp != self.mask.iodp:
                self.ignored += 1
            else:
                self.degradation = (t, content)
        elif isinstance(content, DegradationParameters):
            self.parameters = (t, content)
        elif isinstance(content, IgpMask):
            self.igp_masks[content.band] = content
        elif isinstance(content, IonoDelays):
            mask = self.igp_masks.get(content.band)
            if mask is None or mask.iodi != content.iodi:
                self.ignored += 1
                return
            grid = mask.grid()
            for k in range(15):
                j = 15 * content.block + k
                if j < len(grid):
                    key = (content.band, float(grid[j, 0]), float(grid[j, 1]))
                    self.iono[key] = (float(content.delay_m[k]), int(content.givei[k]), t)
        elif isinstance(content, ServiceMessage):
            self.service[content.number] = (t, content)
        elif isinstance(content, CovarianceMatrices):
            if self.mask is None or content.iodp != self.mask.iodp:
                self.ignored += 1
                return
            for slot, exponent, c in zip(content.slots, content.scale_exponents, content.covariances):
                if slot <= len(self.mask.slots):
                    self.covariance[self.mask.satellites[slot - 1]] = (t, exponent, c)
        elif isinstance(content, GeoNavigation):
            self.geo[prn] = (t, content)
