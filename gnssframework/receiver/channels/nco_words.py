r"""The compiled correlator's fixed-point NCO words from a call's phases and steps, and how
far a call's whole code periods reach; split from `correlator`.

Words are :math:`2^{-32}` cycles (carrier) or chips (code), as a hardware NCO's phase
accumulator: the carrier's phase word :math:`\lfloor (\phi - \lfloor\phi\rfloor) 2^{32}
\rfloor` and step :math:`\mathrm{rint}((\Delta\phi \bmod 1)\, 2^{32})`, the code's from one
code length before the code table's start. `period_words` makes a `correlate_periods` call's
words and reach in one compiled pass (one dispatch instead of about twenty small NumPy
operations, which cost a tenth of a 2.6 MHz tracker call); it is the same arithmetic as
`carrier_words` and the NumPy lines it replaced, to the bit (`tests/receiver/test_nco_words.py`).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

__all__ = ["carrier_words", "period_words"]

_WORD = 2.0**32


def carrier_words(carrier_phase_cycles: np.ndarray, carrier_step_cycles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Carrier NCO phase and step as :math:`2^{-32}`-cycle words (``int64``)."""
    cycles = np.asarray(carrier_phase_cycles, float)
    carrier0 = np.floor((cycles - np.floor(cycles)) * _WORD).astype(np.int64)
    dcarrier = np.rint(np.mod(np.asarray(carrier_step_cycles, float), 1.0) * _WORD).astype(np.int64)
    return carrier0, dcarrier


def _period_words(
    starts, n_periods, code_phase_chips, code_step_chips, carrier_phase_cycles, carrier_step_cycles, n_code
):
    # Per channel c: the carrier words (`carrier_words`), the prompt's code word from one
    # code length before the table's start and its step, and the sample after its last
    # period, ceil((n_periods n_code - phase) / step + 1) past its start. Returns them with
    # the smallest start, the largest reach, the most periods (at least 1) and the call's work in samples (periods times
    # code length over the smallest step, or over 1 where every step is larger).
    n = starts.shape[0]
    carrier0 = np.empty(n, np.int64)
    dcarrier = np.empty(n, np.int64)
    code0 = np.empty(n, np.int64)
    dcode = np.empty(n, np.int64)
    first, reach, periods, most, step_min = 0, 0, 0, 1, 1.0
    for c in range(n):
        cycles = carrier_phase_cycles[c]
        carrier0[c] = np.int64(math.floor((cycles - math.floor(cycles)) * _WORD))
        step = carrier_step_cycles[c]
        dcarrier[c] = np.int64(np.rint((step - math.floor(step)) * _WORD))  # step mod 1, as np.mod
        code0[c] = np.int64(math.floor((code_phase_chips[c] + n_code) * _WORD))
        dcode[c] = np.int64(np.rint(code_step_chips[c] * _WORD))
        end = starts[c] + np.int64(math.ceil((n_periods[c] * n_code - code_phase_chips[c]) / code_step_chips[c] + 1))
        first = starts[c] if c == 0 else min(first, starts[c])
        reach = end if c == 0 else max(reach, end)
        periods += n_periods[c]
        most = max(most, n_periods[c])
        step_min = min(step_min, code_step_chips[c])
    return carrier0, dcarrier, code0, dcode, first, reach, most, periods * n_code / step_min


def _compiled() -> Callable[..., tuple]:
    try:
        import numba
    except ImportError:  # pragma: no cover
        return _period_words
    return numba.njit(cache=True, nogil=True)(_period_words)


#: `_period_words` compiled (the Python function itself where numba is missing).
period_words = _compiled()
