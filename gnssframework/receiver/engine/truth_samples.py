r"""IF samples of a geometry-form `LoopTruth`: the signal a vector loop's truth describes.

What lets one closer run on the analytic model and on samples of the *same* truth
(`engine.sources`): every channel's signal is generated from the truth's own pseudoranges,
so the replica errors a loop records against the truth are those of the samples.

Per channel :math:`i` of run ``run``, at the sample times :math:`t_n = n / f_s`,

.. math::

    x_n = \sum_i a_i\, c_i\!\left(f_{chip} t_n - \rho_i(t_n)/\lambda_{chip}\right)
          e^{\,j\left(2\pi f_{IF} t_n + \theta_{0,i} - 2\pi \rho^{carrier}_i(t_n)/\lambda\right)}
          + w_n, \qquad a_i = \sqrt{2\,(C/N_0)_i / f_s},

with :math:`w_n` complex white noise of unit variance per real dimension (the amplitude
law of `gnssframework.signal.if_samples.generate_if_samples` for complex samples), the
code pseudorange :math:`\rho_i` (`LoopTruth.pseudorange`: geometric range plus receiver
clock, plus the truth's code range error) and the carrier's :math:`\rho^{carrier}_i` (plus
the carrier range error instead): the phases `code_phase_of_range` and the vector loop's
truth give. The ranges are evaluated at the truth's interval edges :math:`kT` and
interpolated linearly to the samples: the error is at most :math:`|\ddot\rho| T^2/8`,
under a micrometre for a satellite's line-of-sight acceleration (< 1 m/s²) and T ≤ 20 ms,
and the receiver clock is the truth's, linear between edges by definition
(`LoopTruth.nav_truth`).
"""

from __future__ import annotations

import numpy as np

from ...errors import ConfigError
from ...navigation.geometry import ranges_from_receivers
from .truth import LoopTruth, code_phase_of_range

__all__ = ["truth_samples", "truth_ranges_m"]

#: Samples generated at once per channel (bounds the temporary arrays to ~100 MB).
_CHUNK = 1 << 21


def truth_ranges_m(truth: LoopTruth, run: int) -> tuple[np.ndarray, np.ndarray]:
    """Code and carrier pseudoranges (m) of run ``run`` at the ``K+1`` interval edges, ``(K+1, channels)`` each."""
    if truth.sat_state is None or truth.receiver_state is None or truth.clock_m is None:
        raise ConfigError("truth", "IF samples of a truth need its geometry form (sat_state, receiver_state, clock_m)")
    t = np.arange(truth.epochs + 1) * truth.coherent_time_s
    rho = ranges_from_receivers(truth.sat_state(t)[0], truth.receiver_state(t)[0])[:, run]
    rho = rho + truth.clock_m[:, run, 0][:, None]
    if truth.range_error_m is None:
        return rho, rho
    code_m, carrier_m = truth.range_error_m(t)
    return rho + code_m[:, run], rho + carrier_m[:, run]


def truth_samples(
    truth: LoopTruth,
    sample_rate_hz: float,
    codes: np.ndarray,
    initial_carrier_phase_rad: np.ndarray,
    rng: np.random.Generator,
    *,
    run: int = 0,
    if_hz: float = 0.0,
    streams: str = "one",
    noise: bool = True,
) -> np.ndarray:
    """Complex samples (``complex64``, unit noise variance per real dimension) of run
    ``run`` of a geometry-form ``truth`` over its ``K`` intervals (see the module text).

    Parameters
    ----------
    truth
        Geometry form (``sat_state``, ``receiver_state``, ``clock_m``); its ``signal``
        gives the chip rate, chip length and wavelength (its tracked component without an
        overlay code: the samples carry neither overlay nor data symbols); its
        ``cn0_dbhz`` (broadcast to ``(runs, channels)``) the amplitudes.
    sample_rate_hz, if_hz
        Sample rate and intermediate frequency.
    codes
        ``(channels, n)`` spreading tables of the channels (`replica_codes`: ``n`` is the
        code length times ``truth.signal.subchips_per_chip``).
    initial_carrier_phase_rad
        ``(channels,)`` carrier phases :math:`\\theta_0` at t = 0 (what the loop is told
        with ``initial_carrier_phase_rad``).
    rng
        The noise's only source.
    streams
        ``"one"``: every channel's signal in one stream ``(n,)`` with one noise, what a
        receiver records (each channel also sees the others' cross-correlation);
        ``"per-channel"``: ``(channels, n)``, each channel's signal alone in its own noise
        (the analytic model's assumption: no multiple-access interference), for
        `SampleSource`'s per-channel streams.
    noise
        False: the noise-free signal (for checks against the analytic model's mean).
    """
    if streams not in ("one", "per-channel"):
        raise ConfigError("streams", f"got {streams!r}; allowed: one, per-channel")
    signal = truth.signal
    if signal.overlay_length(0):
        raise ConfigError(
            "truth.signal",
            f"{signal.name}'s tracked component has an overlay (secondary) code, which these samples "
            "do not carry (nor data symbols): give a signal without one",
        )
    rho_code, rho_carrier = truth_ranges_m(truth, run)
    n_ch = rho_code.shape[1]
    codes = np.asarray(codes)
    theta0 = np.asarray(initial_carrier_phase_rad, float)
    if codes.ndim != 2 or codes.shape[0] != n_ch or np.shape(theta0) != (n_ch,):
        raise ConfigError(
            "codes",
            f"the truth has {n_ch} channels: give (channels, n) codes and (channels,) phases, got "
            f"{codes.shape} and {np.shape(theta0)}",
        )
    cn0 = np.asarray(truth.cn0_dbhz, float)  # (runs, channels), (channels,) or one value
    cn0 = np.broadcast_to(cn0[run] if cn0.ndim == 2 else cn0, (n_ch,))
    amplitude = np.sqrt(2.0 * 10.0 ** (cn0 / 10.0) / sample_rate_hz)
    T = truth.coherent_time_s
    n = int(round(truth.epochs * T * sample_rate_hz))
    t_edges = np.arange(truth.epochs + 1) * T
    one = streams == "one"
    x = np.empty(n if one else (n_ch, n), np.complex64)
    for s0 in range(0, n, _CHUNK):
        t = np.arange(s0, min(n, s0 + _CHUNK)) / sample_rate_hz
        acc = np.zeros(t.size, complex)
        for i in range(n_ch):
            chips = code_phase_of_range(signal, np.interp(t, t_edges, rho_code[:, i]), t)
            carrier = theta0[i] - 2 * np.pi * np.interp(t, t_edges, rho_carrier[:, i]) / signal.wavelength_m
            code = signal.spreading_at(codes[i], chips)
            sig = amplitude[i] * code * np.exp(1j * (2 * np.pi * np.mod(if_hz * t, 1.0) + np.mod(carrier, 2 * np.pi)))
            if one:
                acc += sig
            else:
                x[i, s0 : s0 + t.size] = sig + _noise(rng, t.size, noise)
        if one:
            x[s0 : s0 + t.size] = acc + _noise(rng, t.size, noise)
    return x


def _noise(rng: np.random.Generator, n: int, on: bool) -> np.ndarray | float:
    """``n`` complex white-noise samples of unit variance per real dimension (0 when off)."""
    return rng.standard_normal(n) + 1j * rng.standard_normal(n) if on else 0.0
