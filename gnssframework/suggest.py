"""'Did you mean' hints for a mistyped name: a field, a parameter, a plugin, a choice.

A name differing only in case (``'OCXO'`` for ``'ocxo'``, ``'UKF'`` for ``'ukf'``) is
matched first, since ``difflib`` scores it as unrelated; then the closest name by
``difflib.get_close_matches``.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable

__all__ = ["closest", "did_you_mean"]

#: difflib similarity below which no name is suggested.
CUTOFF = 0.6


def closest(word: object, choices: Iterable[object], cutoff: float = CUTOFF) -> str | None:
    """The choice ``word`` most likely meant, or ``None``.

    Examples
    --------
    >>> closest("OCXO", ["tcxo", "tcxo-hq", "ocxo"]), closest("windw", ["warmup", "window"])
    ('ocxo', 'window')
    >>> closest("zzz", ["kf", "ukf"]) is None
    True
    """
    text = str(word)
    options = [str(c) for c in choices]
    folded = [c for c in options if c.casefold() == text.casefold() and c != text]
    if folded:
        return folded[0]
    close = difflib.get_close_matches(text.casefold(), [c.casefold() for c in options], n=1, cutoff=cutoff)
    return next((c for c in options if close and c.casefold() == close[0]), None)


def did_you_mean(word: object, choices: Iterable[object], cutoff: float = CUTOFF) -> str:
    """``"; did you mean 'x'?"`` to append to an error, or ``""`` when nothing is close.

    Examples
    --------
    >>> did_you_mean("UKF", ["ckf", "ukf"])
    "; did you mean 'ukf'?"
    """
    match = closest(word, choices, cutoff)
    return f"; did you mean {match!r}?" if match is not None else ""
