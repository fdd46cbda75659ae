r"""The assisted start's search: the satellites and Dopplers an approximate position and time predict.

With an `~gnssframework.receiver.navigation.vector_config.Assistance` (a position within
~100 km, the start time within seconds) and a RINEX navigation file, a receiver knows
which satellites are above its horizon and each one's Doppler,
:math:`f_D = -\big((v_s \cdot e) - c\,\dot{\delta t}_s\big) / \lambda` for a receiver at
rest (:math:`e` the unit line of sight, :math:`\dot{\delta t}_s` the satellite clock's
drift). It searches only those, each in a Doppler window about its prediction and over
the whole code period (a start time to seconds says nothing of the code phase): van
Diggelen, *A-GPS*, 2009, ch. 6. The window is small, so the search can afford long
non-coherent sums (the code Doppler followed: `fft_search.search_grid`), which is what
detects a weak signal (`threshold.blocks_for_detection`).

The Doppler half width must hold what the prediction does not know: the position error
(100 km moves a line of sight by 5 mrad: about 20 m/s of a satellite's 3.9 km/s, 100 Hz
on L1), the receiver's own speed (1 m/s: 5.3 Hz) and its oscillator's frequency offset
(0.1 ppm: 158 Hz on L1). The default 500 Hz holds 100 km, 30 m/s and 0.15 ppm.
"""

from __future__ import annotations

import numpy as np
import pymap3d

from ...errors import ConfigError
from ...navigation.ephemeris import Ephemerides, satellite_state
from ...navigation.geometry import line_of_sight
from ...signal.gps_l1ca import GPS_L1CA
from ...signal.spec import SignalSpec
from ..acquisition.assisted import SearchWindow, window_search
from ..acquisition.search import AcquisitionResult
from ..frontend.recording import Recording
from .observables import SPEED_OF_LIGHT_MPS
from .vector_config import Assistance

__all__ = ["predicted_dopplers", "assisted_search"]


def predicted_dopplers(
    rinex: Ephemerides, assist: Assistance, elevation_mask_deg: float = 5.0, signal: SignalSpec = GPS_L1CA
) -> dict[int, float]:
    """Doppler (Hz) of every satellite of ``signal`` with a healthy record in ``rinex``
    above ``elevation_mask_deg`` from the assisted position at its start time (see the module text)."""
    r = np.asarray(assist.position_ecef_m, float)
    lat, lon, h = pymap3d.ecef2geodetic(*r)
    out = {}
    for prn in signal.prns:
        try:
            eph = rinex.select([signal.rinex_satellite(prn)], assist.start_tow_s)
        except KeyError:  # no healthy record of it
            continue
        st = satellite_state(eph, np.array([assist.start_tow_s - 0.075]))
        _, el, _ = pymap3d.ecef2aer(*st.position_m[0], lat, lon, h)
        if el < elevation_mask_deg:
            continue
        _, e = line_of_sight(st.position_m[0], r)
        rate = float(st.velocity_mps[0] @ e) - SPEED_OF_LIGHT_MPS * float(st.clock_drift_s_s[0])
        out[prn] = -rate / signal.wavelength_m
    return out


def assisted_search(
    recording: Recording,
    rinex: Ephemerides,
    assist: Assistance,
    noncoherent: int,
    *,
    coherent_ms: int = 10,
    doppler_halfwidth_hz: float = 500.0,
    pfa: float = 1e-3,
    elevation_mask_deg: float = 5.0,
    signal: SignalSpec = GPS_L1CA,
) -> list[AcquisitionResult]:
    """Search each satellite `predicted_dopplers` gives in ``doppler_halfwidth_hz`` about its
    Doppler and over the whole code period (`window_search`, 10 ms blocks summed by parity,
    ``noncoherent`` of them, the code Doppler followed) from the recording's first sample;
    ``pfa`` per satellite's window. One result per searched satellite, in PRN order."""
    if coherent_ms != 10 or noncoherent % 2:
        raise ConfigError(
            "noncoherent",
            f"the assisted search sums 10 ms blocks by parity: coherent_ms 10 and an "
            f"even noncoherent, got {coherent_ms} and {noncoherent}",
        )
    fs = recording.info.sample_rate_hz
    n = int(round(coherent_ms * signal.code_period_s * fs))
    samples = recording.read(0, n * noncoherent)
    per_code = fs * signal.code_period_s
    results = []
    for prn, doppler in sorted(predicted_dopplers(rinex, assist, elevation_mask_deg, signal).items()):
        window = SearchWindow(0.0, doppler, per_code / 2, doppler_halfwidth_hz)
        results.append(
            window_search(
                samples,
                fs,
                recording.info.if_hz,
                prn,
                window,
                coherent_ms=coherent_ms,
                noncoherent=noncoherent,
                alternate=True,
                pfa=pfa,
                signal=signal,
                code_doppler=True,
            )
        )
    return results
