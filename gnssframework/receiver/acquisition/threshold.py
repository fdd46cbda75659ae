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

__all__ = ["cell_false_alarm", "threshold_from_pfa", "noise_floor", "detection_probability", "blocks_for_detection"]


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


def detection_probability(
    cn0_dbhz: float, coherent_time_s: float, blocks: int, threshold: float, loss_db: float = 0.0
) -> float:
    r"""Probability that a signal's cell exceeds ``threshold`` (the normalised statistic's).

    With a signal of :math:`C/N_0` in every one of the ``blocks`` coherent sums of length
    :math:`T`, each :math:`|z_k|^2/\sigma^2` is non-central chi-square with 2 degrees of
    freedom and non-centrality :math:`2\,(C/N_0)\,T` (its mean :math:`2 + 2 (C/N_0) T`,
    the law the searches' C/N0 estimate inverts), so the sum is non-central chi-square
    with :math:`2K` and :math:`\lambda = 2 K (C/N_0) T` (Kaplan & Hegarty, *Understanding
    GPS/GNSS*, 3rd ed., sec. 8.4). ``loss_db`` lowers :math:`C/N_0` by the search's
    straddle losses (code lag and Doppler between grid points). With 10 ms blocks summed
    by parity (``alternate``) ``blocks`` counts the bit-free parity's: the larger of the
    two sums exceeds the threshold at least as often, so this is a lower bound there.
    """
    if blocks < 1 or coherent_time_s <= 0:
        raise ConfigError("blocks", f"need at least one block of positive length, got {blocks} x {coherent_time_s} s")
    lam = 2.0 * blocks * 10 ** ((cn0_dbhz - loss_db) / 10) * coherent_time_s
    return float(1.0 - special.chndtr(threshold, 2 * blocks, lam))


def blocks_for_detection(
    cn0_dbhz: float,
    coherent_time_s: float,
    pd: float,
    pfa: float,
    cells: int,
    alternate: bool = False,
    loss_db: float = 0.0,
    max_blocks: int = 100,
) -> int:
    r"""Fewest non-coherent blocks :math:`K` that detect a signal of ``cn0_dbhz`` with
    probability at least ``pd`` at the threshold of ``pfa`` over ``cells`` (`threshold_from_pfa`).

    The non-coherent count of a search chosen from theory rather than tried on a file:
    :math:`P_d(K)` = `detection_probability` at the threshold for :math:`K` (which rises
    with :math:`K`, more slowly than the signal's non-centrality). With ``alternate`` the
    search reads :math:`2K` blocks of 10 ms (``noncoherent = 2K``).

    Raises
    ------
    ConfigError
        Naming ``pd`` when even ``max_blocks`` do not reach it.
    """
    if not 0 < pd < 1:
        raise ConfigError("pd", f"detection probability must be in (0, 1), got {pd}")
    for k in range(1, max_blocks + 1):
        threshold = threshold_from_pfa(pfa, cells, k, alternate)
        if detection_probability(cn0_dbhz, coherent_time_s, k, threshold, loss_db) >= pd:
            return k
    raise ConfigError(
        "pd",
        f"{max_blocks} non-coherent blocks of {coherent_time_s * 1e3:g} ms do not detect "
        f"{cn0_dbhz} dB-Hz with probability {pd} at pfa {pfa} over {cells} cells",
    )
