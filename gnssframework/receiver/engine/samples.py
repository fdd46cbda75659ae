"""The sample correlator source of the loop engine: IF samples through the compiled kernels.

See `gnssframework.receiver.engine.sources` for the protocol; `SampleSource` gives the
correlators a real receiver forms, in the analytic model's normalisation, so one loop
closer runs on a recording or a simulated signal as on the Monte Carlo model.
"""

from __future__ import annotations

import numpy as np

from ...errors import ConfigError
from ...signal.correlator_model import tap_offsets
from ...signal.correlators import Correlators
from ..channels.correlator import correlate_channels
from .channel import Channel, ReplicaErrors

__all__ = ["SampleSource"]


class SampleSource:
    r"""Correlators of IF samples with each channel's NCO replica (compiled kernels).

    Interval k of every channel spans samples ``start_sample + k n`` to ``+ n``,
    :math:`n = T f_s` (an integer). The replica's carrier is the intermediate frequency plus
    the channel's carrier NCO: phase :math:`2\pi f_{IF} t + \hat\theta` at the interval's
    start, step :math:`(f_{IF} + \hat f)/f_s` per sample; its code phase and step are the
    channel's code NCO. Sums are divided by :math:`\sqrt{n\,\sigma^2}` (complex samples) or
    :math:`\sqrt{n\,\sigma^2/2}` (real), so the noise has unit variance in I and Q, the
    analytic model's normalisation (`gnssframework.signal.if_samples.correlate_if`).

    Parameters
    ----------
    samples
        ``complex`` or real samples of one stream ``(n,)`` (all channels see it, as in a
        receiver); or ``(n_channels, n)``, one stream per channel (flattened batch order):
        channel i correlates stream i only, a signal without the other satellites'
        cross-correlation, the analytic model's assumption (`truth_samples` with
        ``streams="per-channel"``).
    sample_rate_hz, if_hz
        Sample rate and intermediate frequency.
    codes
        ``(n_channels, code_length)`` ±1 codes of the channels (flattened batch order), or
        ``(n_channels, code_length * subchips_per_chip)`` BOC tables (`replica_codes`).
    coherent_time_s
        T.
    early_late_spacing_chips
        Tap spacing, as the analytic model's (`tap_offsets`).
    noise_std
        Standard deviation of the noise per real dimension (1 for `synthesize_samples`).
    start_sample
        Sample of the first interval's start.
    backend
        ``"numba"`` or ``"numpy"`` (`correlate_channels`); default: the library's.
    subchips_per_chip
        Entries of ``codes`` a chip (``SignalSpec.subchips_per_chip``: 2 for BOC(1,1)); the
        channel's code phase and rate stay in chips.
    """

    def __init__(
        self,
        samples: np.ndarray,
        sample_rate_hz: float,
        if_hz: float,
        codes: np.ndarray,
        coherent_time_s: float,
        *,
        early_late_spacing_chips: float = 1.0,
        noise_std: float = 1.0,
        start_sample: int = 0,
        backend: str | None = None,
        subchips_per_chip: int = 1,
    ) -> None:
        n = coherent_time_s * sample_rate_hz
        if abs(n - round(n)) > 1e-6:
            raise ConfigError(
                "sample_rate_hz",
                f"the coherent time {coherent_time_s} s must hold a whole number of "
                f"samples at {sample_rate_hz} Hz, got {n}",
            )
        samples = np.asarray(samples)
        if samples.ndim not in (1, 2):
            raise ConfigError("samples", f"one stream (n,) or one per channel (channels, n), got shape {samples.shape}")
        #: Offset of each channel's stream in the flat buffer (0: the one stream).
        self.stream_offsets = np.arange(samples.shape[0]) * samples.shape[1] if samples.ndim == 2 else None
        self.samples, self.fs, self.if_hz = samples.reshape(-1), float(sample_rate_hz), float(if_hz)
        self.codes = np.ascontiguousarray(codes, np.float32)
        self.n, self.start = int(round(n)), int(start_sample)
        # A BOC table (`SignalSpec.spreading_table`) holds sub-chips: phases, rates and tap
        # offsets go to the kernels in its units (`channels.correlator.to_table_units`).
        self.subchips = int(subchips_per_chip)
        self.offsets = np.array(list(tap_offsets(early_late_spacing_chips).values())) * self.subchips
        self.norm = np.sqrt(self.n * noise_std**2 * (1.0 if np.iscomplexobj(samples) else 0.5))
        self.backend = backend

    def correlate(
        self, channel: Channel, k: int, errors: ReplicaErrors | None = None, data_bit: np.ndarray | float = 1.0
    ) -> Correlators:
        batch = channel.batch
        n_ch = int(np.prod(batch, dtype=int))
        if self.codes.shape[0] != n_ch:
            raise ConfigError("codes", f"{self.codes.shape[0]} codes for {n_ch} channels")
        if self.stream_offsets is not None and self.stream_offsets.size != n_ch:
            raise ConfigError("samples", f"{self.stream_offsets.size} streams for {n_ch} channels")
        start = self.start + k * self.n
        first = np.full(n_ch, start) if self.stream_offsets is None else self.stream_offsets + start
        flat = lambda a: np.broadcast_to(np.asarray(a, float), batch).reshape(-1)  # noqa: E731
        cycles = np.mod(self.if_hz * start / self.fs, 1.0) + flat(channel.carrier_phase_rad) / (2 * np.pi)
        out = (
            correlate_channels(
                self.samples,
                first,
                np.full(n_ch, self.n),
                flat(channel.code_phase_chips) * self.subchips,
                flat(channel.code_rate_chips_s) * self.subchips / self.fs,
                cycles,
                (self.if_hz + flat(channel.carrier_freq_hz)) / self.fs,
                self.codes,
                self.offsets,
                backend=self.backend,
            )
            / self.norm
        )
        out = out.reshape(batch + (3,))
        return Correlators.trusted(out[..., 0], out[..., 1], out[..., 2])
