r"""Detection threshold from a false-alarm probability and the measured noise floor.

With ``K`` non-coherent sums of one coherent correlation ``z`` whose I and Q noise each
have variance :math:`\sigma^2`, the noise-only statistic :math:`S = \sum_k |z_k|^2/\sigma^2`
is chi-square with :math:`2K` degrees of freedom (Kaplan & Hegarty, *Understanding GPS/GNSS*,
3rd ed., sec. 8.4: square-law detection with non-coherent integration). A search of ``M``
cells with a per-cell false-alarm probability :math:`p` raises a false alarm somewhere
with probability at most :math:`1 - (1 - p)^M` (equality for independent cells; the
neighbouring cells of a grid are correlated, so the true rate is lower and the threshold
conservative). :math:`\sigma^2` is measured, not assumed: the median of the grid over a
chi-square median, which the few cells holding a signal do not move.
"""

from __future__ import annotations

import numpy as np
from scipy import special  # not scipy.stats: its import costs a second of every run's start-up

from ...errors import ConfigError

__all__ = ["cell_false_alarm", "threshold_from_pfa", "noise_floor"]


def cell_false_alarm(pfa: float, cells: int) -> float:
    """Per-cell probability :math:`p = 1 - (1 - P_{fa})^{1/M}` for a search-wide ``pfa`` over ``cells``."""
    if not 0 < pfa < 1:
        raise ConfigError("pfa", f"false-alarm probability must be in (0, 1), got {pfa}")
    return float(-np.expm1(np.log1p(-pfa) / cells))


def threshold_from_pfa(pfa: float, cells: int, noncoherent: int, alternate: bool = False) -> float:
    """Threshold on the normalised statistic: the chi-square(2K) quantile exceeded with the per-cell probability.

    ``alternate`` (`fft_search.search_grid`): the statistic is the larger of two independent
    chi-square(2K) sums of ``K = noncoherent`` blocks each (the even and the odd blocks),
    which exceeds :math:`x` with probability :math:`1 - (1 - q(x))^2`; the threshold is the
    chi-square(2K) quantile of :math:`q = 1 - \\sqrt{1 - p}`.
    """
    p = cell_false_alarm(pfa, cells)
    if alternate:
        return float(special.chdtri(2 * noncoherent, -np.expm1(0.5 * np.log1p(-p))))
    return float(special.chdtri(2 * noncoherent, p))


def noise_floor(raw_grid: np.ndarray, noncoherent: int, alternate: bool = False) -> float:
    """:math:`\\sigma^2` of one correlation's I (or Q) from a grid of raw sums ``sum |z|^2``
    (with ``alternate``, of the larger of two chi-square(2K) sums of ``K = noncoherent``
    blocks: median at the chi-square(2K) quantile :math:`\\sqrt{1/2}`)."""
    if alternate:
        return float(np.median(raw_grid) / (2 * special.gammaincinv(noncoherent, np.sqrt(0.5))))
    return float(np.median(raw_grid) / (2 * special.gammaincinv(noncoherent, 0.5)))
