r"""Closing the loop of a channel filter that outputs errors instead of NCO commands.

The vector-tracking channel filters (``discriminator``, ``iq-filter``) hand a navigation
filter a code error ``code_error_chips`` and a frequency error ``freq_error_hz``; part 2's
vector loop closes them through the position solution. On one channel alone they are
closed here by a first-order FLL and a first-order DLL (carrier aided): each update moves
the carrier NCO by :math:`K_f\,\delta f` and the code NCO by :math:`K_c\,\delta\tau`, with
:math:`K = 4 B_L T` for a loop of noise bandwidth :math:`B_L` (a first-order loop's
:math:`B_L = \omega_0/4`; Kaplan & Hegarty, 3rd ed., table 8.23). The filter is told the
moves (``nco_shift_chips``, ``nco_shift_hz``), as the vector loop tells it, so its error
states stay relative to the replica in use.
"""

from __future__ import annotations

from dataclasses import dataclass
from collections.abc import Mapping

import numpy as np

from ...errors import ConfigError

__all__ = ["ErrorFeedback", "ERROR_OUTPUTS"]

#: What a channel filter must provide to be closed by `ErrorFeedback`.
ERROR_OUTPUTS = ("code_error_chips", "freq_error_hz")


@dataclass
class ErrorFeedback:
    """First-order FLL and DLL around an error-output channel filter."""

    fll_bandwidth_hz: float
    dll_bandwidth_hz: float
    coherent_time_s: float

    def __post_init__(self) -> None:
        self.k_freq = 4 * self.fll_bandwidth_hz * self.coherent_time_s
        self.k_code = 4 * self.dll_bandwidth_hz * self.coherent_time_s
        if not (0 < self.k_freq <= 1 and 0 < self.k_code <= 1):
            raise ConfigError("closure", f"4 B_L T must be in (0, 1]: FLL {self.k_freq:g}, DLL {self.k_code:g}")

    def moves(self, outputs: Mapping[str, np.ndarray]) -> tuple[float, float]:
        """``(code_step_chips, doppler_step_hz)`` of the NCOs after this update."""
        return (self.k_code * float(outputs["code_error_chips"]), self.k_freq * float(outputs["freq_error_hz"]))
