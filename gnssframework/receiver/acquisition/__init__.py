"""Acquisition: parallel code-phase search by FFT, threshold from a false-alarm probability."""

from .fft_search import (
    code_replica,
    fine_doppler,
    first_period_lag,
    overlay_doppler,
    overlay_refine_periods,
    search_grid,
    sideband_overlap,
    sideband_power_fraction,
    sideband_replicas,
)
from .search import Acquisition, AcquisitionResult
from .threshold import cell_false_alarm, noise_floor, threshold_from_pfa

__all__ = [
    "Acquisition",
    "AcquisitionResult",
    "search_grid",
    "fine_doppler",
    "first_period_lag",
    "overlay_doppler",
    "overlay_refine_periods",
    "code_replica",
    "sideband_replicas",
    "sideband_overlap",
    "sideband_power_fraction",
    "threshold_from_pfa",
    "cell_false_alarm",
    "noise_floor",
]
