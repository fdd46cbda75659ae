"""Analytic correlator model: early / prompt / late outputs with correlated noise.

Normalisation
-------------
The noise of every correlator output has **unit variance in I and in Q**. A signal of
carrier-to-noise density ratio C/N0 (linear ``c``, Hz) integrated coherently over T
seconds then has amplitude

$$
A = \\sqrt{2\\, c\\, T}, \\qquad \\frac{A^2}{2 \\sigma^2} = c\\,T,
$$

so ``|P|^2 = A^2 + 2`` on average. The noise of two taps ``Delta`` chips apart is
correlated with coefficient ``R(Delta)``, the code autocorrelation, because both
correlate the same white noise against shifted copies of one code.

Conventions
-----------
- ``code_error_chips`` is true delay minus replica delay. A positive error means the
  signal arrives later than the replica, and the late tap is the stronger.
- Tap offsets are relative to the prompt, negative for early:
  ``offsets = (-d, 0, +d)`` with ``d = early_late_spacing_chips / 2``. A tap at offset
  ``o`` sees ``R(code_error - o)``.
- ``R`` is the signal's (`SignalSpec.autocorrelation`, GPS L1 C/A by default): the
  triangle ``max(0, 1 - |tau|)`` for BPSK, a train of triangles for BOC and CBOC.
- ``carrier_phase_rad`` is the phase error at the start of the interval. With a
  frequency error ``df`` the output is rotated by its mean over the interval,
  ``pi df T + phase``, and scaled by ``sinc(df T)`` (Zou et al. 2018, eqs. 2-7).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from .. import random_streams as draw
from ..errors import ConfigError
from .correlators import Correlators
from .gps_l1ca import GPS_L1CA
from .spec import SignalSpec

__all__ = [
    "amplitude_from_cn0",
    "code_autocorrelation",
    "tap_offsets",
    "correlator_mean",
    "tap_noise_cov",
    "simulate_correlators",
    "CorrelatorSimulator",
]


def amplitude_from_cn0(cn0_dbhz: np.ndarray | float, coherent_time_s: float) -> np.ndarray:
    """Correlator amplitude ``A = sqrt(2 c T)`` for unit-variance I and Q noise."""
    return np.sqrt(2.0 * 10.0 ** (np.asarray(cn0_dbhz, dtype=float) / 10.0) * coherent_time_s)


@lru_cache(maxsize=16)
def _band_limited_table(
    bandwidth_hz: float, chip_rate_hz: float, pulse: tuple[float, ...] = (1.0,)
) -> tuple[np.ndarray, np.ndarray]:
    r"""R(tau) of a code with chip pulse ``pulse`` through an ideal low-pass front end of
    two-sided width B: :math:`R(\tau) = \int_{-B/2}^{B/2} G(f) \cos(2\pi f \tau T_c) df`.

    BPSK (``pulse = (1,)``): :math:`G(f) = T_c\,\mathrm{sinc}^2(f T_c)`. A pulse constant
    on :math:`S` pieces of width :math:`\Delta = T_c / S` (values :math:`v_k`, unit mean
    power; BOC, CBOC) has the spectrum :math:`G(f) = |\sum_k v_k \Delta\,\mathrm{sinc}(f
    \Delta) e^{-j 2\pi f (k + 1/2) \Delta}|^2 / T_c` (Betz 2016, ch. 12), which is the
    BPSK one for :math:`S = 1`.
    """
    Tc = 1.0 / chip_rate_hz
    tau = np.linspace(-2.0, 2.0, 2001)  # chips
    if pulse == (1.0,):
        f = np.linspace(-bandwidth_hz / 2, bandwidth_hz / 2, 4001)
        psd = Tc * np.sinc(f * Tc) ** 2
    else:
        s = len(pulse)
        # Sample the spectrum finely enough for its S-times-wider main lobes.
        f = np.linspace(-bandwidth_hz / 2, bandwidth_hz / 2, 4000 * max(1, s) + 1)
        delta = Tc / s
        centres = (np.arange(s) + 0.5) * delta
        spectrum = np.sinc(f * delta) * delta * (np.exp(-2j * np.pi * f[:, None] * centres) @ np.asarray(pulse))
        psd = np.abs(spectrum) ** 2 / Tc
    r = np.trapezoid(psd[None, :] * np.cos(2 * np.pi * f[None, :] * tau[:, None] * Tc), f, axis=1)
    return tau, r


def code_autocorrelation(
    tau_chips: np.ndarray,
    bandwidth_hz: float | None = None,
    chip_rate_hz: float | None = None,
    signal: SignalSpec = GPS_L1CA,
) -> np.ndarray:
    """Code autocorrelation of ``signal`` (GPS L1 C/A by default) at ``tau_chips``.

    Parameters
    ----------
    tau_chips
        Lags in chips.
    bandwidth_hz
        ``None`` for the ideal autocorrelation: the triangle ``max(0, 1 - |tau|)`` for
        BPSK, the triangle train of `SignalSpec.autocorrelation` for BOC. Otherwise the
        two-sided bandwidth of an ideal (brick-wall) front-end filter. The peak then drops
        below 1 by the power the filter removes (0.90 at 2.046 MHz for BPSK(1)), and the
        corners are rounded.
    chip_rate_hz
        The chip rate the bandwidth is measured against (``signal``'s by default).
    signal
        The signal whose code and sub-carrier make the correlation.
    """
    tau = np.asarray(tau_chips, dtype=float)
    if bandwidth_hz is None:
        if signal.is_bpsk:
            return np.maximum(0.0, 1.0 - np.abs(tau))
        return signal.autocorrelation(tau)
    if bandwidth_hz <= 0:
        raise ConfigError("bandwidth_hz", f"must be > 0 or None, got {bandwidth_hz}")
    rate = signal.chip_rate_hz if chip_rate_hz is None else chip_rate_hz
    pulse = tuple(float(v) for v in signal.chip_pulse(0))  # (1.0,) for BPSK
    grid, r = _band_limited_table(float(bandwidth_hz), float(rate), pulse)
    return np.interp(tau, grid, r, left=0.0, right=0.0)


def tap_offsets(early_late_spacing_chips: float, extra: dict[str, float] | None = None) -> dict[str, float]:
    """Offsets of the taps (chips, negative = early): early, prompt, late, then extras."""
    if not 0 < early_late_spacing_chips <= 2:
        raise ConfigError("early_late_spacing_chips", f"must be in (0, 2], got {early_late_spacing_chips}")
    d = early_late_spacing_chips / 2
    out = {"early": -d, "prompt": 0.0, "late": d}
    out.update(extra or {})
    return out


def correlator_mean(
    amplitude: np.ndarray | float,
    code_error_chips: np.ndarray | float,
    carrier_phase_rad: np.ndarray | float,
    freq_error_hz: np.ndarray | float,
    coherent_time_s: float,
    offsets_chips: np.ndarray,
    data_bit: np.ndarray | float = 1.0,
    bandwidth_hz: float | None = None,
    signal: SignalSpec = GPS_L1CA,
) -> np.ndarray:
    """Noise-free complex outputs of taps at ``offsets_chips``, shape ``(..., n_taps)``
    (``R`` the autocorrelation of ``signal``, `code_autocorrelation`).

    $$
    y_o = A\\, D\\, R(\\delta\\tau - o)\\, \\mathrm{sinc}(\\delta f T)\\, e^{j(\\pi \\delta f T + \\delta\\theta)}
    $$
    """
    amp = np.asarray(amplitude, dtype=float)
    dtau = np.asarray(code_error_chips, dtype=float)
    df = np.asarray(freq_error_hz, dtype=float)
    phase = np.pi * df * coherent_time_s + np.asarray(carrier_phase_rad, dtype=float)
    r = code_autocorrelation(dtau[..., None] - np.asarray(offsets_chips, dtype=float), bandwidth_hz, signal=signal)
    common = amp * np.asarray(data_bit, dtype=float) * np.sinc(df * coherent_time_s)
    return (common * np.exp(1j * phase))[..., None] * r


def tap_noise_cov(
    offsets_chips: np.ndarray, bandwidth_hz: float | None = None, signal: SignalSpec = GPS_L1CA
) -> np.ndarray:
    """Covariance of the I (or Q) noise of the taps: ``R(o_i - o_j)`` of ``signal``."""
    o = np.asarray(offsets_chips, dtype=float)
    return code_autocorrelation(o[:, None] - o[None, :], bandwidth_hz, signal=signal)


def simulate_correlators(
    code_error_chips: np.ndarray | float,
    carrier_phase_rad: np.ndarray | float,
    freq_error_hz: np.ndarray | float,
    cn0_dbhz: np.ndarray | float,
    coherent_time_s: float,
    rng: np.random.Generator,
    early_late_spacing_chips: float = 1.0,
    data_bit: np.ndarray | float = 1.0,
    bandwidth_hz: float | None = None,
    extra_taps: dict[str, float] | None = None,
    amplitude: np.ndarray | None = None,
    signal: SignalSpec = GPS_L1CA,
) -> Correlators:
    """Draw one coherent interval of correlator outputs for a batch of channels.

    Parameters
    ----------
    code_error_chips, carrier_phase_rad, freq_error_hz
        Tracking errors, broadcast together to the batch shape.
    cn0_dbhz
        C/N0 per element (ignored if ``amplitude`` is given).
    coherent_time_s
        Coherent integration time T.
    rng
        The only source of randomness.
    early_late_spacing_chips
        Early-to-late spacing (1 chip by default: early and late half a chip off prompt).
    data_bit
        Navigation data bit (+1/-1) per element; 1 after wipe-off.
    bandwidth_hz
        Front-end two-sided bandwidth (``None``: infinite, triangle).
    extra_taps
        Further taps by name and offset, e.g. ``{"very_early": -1.0, "very_late": 1.0}``.
    amplitude
        Give the amplitude directly (e.g. under scintillation) instead of C/N0.
    signal
        The signal whose autocorrelation shapes the taps (GPS L1 C/A by default).

    Returns
    -------
    Correlators
        With unit-variance I and Q noise, correlated across taps as ``R(o_i - o_j)``.
    """
    sim = CorrelatorSimulator(coherent_time_s, early_late_spacing_chips, bandwidth_hz, extra_taps, signal)
    amp = amplitude_from_cn0(cn0_dbhz, coherent_time_s) if amplitude is None else np.asarray(amplitude, float)
    return sim.draw(code_error_chips, carrier_phase_rad, freq_error_hz, amp, rng, data_bit)


class CorrelatorSimulator:
    """`simulate_correlators` with its per-run constants computed once.

    A harness that draws correlators every interval (the vector and deep-integration
    loops) builds one per run: the tap offsets and the noise covariance's root (an
    ``eigh``) do not change between intervals, so only the draw remains per interval.
    The draws and the arithmetic are those of `simulate_correlators`, which is this
    class used once.

    Parameters
    ----------
    coherent_time_s, early_late_spacing_chips, bandwidth_hz, extra_taps, signal
        As in `simulate_correlators`.
    """

    def __init__(
        self,
        coherent_time_s: float,
        early_late_spacing_chips: float = 1.0,
        bandwidth_hz: float | None = None,
        extra_taps: dict[str, float] | None = None,
        signal: SignalSpec = GPS_L1CA,
    ) -> None:
        offsets = tap_offsets(early_late_spacing_chips, extra_taps)
        self.names = list(offsets)
        self.offsets_chips = np.array([offsets[n] for n in self.names])
        self.coherent_time_s = float(coherent_time_s)
        self.bandwidth_hz = bandwidth_hz
        self.signal = signal
        w, v = np.linalg.eigh(tap_noise_cov(self.offsets_chips, bandwidth_hz, signal))
        root = v * np.sqrt(np.clip(w, 0.0, None))  # PSD root: taps may be (nearly) coincident
        self.root_t = root.T

    def draw(
        self,
        code_error_chips: np.ndarray | float,
        carrier_phase_rad: np.ndarray | float,
        freq_error_hz: np.ndarray | float,
        amplitude: np.ndarray,
        rng: np.random.Generator,
        data_bit: np.ndarray | float = 1.0,
    ) -> Correlators:
        """One interval of correlator outputs (`simulate_correlators`, with the amplitude
        ``A = sqrt(2 c T)`` given: `amplitude_from_cn0`)."""
        mean = correlator_mean(
            amplitude,
            code_error_chips,
            carrier_phase_rad,
            freq_error_hz,
            self.coherent_time_s,
            self.offsets_chips,
            data_bit,
            self.bandwidth_hz,
            self.signal,
        )
        shape = mean.shape
        root_t = self.root_t
        noise = draw.standard_normal(rng, shape, 0) @ root_t + 1j * (draw.standard_normal(rng, shape, 0) @ root_t)
        out = mean + noise
        if len(self.names) == 3:
            return Correlators.trusted(out[..., 0], out[..., 1], out[..., 2])
        taps = {n: out[..., i] for i, n in enumerate(self.names)}
        return Correlators(taps.pop("early"), taps.pop("prompt"), taps.pop("late"), extra=taps)
