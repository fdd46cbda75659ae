r"""Broadcast records from GPS CNAV: messages 10 and 11 (orbit), 30-37 (clock) and 30 (group
delays, Klobuchar coefficients) assembled into the `ephemeris.Ephemerides` positions take.

A CNAV orbit is the LNAV one relative to references, with two rates LNAV lacks
(IS-GPS-200 30.3.3.1, Tables 30-I and 30-II):

.. math:: \sqrt{A} = \sqrt{A_{REF} + \Delta A},\quad
          \dot\Omega = (\dot\Omega_{REF} + \Delta\dot\Omega)\,\pi

and :math:`\dot A`, :math:`\Delta\dot n_0` kept as the record's ``Adot`` (m/s) and
``DeltaN0dot`` (rad/s², the broadcast semicircles/s² times :math:`\pi`), which
`ephemeris.satellite_state` applies (`ephemeris.CNAV_FIELDS`). The clock is that of a
type 30-37 message whose :math:`t_{oc}` equals the orbit's :math:`t_{oe}` (or, failing one,
shares its :math:`t_{op}`: one upload); T_GD and :math:`ISC_{L2C}` come from the last type 30
(its group delays change with the satellite's hardware, not with the upload), so an L2C
user's clock is :math:`\Delta t_{SV} - T_{GD} + ISC_{L2C}` and an L1 C/A user's
:math:`\Delta t_{SV} - T_{GD} + ISC_{L1C/A}` (30.3.3.3.1.1.1,
`ephemeris.single_frequency_clock_s`; :math:`\gamma T_{GD}` where ISC is broadcast as not
available, and T_GD 0 where it is, as GNSS-SDR takes it).

A record holds the health bit of message type 10 of the band decoded (L2, or L5 for a
receiver decoding L5 I5) as its health, the URA_ED index as its accuracy (the LNAV URA table for indices 0-15,
:math:`2^{1 + N/2}` m below 0, IS-GPS-200 30.3.3.1.1.4), and :math:`t_{oe} / 300` as its issue
of data (CNAV has no IODE; a new upload has a new :math:`t_{oe}`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .cnav import (
    A_REF_M,
    MESSAGE_BITS,
    OMEGA_DOT_REF_SC_S,
    CnavClock,
    CnavEphemeris,
    CnavGroupDelays,
    CnavMessage,
    _unsigned,
    parse_clock,
    parse_ephemeris,
    parse_group_delays,
    parse_utc,
)
from .ephemeris import Ephemerides
from .lnav import IonoUtc
from .ura import ura_ed_m

__all__ = ["cnav_record", "CnavRecords", "cnav_records", "CNAV_LEAP_S", "HEALTH_BIT"]

#: GPS-UTC leap seconds taken where no type 33 message was decoded (as a RINEX header
#: without LEAP SECONDS, `rinex_nav_header`).
CNAV_LEAP_S = 18
_PI = np.pi  # IS-GPS-200's semicircle (the ICD's own value of pi)
#: The bit of message type 10's ``health_l1_l2_l5`` (L1 the high bit, L2 the middle one, L5
#: the low one) a record holds, by the band of the signal decoded.
HEALTH_BIT = {"L2": 1, "L5": 0}


def cnav_record(
    eph: CnavEphemeris, clock: CnavClock, delays: CnavGroupDelays, sv: str | None = None, band: str = "L2"
) -> Ephemerides:
    """One `Ephemerides` record (georinex names, radians) of a satellite's orbit (types 10
    and 11, `cnav.parse_ephemeris`), clock (`cnav.parse_clock`) and group delays
    (`cnav.parse_group_delays`), named ``sv`` (default ``G`` and the PRN: give ``J01`` for
    QZSS PRN 193), its health the ``band``'s bit (`HEALTH_BIT`: ``"L2"`` or ``"L5"``). See
    the module text."""
    tgd = delays.tgd_s if np.isfinite(delays.tgd_s) else 0.0
    elements = {
        "sqrtA": np.sqrt(A_REF_M + eph.delta_a_m),
        "Eccentricity": eph.e,
        "Io": eph.i0_sc * _PI,
        "Omega0": eph.omega0_sc * _PI,
        "omega": eph.omega_sc * _PI,
        "M0": eph.m0_sc * _PI,
        "DeltaN": eph.delta_n0_sc_s * _PI,
        "OmegaDot": (OMEGA_DOT_REF_SC_S + eph.delta_omega_dot_sc_s) * _PI,
        "IDOT": eph.i0_dot_sc_s * _PI,
        "Cuc": eph.cuc_rad,
        "Cus": eph.cus_rad,
        "Crc": eph.crc_m,
        "Crs": eph.crs_m,
        "Cic": eph.cic_rad,
        "Cis": eph.cis_rad,
        "Toe": eph.toe_s,
        "SVclockBias": clock.af0_s,
        "SVclockDrift": clock.af1_s_s,
        "SVclockDriftRate": clock.af2_s_s2,
        "TGD": tgd,
        "Adot": eph.a_dot_m_s,
        "DeltaN0dot": eph.delta_n0_dot_sc_s2 * _PI,
        "ISC_L1CA": delays.isc_l1ca_s,
        "ISC_L2C": delays.isc_l2c_s,
        "ISC_L5I5": delays.isc_l5i5_s,
        "CNAV": 1.0,
        "Top": eph.top_s,
        "HealthL1L2L5": eph.health_l1_l2_l5,
    }
    return Ephemerides(
        np.array([sv or f"G{eph.prn:02d}"]),
        np.array([float(clock.toc_s)]),
        {k: np.array([float(v)]) for k, v in elements.items()},
        np.array([float((eph.health_l1_l2_l5 >> HEALTH_BIT[band]) & 1)]),
        np.array([eph.toe_s / 300.0]),
        np.array([ura_ed_m(eph.ura_ed_index)]),
    )


@dataclass(frozen=True)
class CnavRecords:
    """What a satellite's CNAV messages give for positions.

    ``records``: each record as it became complete, with the index (in the messages given)
    of the message that completed it; ``iono``: the last type 30's Klobuchar coefficients
    with the GPS-UTC parameters of the last type 33 (`CNAV_LEAP_S` and zero polynomial
    without one; None without a type 30); ``week``: the full (13-bit) week of the last type 10.
    """

    records: list[tuple[int, Ephemerides]]
    iono: IonoUtc | None
    week: int | None


def cnav_records(messages: list[CnavMessage], sv: str | None = None, band: str = "L2") -> CnavRecords:
    """The records of one satellite's messages in the order received (`cnav.decode_cnav`'s;
    those failing their CRC are passed over): a record is made once an orbit (types 10 and 11
    of one :math:`t_{oe}`), its clock and a type 30 have arrived, and again at each new
    orbit or clock (see the module text). ``sv`` names the records and ``band`` picks their
    health bit (`cnav_record`)."""
    orbit10: dict[float, CnavMessage] = {}
    orbit11: dict[float, CnavMessage] = {}
    clocks: list[CnavClock] = []
    delays: CnavGroupDelays | None = None
    utc = None
    week = None
    made: set[tuple[float, float]] = set()
    records: list[tuple[int, Ephemerides]] = []
    for index, m in enumerate(messages):
        if not m.crc_ok or m.bits.size != MESSAGE_BITS:
            continue
        if m.msg_type == 10:
            orbit10[300.0 * _unsigned(m.bits, 71, 11)] = m  # toe, 300 s units (Table 30-I)
            week = _unsigned(m.bits, 39, 13)
        elif m.msg_type == 11:
            orbit11[300.0 * _unsigned(m.bits, 39, 11)] = m
        elif 30 <= m.msg_type <= 37:
            clocks.append(parse_clock(m))
            if m.msg_type == 30:
                delays = parse_group_delays(m)
            elif m.msg_type == 33:
                utc = parse_utc(m)
        else:
            continue
        if delays is None:
            continue
        for toe in sorted(set(orbit10) & set(orbit11)):
            eph = parse_ephemeris(orbit10[toe], orbit11[toe])
            clock = _clock_of(eph, clocks)
            if clock is None or (toe, clock.toc_s) in made:
                continue
            made.add((toe, clock.toc_s))
            records.append((index, cnav_record(eph, clock, delays, sv, band)))
    iono = None
    if delays is not None:
        alpha, beta = delays.iono.alpha, delays.iono.beta
        iono = IonoUtc(alpha, beta, dt_ls_s=CNAV_LEAP_S)
        if utc is not None:
            iono = IonoUtc(
                alpha,
                beta,
                a0_s=utc.a0_s,
                a1_s_s=utc.a1_s_s,
                tot_s=utc.tot_s,
                wnt=utc.wn_ot % 256,
                dt_ls_s=int(utc.delta_t_ls_s),
                wn_lsf=utc.wn_lsf % 256,
                dn=int(utc.dn),
                dt_lsf_s=int(utc.delta_t_lsf_s),
            )
    return CnavRecords(records, iono, week)


def _clock_of(eph: CnavEphemeris, clocks: list[CnavClock]) -> CnavClock | None:
    """The last clock of the orbit's upload: toc equal to its toe, else its top."""
    for match in (lambda c: c.toc_s == eph.toe_s, lambda c: c.top_s == eph.top_s):
        found = [c for c in clocks if match(c)]
        if found:
            return found[-1]
    return None
