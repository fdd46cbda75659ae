"""The receiver tests' I/NAV recordings: Galileo satellites of real broadcast records
(tests/data/galileo_inav_20feb2022_05h.rnx) seen from a station, each sending E1-B with
BOC(1,1) carrying its I/NAV (`inav.inav_symbols`) with the code phase, Doppler and symbol
timing of the geometry (light time, Earth rotation, satellite clock; updated every 0.5 s),
45 dB-Hz, complex int16 SigMF at 4 MHz. GST is taken as GPS time (the GGTO, nanoseconds,
left out): the records' Toe and the signals' GST share one time scale."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gnssframework.navigation import inav
from gnssframework.navigation.ephemeris import read_rinex_nav, satellite_state
from gnssframework.signal.galileo_e1 import GALILEO_E1B_BOC11
from light_time import signal_flight
from noisy_recording import signal_chunks, write_noisy_recording

WN = 1174  # the GST week of the records (2022-02-20: GPS week 2198)
GPS_WEEK = WN + 1024
NAV = Path(__file__).parent / "data" / "galileo_inav_20feb2022_05h.rnx"
#: The IGS station VILL (Villafranca, Spain), ECEF (m).
STATION = np.array([4849833.676, -335048.888, 4116014.971])
FS = 4e6
SIGNAL = GALILEO_E1B_BOC11


def galileo_records():
    return read_rinex_nav(NAV, systems="E")


def satellite_time(eph, t_rx):
    """Satellite time of the signal received at true time ``t_rx`` by the station."""
    tau, clock, _ = signal_flight(eph, t_rx, STATION)
    return t_rx - tau + clock


def highest(nav, t, n):
    """The ``n`` satellites highest above the station at ``t`` (records within 2 h of ``t``)."""
    sel = nav.subset(np.flatnonzero((nav.health == 0) & (np.abs(nav.elements["Toe"] - t) < 7200)))
    up = STATION / np.linalg.norm(STATION)
    los = satellite_state(sel, t).position_m - STATION
    el = los @ up / np.linalg.norm(los, axis=1)
    return sel.subset(np.argsort(-el)[:n])


def inav_data(sats, t_sv0: np.ndarray, duration_s: float) -> list[tuple[np.ndarray, float]]:
    """Each satellite's I/NAV symbols (`inav.inav_symbols`) for ``duration_s`` from 0.1 s
    before its satellite time ``t_sv0``, with the time into the first."""
    return [
        inav.inav_symbols(
            sats.subset(np.array([k])), WN, float(t_sv0[k]) - 0.1, int(duration_s * inav.SYMBOL_RATE_HZ) + 50
        )
        for k in range(sats.sv.size)
    ]


def satellite_chunks(groups, tow0: float, duration_s: float, cn0_dbhz: float, rng: np.random.Generator):
    """The signals (no noise) of every satellite of ``groups``, ``(records, signal, t_sv0,
    data)`` with ``t_sv0`` their satellite times at ``tow0`` and ``data`` each one's symbols
    from 0.1 s before it (`inav_data`, `lnav.lnav_symbols`), in `CHUNK_S` chunks at `FS`
    from time ``tow0``: code phase, Doppler and symbol timing of the geometry seen from
    `STATION`, updated every chunk (`noisy_recording.signal_chunks`). A generator
    (`write_noisy_recording` draws each chunk's noise after it)."""
    gens = [
        signal_chunks(
            sats,
            tow0,
            duration_s,
            signal,
            FS,
            satellite_time,
            [(np.asarray(bits, float), float(t_sv0[k]) - 0.1 - into) for k, (bits, into) in enumerate(data)],
            cn0_dbhz,
            rng,
        )
        for sats, signal, t_sv0, data in groups
    ]
    for parts in zip(*gens):
        yield sum(parts)


def write_inav_recording(path: Path, sats, tow0: float, duration_s: float, seed: int, cn0_dbhz: float = 45.0) -> Path:
    """Write ``duration_s`` of the satellites ``sats`` (an `Ephemerides`) from time ``tow0``."""
    rng = np.random.default_rng(seed)
    t_sv0 = satellite_time(sats, np.array(tow0))
    groups = [(sats, SIGNAL, t_sv0, inav_data(sats, t_sv0, duration_s))]
    return write_noisy_recording(path, satellite_chunks(groups, tow0, duration_s, cn0_dbhz, rng), FS, rng)


#: The E5a-I recordings' records: the I/NAV file's (no file here holds F/NAV records of
#: more than three satellites), relabelled as F/NAV ones (``FNAV`` 1: clock for E1,E5a, the
#: I/NAV record's BGD(E1,E5b) standing for BGD(E1,E5a)). The orbits and clocks are real; the
#: pairing of clock and group delay is the test's, and generator and receiver share it.
E5A_FS = 10.5e6
#: (f_E1 / f_E5a)^2: the E5a single-frequency user's factor on BGD(E1,E5a) (OS SIS ICD 5.1.5).
E5A_GAMMA = (1575.42 / 1176.45) ** 2


def fnav_records():
    """The I/NAV file's records relabelled as F/NAV ones (see `E5A_FS`'s note)."""
    nav = galileo_records()
    return type(nav)(
        nav.sv, nav.toc_s, {**nav.elements, "FNAV": np.ones(nav.sv.size)}, nav.health, nav.iode, nav.accuracy_m
    )


def e5a_satellite_time(eph, t_rx):
    """The E5a SV time of the signal received at true time ``t_rx`` by the station: the E1
    user's clock (``clock - BGD(E1,E5a)`` of an F/NAV record) less ``(γ - 1) BGD(E1,E5a)``,
    computed here, not by the library."""
    return satellite_time(eph, t_rx) - (E5A_GAMMA - 1.0) * eph.elements["TGD"]


def write_e5a_recording(path: Path, sats, tow0: float, duration_s: float, seed: int, cn0_dbhz: float = 45.0) -> Path:
    """Write ``duration_s`` of Galileo E5a-I (F/NAV pages of each record, `fnav.fnav_symbols`,
    under CS20_1) from the satellites ``sats`` (F/NAV records) from GPS time ``tow0``, seen
    from `STATION`, complex int8 at `E5A_FS`."""
    from gnssframework.navigation import fnav
    from gnssframework.signal.galileo_e5a import GALILEO_E5AI

    rng = np.random.default_rng(seed)
    t_sv0 = e5a_satellite_time(sats, np.array(tow0))
    streams = []
    for k in range(sats.sv.size):
        symbols, into = fnav.fnav_symbols(
            sats.subset(np.array([k])), WN, float(t_sv0[k]) - 0.1, int(duration_s * 50) + 20
        )
        streams.append((symbols.astype(float), float(t_sv0[k]) - 0.1 - into))
    chunks = signal_chunks(sats, tow0, duration_s, GALILEO_E5AI, E5A_FS, e5a_satellite_time, streams, cn0_dbhz, rng)
    return write_noisy_recording(path, chunks, E5A_FS, rng, fmt="ci8")


#: The B1I recordings' records: the I/NAV file's, relabelled as BeiDou D1 ones, E nn as
#: C(nn + 20) (PRN 21-56: MEO numbers, no GEO), their times read as BDT. The orbits and
#: clocks are real Galileo ones; the BeiDou constants (CGCS2000's Earth rotation, BDT) are
#: applied to them by generator and receiver alike, and T_GD1 is the record's BGD. Only the
#: satellites whose af0 fits D1's 24 bits (under 2^-10 s: some Galileo clocks are 5 ms off).
B1I_FS = 4.2e6  # no ratio of small integers with 2.046 Mchip/s (none of 4.092 MHz's dead band)
BDT_WEEK = GPS_WEEK - 1356


def bds_records():
    """The I/NAV file's records relabelled as BeiDou ones (see `B1I_FS`'s note)."""
    nav = galileo_records()
    nav = nav.subset(np.flatnonzero(np.abs(nav.elements["SVclockBias"]) < 2.0**-10))
    sv = np.array([f"C{int(s[1:]) + 20:02d}" for s in nav.sv])
    elements = {k: v for k, v in nav.elements.items() if k != "FNAV"}
    return type(nav)(sv, nav.toc_s, elements, nav.health, nav.iode, nav.accuracy_m)


def d1_streams(sats, t_sv0: np.ndarray, duration_s: float, iono=None) -> list[tuple[np.ndarray, float]]:
    """Each BeiDou satellite's D1 bits (`d1nav.d1_symbols`, ``iono`` the Klobuchar
    coefficients of subframe 1) for ``duration_s`` from 0.1 s before its SV time ``t_sv0``
    (GPS time; its SOW is BDT, 14 s less), with the SV time (GPS) of the first bit's start:
    the streams of `noisy_recording.signal_chunks`."""
    from gnssframework.navigation import d1nav

    streams = []
    for k in range(sats.sv.size):
        bits, into = d1nav.d1_symbols(
            sats.subset(np.array([k])), BDT_WEEK, float(t_sv0[k]) - 14.0 - 0.1, int(duration_s * 50) + 20, iono
        )
        streams.append((bits.astype(float), float(t_sv0[k]) - 0.1 - into))
    return streams


def ionosphere_delayed(sv_time, iono):
    """``sv_time`` with the ionosphere of the broadcast model ``iono`` between each satellite
    and `STATION`: the signal received at ``t_rx`` left the satellite the model's delay
    earlier (the code's group delay; the carrier is delayed alike here, where it should be
    advanced: the fixes read the code)."""
    import pymap3d

    lat, lon, h = pymap3d.ecef2geodetic(*STATION)

    def delayed(sats, t_rx):
        t = np.asarray(t_rx, float)
        pos = signal_flight(sats, t, STATION).position_m
        az, el, _ = pymap3d.ecef2aer(pos[..., 0], pos[..., 1], pos[..., 2], lat, lon, h)
        return sv_time(sats, t) - iono.delay_s(lat, lon, np.asarray(az), np.asarray(el), t)

    return delayed


def write_b1i_recording(
    path: Path, sats, tow0: float, duration_s: float, seed: int, cn0_dbhz: float = 45.0, iono=None
) -> Path:
    """Write ``duration_s`` of BeiDou B1I (D1 subframes of each record, `d1_streams`, under
    NH20) from the satellites ``sats`` (BeiDou records) from GPS time ``tow0``, seen from
    `STATION`, complex int8 at `B1I_FS`; with ``iono`` (a `bds_iono.BdsKlobuchar`) its
    coefficients in subframe 1 and its delay on every signal (`ionosphere_delayed`)."""
    from gnssframework.signal.beidou_b1i import BEIDOU_B1I

    rng = np.random.default_rng(seed)
    sv_time = satellite_time if iono is None else ionosphere_delayed(satellite_time, iono)
    t_sv0 = sv_time(sats, np.array(tow0))
    streams = d1_streams(sats, t_sv0, duration_s, iono)
    chunks = signal_chunks(sats, tow0, duration_s, BEIDOU_B1I, B1I_FS, sv_time, streams, cn0_dbhz, rng)
    return write_noisy_recording(path, chunks, B1I_FS, rng, fmt="ci8")


#: VILL's navigation file of 2018-06-19 (sbf2rin): its one BeiDou GEO record, C05.
VILL_NAV = Path(__file__).parent / "data" / "VILL00ESP_R_20181700000_06H_MN.rnx"


def geo_records(toe_bdt: float = 18_000.0):
    """Two BeiDou GEO records in view of `STATION` for ``toe_bdt`` (BDT s of week): VILL's
    real C05 (58.7 deg E, 11 deg up) moved to that Toe with its orbit in ECEF unchanged
    (Toe and toc shifted alike, Omega0 by the Earth's turn over the shift: the GEO formula
    of BDS-SIS-ICD-B1I 5.2.4.12 takes Omega0 - omega_e Toe), and the same orbit 38.5 deg
    further west as C01 (made up: 20 deg E, 33 deg up), so that two GEOs are in view."""
    from gnssframework.navigation.ephemeris import OMEGA_EARTH_BDS_RAD_S

    nav = read_rinex_nav(VILL_NAV, systems="C")
    c05 = nav.subset(np.flatnonzero(nav.sv == "C05")[:1])
    shift = toe_bdt - float(c05.elements["Toe"][0])
    out = []
    for sv, west_rad in (("C05", 0.0), ("C01", np.radians(38.5))):
        el = {k: np.array(v, float, copy=True) for k, v in c05.elements.items()}
        el["Toe"] = el["Toe"] + shift
        el["Omega0"] = np.angle(np.exp(1j * (el["Omega0"] + OMEGA_EARTH_BDS_RAD_S * shift - west_rad)))
        out.append(type(c05)(np.array([sv]), c05.toc_s + shift, el, c05.health, c05.iode, c05.accuracy_m))
    return type(c05).concatenate(out)


def d2_streams(sats, t_sv0: np.ndarray, duration_s: float) -> list[tuple[np.ndarray, float]]:
    """Each GEO satellite's D2 bits (`d2nav.d2_symbols`) for ``duration_s`` from 0.1 s
    before its SV time ``t_sv0`` (GPS time), with the SV time of the first bit's start:
    as `d1_streams` for D1."""
    from gnssframework.navigation import d2nav

    streams = []
    for k in range(sats.sv.size):
        bits, into = d2nav.d2_symbols(
            sats.subset(np.array([k])), BDT_WEEK, float(t_sv0[k]) - 14.0 - 0.1, int(duration_s * 500) + 200
        )
        streams.append((bits.astype(float), float(t_sv0[k]) - 0.1 - into))
    return streams


def write_b1i_geo_recording(
    path: Path, meo, geo, tow0: float, duration_s: float, seed: int, cn0_dbhz: float = 45.0
) -> Path:
    """As `write_b1i_recording`, with the GEO satellites ``geo`` beside the D1 ones ``meo``:
    B1I without NH code carrying D2 at 500 bit/s (`beidou-b1i-geo`), on the same carrier."""
    from gnssframework.signal.beidou_b1i import BEIDOU_B1I, BEIDOU_B1I_GEO

    rng = np.random.default_rng(seed)
    parts = []
    for sats, signal, streams in ((meo, BEIDOU_B1I, d1_streams), (geo, BEIDOU_B1I_GEO, d2_streams)):
        t_sv0 = satellite_time(sats, np.array(tow0))
        data = streams(sats, t_sv0, duration_s)
        parts.append(signal_chunks(sats, tow0, duration_s, signal, B1I_FS, satellite_time, data, cn0_dbhz, rng))
    chunks = (a + b for a, b in zip(*parts))
    return write_noisy_recording(path, chunks, B1I_FS, rng, fmt="ci8")
