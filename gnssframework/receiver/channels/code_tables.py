"""Code tables of the compiled correlator: every tap's code chip for every position of the
prompt's code word, in one lookup (`CodeTables`, `code_tables`); split from `correlator`."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...errors import ConfigError

__all__ = ["MAX_TAPS", "CodeTables", "code_tables"]

_MASK32 = (1 << 32) - 1


#: Taps a `CodeTables` pattern holds (one bit each in an int32).
MAX_TAPS = 31


@dataclass(frozen=True)
class CodeTables:
    r"""Every tap's code chip, for every position of the prompt's code word, in one lookup.

    Tap t's code word is the prompt's word :math:`u` plus :math:`D_t = \mathrm{round}(o_t
    2^{32})`, so its chip is :math:`\lfloor u / 2^{32} \rfloor + \lfloor D_t / 2^{32}
    \rfloor + [f \ge T_t]` with :math:`f = u \bmod 2^{32}` and :math:`T_t = 2^{32} - (D_t
    \bmod 2^{32})`: all taps' chips follow from the prompt's chip and how many of the
    distinct thresholds :math:`T_{(1)} < \dots < T_{(M)}` the fraction has crossed. So
    ``patterns[c, chip * (M + 1) + crossed]`` holds, bit t, whether tap t's code is -1.

    Attributes
    ----------
    patterns
        ``(n_channels, n_chips * (M + 1))`` ``int32``; chip k of the prompt's word is code
        chip ``k mod n_code`` (1023 for L1 C/A).
    thresholds
        The :math:`M` distinct thresholds, ascending (``int64``).
    offsets_chips
        The taps they were made for.
    n_chips
        Prompt chips covered.
    """

    patterns: np.ndarray
    thresholds: np.ndarray
    offsets_chips: np.ndarray
    n_chips: int

    def fits(self, n_channels: int, offsets_chips: np.ndarray, n_chips: int) -> bool:
        """Made for ``n_channels`` channels, these taps, and at least ``n_chips`` chips."""
        return (
            self.patterns.shape[0] == n_channels
            and self.n_chips >= n_chips
            and np.array_equal(self.offsets_chips, np.asarray(offsets_chips, float))
        )


def _tap_words(offsets_chips: np.ndarray) -> np.ndarray:
    return np.rint(np.asarray(offsets_chips, float) * 2.0**32).astype(np.int64)


_RECENT_TABLES: dict[tuple, CodeTables] = {}


def _cached_tables(codes: np.ndarray, offsets_chips: np.ndarray, periods: int) -> CodeTables:
    """`code_tables` for a caller that passed none: the last few are kept (a caller that
    correlates the same channels again need not build them again)."""
    key = (np.ascontiguousarray(codes).tobytes(), np.asarray(offsets_chips, float).tobytes(), periods)
    if key not in _RECENT_TABLES:
        if len(_RECENT_TABLES) >= 8:
            del _RECENT_TABLES[next(iter(_RECENT_TABLES))]
        _RECENT_TABLES[key] = code_tables(codes, offsets_chips, periods)
    return _RECENT_TABLES[key]


def code_tables(codes: np.ndarray, offsets_chips: np.ndarray, periods: int = 3) -> CodeTables:
    """The `CodeTables` of ``codes`` (``(n_channels, n_code)`` ±1) for taps at
    ``offsets_chips``, over ``periods`` code lengths of the prompt's word: made once by a
    caller that correlates the same channels many times. Three periods cover one code
    period of integration from any start phase (the kernels start the word one code length
    in)."""
    offsets = np.asarray(offsets_chips, float)
    if offsets.size > MAX_TAPS:
        raise ConfigError("offsets_chips", f"at most {MAX_TAPS} taps, got {offsets.size}")
    words = _tap_words(offsets)
    rem = words & _MASK32
    thr = np.unique(2**32 - rem[rem > 0])
    m = thr.size
    n_code = codes.shape[1]
    n_chips = periods * n_code
    chip = np.arange(n_chips)[:, None, None]
    crossed = np.arange(m + 1)[None, :, None]
    # Tap t has crossed its threshold in region j when T_t is among the first j thresholds.
    ahead = (rem > 0) & (np.searchsorted(thr, 2**32 - rem) < crossed)
    idx = (chip + (words >> 32) + ahead) % n_code  # (n_chips, m + 1, n_taps)
    negative = np.asarray(codes)[:, idx] < 0
    patterns = np.sum(negative.astype(np.int64) << np.arange(offsets.size), axis=-1).astype(np.int32)
    # C order whatever the shapes (one compiled signature: a layout change recompiles).
    return CodeTables(
        np.ascontiguousarray(patterns.reshape(codes.shape[0], -1)), thr.astype(np.int64), offsets.copy(), n_chips
    )
