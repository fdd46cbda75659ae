"""Filter consistency: the normalised estimation error squared (NEES).

For an estimate with error $e$ and claimed covariance $P$, $\\epsilon = e^T P^{-1} e$;
a consistent filter of dimension n has $E[\\epsilon] = n$ (Bar-Shalom, Li and
Kirubarajan 2001, *Estimation with Applications to Tracking and Navigation*, sec. 5.4.2).
"""

from __future__ import annotations

import numpy as np

__all__ = ["nees"]


def nees(err: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """$e^T P^{-1} e$ batched over the leading axes: ``err (..., n)``, ``cov (..., n, n)`` -> ``(...)``.

    Solved, not inverted (Cholesky-free ``np.linalg.solve``), so an ill-conditioned P
    loses no more digits than it must.

    Examples
    --------
    >>> float(nees(np.array([1.0, 2.0]), np.diag([1.0, 4.0])))
    2.0
    """
    err = np.asarray(err, dtype=float)
    out: np.ndarray = np.einsum("...i,...i->...", err, np.linalg.solve(cov, err[..., None])[..., 0])
    return out
