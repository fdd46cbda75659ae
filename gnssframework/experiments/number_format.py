"""One format for the numbers of a report: significant figures matched to the standard error.

A value is printed to the decimal place of its standard error's second significant
figure (``0.4699`` with SE ``0.039`` -> ``0.470``); a spread printed beside it (a standard
deviation, an SE) goes to the same place, so every number of a cell has the same
resolution. A spread that is zero or at floating-point rounding level relative to the
value is no spread: the value is printed alone to :data:`BARE_DIGITS` significant figures.
Very small or very large numbers share one power of ten: ``(6.56 ± 0.39)e-07``.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["format_estimate", "at_rounding_level", "decimals_for", "BARE_DIGITS", "SE_DIGITS"]

#: Significant figures kept of the standard error.
SE_DIGITS = 2
#: Significant figures of a value printed without an SE.
BARE_DIGITS = 4
#: A spread at most this many ulps of the values' scale is floating-point rounding, not data.
ROUNDING_ULPS = 64
#: Decimal places beyond which (or a magnitude from 1e6 on) the numbers share a power of ten.
MAX_DECIMALS = 6


def at_rounding_level(spread: float | None, scale: float) -> bool:
    """Whether ``spread`` is zero, missing or within rounding of numbers of size ``scale``.

    Examples
    --------
    >>> at_rounding_level(2.9e-17, 0.228), at_rounding_level(1e-6, 0.228), at_rounding_level(0.0, 0.0)
    (True, False, True)
    """
    if spread is None or not math.isfinite(spread) or spread == 0.0:
        return True
    return bool(abs(spread) <= ROUNDING_ULPS * np.finfo(float).eps * abs(scale))


def decimals_for(se: float, digits: int = SE_DIGITS) -> int:
    """Decimal places that leave ``digits`` significant figures of ``se`` (negative: tens,
    hundreds...).

    Examples
    --------
    >>> decimals_for(0.039), decimals_for(3.9), decimals_for(160.0)
    (3, 1, -1)
    """
    return digits - 1 - math.floor(math.log10(abs(se)))


def _fixed(x: float, decimals: int, sign: bool) -> str:
    x = round(x, decimals) + 0.0  # + 0.0 turns a rounded -0.0 into 0.0
    return f"{x:+.{max(decimals, 0)}f}" if sign else f"{x:.{max(decimals, 0)}f}"


def format_estimate(
    value: float | None,
    se: float | None = None,
    spread: float | None = None,
    *,
    scale: float | None = None,
    sign: bool = False,
) -> str:
    """``value`` (and ``± spread``) at the resolution its standard error ``se`` supports.

    Parameters
    ----------
    value
        The estimate (a mean, a mean difference); ``None`` prints ``–``.
    se
        Its standard error; sets the decimal place. Zero, missing or at rounding level of
        ``scale`` prints the value alone to :data:`BARE_DIGITS` significant figures.
    spread
        What is printed after ``±`` (default: ``se``), at the same decimal place.
    scale
        Size of the numbers ``se`` was computed from, for the rounding-level test
        (default ``|value|``; a difference of equal values passes their size).
    sign
        Print ``+`` before a positive value (differences).

    Examples
    --------
    >>> format_estimate(0.4699, 0.039)
    '0.470 ± 0.039'
    >>> format_estimate(1844.4, 469.1, spread=1626.0)
    '1840 ± 1630'
    >>> format_estimate(0.228, 2.9e-17)
    '0.228'
    >>> format_estimate(1.88e-4, 6.904e-5, sign=True)
    '+0.000188 ± 0.000069'
    >>> format_estimate(6.557e-7, 3.86e-8)
    '(6.56 ± 0.39)e-07'
    """
    if value is None or not math.isfinite(value):
        return "–"
    spread = se if spread is None else spread
    if at_rounding_level(se, abs(value) if scale is None else scale):
        text = f"{value:+.{BARE_DIGITS}g}" if sign else f"{value:.{BARE_DIGITS}g}"
        return "0" if value == 0 else text
    decimals = decimals_for(se)
    biggest = max(abs(value), abs(spread))
    if decimals <= MAX_DECIMALS and biggest < 1e6:
        return f"{_fixed(value, decimals, sign)} ± {_fixed(spread, decimals, False)}"
    exponent = math.floor(math.log10(biggest))
    shift = 10.0**exponent
    inner = decimals + exponent
    return f"({_fixed(value / shift, inner, sign)} ± {_fixed(spread / shift, inner, False)})e{exponent:+03d}"
