"""C/N0 fades: a drop of the carrier-to-noise density ratio over a time window.

A receiver's correlators carry the signal with amplitude $A$ in noise of standard
deviation $\\sigma$ per I and Q; their C/N0 is $c = A^2 / (2 \\sigma^2 T)$ (unit-variance
noise: `gnssframework.signal.correlator_model.amplitude_from_cn0`). A fade of $d$ dB
lowers it by $d$ dB in one of two ways, which look alike in C/N0 but not to a filter
that models the noise:

- ``attenuation``: the signal loses $d$ dB (foliage, a building or a vehicle between
  the antenna and some satellites): $A \\to A\\,10^{-d/20}$, the noise unchanged. A
  receiver whose correlators are scaled to a known noise level (an AGC, or a noise
  estimate) sees this whatever the cause.
- ``noise-floor``: the noise density rises by $d$ dB at a fixed front-end gain (in-band
  interference, common to every channel): $\\sigma \\to \\sigma\\,10^{d/20}$, the
  signal unchanged, so a filter's R fixed at the nominal noise is too small.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

__all__ = ["CN0Fade", "FadeCause", "lowest_channels"]

#: How a fade lowers the C/N0 (`CN0Fade.cause`).
FadeCause = Literal["attenuation", "noise-floor"]


@dataclass(frozen=True)
class CN0Fade:
    """A step drop of ``depth_db`` in C/N0 from ``start_s`` for ``duration_s`` (None: to
    the end), on the channels of a mask, by ``cause`` (see the module).

    An interval is faded when its middle lies in ``[start_s, start_s + duration_s)``.
    """

    depth_db: float
    start_s: float
    duration_s: float | None = None
    cause: FadeCause = "attenuation"

    def active(self, t_mid_s: np.ndarray) -> np.ndarray:
        """Whether each interval (by its mid time, s) is faded: boolean, ``t_mid_s.shape``."""
        t = np.asarray(t_mid_s, float)
        end = np.inf if self.duration_s is None else self.start_s + self.duration_s
        return (t >= self.start_s) & (t < end)

    def loss_db(self, t_mid_s: np.ndarray, faded: np.ndarray) -> np.ndarray:
        """C/N0 loss (dB) of each interval and channel, ``(K, *faded.shape)``: ``depth_db``
        where the interval is faded and the channel is in the mask ``faded``, else 0."""
        on = self.active(t_mid_s).reshape((-1,) + (1,) * np.ndim(faded))
        return np.where(on & np.asarray(faded, bool), float(self.depth_db), 0.0)

    def gains(self, t_mid_s: np.ndarray, faded: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Amplitude factors of the signal and of the noise, each ``(K, *faded.shape)``.

        Their C/N0 is the nominal one minus `loss_db`: $(g_s / g_n)^2 = 10^{-L/10}$.
        """
        amp = 10.0 ** (-self.loss_db(t_mid_s, faded) / 20.0)
        ones = np.ones_like(amp)
        return (amp, ones) if self.cause == "attenuation" else (ones, 1.0 / amp)


def lowest_channels(elevation_deg: np.ndarray, count: int | None) -> np.ndarray:
    """Mask of the ``count`` lowest channels of each run (None: all), ``elevation_deg.shape``
    ``(runs, ch)``: an obstruction near the horizon (trees, a building) shadows the low
    satellites first."""
    el = np.asarray(elevation_deg, float)
    if count is None or count >= el.shape[-1]:
        return np.ones(el.shape, bool)
    rank = np.argsort(np.argsort(el, axis=-1, kind="stable"), axis=-1)  # 0 = lowest
    return rank < count
