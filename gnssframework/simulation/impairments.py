"""Colored (AR(1)) noise, multipath and cycle slips."""

from __future__ import annotations

import numpy as np

from .. import random_streams as draw
from ..errors import ConfigError
from ..signal.correlator_model import correlator_mean

__all__ = ["ar1_noise", "multipath_correlator_mean", "eml_multipath_error_chips", "cycle_slips"]


def ar1_noise(
    psi: float | np.ndarray,
    innovation_std: float | np.ndarray,
    n: int,
    rng: np.random.Generator,
    batch_shape: tuple[int, ...] = (),
    stationary: bool = True,
) -> np.ndarray:
    """AR(1) process $V_k = \\psi V_{k-1} + \\xi_k$, $\\xi_k \\sim N(0, \\sigma^2)$, time on axis 0.

    With ``stationary=True`` the first sample is drawn from the stationary law
    $N(0, \\sigma^2/(1-\\psi^2))$, so the whole sequence is stationary.
    ``psi`` and ``innovation_std`` broadcast over the trailing (batch) dimensions.
    """
    psi = np.asarray(psi, dtype=float)
    if np.any(np.abs(psi) >= 1):
        raise ConfigError("psi", f"must satisfy |psi| < 1, got {psi}")
    shape = np.broadcast_shapes(tuple(batch_shape), psi.shape, np.shape(innovation_std))
    xi = draw.standard_normal(rng, (n,) + shape, run_axis=1) * innovation_std
    if stationary:
        xi[0] = xi[0] / np.sqrt(1 - psi**2)
    if psi.ndim == 0:  # one psi: a single IIR filter over time
        from scipy import signal  # here: scipy.signal's import costs every receiver run a second

        return signal.lfilter([1.0], [1.0, -float(psi)], xi, axis=0)
    out = np.empty_like(xi)
    out[0] = xi[0]
    for k in range(1, n):  # per-element psi: recursion over time, batched over elements
        out[k] = psi * out[k - 1] + xi[k]
    return out


def multipath_correlator_mean(
    amplitude: np.ndarray,
    code_error_chips: np.ndarray,
    carrier_phase_rad: np.ndarray,
    freq_error_hz: np.ndarray,
    coherent_time_s: float,
    offsets_chips: np.ndarray,
    relative_amplitude: np.ndarray | float,
    delay_chips: np.ndarray | float,
    relative_phase_rad: np.ndarray | float,
    relative_freq_hz: np.ndarray | float = 0.0,
    bandwidth_hz: float | None = None,
) -> np.ndarray:
    """Noise-free taps of a direct ray plus one reflected ray.

    The reflection arrives ``delay_chips`` later with amplitude ``relative_amplitude``
    (alpha) times the direct one, carrier phase offset ``relative_phase_rad`` and phase
    rate ``relative_freq_hz`` (the fading frequency). The two rays add in the correlators:

    $$
    y_o = y_o^{direct}(\\delta\\tau) + \\alpha\\, y_o(\\delta\\tau - \\Delta, \\delta\\theta + \\psi, \\delta f + f_{mp})
    $$
    """
    direct = correlator_mean(
        amplitude,
        code_error_chips,
        carrier_phase_rad,
        freq_error_hz,
        coherent_time_s,
        offsets_chips,
        bandwidth_hz=bandwidth_hz,
    )
    reflected = correlator_mean(
        np.asarray(amplitude) * relative_amplitude,
        np.asarray(code_error_chips) - delay_chips,
        np.asarray(carrier_phase_rad) + relative_phase_rad,
        np.asarray(freq_error_hz) + relative_freq_hz,
        coherent_time_s,
        offsets_chips,
        bandwidth_hz=bandwidth_hz,
    )
    return direct + reflected


def eml_multipath_error_chips(
    relative_amplitude: float, delay_chips: np.ndarray, early_late_spacing_chips: float = 1.0, in_phase: bool = True
) -> np.ndarray:
    """Closed-form tracking bias of a coherent EML DLL with one in-phase (or anti-phase)
    reflection, triangle autocorrelation, while both taps stay on the correlation
    slopes ($\\Delta < d - $ bias):

    $$
    \\epsilon = \\pm \\frac{\\alpha \\Delta}{1 \\pm \\alpha}
    $$

    the classic multipath error envelope's short-delay branch (Braasch; Van Nee).
    """
    a = relative_amplitude if in_phase else -relative_amplitude
    delay = np.asarray(delay_chips, dtype=float)
    d = early_late_spacing_chips / 2
    if np.any(delay >= d):
        raise ConfigError("delay_chips", f"the closed form holds for delays below d = {d} chips")
    return a * delay / (1 + a)


def cycle_slips(
    n_epochs: int,
    probability_per_epoch: float,
    rng: np.random.Generator,
    max_cycles: int = 10,
    batch_shape: tuple[int, ...] = (),
    half_cycles: bool = False,
    min_cycles: int = 1,
) -> np.ndarray:
    """Cumulative carrier-phase slips (cycles) at each epoch, time on axis 0.

    At each epoch after the first a slip happens with ``probability_per_epoch``; its
    size is uniform in ``±min_cycles..max_cycles`` (half cycles if ``half_cycles``, as a
    Costas loop slips). A slip at the first epoch would only change the ambiguity, so
    there is none. Add ``slips * wavelength`` to a carrier-phase range in metres; the
    slip epochs are where ``np.diff(slips, axis=0, prepend=0)`` is non-zero.
    """
    if not 0 <= probability_per_epoch <= 1:
        raise ConfigError("probability_per_epoch", f"must be in [0, 1], got {probability_per_epoch}")
    if not 1 <= min_cycles <= max_cycles:
        raise ConfigError("min_cycles", f"needs 1 <= min_cycles <= max_cycles, got {min_cycles} and {max_cycles}")
    shape = (n_epochs,) + tuple(batch_shape)
    happens = draw.random(rng, shape, run_axis=1) < probability_per_epoch
    happens[0] = False
    size = draw.integers(rng, min_cycles, max_cycles + 1, shape, run_axis=1) * draw.choice(
        rng, [-1, 1], shape, run_axis=1
    )
    step = np.where(happens, size, 0) * (0.5 if half_cycles else 1.0)
    return np.cumsum(step, axis=0)
