r"""Correlator sources of the loop engine: where a channel's correlators come from.

A source turns a `Channel`'s replica over one coherent interval into early, prompt and
late correlators normalised to unit-variance I and Q noise
(`gnssframework.signal.correlator_model`), the same for every source, so a loop closer
runs on any of them unchanged:

- `AnalyticSource`: the analytic correlator model (`CorrelatorSimulator`, Zou et al. 2018,
  eqs. 2-7) at the replica's true errors (truth minus replica), as the Monte Carlo
  scenarios draw them;
- `gnssframework.receiver.engine.samples.SampleSource`: intermediate-frequency samples (a
  recording, or a simulated signal from
  `gnssframework.signal.if_samples` / `gnssframework.receiver.frontend.synthetic`)
  correlated with the channel's NCO replica by the compiled kernels
  (`gnssframework.receiver.channels.correlator.correlate_channels`).
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from ...errors import ConfigError
from ...signal.correlator_model import CorrelatorSimulator
from ...signal.correlators import Correlators
from .channel import Channel, ReplicaErrors

__all__ = ["CorrelatorSource", "AnalyticSource"]


class CorrelatorSource(Protocol):
    """What gives a loop the correlators of interval ``k`` of a channel's replica."""

    def correlate(
        self, channel: Channel, k: int, errors: ReplicaErrors | None = None, data_bit: np.ndarray | float = 1.0
    ) -> Correlators:
        """Correlators of interval ``k`` (batch shape of ``channel``). ``errors``: the
        replica's true errors over it (needed by the analytic source, ignored by samples);
        ``data_bit``: the interval's data symbol (analytic source; samples carry theirs)."""


class AnalyticSource:
    """Correlators drawn from the analytic model at the replica's true errors.

    Parameters
    ----------
    simulator
        The model's per-run constants (`CorrelatorSimulator`).
    amplitude
        Signal amplitude ``A = sqrt(2 c T)`` (`amplitude_from_cn0`), batch shape.
    rng
        The only source of the noise.
    amplitude_scale
        Optional ``(K, ...)`` factor on the amplitude per interval (scintillation), or a scalar.
    signal_gain, noise_gain
        Optional ``(K, ...)`` gains of the signal and the noise per interval (a C/N0 fade):
        drawn at ``A g_s / g_n``, then every tap scaled by ``g_n``.
    """

    def __init__(
        self,
        simulator: CorrelatorSimulator,
        amplitude: np.ndarray,
        rng: np.random.Generator,
        *,
        amplitude_scale: np.ndarray | float | None = None,
        signal_gain: np.ndarray | None = None,
        noise_gain: np.ndarray | None = None,
    ) -> None:
        self.simulator, self.amplitude, self.rng = simulator, amplitude, rng
        self.scale = None if amplitude_scale is None else np.asarray(amplitude_scale)
        self.signal_gain, self.noise_gain = signal_gain, noise_gain

    def correlate(
        self, channel: Channel, k: int, errors: ReplicaErrors | None = None, data_bit: np.ndarray | float = 1.0
    ) -> Correlators:
        if errors is None:
            raise ConfigError("errors", "the analytic correlator source needs the replica's true errors")
        amp = self.amplitude
        if self.scale is not None:
            amp = np.asarray(amp * (self.scale[k] if self.scale.ndim else self.scale), float)
        if self.signal_gain is None and self.noise_gain is None:
            return self.simulator.draw(errors.code_chips, errors.phase_rad, errors.freq_hz, amp, self.rng, data_bit)
        g_s = 1.0 if self.signal_gain is None else self.signal_gain[k]
        g_n = 1.0 if self.noise_gain is None else self.noise_gain[k]
        c = self.simulator.draw(
            errors.code_chips, errors.phase_rad, errors.freq_hz, amp * g_s / g_n, self.rng, data_bit
        )
        return Correlators.trusted(c.early * g_n, c.prompt * g_n, c.late * g_n)
