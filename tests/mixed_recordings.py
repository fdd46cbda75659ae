"""The receiver tests' GPS + Galileo recording: Galileo satellites of real broadcast records
(tests/data/galileo_inav_20feb2022_05h.rnx, `inav_recordings`) sending E1-B (BOC(1,1)) with
their I/NAV, and GPS satellites sending L1 C/A with their LNAV, seen from VILL, each with
the code phase, Doppler and data timing of the geometry (light time, Earth rotation,
satellite clock; updated every 0.5 s), 45 dB-Hz, complex int16 SigMF at 4 MHz.

No GPS navigation file of that day is in tests/data: the GPS orbits are those of the
project's 2005 file (tests/data/07590920.05n) with their Toc and Toe moved to 18000 s of
the 2022 week (the Kepler elements unchanged: valid orbits at other longitudes), a
synthetic constellation the generator and the receiver share through `write_mixed_nav`.
GST is taken as GPS time (the generator has no GGTO): the fixes' Galileo-GPS clock
offset is the receiver's alone."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gnssframework.navigation import lnav
from gnssframework.navigation.ephemeris import Ephemerides, read_rinex_nav, satellite_state
from gnssframework.receiver.navigation.rinex_nav import NavRecord, write_rinex_nav
from gnssframework.signal.galileo_e1 import GALILEO_E1B_BOC11
from gnssframework.signal.gps_l1ca import GPS_L1CA
from inav_recordings import FS, GPS_WEEK, NAV as GALILEO_NAV, STATION, inav_data, satellite_chunks, satellite_time
from noisy_recording import write_noisy_recording

GPS_NAV = Path(__file__).parent / "data" / "07590920.05n"
TOE_S = 18000.0


def moved_gps_records() -> Ephemerides:
    """The 2005 file's first record of each GPS satellite, Toc and Toe at `TOE_S`."""
    nav = read_rinex_nav(GPS_NAV)
    _, first = np.unique(nav.sv, return_index=True)
    nav = nav.subset(np.sort(first))
    elements = dict(nav.elements)
    elements["Toe"] = np.full(nav.sv.size, TOE_S)
    return Ephemerides(nav.sv, np.full(nav.sv.size, TOE_S), elements, nav.health, nav.iode, nav.accuracy_m)


def highest(nav: Ephemerides, t: float, n: int) -> Ephemerides:
    """The ``n`` healthy satellites of ``nav`` highest above the station at ``t`` (records within 2 h)."""
    sel = nav.subset(np.flatnonzero((nav.health == 0) & (np.abs(nav.elements["Toe"] - t) < 7200)))
    sel = sel.subset(np.unique(sel.sv, return_index=True)[1])
    up = STATION / np.linalg.norm(STATION)
    los = satellite_state(sel, t).position_m - STATION
    el = los @ up / np.linalg.norm(los, axis=1)
    return sel.subset(np.argsort(-el)[:n])


def write_mixed_nav(path: Path, gps: Ephemerides) -> Path:
    """A RINEX 3.04 mixed navigation file: the ``gps`` records (`write_rinex_nav`) and every
    Galileo record of the I/NAV excerpt, for ``receive --ephemeris``."""
    gps_file = write_rinex_nav(
        path.with_suffix(".gps"),
        [NavRecord(int(s[1:]), gps.subset(np.array([k])), GPS_WEEK, TOE_S) for k, s in enumerate(gps.sv)],
    )
    body = []
    for f in (gps_file, GALILEO_NAV):
        lines = f.read_text().splitlines(keepends=True)
        body += lines[next(i for i, line in enumerate(lines) if "END OF HEADER" in line) + 1 :]
    header = (
        f"{'3.04':>9}{'':11}{'N: GNSS NAV DATA':<20}{'M: MIXED':<20}RINEX VERSION / TYPE\n{'':60}END OF HEADER       \n"
    )
    path.write_text(header + "".join(body))
    gps_file.unlink()
    return path


