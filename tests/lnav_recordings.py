"""The receiver tests' LNAV recordings: satellites of real
broadcast records (tests/data/07590920.05n) seen from the station of
07590920.05o, each carrying its LNAV with the code phase,
Doppler and data timing of the geometry, 45 dB-Hz, complex int16 SigMF at 2.046 MHz; a
satellite may be blanked over an interval (no signal, the noise goes on); an SBAS GEO may be
added (`Geo`: its 500 symbol/s stream at a fixed range, no Doppler)."""

from __future__ import annotations

from pathlib import Path
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from gnssframework.navigation import lnav
from gnssframework.signal.constants import L1_FREQ_HZ
from gnssframework.signal.if_samples import generate_if_samples
from gnssframework.signal.sbas_l1 import SBAS_L1
from gnssframework.navigation.ephemeris import satellite_state
from light_time import C, signal_flight  # noqa: F401 (C: the receiver tests import it from here)
from noisy_recording import write_noisy_recording

WEEK = 1316  # the week the generator's LNAV carries
DATA = Path(__file__).parent / "data"
NAV = DATA / "07590920.05n"
STATION = np.array([-3976219.5082, 3382372.5671, 3652512.9849])
FS = 2.046e6
# GPS time of the first sample: subframe 2 starts 2.6 s in and has arrived 8.6 s in (bit sync
# needs bit transitions: the end of subframe 1 before it has them; the generator's empty page
# 25 of subframe 5 would have none).
TOW0 = 518_706.0 - 2.6
CHUNK_S = 0.5


@dataclass(frozen=True)
class Geo:
    """An SBAS GEO in a recording: PRN ``prn`` sending ``symbols`` (±1, 2 ms each) from GPS
    time ``first_symbol_tow`` (its SNT, steered to GPS time), received ``delay_s`` later
    (a GEO's range, held fixed: no Doppler), at ``cn0_dbhz``."""

    prn: int
    symbols: np.ndarray
    first_symbol_tow: float
    delay_s: float = 0.125
    cn0_dbhz: float = 45.0


def _satellite_time(eph, t_rx):
    """t_SV of the signal received at true GPS time t_rx by the station (receiver clock exact)."""
    tau, clock, _ = signal_flight(eph, t_rx, STATION)
    return t_rx - tau + clock


def _strongest(nav, t, n):
    sel = nav.select(np.unique(nav.sv), t)
    up = STATION / np.linalg.norm(STATION)
    los = satellite_state(sel, t).position_m - STATION
    el = los @ up / np.linalg.norm(los, axis=1)
    return sel.subset(np.argsort(-el)[:n])


def _chunk_doppler(sats, t_s: float) -> np.ndarray:
    """The Doppler (Hz) the generator holds over the chunk starting at GPS time ``t_s``: the
    satellite time's rate over the chunk."""
    start, end = _satellite_time(sats, t_s), _satellite_time(sats, t_s + CHUNK_S)
    return L1_FREQ_HZ * ((end - start) / CHUNK_S - 1)


def true_dopplers(sats, tow0: float, duration_s: float) -> np.ndarray:
    """``(chunks, satellites)`` Dopplers (Hz) of `write_lnav_recording`'s chunks, the truth
    to compare a channel's with."""
    return np.array([_chunk_doppler(sats, tow0 + c * CHUNK_S) for c in range(int(round(duration_s / CHUNK_S)))])


def write_lnav_recording(
    path: Path,
    sats,
    tow0: float,
    duration_s: float,
    seed: int,
    blank: tuple[int, float, float] | None = None,
    cn0_dbhz: float | Callable[[float], float] = 45.0,
    code_delay: tuple[int, float, float] | None = None,
    sample_rate_hz: float = FS,
    iono_m: np.ndarray | None = None,
    geo: Geo | None = None,
) -> Path:
    """Write ``duration_s`` of the satellites ``sats`` (an `Ephemerides`) from GPS time
    ``tow0`` to ``path`` (``.sigmf-data`` with its metadata); ``blank`` = (index of a
    satellite, start s, end s) leaves that satellite out of the chunks starting in
    ``[start, end)``; ``cn0_dbhz`` a constant or a function of the chunk's start (s into
    the file), every satellite's; ``code_delay`` = (index of a satellite, start s, metres)
    delays that satellite's code (not its carrier) by that many metres in the chunks from
    start on (a code fault: multipath-like or spoofed); ``sample_rate_hz`` the file's rate
    (`FS`, 2 samples a chip, by default); ``iono_m`` each satellite's ionospheric code delay
    on L1 (m, constant: the code and its data bits sent that much earlier, the carrier's
    advance left out); ``geo`` an SBAS GEO's signal added (`Geo`)."""
    rng = np.random.default_rng(seed)
    n = int(round(CHUNK_S * sample_rate_hz))
    t_sv0 = _satellite_time(sats, np.array(tow0))
    symbols = [
        lnav.lnav_symbols(sats.subset(np.array([k])), WEEK, float(t_sv0[k]) - 0.1, int(duration_s * 50) + 20)
        for k in range(sats.sv.size)
    ]
    phase = np.zeros(sats.sv.size)
    cn0_at = cn0_dbhz if callable(cn0_dbhz) else (lambda t_s: cn0_dbhz)

    def chunks():
        for c in range(int(round(duration_s / CHUNK_S))):
            t0 = c * CHUNK_S
            start = _satellite_time(sats, tow0 + t0)
            doppler = _chunk_doppler(sats, tow0 + t0)
            x = np.zeros(n, complex)
            for k in range(sats.sv.size):
                if blank is not None and k == blank[0] and blank[1] <= t0 < blank[2]:
                    phase[k] += 2 * np.pi * doppler[k] * CHUNK_S
                    continue
                bits, into = symbols[k]
                first_tsv = float(t_sv0[k]) - 0.1 - into  # t_SV of the first bit edge
                tsv = start[k] - (0.0 if iono_m is None else iono_m[k] / C)
                if code_delay is not None and k == code_delay[0] and t0 >= code_delay[1]:
                    tsv = tsv - code_delay[2] / C  # the code transmitted that much earlier
                x += generate_if_samples(
                    int(sats.sv[k][1:]),
                    CHUNK_S,
                    sample_rate_hz,
                    0.0,
                    cn0_at(t0),
                    rng,
                    doppler_hz=doppler[k],
                    code_phase_chips=(tsv * 1e3 % 1.0) * 1023,
                    carrier_phase_rad=phase[k],
                    complex_samples=True,
                    data_bits=bits,
                    first_bit_edge_s=first_tsv - (start[k] if iono_m is None else tsv),
                    noise=False,
                ).samples
                phase[k] += 2 * np.pi * doppler[k] * CHUNK_S
            if geo is not None:
                t_geo = tow0 + t0 - geo.delay_s  # the GEO's time of the chunk's first sample
                x += generate_if_samples(
                    geo.prn,
                    CHUNK_S,
                    sample_rate_hz,
                    0.0,
                    geo.cn0_dbhz,
                    rng,
                    code_phase_chips=(t_geo * 1e3 % 1.0) * 1023,
                    complex_samples=True,
                    data_bits=geo.symbols,
                    first_bit_edge_s=geo.first_symbol_tow - t_geo,
                    noise=False,
                    signal=SBAS_L1,
                ).samples
            yield x

    return write_noisy_recording(path, chunks(), sample_rate_hz, rng)
