r"""Receiver clock model from Allan-variance h-parameters.

Two states, bias b (s) and drift d (s/s), with $\dot b = d + w_f$ and $\dot d = w_g$:
white frequency noise of spectral density $S_f = h_0/2$ and random-walk frequency
noise $S_g = 2\pi^2 h_{-2}$ (Brown & Hwang, *Introduction to Random Signals and
Applied Kalman Filtering*, 4th ed., §9.3). Discretised exactly over an interval T:

$$
Q = \begin{bmatrix} S_f T + S_g T^3/3 & S_g T^2/2 \\ S_g T^2/2 & S_g T \end{bmatrix}
$$

Two integrators cannot produce flicker frequency noise (a flat Allan variance
$2 \ln 2\, h_{-1}$), so $h_{-1}$ enters `allan_variance` but not the simulation. For
the TCXO preset flicker is below 10 % of the Allan variance at every $\tau$; for the
OCXO preset it is 40 % at 0.1 s and 20 % at 1 s, which the simulated clock lacks.
A common alternative Q with $h_0/(2T)$ in the drift term treats d as an interval
*average* frequency. It is inconsistent with the random-walk transition above, and
simulating with it inflates the Allan variance a hundredfold; we tested this.

$$
\sigma_y^2(\tau) = \frac{h_0}{2\tau} + 2 \ln 2\, h_{-1} + \frac{2\pi^2}{3} h_{-2} \tau
$$
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from .. import random_streams as draw
from ..errors import ConfigError

__all__ = ["ClockModel", "TCXO", "TCXO_HQ", "OCXO", "PRESETS", "ClockPreset", "Oscillator", "oscillator_cycles"]


@dataclass(frozen=True)
class ClockModel:
    """Oscillator h-parameters (fractional frequency PSD coefficients)."""

    h0: float
    h_1: float
    h_2: float

    def process_noise(self, interval_s: float) -> np.ndarray:
        """Q of [bias (s), drift (s/s)] over ``interval_s``."""
        T = interval_s
        sf, sg = self.h0 / 2, 2 * np.pi**2 * self.h_2
        return np.array([[sf * T + sg * T**3 / 3, sg * T**2 / 2], [sg * T**2 / 2, sg * T]])

    def tracking_process_noise(self, interval_s: float, carrier_hz: float, code_rate_hz: float) -> np.ndarray:
        r"""Q of a tracking channel's ``[code (chips), carrier phase (rad), carrier frequency (Hz)]``
        driven by this clock over ``interval_s``.

        A receiver clock bias b (s) delays the code by $f_{code} b$ chips, a code phase
        error (truth minus replica, `gnssframework.receiver.engine.channel`) of
        $-f_{code} b$, and rotates the carrier by $-2\pi f_c b$ rad; its drift d moves the
        carrier frequency by $-f_c d$ Hz.
        With $G$ that map, $Q_{trk} = G\, Q_{clock}\, G^T$ (Q of `process_noise`), which is
        exact because the channel's code/phase/frequency transition over T is the clock's
        $[[1, T], [0, 1]]$ in these units. Used to derive a channel filter's process noise
        from the oscillator's h-parameters instead of setting it by hand.
        """
        G = np.array([[-code_rate_hz, 0.0], [-2 * np.pi * carrier_hz, 0.0], [0.0, -carrier_hz]])
        return G @ self.process_noise(interval_s) @ G.T

    def allan_variance(self, tau_s: np.ndarray, include_flicker: bool = True) -> np.ndarray:
        """Theoretical Allan variance $\\sigma_y^2(\\tau)$; ``include_flicker=False`` gives
        the part `simulate` reproduces."""
        tau = np.asarray(tau_s, dtype=float)
        flicker = 2 * np.log(2) * self.h_1 if include_flicker else 0.0
        return self.h0 / (2 * tau) + flicker + 2 * np.pi**2 / 3 * self.h_2 * tau

    def simulate(
        self, n: int, interval_s: float, rng: np.random.Generator, batch_shape: tuple[int, ...] = ()
    ) -> tuple[np.ndarray, np.ndarray]:
        """Bias (s) and drift (s/s) at ``n`` epochs, both starting at 0; time on axis 0."""
        if n < 1 or interval_s <= 0:
            raise ConfigError("n", "needs n >= 1 epochs and interval_s > 0")
        Q = self.process_noise(interval_s)
        L = np.linalg.cholesky(Q)
        w = draw.standard_normal(rng, (n, *batch_shape, 2), run_axis=1) @ L.T
        drift = np.cumsum(w[..., 1], axis=0) - w[..., 1]  # drift at the start of each interval
        bias = np.cumsum(w[..., 0] + interval_s * drift, axis=0)
        return bias - bias[0], drift


#: Temperature-compensated crystal oscillator, Brown & Hwang's (low-quality) typical values:
#: Allan deviation 3.2e-9 at 10 ms, i.e. about 5 Hz of white carrier-frequency jitter per
#: 10-ms interval at L1, far above the GNSS-grade TCXOs of current receivers.
TCXO = ClockModel(h0=2e-19, h_1=7e-21, h_2=2e-20)
#: A good (GNSS-grade) TCXO: the "high-quality TCXO" h-values of the GNSS receiver-research
#: literature (e.g. the ``HIGH_QUALITY_TCXO`` preset of Auburn GAVLAB's navtools/sturdr
#: receivers), Allan deviation 3.2e-10 at 10 ms and 1.5e-10 at 100 ms. The random-walk
#: term is Brown & Hwang's; the white-FM term is a hundred times lower.
TCXO_HQ = ClockModel(h0=2e-21, h_1=1e-22, h_2=2e-20)
#: Oven-controlled crystal oscillator (Brown & Hwang's typical values).
OCXO = ClockModel(h0=2e-25, h_1=7e-25, h_2=6e-25)
PRESETS = {"tcxo": TCXO, "tcxo-hq": TCXO_HQ, "ocxo": OCXO}

#: The name of a preset above (a filter's model of its receiver's clock).
ClockPreset = Literal["tcxo", "tcxo-hq", "ocxo"]
#: A scenario's receiver oscillator: ``none`` (an ideal clock) or the name of a preset above.
Oscillator = Literal["none", ClockPreset]


def oscillator_cycles(
    oscillator: str, epochs: int, interval_s: float, rng: np.random.Generator, runs: int, carrier_hz: float
) -> np.ndarray | None:
    r"""The carrier cycles ``(epochs+1, runs)`` a receiver oscillator adds to a signal's
    truth, or None for ``"none"`` (an ideal clock).

    A clock bias b (s) delays the replica, so the received carrier moves by $-f_c b$
    cycles relative to it and the code by $-f_{code} b$ chips: code and carrier together,
    as a line-of-sight motion of $-c\,b$ would (`ClockModel.tracking_process_noise`).
    b is the preset's two-state clock (white and random-walk frequency noise, exact over
    the interval; flicker frequency noise is not simulated), starting at 0 with zero
    drift: the receiver's frequency offset at acquisition is absorbed in the known Doppler.
    """
    if oscillator == "none":
        return None
    bias_s, _ = PRESETS[oscillator].simulate(epochs + 1, interval_s, rng, batch_shape=(runs,))
    return -carrier_hz * bias_s