def write_mixed_recording(
    path: Path, gps, galileo, tow0: float, duration_s: float, seed: int, cn0_dbhz: float = 45.0
) -> Path:
    """Write ``duration_s`` of the GPS records ``gps`` and the Galileo ones ``galileo`` from time ``tow0``."""
    rng = np.random.default_rng(seed)
    t_gps, t_gal = satellite_time(gps, np.array(tow0)), satellite_time(galileo, np.array(tow0))
    lnav_data = [
        lnav.lnav_symbols(gps.subset(np.array([k])), GPS_WEEK, float(t_gps[k]) - 0.1, int(duration_s * 50) + 20)
        for k in range(gps.sv.size)
    ]
    groups = [
        (gps, GPS_L1CA, t_gps, lnav_data),
        (galileo, GALILEO_E1B_BOC11, t_gal, inav_data(galileo, t_gal, duration_s)),
    ]
    return write_noisy_recording(path, satellite_chunks(groups, tow0, duration_s, cn0_dbhz, rng), FS, rng)


#: GPS L1 C/A with BeiDou B1I in one complex recording: the band from B1I's lower main-lobe
#: edge (1559.052 MHz) to L1's upper one (1576.443 MHz), 17.39 MHz, centred in 17.6 MHz.
#: Each signal is made at a quarter of the rate (4.4 MHz, its own band) and interpolated.
WIDE_FS = 17.6e6
WIDE_UP = 4
WIDE_LO_HZ = 0.5 * ((1561.098e6 - 2.046e6) + (1575.42e6 + 1.023e6))


def _shifted_up(chunks, if_hz: float):
    """Chunks made at ``WIDE_FS / WIDE_UP`` around 0 Hz, interpolated to `WIDE_FS` by a
    polyphase low-pass (`scipy.signal.resample_poly`: the front end's band of each signal;
    a few samples at each chunk's edges are tapered) and moved to ``if_hz``, the carrier's
    phase continuous from chunk to chunk."""
    from scipy.signal import resample_poly

    from gnssframework.signal.if_samples import carrier_phasor

    start = 0
    for x in chunks:
        y = resample_poly(x, WIDE_UP, 1)
        # The phase at the chunk's first sample in whole turns removed, then its carrier
        # (two short tables: `carrier_phasor`).
        yield y * carrier_phasor(2 * np.pi * ((if_hz * start / WIDE_FS) % 1.0), 2 * np.pi * if_hz / WIDE_FS, y.size)
        start += y.size


def write_gps_bds_recording(
    path: Path, gps, bds, tow0: float, duration_s: float, seed: int, cn0_dbhz: float = 45.0
) -> Path:
    """Write ``duration_s`` of the GPS records ``gps`` (L1 C/A, LNAV) and the BeiDou ones
    ``bds`` (B1I, D1; `inav_recordings.bds_records`) from time ``tow0``, complex int8 at
    `WIDE_FS` around `WIDE_LO_HZ`: L1 at IF +7.67 MHz (the file's IF), B1I at -6.65 MHz,
    each at ``cn0_dbhz`` in the white noise of the whole band."""
    from gnssframework.signal.beidou_b1i import BEIDOU_B1I
    from inav_recordings import d1_streams
    from noisy_recording import signal_chunks

    rng = np.random.default_rng(seed)
    t_gps, t_bds = satellite_time(gps, np.array(tow0)), satellite_time(bds, np.array(tow0))
    lnav_streams = []
    for k in range(gps.sv.size):
        bits, into = lnav.lnav_symbols(
            gps.subset(np.array([k])), GPS_WEEK, float(t_gps[k]) - 0.1, int(duration_s * 50) + 20
        )
        lnav_streams.append((np.asarray(bits, float), float(t_gps[k]) - 0.1 - into))
    # At a quarter of the rate, the unit noise of the whole band is 4 times each signal's share.
    cn0_low = cn0_dbhz - 10 * np.log10(WIDE_UP)
    gens = [
        _shifted_up(
            signal_chunks(sats, tow0, duration_s, signal, WIDE_FS / WIDE_UP, satellite_time, streams, cn0_low, rng),
            signal.carrier_freq_hz - WIDE_LO_HZ,
        )
        for sats, signal, streams in (
            (gps, GPS_L1CA, lnav_streams),
            (bds, BEIDOU_B1I, d1_streams(bds, t_bds, duration_s)),
        )
    ]
    chunks = (a + b for a, b in zip(*gens))
    return write_noisy_recording(path, chunks, WIDE_FS, rng, fmt="ci8", if_hz=GPS_L1CA.carrier_freq_hz - WIDE_LO_HZ)
