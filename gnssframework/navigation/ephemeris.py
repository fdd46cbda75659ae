"""Satellite position, velocity and clock from GPS, QZSS, Galileo and BeiDou broadcast ephemerides.

The one place the framework turns broadcast ephemeris records into satellite states: the
simulation's :class:`~gnssframework.simulation.ephemeris.BroadcastEphemeris` and a
software receiver both call :func:`satellite_state`. Records come from RINEX 2 or 3
navigation files through georinex (:func:`read_rinex_nav`).

The four systems share the Keplerian user algorithm of IS-GPS-200 Table 20-IV, each with
its own constants: GPS (WGS 84, IS-GPS-200), QZSS (IS-QZSS-PNT-005, LNAV ephemeris of the
L1 C/A signal: IS-GPS-200's parameters and user algorithm, GM = 3.986005e14 m^3/s^2 and
Earth rotation 7.2921151467e-5 rad/s; QZS-3's GEO orbit takes the same algorithm, unlike
BeiDou's GEOs), Galileo (Galileo OS SIS ICD 5.1.1:
GM = 3.986004418e14 m^3/s^2, Earth rotation 7.2921151467e-5 rad/s) and BeiDou (CGCS2000,
BDS-SIS-ICD-B1I 3.0 5.2.4: GM = 3.986004418e14, Earth rotation 7.2921150e-5 rad/s), with
the BDS GEO satellites (C01-C05, C59-C63) in the ICD's own formula (5.2.4.12: node without
the Earth rotation, then a -5 degree rotation about X and the rotation ωe tk about Z).
GLONASS records are position/velocity/acceleration state vectors, which this code does
not propagate: asking for them raises a ValueError; so does any other system.

Times given to :func:`satellite_state` and :meth:`Ephemerides.select` are GPS seconds of
the week. Each record keeps its broadcast times (``toc_s``, ``Toe``) in its own system's
seconds of week, and the conversion is made there, at the boundary:

* Galileo System Time is steered to GPS time. The remaining offset GGTO (RINEX header
  line GPGA/GAGP: 22 ns and 2.3 ns in the two test files, 7 m and 0.7 m of range) is not
  applied: it moves a satellite by under a millimetre, and a receiver mixing GPS and
  Galileo ranges estimates it as an inter-system time offset (`pvt.solve_position`'s clock
  per system; or gives it as ``time_offsets_s``, which corrects the ranges). Its seconds of week are
  GPS's; its 12-bit week number counts from 1999-08-22 (GPS week 1024) and rolls over at
  4096, GPS's 10-bit one at 1024; RINEX writes the Galileo week continuous with GPS's,
  and a seconds-of-week interface sees neither rollover.
* QZSS Time (QZSST, IS-QZSS-PNT-005) is aligned to GPS time: the same week number and
  seconds of week, its residual offset steered to a few ns (RTKLIB's ``pntpos.c`` gives
  QZSS the GPS receiver clock for this reason), so its records take GPS seconds of week.
* BeiDou Time is BDT = GPST - 14 s (its week 0 starts 2006-01-01 00:00:00 UTC, GPS week
  1356 + 14 s), so a GPS time t is t - 14 s in BDT seconds of week; BDT weeks roll over
  at 8192, GPS's at 1024, which a seconds-of-week interface does not see.

:func:`gps_seconds_of_week` converts ``datetime64`` epochs.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import ConfigError, DataFileError
from ..signal.beidou_b1c import BEIDOU_B1C
from ..signal.gps_l1ca import GPS_L1CA
from ..signal.gps_l2c import GPS_L2C
from ..signal.gps_l5 import GPS_L5I
from ..signal.spec import SignalSpec
from .weeks import GPS_EPOCH

__all__ = [
    "Ephemerides",
    "SatelliteState",
    "read_rinex_nav",
    "satellite_state",
    "gps_seconds_of_week",
    "GM_GPS_M3_S2",
    "OMEGA_EARTH_RAD_S",
    "F_RELATIVISTIC_S_SQRTM",
    "ORBIT_FIELDS",
    "CLOCK_FIELDS",
    "GM_GAL_BDS_M3_S2",
    "OMEGA_EARTH_BDS_RAD_S",
    "F_RELATIVISTIC_GAL_BDS_S_SQRTM",
    "SYSTEM_TIME_OFFSET_S",
    "SYSTEMS",
    "is_bds_geo",
    "single_frequency_clock_s",
    "ionosphere_scale",
    "clock_defined",
    "records_with_clock",
    "require_records_with_clock",
    "CNAV_FIELDS",
    "GALILEO_FIELDS",
    "OPTIONAL_FIELDS",
    "BDS_CNAV_FIELDS",
]

#: WGS 84 gravitational constant of IS-GPS-200 (Table 20-IV), m^3/s^2.
GM_GPS_M3_S2 = 3.986005e14
#: WGS 84 Earth rotation rate of IS-GPS-200 (Table 20-IV), rad/s.
OMEGA_EARTH_RAD_S = 7.2921151467e-5
#: Relativistic clock constant F = -2 sqrt(mu) / c^2 (IS-GPS-200 20.3.3.3.3.1), s/sqrt(m).
F_RELATIVISTIC_S_SQRTM = -4.442807633e-10
#: Galileo (OS SIS ICD 5.1.1) and BeiDou (CGCS2000, BDS-SIS-ICD-B1I 3.0 5.2.4) GM, m^3/s^2.
GM_GAL_BDS_M3_S2 = 3.986004418e14
#: CGCS2000 Earth rotation rate (BDS-SIS-ICD-B1I 3.0 5.2.4), rad/s; Galileo's is GPS's.
OMEGA_EARTH_BDS_RAD_S = 7.2921150e-5
#: F = -2 sqrt(mu) / c^2 with the Galileo/BeiDou mu (Galileo OS SIS ICD 5.1.4, BDS ICD 5.2.4.10), s/sqrt(m).
F_RELATIVISTIC_GAL_BDS_S_SQRTM = -4.442807309e-10
#: GPS time minus the system's time, s: BDT = GPST - 14 s; GST is steered to GPST.
SYSTEM_TIME_OFFSET_S = {"G": 0.0, "J": 0.0, "E": 0.0, "C": 14.0}
#: Systems whose records this module propagates (RINEX letters).
SYSTEMS = ("G", "J", "E", "C")
#: Systems on GPS's constants (IS-GPS-200 Table 20-IV; QZSS: IS-QZSS-PNT-005 takes them over).
_GPS_CONSTANTS = ("G", "J")
_SYSTEM_NAMES = {
    "G": "GPS",
    "E": "Galileo",
    "C": "BeiDou",
    "R": "GLONASS",
    "J": "QZSS",
    "I": "NavIC/IRNSS",
    "S": "SBAS",
}
_GEO_TILT_RAD = np.radians(-5.0)  # BDS GEO: rotation about X of BDS-SIS-ICD-B1I 5.2.4.12
_HALF_WEEK_S = 302_400.0
_GPS_EPOCH = np.datetime64(GPS_EPOCH, "ns")

#: georinex names of the Keplerian elements (IS-GPS-200 Table 20-III).
ORBIT_FIELDS = (
    "sqrtA",
    "Eccentricity",
    "Io",
    "Omega0",
    "omega",
    "M0",
    "DeltaN",
    "OmegaDot",
    "IDOT",
    "Cuc",
    "Cus",
    "Crc",
    "Crs",
    "Cic",
    "Cis",
    "Toe",
)
#: georinex names of the clock terms af0, af1, af2 (s, s/s, s/s^2) and the group delay T_GD (s).
#: For Galileo and BeiDou records ``TGD`` holds the group delay of the single-frequency user
#: (see :func:`read_rinex_nav`): BGD(E1,E5b) or BGD(E1,E5a), and T_GD1.
CLOCK_FIELDS = ("SVclockBias", "SVclockDrift", "SVclockDriftRate", "TGD")

#: Elements only a CNAV record has (`cnav_records`, IS-GPS-200 30.3.3.1 and 30.3.3.3.1.1):
#: the rate of the semi-major axis ``Adot`` (m/s), the rate of the mean motion difference
#: ``DeltaN0dot`` (rad/s^2) and the inter-signal corrections ``ISC_L1CA``, ``ISC_L2C`` and
#: ``ISC_L5I5`` (s; IS-GPS-705 20.3.3.3.1.2), and what a RINEX 4 CNAV record writes besides:
#: ``CNAV`` 1 for a record from CNAV, ``Top`` (s of week) and ``HealthL1L2L5`` (the 3-bit
#: health word of message type 10, L1 the high bit); with the value that means "absent" in a
#: record without them (an LNAV-style orbit, no ISC).
CNAV_FIELDS = {
    "Adot": 0.0,
    "DeltaN0dot": 0.0,
    "ISC_L1CA": float("nan"),
    "ISC_L2C": float("nan"),
    "ISC_L5I5": float("nan"),
    "CNAV": 0.0,
    "Top": float("nan"),
    "HealthL1L2L5": float("nan"),
}
#: Elements only some Galileo records have: ``FNAV`` 1 where the record's clock is for the
#: E1,E5a pair (F/NAV, RINEX data source bit 8; its ``TGD`` BGD(E1,E5a)), 0 for the E1,E5b
#: pair of I/NAV (and any other system's record).
GALILEO_FIELDS = {"FNAV": 0.0}
#: Elements only a BeiDou B-CNAV1/2/3 record has (RINEX 4 ``CNV1``-``CNV3``): ``BDS_CNAV`` 1,
#: the B1C pilot's and B2a pilot's group delays to B3I ``TGD_B1Cp``, ``TGD_B2ap`` (s), the data
#: components' ``ISC_B1Cd``, ``ISC_B2ad`` and B2b's ``TGD_B2bI`` (BDS-SIS-ICD-B1C 7.6.2).
BDS_CNAV_FIELDS = {
    "BDS_CNAV": 0.0,
    "TGD_B1Cp": float("nan"),
    "TGD_B2ap": float("nan"),
    "ISC_B1Cd": float("nan"),
    "ISC_B2ad": float("nan"),
    "TGD_B2bI": float("nan"),
}
#: Every element a record may lack, with the value that means "absent".
OPTIONAL_FIELDS = {**CNAV_FIELDS, **GALILEO_FIELDS, **BDS_CNAV_FIELDS}
#: BeiDou carriers (Hz) whose user takes a B-CNAV record's group delay: B1C, B2a.
_BDS_CNAV_DELAYS = {BEIDOU_B1C.carrier_freq_hz: "TGD_B1Cp", GPS_L5I.carrier_freq_hz: "TGD_B2ap"}


#: Keplerian and clock fields of a broadcast navigation message (the decoders' names, angles
#: in semicircles) -> georinex names of `read_rinex_nav` (angles in radians there).
KEPLER_TO_RINEX = {
    "sqrt_a_sqrtm": "sqrtA",
    "e": "Eccentricity",
    "i0_sc": "Io",
    "omega0_sc": "Omega0",
    "omega_sc": "omega",
    "m0_sc": "M0",
    "delta_n_sc_s": "DeltaN",
    "omega_dot_sc_s": "OmegaDot",
    "idot_sc_s": "IDOT",
    "cuc_rad": "Cuc",
    "cus_rad": "Cus",
    "crc_m": "Crc",
    "crs_m": "Crs",
    "cic_rad": "Cic",
    "cis_rad": "Cis",
    "toe_s": "Toe",
    "af0_s": "SVclockBias",
    "af1_s_s": "SVclockDrift",
    "af2_s_s2": "SVclockDriftRate",
}
#: The fields of `KEPLER_TO_RINEX` broadcast in semicircles (or semicircles per second).
SEMICIRCLE_FIELDS = ("delta_n_sc_s", "m0_sc", "omega0_sc", "i0_sc", "omega_sc", "omega_dot_sc_s", "idot_sc_s")


def _system_error(letter: str) -> ValueError:
    name = _SYSTEM_NAMES.get(letter, "unknown")
    if letter == "R":
        return ValueError(
            "GLONASS (R) records are position/velocity/acceleration state vectors; this code does not "
            "propagate them (GPS G, QZSS J, Galileo E, BeiDou C only)"
        )
    return ValueError(
        f"system {letter!r} ({name}) is not handled by this code (GPS G, QZSS J, Galileo E, BeiDou C only)"
    )


def _letters(sv: np.ndarray) -> np.ndarray:
    """System letter of each satellite name; a ValueError for a system not handled."""
    letters = np.asarray(sv).astype("U1")
    for letter in np.unique(letters):
        if letter not in SYSTEMS:
            raise _system_error(str(letter))
    return letters


def is_bds_geo(sv: np.ndarray | list[str]) -> np.ndarray:
    """True for BeiDou GEO satellites: C01-C05 and C59-C63 (the PRNs of BDS-SIS-ICD-B1I 3.0)."""
    sv = np.atleast_1d(np.asarray(sv).astype(str))
    prn = np.array([int(s[1:]) if s[1:].isdigit() else 0 for s in sv])
    return (sv.astype("U1") == "C") & ((prn <= 5) | (prn >= 59))


@dataclass(frozen=True)
class Ephemerides:
    """Broadcast ephemeris records, one per entry (batch-first over records).

    Attributes
    ----------
    sv
        ``(N,)`` satellite of each record (``"G08"``, ``"E19"``, ``"C05"``).
    toc_s
        ``(N,)`` clock reference time, seconds of week in the record's own system time
        (GPS, QZSS and Galileo: GPS time; BeiDou: BDT), as ``elements["Toe"]``.
    elements
        ``ORBIT_FIELDS`` and ``CLOCK_FIELDS``, each ``(N,)``, as broadcast.
    health
        ``(N,)`` the SV health word (0: healthy): GPS SV health, Galileo SV health bits
        (signal health and data validity of E1-B, E5a and E5b: any flag set counts as not
        healthy), BeiDou SatH1.
    iode
        ``(N,)`` issue of data: GPS IODE, Galileo IODnav, BeiDou AODE.
    accuracy_m
        ``(N,)`` broadcast accuracy, m: GPS URA and BeiDou URA (``SVacc``), Galileo SISA
        (-1 where RINEX writes no accuracy prediction); None where not read.
    """

    sv: np.ndarray
    toc_s: np.ndarray
    elements: dict[str, np.ndarray]
    health: np.ndarray
    iode: np.ndarray
    accuracy_m: np.ndarray | None = None

    @classmethod
    def concatenate(cls, records: list[Ephemerides]) -> Ephemerides:
        """One `Ephemerides` of several, in order; a record without an `OPTIONAL_FIELDS`
        element another has takes its absent value (the accuracy is kept where every record
        has one).

        Raises
        ------
        ValueError
            Without a record, or where a record lacks an element that is not an optional one.
        """
        if not records:
            raise ValueError("no ephemeris record to concatenate")
        keys = list(dict.fromkeys(k for r in records for k in r.elements))

        def column(r: Ephemerides, k: str) -> np.ndarray:
            if k in r.elements:
                return r.elements[k]
            if k not in OPTIONAL_FIELDS:
                raise ValueError(f"ephemeris record of {', '.join(map(str, r.sv))} has no element {k!r}")
            return np.full(r.sv.shape, OPTIONAL_FIELDS[k])

        accuracy = (
            None if any(r.accuracy_m is None for r in records) else np.concatenate([r.accuracy_m for r in records])
        )
        return cls(
            np.concatenate([r.sv for r in records]),
            np.concatenate([r.toc_s for r in records]),
            {k: np.concatenate([column(r, k) for r in records]) for k in keys},
            np.concatenate([r.health for r in records]),
            np.concatenate([r.iode for r in records]),
            accuracy,
        )

    def subset(self, index: np.ndarray) -> Ephemerides:
        return Ephemerides(
            self.sv[index],
            self.toc_s[index],
            {k: v[index] for k, v in self.elements.items()},
            self.health[index],
            self.iode[index],
            None if self.accuracy_m is None else self.accuracy_m[index],
        )

    def of_systems(self, systems: str) -> Ephemerides:
        """The records of the systems named by RINEX letters (``"E"``, ``"GEC"``).

        Raises
        ------
        ValueError
            For a system this code does not propagate (GLONASS ``R`` among them).
        """
        for letter in systems:
            if letter not in SYSTEMS:
                raise _system_error(letter)
        return self.subset(np.flatnonzero(np.isin(self.sv.astype("U1"), list(systems))))

    def select(self, sv: np.ndarray | list[str], t_s: float, healthy_only: bool = True) -> Ephemerides:
        """For each satellite of ``sv``, the record whose ``Toe`` is nearest ``t_s``
        (GPS seconds of week, converted to the record's system time; across the week
        crossover); healthy records only unless ``healthy_only`` is False.

        Raises
        ------
        KeyError
            Naming a satellite without a (healthy) record.
        ValueError
            Naming a satellite of a system this code does not propagate (GLONASS among them).
        """
        picks = []
        _letters(np.atleast_1d(sv))
        for name in np.atleast_1d(sv):
            ok = (self.sv == name) & ((self.health == 0) | (not healthy_only))
            if not ok.any():
                raise KeyError(f"no {'healthy ' if healthy_only else ''}ephemeris of {name}")
            idx = np.flatnonzero(ok)
            dt = _wrap_week(t_s - SYSTEM_TIME_OFFSET_S[str(name)[0]] - self.elements["Toe"][idx])
            picks.append(idx[np.argmin(np.abs(dt))])
        return self.subset(np.array(picks, dtype=int))


@dataclass(frozen=True)
class SatelliteState:
    """Satellite states at transmit times (shapes ``(..., 3)`` and ``(...)``).

    ``clock_s`` is the SV clock offset of IS-GPS-200 20.3.3.3.3.1 including the
    relativistic term (``relativistic_s``), for the ionosphere-free P1/P2 combination;
    ``clock_l1_s`` subtracts T_GD, for an L1 C/A single-frequency user (20.3.3.3.3.2).
    For a Galileo record ``clock_s`` is the clock of the record's dual-frequency pair
    (I/NAV: E1,E5b; F/NAV: E1,E5a) and ``clock_l1_s`` the E1 single-frequency user's,
    clock_s - BGD(E1,E5b) or clock_s - BGD(E1,E5a) (Galileo OS SIS ICD 5.1.5). For a
    BeiDou record ``clock_s`` is the B3I clock and ``clock_l1_s`` the B1I user's,
    clock_s - T_GD1 (BDS-SIS-ICD-B1I 5.2.4.10). Clocks are seconds, not a time scale:
    they need no BDT conversion.
    """

    position_m: np.ndarray
    velocity_mps: np.ndarray
    clock_s: np.ndarray
    clock_drift_s_s: np.ndarray
    relativistic_s: np.ndarray
    clock_l1_s: np.ndarray


def single_frequency_clock_s(
    eph: Ephemerides, state: SatelliteState, carrier_freq_hz: float, reference: SignalSpec = GPS_L1CA
) -> np.ndarray:
    r"""The SV clock offset (s) a single-frequency user of a signal at ``carrier_freq_hz``
    applies.

    GPS and QZSS: :math:`\Delta t_{SV} - \gamma\,T_{GD}`, with
    :math:`\gamma = (f_{ref}/f)^2` and ``reference`` the signal whose user T_GD serves
    as it is (IS-GPS-200 20.3.3.3.3.2: L1, so :math:`\gamma` is 1 on L1 and
    :math:`(77/60)^2 = 1.6469` on L2). For L2C this is the L2 P(Y) user's correction, which
    RTKLIB also takes when there is no CNAV ISC, as in a RINEX LNAV record. A CNAV record
    (`cnav_records`) with its inter-signal corrections gives an L2C user
    :math:`\Delta t_{SV} - T_{GD} + ISC_{L2C}` and an L1 C/A user
    :math:`\Delta t_{SV} - T_{GD} + ISC_{L1C/A}` instead (IS-GPS-200 30.3.3.3.1.1.1), and an
    L5 I5 user :math:`\Delta t_{SV} - T_{GD} + ISC_{L5I5}` (IS-GPS-705 20.3.3.3.1.2.2); an L5
    user without that ISC takes :math:`\gamma T_{GD}` with :math:`\gamma = (154/115)^2`, the
    same generic rule (no ICD defines it: a record without CNAV's ISCs says nothing of L5).
    Galileo on E5a: :math:`\Delta t_{SV} - (f_{E1}/f_{E5a})^2 BGD(E1,E5a)` from a record whose
    clock is for E1,E5a (``FNAV`` 1: F/NAV's, OS SIS ICD 5.1.5); NaN from an I/NAV record,
    whose clock is for E1,E5b (no E5a user's clock can be made of it). BeiDou, whose clocks
    are referred to B3I: on B1I :math:`\Delta t_{SV} - T_{GD1}` from a D1/D2 record; on B1C
    :math:`\Delta t_{SV} - T_{GD,B1Cp}` and on B2a :math:`\Delta t_{SV} - T_{GD,B2ap}` from a
    B-CNAV record (``BDS_CNAV`` 1, RINEX 4 ``CNV1``-``CNV3``; BDS-SIS-ICD-B1C 7.6.2, the
    pilot's: the data component's ISC is kept, not applied), NaN from it on another carrier;
    a D1/D2 record gives T_GD1's clock on every carrier (one carrier named for all systems,
    GPS L1's, says nothing of BeiDou's signal: a caller tracking B1C should give B-CNAV
    records, whose T_GD,B1Cp is B1C's). Other systems and carriers:
    ``state.clock_l1_s``, their own single-frequency user's (E1, B1I), whatever
    ``carrier_freq_hz``.
    """
    letters = np.asarray(eph.sv).astype("U1")
    return _beidou_clock(eph, state, carrier_freq_hz, letters, _clock_of_others(eph, state, carrier_freq_hz, reference))


def _beidou_clock(eph: Ephemerides, state: SatelliteState, carrier_freq_hz: float, letters, clock) -> np.ndarray:
    """BeiDou records' clocks kept to their own group delays: a B-CNAV record gives a user on
    B1C's or B2a's carrier ``Δt_SV - T_GD`` of that signal's pilot and no B1I user a clock (it
    has no T_GD1); a D1/D2 record gives ``Δt_SV - T_GD1`` (B1I's) on every carrier, as before
    (a call naming one carrier for all systems, e.g. GPS L1's, says nothing of BeiDou's)."""
    beidou = letters == "C"
    if not beidou.any():
        return clock
    cnav = beidou & (eph.elements.get("BDS_CNAV", np.zeros(letters.shape)) == 1.0)
    for hz, name in _BDS_CNAV_DELAYS.items():
        if abs(float(carrier_freq_hz) - hz) < 1.0:
            delay = eph.elements.get(name, np.full(letters.shape, np.nan))
            return np.where(cnav, state.clock_s - delay, clock)
    return np.where(cnav, np.nan, clock)


def _clock_of_others(
    eph: Ephemerides, state: SatelliteState, carrier_freq_hz: float, reference: SignalSpec
) -> np.ndarray:
    """`single_frequency_clock_s` of every record before BeiDou's own group delays."""
    gamma = ionosphere_scale(carrier_freq_hz, reference)
    letters = np.asarray(eph.sv).astype("U1")
    gps = np.isin(letters, ["G", "J"])
    if gamma == 1.0:  # the reference's carrier (L1: C/A, E1, B1C): the record's own clock, as it was
        isc_l1 = eph.elements.get("ISC_L1CA")
        if isc_l1 is None:  # no CNAV record: T_GD alone, as LNAV's (and E1's, B1I's) user takes it
            return state.clock_l1_s
        return np.where(gps & np.isfinite(isc_l1), state.clock_l1_s + np.nan_to_num(isc_l1), state.clock_l1_s)
    scaled = state.clock_s - gamma * (state.clock_s - state.clock_l1_s)  # Δt_SV - γ T_GD (or BGD)
    e5a = abs(float(carrier_freq_hz) - GPS_L5I.carrier_freq_hz) < 1.0  # Galileo E5a: L5's carrier
    clock = np.where(gps | (e5a & (letters == "E")), scaled, state.clock_l1_s)
    for name, band in (("ISC_L2C", GPS_L2C), ("ISC_L5I5", GPS_L5I)):
        isc = eph.elements.get(name)
        if isc is not None and abs(float(carrier_freq_hz) - band.carrier_freq_hz) < 1.0:
            clock = np.where(gps & np.isfinite(isc), state.clock_l1_s + np.nan_to_num(isc), clock)
    return np.where(clock_defined(eph, carrier_freq_hz), clock, np.nan)


def clock_defined(eph: Ephemerides, carrier_freq_hz: float) -> np.ndarray:
    """``(N,)`` whether each record gives a single-frequency user of ``carrier_freq_hz`` a
    clock (`single_frequency_clock_s`): every record but a Galileo one whose clock is for
    E1,E5b (``FNAV`` 0, I/NAV's) on E5a, where only an E1,E5a clock serves, and a BeiDou
    B-CNAV record off B1C's and B2a's carriers (it has no T_GD1)."""
    letters = np.asarray(eph.sv).astype("U1")
    cnav = (letters == "C") & (eph.elements.get("BDS_CNAV", np.zeros(letters.shape)) == 1.0)
    f = float(carrier_freq_hz)
    # A B-CNAV record serves B1C's and B2a's carriers only (no T_GD1 for B1I or another signal).
    ok = ~cnav | any(abs(f - hz) < 1.0 for hz in _BDS_CNAV_DELAYS)
    if abs(f - GPS_L5I.carrier_freq_hz) >= 1.0:
        return ok
    return ok & ((letters != "E") | (eph.elements.get("FNAV", np.zeros(letters.shape)) == 1.0))


def records_with_clock(eph: Ephemerides | None, carrier_freq_hz: float) -> Ephemerides | None:
    """The records of ``eph`` that give a clock on ``carrier_freq_hz`` (`clock_defined`);
    None without ``eph`` or without any such record."""
    if eph is None:
        return None
    keep = np.flatnonzero(clock_defined(eph, carrier_freq_hz))
    return eph.subset(keep) if keep.size else None


def require_records_with_clock(
    eph: Ephemerides, signal: SignalSpec, field: str, source: str, hint: str = ""
) -> Ephemerides:
    """`records_with_clock` of ``eph`` for ``signal``'s carrier, refused in one line naming
    ``field``, ``source`` (what the records came from) and ``hint`` when none gives its user
    a clock (`clock_defined`: only E5a refuses, a Galileo record without F/NAV's clock)."""
    usable = records_with_clock(eph, signal.carrier_freq_hz)
    if usable is None:
        if signal.system == "C":
            raise ConfigError(
                field,
                f"no record gives a {signal.name} user a clock: {source} holds BeiDou B-CNAV records only "
                f"(RINEX 4 CNV1-CNV3), which have no T_GD1 for it: give D1/D2 records{hint}",
            )
        raise ConfigError(
            field,
            f"no record gives a {signal.name} user a clock: {source} holds no Galileo F/NAV record (RINEX "
            f"data source bit 8: the clock for E5a,E1), which an E5a user's clock needs{hint}",
        )
    return usable


def ionosphere_scale(carrier_freq_hz: float, reference: SignalSpec = GPS_L1CA) -> float:
    """The factor :math:`(f_{ref}/f)^2` that takes a first-order ionospheric delay at
    ``reference``'s carrier (the Klobuchar model's is L1's, IS-GPS-200 20.3.3.5.2.5) to
    ``carrier_freq_hz`` (the delay goes as :math:`1/f^2`); exactly 1 within 1e-9 of it (a
    carrier computed back from a wavelength)."""
    scale = (reference.carrier_freq_hz / float(carrier_freq_hz)) ** 2
    return 1.0 if abs(scale - 1.0) < 1e-9 else scale


def _wrap_week(dt_s):
    """Account for the beginning or end of week crossover (IS-GPS-200 20.3.3.4.3)."""
    return (np.asarray(dt_s, float) + _HALF_WEEK_S) % (2 * _HALF_WEEK_S) - _HALF_WEEK_S


def gps_seconds_of_week(epoch: np.ndarray) -> np.ndarray:
    """GPS seconds of week of ``datetime64`` epochs given in GPS time."""
    ns = (np.asarray(epoch, dtype="datetime64[ns]") - _GPS_EPOCH).astype(np.int64)
    return (ns % (604_800 * 10**9)) / 1e9


def satellite_state(eph: Ephemerides, t_s: np.ndarray | float) -> SatelliteState:
    """Position, velocity (ECEF: WGS 84, Galileo's GTRF, BeiDou's CGCS2000) and clock of
    each record at GPS time ``t_s``.

    Position follows the user algorithm of IS-GPS-200 Table 20-IV (Kepler's equation by
    Newton's method, second-harmonic corrections, Earth-fixed node longitude) with each
    system's GM and Earth rotation rate; BeiDou GEO records (:func:`is_bds_geo`) take the
    ICD's GEO formula (BDS-SIS-ICD-B1I 3.0 5.2.4.12); a CNAV record (`CNAV_FIELDS`) adds the
    rates of its semi-major axis and mean motion (IS-GPS-200 Table 30-II, with
    :math:`A_0` in the relativistic term). Velocity is the time derivative
    (analytic); the clock is af0 + af1 (t - toc) + af2 (t - toc)^2 plus the relativistic
    term F e sqrt(A) sin E (IS-GPS-200 20.3.3.3.3.1; Galileo ICD 5.1.4; BDS ICD 5.2.4.10),
    in the record's system time (BDT = GPST - 14 s).

    Parameters
    ----------
    eph
        ``S`` records (one per satellite, :meth:`Ephemerides.select`).
    t_s
        Transmit times, GPS seconds of week, broadcastable to ``(..., S)``: the satellite
        time corrected for the SV clock, as the ICD's ``t``.

    Returns
    -------
    SatelliteState
        Arrays of shape ``(..., S, 3)`` and ``(..., S)``.
    """
    e = eph.elements
    letters = _letters(eph.sv)
    gps = np.isin(letters, _GPS_CONSTANTS)
    geo = is_bds_geo(eph.sv)
    gm = np.where(gps, GM_GPS_M3_S2, GM_GAL_BDS_M3_S2)
    we = np.where(letters == "C", OMEGA_EARTH_BDS_RAD_S, OMEGA_EARTH_RAD_S)
    f_rel = np.where(gps, F_RELATIVISTIC_S_SQRTM, F_RELATIVISTIC_GAL_BDS_S_SQRTM)
    offset = np.array([SYSTEM_TIME_OFFSET_S[str(x)] for x in letters], dtype=float).reshape(letters.shape)
    t = np.asarray(t_s, dtype=float) - offset  # GPS time to each record's system time
    tk = _wrap_week(t - e["Toe"])
    # A CNAV record's rates (IS-GPS-200 Table 30-II): A_k = A_0 + Adot t_k and
    # n_A = n_0 + Delta n_0 + Delta n0dot t_k / 2; zero in an LNAV-style record.
    a_dot, dn_dot = e.get("Adot", 0.0), e.get("DeltaN0dot", 0.0)
    A0 = e["sqrtA"] ** 2
    A = A0 + a_dot * tk
    n0 = np.sqrt(gm / A0**3)
    n = n0 + e["DeltaN"]
    M = e["M0"] + (n + 0.5 * dn_dot * tk) * tk
    ecc = e["Eccentricity"]
    E = np.array(M, dtype=float, copy=True)
    for _ in range(10):  # Newton on Kepler's equation; converges in 3-4 steps for e < 0.03
        E = E - (E - ecc * np.sin(E) - M) / (1 - ecc * np.cos(E))
    sinE, cosE = np.sin(E), np.cos(E)
    nu = np.arctan2(np.sqrt(1 - ecc**2) * sinE, cosE - ecc)
    phi = nu + e["omega"]
    s2, c2 = np.sin(2 * phi), np.cos(2 * phi)
    u = phi + e["Cus"] * s2 + e["Cuc"] * c2
    r = A * (1 - ecc * cosE) + e["Crs"] * s2 + e["Crc"] * c2
    i = e["Io"] + e["Cis"] * s2 + e["Cic"] * c2 + e["IDOT"] * tk
    x_orb, y_orb = r * np.cos(u), r * np.sin(u)
    # BDS GEO: the node in the inertial frame of the broadcast elements (no -ωe tk), BDS ICD 5.2.4.12.
    node_rate = np.where(geo, e["OmegaDot"], e["OmegaDot"] - we)
    node = e["Omega0"] + node_rate * tk - we * e["Toe"]
    cn, sn, ci, si = np.cos(node), np.sin(node), np.cos(i), np.sin(i)
    x = x_orb * cn - y_orb * ci * sn
    y = x_orb * sn + y_orb * ci * cn
    z = y_orb * si
    # Time derivatives of the same chain.
    E_dot = (n + dn_dot * tk) / (1 - ecc * cosE)
    phi_dot = np.sqrt(1 - ecc**2) * E_dot / (1 - ecc * cosE)
    u_dot = phi_dot * (1 + 2 * (e["Cus"] * c2 - e["Cuc"] * s2))
    r_dot = a_dot * (1 - ecc * cosE) + A * ecc * sinE * E_dot + 2 * phi_dot * (e["Crs"] * c2 - e["Crc"] * s2)
    i_dot = e["IDOT"] + 2 * phi_dot * (e["Cis"] * c2 - e["Cic"] * s2)
    xo_dot = r_dot * np.cos(u) - y_orb * u_dot
    yo_dot = r_dot * np.sin(u) + x_orb * u_dot
    vx = xo_dot * cn - yo_dot * ci * sn + y_orb * si * sn * i_dot - y * node_rate
    vy = xo_dot * sn + yo_dot * ci * cn - y_orb * si * cn * i_dot + x * node_rate
    vz = yo_dot * si + y_orb * ci * i_dot
    if geo.any():
        x, y, z, vx, vy, vz = _geo_to_earth_fixed(geo, we * tk, (x, y, z), (vx, vy, vz), we)
    dtc = _wrap_week(t - eph.toc_s)
    rel = f_rel * ecc * e["sqrtA"] * sinE
    rel_dot = f_rel * ecc * e["sqrtA"] * cosE * E_dot
    clock = e["SVclockBias"] + e["SVclockDrift"] * dtc + e["SVclockDriftRate"] * dtc**2 + rel
    drift = e["SVclockDrift"] + 2 * e["SVclockDriftRate"] * dtc + rel_dot
    return SatelliteState(np.stack([x, y, z], -1), np.stack([vx, vy, vz], -1), clock, drift, rel, clock - e["TGD"])


def _geo_to_earth_fixed(geo, theta, pos, vel, we):
    """BDS GEO: [X Y Z] = Rz(ωe tk) Rx(-5 deg) [X_GK Y_GK Z_GK] and its time derivative
    (BDS-SIS-ICD-B1I 3.0 5.2.4.12), where ``geo``; the other entries pass unchanged."""
    gx, gy, gz = pos
    c5, s5 = np.cos(_GEO_TILT_RAD), np.sin(_GEO_TILT_RAD)
    ct, st = np.cos(theta), np.sin(theta)

    def rotate(ax, ay, az):
        bx, by, bz = ax, c5 * ay + s5 * az, -s5 * ay + c5 * az  # Rx(phi) = [[1,0,0],[0,c,s],[0,-s,c]]
        return ct * bx + st * by, -st * bx + ct * by, bz  # Rz(theta) = [[c,s,0],[-s,c,0],[0,0,1]]

    px, py, pz = rotate(gx, gy, gz)
    wx, wy, wz = rotate(*vel)
    wx, wy = wx + we * py, wy - we * px  # d/dt Rz(ωe tk) v = Rz v' + ωe ((Rz v)_y, -(Rz v)_x, 0)
    out = [np.where(geo, new, old) for new, old in zip((px, py, pz, wx, wy, wz), (*pos, *vel))]
    return tuple(out)


#: Per system: georinex names of (group delay source(s), health, issue of data, accuracy).
_SYSTEM_FIELDS = {
    "G": (("TGD",), "health", "IODE", "SVacc"),
    "J": (("TGD",), "health", "IODE", "SVacc"),  # RINEX 3 QZSS records: GPS's fields
    "E": (("BGDe5a", "BGDe5b", "DataSrc"), "health", "IODnav", "SISA"),
    "C": (("TGD1",), "SatH1", "AODE", "SVacc"),
}


def _group_delay(letter: str, values: dict) -> np.ndarray:
    """The single-frequency user's group delay of each record (NaN where it cannot be told)."""
    if letter in _GPS_CONSTANTS:
        return values["TGD"]  # QZSS L1 C/A: T_GD as GPS's
    if letter == "C":
        return values["TGD1"]  # B1I user: clock - T_GD1 (BDS-SIS-ICD-B1I 3.0 5.2.4.10)
    # Galileo (OS SIS ICD 5.1.5, RINEX 3 data source bits 8 and 9): an I/NAV record's clock is
    # for E1,E5b, so the E1 user takes BGD(E1,E5b); an F/NAV record's is for E1,E5a: BGD(E1,E5a).
    src = np.where(np.isfinite(values["DataSrc"]), values["DataSrc"], 0).astype(np.int64)
    return np.where(src & 512, values["BGDe5b"], np.where(src & 256, values["BGDe5a"], np.nan))


def read_rinex_nav(
    path: str | Path, systems: str = "G", cnav_band: str = "L2", bds_messages: str = "D1D2"
) -> Ephemerides:
    """Every complete ephemeris record of the ``systems`` (RINEX letters, ``"G"``,
    ``"GEC"``) in a RINEX 2 or 3 navigation file (georinex), or a RINEX 4 one (`rinex4_nav`;
    its GPS and QZSS CNAV and CNV2 records too, their health the ``cnav_band``'s bit of the
    L1/L2/L5 word: ``"L1"``, ``"L2"`` or ``"L5"``; of BeiDou's, the D1/D2 records
    (``bds_messages="D1D2"``, a B1I user's, as a RINEX 3 file holds) or the B-CNAV records
    ``CNV1``-``CNV3`` (``"CNAV"``, a B1C or B2a user's: `BDS_CNAV_FIELDS`), never both, so that
    no B1I fix takes a B-CNAV record of the same hour).

    A Galileo record also holds ``elements["FNAV"]``: 1 where its clock is for E1,E5a (data
    source bit 8 without bit 9), 0 otherwise (`GALILEO_FIELDS`).

    ``elements["TGD"]`` holds each record's group delay for the single-frequency user:
    GPS T_GD (L1 C/A); Galileo BGD(E1,E5b) for an I/NAV record (RINEX data source bit 9:
    clock for E5b,E1) and BGD(E1,E5a) for an F/NAV one (bit 8), for an E1 user (OS SIS ICD
    5.1.5); BeiDou T_GD1 (B1I). Where a file has an I/NAV and an F/NAV record of the same
    satellite and epoch both are read (georinex's ``E19`` and ``E19_1``, both named ``E19``
    here), and :meth:`Ephemerides.select` takes the one read first (georinex: file order).
    A record georinex misreads (its fields after BROADCAST ORBIT 5 shifted by one, seen in
    IGS merged files) is left out with a warning naming how many.

    Raises
    ------
    DataFileError
        If the file is missing, unreadable or holds no complete record of the systems (one
        line, naming the file).
    ValueError
        For a system this code does not propagate (GLONASS ``R``: state vectors).
    """
    import georinex

    for letter in systems:
        if letter not in SYSTEMS:
            raise _system_error(letter)
    path = Path(path)
    if not path.exists():
        raise DataFileError(str(path), None, "no such file")
    from .rinex4_nav import is_rinex4

    if is_rinex4(path):  # georinex reads RINEX 2 and 3 only
        return _read_rinex4(path, systems, cnav_band, bds_messages)
    if bds_messages != "D1D2" and "C" in systems:
        raise DataFileError(
            str(path), None, "BeiDou B-CNAV records are RINEX 4's (CNV1-CNV3): this file is RINEX 2 or 3"
        )
    names = "/".join(_SYSTEM_NAMES[letter] for letter in systems)
    parts = []
    for letter in dict.fromkeys(systems):
        try:
            with warnings.catch_warnings():  # georinex's xarray calls emit FutureWarnings per record
                warnings.simplefilter("ignore", FutureWarning)
                nav = georinex.load(path, use=letter)
        except Exception as exc:  # noqa: BLE001 - georinex raises many types
            raise DataFileError(str(path), None, f"georinex could not read it: {type(exc).__name__}: {exc}") from None
        if nav.attrs.get("rinextype") != "nav":
            raise DataFileError(str(path), 1, f"not a navigation file (RINEX type {nav.attrs.get('rinextype')!r})")
        # A RINEX 2 file of one system comes back whatever ``use`` asked: keep this system's satellites.
        own = [name for name in nav.sv.values.astype(str) if name[:1] == letter] if "sv" in nav.dims else []
        if not own and len(systems) > 1:
            continue  # none of this system's records: the others may be there
        if not own:
            raise DataFileError(
                str(path),
                None,
                f"not a {_SYSTEM_NAMES[letter]} navigation file: it holds no {_SYSTEM_NAMES[letter]} ({letter}) record",
            )
        nav = nav.sel(sv=own)
        delay_fields, health, iod, accuracy = _SYSTEM_FIELDS[letter]
        orbit_clock = ORBIT_FIELDS + CLOCK_FIELDS[:3]
        fields = orbit_clock + delay_fields + (health, iod)
        missing = [f for f in fields if f not in nav.data_vars]
        if missing:
            raise DataFileError(
                str(path), None, f"not a {_SYSTEM_NAMES[letter]} navigation file: lacks {', '.join(missing)}"
            )
        values = {f: nav[f].values for f in fields}  # (time, sv)
        values["TGD"] = _group_delay(letter, values)
        required = orbit_clock + ("TGD", health, iod)
        ok = np.all([np.isfinite(values[f]) for f in required], axis=0)
        # georinex misreads a record whose orbit lines carry more fields than the file's
        # first records (IGS merges of Galileo I/NAV and F/NAV): its later fields shift by
        # one, so the health word takes the SISA (3.12 m) and the transmission time a BGD.
        # (Only Galileo's are checked: a GPS or BDS transmission time may be negative by the RINEX rules.)
        with np.errstate(invalid="ignore"):
            misread = ok & ((values[health] != np.round(values[health])) | (values[health] < 0)) & (letter == "E")
        if misread.any():
            warnings.warn(
                f"{path.name}: {int(misread.sum())} {_SYSTEM_NAMES[letter]} records misread by georinex "
                f"(fields shifted after BROADCAST ORBIT 5: the health word is not an integer), not used",
                stacklevel=2,
            )
            ok &= ~misread
        ti, si = np.nonzero(ok)
        acc = nav[accuracy].values[ti, si].astype(float) if accuracy in nav.data_vars else np.full(ti.size, np.nan)
        # The record's epoch is its Toc, written in the system's own time (BDT for BeiDou);
        # its seconds of week are those of the calendar date, as for GPS.
        # georinex names a second record of the same satellite and epoch "E19_1" (Galileo I/NAV and F/NAV).
        sv = np.array([name.split("_")[0] for name in nav.sv.values[si].astype(str)], dtype=str)
        elements = {f: values[f][ti, si].astype(float) for f in ORBIT_FIELDS + CLOCK_FIELDS}
        if letter == "E":  # the clock's pair (data source bits 8, 9): E1,E5a for F/NAV's
            src = np.nan_to_num(values["DataSrc"][ti, si]).astype(np.int64)
            elements["FNAV"] = (((src & 256) != 0) & ((src & 512) == 0)).astype(float)
        parts.append(
            (
                sv,
                gps_seconds_of_week(nav.time.values[ti]),
                elements,
                values[health][ti, si].astype(float),
                values[iod][ti, si].astype(float),
                acc,
            )
        )
    if not parts or sum(p[0].size for p in parts) == 0:
        raise DataFileError(str(path), None, f"no complete {names} ephemeris record")
    names_read = list(dict.fromkeys(k for p in parts for k in p[2]))
    return Ephemerides(
        np.concatenate([p[0] for p in parts]),
        np.concatenate([p[1] for p in parts]),
        {
            f: np.concatenate([p[2].get(f, np.full(p[0].size, OPTIONAL_FIELDS.get(f, np.nan))) for p in parts])
            for f in names_read
        },
        np.concatenate([p[3] for p in parts]),
        np.concatenate([p[4] for p in parts]),
        np.concatenate([p[5] for p in parts]),
    )


def _read_rinex4(path: Path, systems: str, cnav_band: str, bds_messages: str = "D1D2") -> Ephemerides:
    """`read_rinex_nav` of a RINEX 4 file: its ``EPH`` records of `rinex4_nav.EPH_LAYOUTS`
    with the fields and meanings of a RINEX 3 file's (file order kept); a CNAV record's
    ``Toe`` its epoch, its health the ``cnav_band`` bit, its issue of data t_oe / 300 and
    its accuracy the URA_ED index's metres, as `cnav_records` gives a decoded one."""
    from .rinex4_nav import CNAV_HEALTH_BITS, ISC_ABSENT_S, eph_tables, scan_rinex4_nav
    from .ura import ura_ed_m

    if cnav_band not in CNAV_HEALTH_BITS:
        raise ValueError(f"cnav_band {cnav_band!r}: one of {', '.join(CNAV_HEALTH_BITS)}")
    if bds_messages not in ("D1D2", "CNAV"):
        raise ValueError(f"bds_messages {bds_messages!r}: D1D2 or CNAV")
    _, records = scan_rinex4_nav(path)
    beidou_cnav = bds_messages == "CNAV"
    wanted = [
        r
        for r in records
        if r.kind == "EPH" and r.sv[:1] in systems and (r.sv[:1] != "C" or r.message.startswith("CNV") == beidou_cnav)
    ]
    parts = []
    for index, letter, message, group, values in eph_tables(wanted):
        sv = np.array([r.sv for r in group], dtype=str)
        toc_s = gps_seconds_of_week(np.array([r.epoch for r in group])).astype(float)
        elements: dict[str, np.ndarray] = {}
        if letter == "C" and message.startswith("CNV"):
            health = values["health"]
            # CNV1/CNV2 carry an IODE; CNV3 none: t_oe / 300 stands for it, as for GPS CNAV.
            iod = values["IODE"] if "IODE" in values else np.round(values["Toe"] / 300.0)
            accuracy = np.full(sv.size, np.nan)  # SISAI indices: no metres assigned here
            values["TGD"] = np.full(sv.size, np.nan)  # no B1I group delay: a B1I user gets no clock
            for name in ("TGD_B1Cp", "TGD_B2ap", "ISC_B1Cd", "ISC_B2ad", "TGD_B2bI"):
                if name in values:
                    elements[name] = values[name]
            elements.update(Adot=values["Adot"], DeltaN0dot=values["DeltaN0dot"], BDS_CNAV=np.ones(sv.size))
        elif message in ("CNAV", "CNV2"):
            values["Toe"] = toc_s  # RINEX 4 writes no t_oe: it is t_oc
            word = np.nan_to_num(values["health"], nan=-1).astype(np.int64)
            health = np.where(word < 0, np.nan, (word >> CNAV_HEALTH_BITS[cnav_band]) & 1).astype(float)
            iod = np.round(values["Toe"] / 300.0)
            accuracy = np.array([ura_ed_m(int(u)) if np.isfinite(u) else np.nan for u in values["URAI_ED"]])
            for isc in ("ISC_L1CA", "ISC_L2C", "ISC_L5I5"):
                elements[isc] = np.where(values[isc] == ISC_ABSENT_S, np.nan, values[isc])
            elements.update(
                Adot=values["Adot"],
                DeltaN0dot=values["DeltaN0dot"],
                CNAV=np.ones(sv.size),
                Top=values["Top"],
                HealthL1L2L5=values["health"],
            )
        else:
            delay_fields, health_name, iod_name, accuracy_name = _SYSTEM_FIELDS[letter]
            values["TGD"] = _group_delay(letter, values)
            health, iod, accuracy = values[health_name], values[iod_name], values[accuracy_name]
            if letter == "E":
                src = np.nan_to_num(values["DataSrc"]).astype(np.int64)
                elements["FNAV"] = (((src & 256) != 0) & ((src & 512) == 0)).astype(float)
        for name in ORBIT_FIELDS + CLOCK_FIELDS:
            elements[name] = values[name]
        needed = ORBIT_FIELDS + (CLOCK_FIELDS[:3] if letter == "C" and message.startswith("CNV") else CLOCK_FIELDS)
        complete = np.all([np.isfinite(elements[f]) for f in needed], axis=0)
        keep = np.flatnonzero(complete & np.isfinite(health) & np.isfinite(iod))
        if keep.size:
            parts.append(
                (
                    index[keep],
                    Ephemerides(
                        sv[keep],
                        toc_s[keep],
                        {k: v[keep].astype(float) for k, v in elements.items()},
                        health[keep].astype(float),
                        iod[keep].astype(float),
                        accuracy[keep].astype(float),
                    ),
                )
            )
    if not parts:
        read = sorted({f"{r.sv[:1]} {r.message}" for r in wanted})
        held = f" (it holds {', '.join(read)}: none of them read here)" if read else ""
        raise DataFileError(str(path), None, f"no complete {systems} ephemeris record{held}")
    merged = Ephemerides.concatenate([p[1] for p in parts])
    return merged.subset(np.argsort(np.concatenate([p[0] for p in parts]), kind="stable"))
