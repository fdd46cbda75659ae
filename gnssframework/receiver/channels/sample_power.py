"""The tracker's noise scale: the sum of squares of a block of recorded sample components,
in exact integer arithmetic for ``int8``/``int16`` recordings (`sum_of_squares`)."""

from __future__ import annotations

import numpy as np

try:
    import numba

    HAVE_NUMBA = True
except ImportError:  # pragma: no cover
    HAVE_NUMBA = False

__all__ = ["sum_of_squares"]


def _integer_sum_of_squares(values: np.ndarray) -> np.int64:
    total = np.int64(0)
    for v in values:
        w = np.int64(v)
        total += w * w
    return total


_compiled_sum_of_squares = numba.njit(cache=True, nogil=True)(_integer_sum_of_squares) if HAVE_NUMBA else None


def sum_of_squares(values: np.ndarray) -> float:
    """:math:`\\sum_i x_i^2` of a block of recorded sample components (the tracker's noise
    scale, measured on every block it reads).

    ``int8`` and ``int16`` blocks in one compiled pass of exact ``int64`` arithmetic: the
    same number as the ``float64`` sum of the squares, which is exact while below
    :math:`2^{53}` (e.g. 5e11 ``int8`` components); other types as ``float32`` squares
    summed in ``float64``.
    """
    x = np.asarray(values)
    if _compiled_sum_of_squares is not None and x.dtype in (np.int8, np.int16) and x.ndim == 1:
        return float(_compiled_sum_of_squares(x))
    x = x.astype(np.float32)
    return float(np.sum(x * x, dtype=np.float64))
