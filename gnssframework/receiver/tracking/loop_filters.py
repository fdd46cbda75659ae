"""Digital loop filters of order 1-3, batch-first.

Coefficients follow Kaplan & Hegarty, *Understanding GPS/GNSS* (3rd ed., table of
loop-filter characteristics), for noise bandwidth $B_L$:

| order | natural frequency | filter (Laplace) |
| --- | --- | --- |
| 1 | $\\omega_0 = B_L / 0.25$ | $\\omega_0$ |
| 2 | $\\omega_0 = B_L / 0.53$ | $a_2 \\omega_0 + \\omega_0^2 / s$, $a_2 = \\sqrt 2$ |
| 3 | $\\omega_0 = B_L / 0.7845$ | $b_3 \\omega_0 + a_3 \\omega_0^2 / s + \\omega_0^3 / s^2$, $a_3 = 1.1$, $b_3 = 2.4$ |

The integrators are discretised with the rectangular (Euler) rule at the update
interval T. This is accurate while $B_L T \\ll 1$; the realised noise bandwidth
exceeds $B_L$ by a few percent at $B_L T = 0.05$.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...errors import ConfigError

__all__ = ["LoopFilter", "natural_frequency", "check_bandwidth_time", "MAX_BANDWIDTH_TIME"]

_BANDWIDTH_RATIO = {1: 0.25, 2: 0.53, 3: 0.7845}
#: Largest B_L T of a loop (main or assisting) discretised with the rectangular rule: beyond
#: it the discrete loop no longer behaves like the analog one and soon diverges.
MAX_BANDWIDTH_TIME = 0.2


def check_bandwidth_time(bandwidth_hz: float, update_s: float, field: str) -> None:
    """Refuse a loop bandwidth too large for the update interval.

    Raises
    ------
    ConfigError
        Naming ``field`` when ``bandwidth_hz * update_s`` exceeds `MAX_BANDWIDTH_TIME`.
    """
    if bandwidth_hz * update_s > MAX_BANDWIDTH_TIME:
        raise ConfigError(
            field,
            f"B_L T = {bandwidth_hz * update_s:.3g} at T = {update_s:g} s is too large for a "
            f"discretised analog loop (at most {MAX_BANDWIDTH_TIME}: {MAX_BANDWIDTH_TIME / update_s:g} "
            f"Hz at this T; got {bandwidth_hz!r} Hz)",
        )


def natural_frequency(order: int, bandwidth_hz: float) -> float:
    """$\\omega_0$ (rad/s) of a loop of ``order`` with noise bandwidth ``bandwidth_hz``."""
    if order not in _BANDWIDTH_RATIO:
        raise ConfigError("order", f"loop order must be 1, 2 or 3, got {order}")
    if bandwidth_hz <= 0:
        raise ConfigError("bandwidth_hz", f"must be > 0, got {bandwidth_hz}")
    return bandwidth_hz / _BANDWIDTH_RATIO[order]


@dataclass
class LoopFilter:
    """A batch of loop filters: error in, rate command out (error units per second).

    With a phase error in cycles the output is a frequency in Hz; with a code error in
    chips, a code-rate correction in chips/s. An optional second input (e.g. an FLL's
    frequency error, in output units) enters one integrator earlier, which is the
    FLL-assisted PLL of Kaplan & Hegarty (order of the FLL = order of the PLL - 1).

    Parameters
    ----------
    order
        1, 2 or 3.
    bandwidth_hz
        Noise bandwidth $B_L$ of the main (phase/code) loop.
    update_s
        Update interval T.
    assist_bandwidth_hz
        Noise bandwidth of the assisting frequency loop (0: no assist).
    """

    order: int
    bandwidth_hz: float
    update_s: float
    assist_bandwidth_hz: float = 0.0

    def __post_init__(self) -> None:
        self.w0 = natural_frequency(self.order, self.bandwidth_hz)
        check_bandwidth_time(self.bandwidth_hz, self.update_s, "bandwidth_hz")
        self.wf = 0.0
        if self.assist_bandwidth_hz:
            check_bandwidth_time(self.assist_bandwidth_hz, self.update_s, "assist_bandwidth_hz")
            if self.order < 2:
                raise ConfigError("order", "a frequency-assisted loop needs order 2 or 3")
            self.wf = natural_frequency(self.order - 1, self.assist_bandwidth_hz)
        self.reset(())

    def reset(
        self, batch_shape: tuple[int, ...], rate0: np.ndarray | float = 0.0, accel0: np.ndarray | float = 0.0
    ) -> None:
        """Start a batch; ``rate0`` is the initial rate command (e.g. acquired Doppler)."""
        self.rate = np.broadcast_to(np.asarray(rate0, float), batch_shape).copy()
        self.accel = np.broadcast_to(np.asarray(accel0, float), batch_shape).copy()

    def __call__(self, error: np.ndarray, freq_error: np.ndarray | float = 0.0) -> np.ndarray:
        """Advance one update with ``error`` (and the assist input); return the rate command."""
        T, w0, wf = self.update_s, self.w0, self.wf
        if self.order == 1:
            return self.rate + w0 * error
        if self.order == 2:
            self.rate = self.rate + T * (w0**2 * error + wf * freq_error)
            return self.rate + np.sqrt(2.0) * w0 * error
        self.accel = self.accel + T * (w0**3 * error + wf**2 * freq_error)
        self.rate = self.rate + T * (self.accel + 1.1 * w0**2 * error + np.sqrt(2.0) * wf * freq_error)
        return self.rate + 2.4 * w0 * error
