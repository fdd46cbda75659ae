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
from gnssframework.signal.constants import L1_FREQ_HZ
from gnssframework.signal.galileo_e1 import GALILEO_E1B_BOC11
from gnssframework.signal.if_samples import generate_if_samples
from light_time import signal_flight
from noisy_recording import write_noisy_recording

WN = 1174  # the GST week of the records (2022-02-20: GPS week 2198)
GPS_WEEK = WN + 1024
NAV = Path(__file__).parent / "data" / "galileo_inav_20feb2022_05h.rnx"
#: The IGS station VILL (Villafranca, Spain), ECEF (m).
STATION = np.array([4849833.676, -335048.888, 4116014.971])
FS = 4e6
CHUNK_S = 0.5
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
    `STATION`, updated every chunk. A generator (`write_noisy_recording` draws each chunk's
    noise after it)."""
    n = int(round(CHUNK_S * FS))
    phases = [np.zeros(sats.sv.size) for sats, *_ in groups]
    for c in range(int(round(duration_s / CHUNK_S))):
        t0 = tow0 + c * CHUNK_S
        x = np.zeros(n, complex)
        for (sats, signal, t_sv0, data), phase in zip(groups, phases):
            start = satellite_time(sats, t0)
            doppler = L1_FREQ_HZ * ((satellite_time(sats, t0 + CHUNK_S) - start) / CHUNK_S - 1)
            for k in range(sats.sv.size):
                bits, into = data[k]
                first_tsv = float(t_sv0[k]) - 0.1 - into  # satellite time of the first symbol's edge
                x += generate_if_samples(
                    int(sats.sv[k][1:]),
                    CHUNK_S,
                    FS,
                    0.0,
                    cn0_dbhz,
                    rng,
                    doppler_hz=doppler[k],
                    code_phase_chips=(start[k] / signal.code_period_s % 1.0) * signal.code_length_chips,
                    carrier_phase_rad=phase[k],
                    complex_samples=True,
                    data_bits=np.asarray(bits, float),
                    first_bit_edge_s=first_tsv - start[k],
                    noise=False,
                    signal=signal,
                ).samples
                phase[k] += 2 * np.pi * doppler[k] * CHUNK_S
        yield x


def write_inav_recording(path: Path, sats, tow0: float, duration_s: float, seed: int, cn0_dbhz: float = 45.0) -> Path:
    """Write ``duration_s`` of the satellites ``sats`` (an `Ephemerides`) from time ``tow0``."""
    rng = np.random.default_rng(seed)
    t_sv0 = satellite_time(sats, np.array(tow0))
    groups = [(sats, SIGNAL, t_sv0, inav_data(sats, t_sv0, duration_s))]
    return write_noisy_recording(path, satellite_chunks(groups, tow0, duration_s, cn0_dbhz, rng), FS, rng)
