r"""Assisted acquisition: a search in a narrow window around a predicted code phase and Doppler.

A receiver with a navigation solution predicts where a satellite's signal is: its code
phase from the predicted pseudorange, its Doppler from the predicted range rate, each
with the solution's uncertainty. The search then decides over the cells of that window
only. The statistic of each cell is the one of the full search
(`fft_search.search_grid`, noise floor `threshold.noise_floor` measured on the whole grid,
where the few signal cells do not move the median), but with :math:`M_w` cells instead of
the full grid's :math:`M`, the per-cell false-alarm probability for the same ``pfa`` is
:math:`1 - (1 - P_{fa})^{1/M_w}` (`threshold.cell_false_alarm`): larger, so the threshold
is lower and a weaker signal is detected at the same false-alarm rate over the window
(Kaplan & Hegarty, *Understanding GPS/GNSS*, 3rd ed., sec. 8.4; van Diggelen, *A-GPS*,
2009, ch. 6: assistance shrinks the search space).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...errors import ConfigError
from ...signal.gps_l1ca import GPS_L1CA
from ...signal.spec import SignalSpec
from .fft_search import first_period_lag, search_grid
from .search import AcquisitionResult
from .threshold import noise_floor, threshold_from_pfa

__all__ = ["SearchWindow", "window_search"]


@dataclass(frozen=True)
class SearchWindow:
    """Where to look: ``code_start_samples`` the predicted first sample (from the searched
    block's start) at which a code period begins, ``doppler_hz`` the predicted Doppler,
    and the half widths searched around them (samples, Hz)."""

    code_start_samples: float
    doppler_hz: float
    code_halfwidth_samples: float
    doppler_halfwidth_hz: float


def window_search(
    samples: np.ndarray,
    sample_rate_hz: float,
    if_hz: float,
    prn: int,
    window: SearchWindow,
    *,
    coherent_ms: int = 10,
    noncoherent: int = 8,
    alternate: bool = True,
    pfa: float = 1e-3,
    signal: SignalSpec = GPS_L1CA,
    code_doppler: bool = False,
) -> AcquisitionResult:
    """Search ``prn`` in ``window`` only (see the module text).

    Parameters
    ----------
    samples
        ``coherent_ms * noncoherent`` ms of samples (complex, or real at ``if_hz``).
    window
        `SearchWindow`; the code window is taken modulo one code period.
    coherent_ms, noncoherent, alternate
        As the ``pcps`` search's (``alternate``: 10 ms blocks summed by parity).
    pfa
        False-alarm probability over the window's cells.
    signal
        The searched signal's description; ``coherent_ms`` counts its code periods
        (milliseconds for GPS L1 C/A).
    code_doppler
        Follow the code Doppler across the blocks (`fft_search.search_grid`): for long
        non-coherent sums.

    Returns
    -------
    AcquisitionResult
        The window's best cell; ``threshold`` the window's, ``code_phase_samples`` the
        first sample of a code period at it, ``doppler_hz`` the bin centre.
    """
    if window.code_halfwidth_samples < 0 or window.doppler_halfwidth_hz < 0:
        raise ConfigError(
            "window",
            f"half widths must be >= 0, got {window.code_halfwidth_samples} samples and "
            f"{window.doppler_halfwidth_hz} Hz",
        )
    if alternate and noncoherent % 2:
        raise ConfigError("noncoherent", f"alternate blocks need an even number of blocks, got {noncoherent}")
    signal.check_prn(prn)
    T = coherent_ms * signal.code_period_s
    n = int(round(T * sample_rate_hz))
    if samples.shape[0] < n * noncoherent:
        raise ConfigError("samples", f"the window search needs {n * noncoherent} samples, got {samples.shape[0]}")
    step = 1.0 / (2 * T)  # half a sinc lobe, as the full search's default
    half = int(np.ceil(window.doppler_halfwidth_hz / step))
    dopplers = window.doppler_hz + np.arange(-half, half + 1) * step
    blocks = noncoherent // 2 if alternate else noncoherent
    grid = search_grid(
        samples, sample_rate_hz, if_hz, (prn,), T, noncoherent, dopplers, alternate, signal, code_doppler
    )[0]
    sigma2 = noise_floor(grid, blocks, alternate)
    # Lags within the half width of the predicted start, modulo one code period.
    per_code = sample_rate_hz * signal.code_length_chips / signal.chip_rate_hz
    lag = np.arange(n)
    offset = (lag - window.code_start_samples + per_code / 2) % per_code - per_code / 2
    inside = np.abs(offset) <= window.code_halfwidth_samples + 0.5
    stat = grid[:, inside] / sigma2
    d, j = np.unravel_index(int(np.argmax(stat)), stat.shape)
    s = first_period_lag(int(lag[inside][j]), sample_rate_hz, signal)
    peak = float(stat[d, j])
    threshold = threshold_from_pfa(pfa, int(stat.size), blocks, alternate)
    # E[S] = K(2 + 2cT duty), as the pcps search's C/N0 (`SignalSpec.replica_duty`).
    c = max((peak / blocks - 2.0) / (2 * T * signal.replica_duty), 1e-3)
    chips = float((-s * signal.chip_rate_hz / sample_rate_hz) % signal.code_length_chips)
    return AcquisitionResult(
        int(prn), peak > threshold, float(dopplers[d]), s, chips, float(10 * np.log10(c)), peak, threshold
    )
