"""Ionospheric scintillation generators: the Cornell model and the AJ-Stanford model.

Both return the complex scintillation factor z(t) that multiplies the signal:
$|z|^2$ is the intensity (mean 1) and $\\arg z$ the scintillation phase. In a
closed-loop run, ``|z|`` scales the correlator amplitude and ``arg z`` adds to the
carrier phase (`SignalTruth`).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy import optimize, special  # signal and stats in the functions: their imports cost every run a second

from .. import random_streams as draw
from ..errors import ConfigError

__all__ = ["cornell", "aj_stanford", "s4_index", "rice_k_from_s4"]


def s4_index(z: np.ndarray, axis: int = 0) -> np.ndarray:
    """Amplitude scintillation index $S_4 = \\sqrt{(\\langle I^2\\rangle - \\langle I\\rangle^2)/\\langle I\\rangle^2}$, $I = |z|^2$."""
    intensity = np.abs(z) ** 2
    m = intensity.mean(axis=axis)
    return np.sqrt(np.clip(intensity.var(axis=axis), 0, None)) / m


def rice_k_from_s4(s4: float) -> float:
    """Rice factor K of a Rician amplitude whose intensity has index ``s4`` (0 < S4 <= 1).

    From $S_4^2 = (1 + 2K)/(1 + K)^2$: $K = \\sqrt{1 - S_4^2}\\,(1 + \\sqrt{1 - S_4^2}) / S_4^2$.
    """
    if not 0 < s4 <= 1:
        raise ConfigError("s4", f"the Cornell model needs 0 < S4 <= 1, got {s4}")
    r = np.sqrt(1 - s4**2)
    return float(r * (1 + r) / s4**2)


@lru_cache(maxsize=1)
def _butterworth2_tau0_factor() -> float:
    """x with $e^{-x}(\\cos x + \\sin x) = e^{-1}$.

    The normalised autocorrelation of white noise through a 2nd-order Butterworth
    low-pass of natural frequency $\\omega_n$ is $e^{-a\\tau}(\\cos a\\tau + \\sin a\\tau)$,
    $a = \\omega_n/\\sqrt 2$, so $\\tau_0 = x / a$ (x = 1.2396...).
    """
    return float(optimize.brentq(lambda x: np.exp(-x) * (np.cos(x) + np.sin(x)) - np.exp(-1), 0.5, 2.0))


def _check_common(duration_s: float, sample_rate_hz: float) -> int:
    if duration_s <= 0 or sample_rate_hz <= 0:
        raise ConfigError("duration_s", "duration and sample rate must be > 0")
    return int(round(duration_s * sample_rate_hz))


def cornell(
    s4: float,
    tau0_s: float,
    duration_s: float,
    sample_rate_hz: float,
    rng: np.random.Generator,
    batch_shape: tuple[int, ...] = (),
) -> np.ndarray:
    """Cornell Scintillation Model (Humphreys et al., IEEE TAES 2009).

    $z(t) = \\sqrt{K/(K+1)} + \\xi(t)$: a constant direct part and a diffuse complex
    Gaussian part $\\xi$ of power $1/(K+1)$, white noise through a 2nd-order Butterworth
    low-pass. K is the Rice factor that gives ``s4``; the cutoff is set so that the
    diffuse part decorrelates to 1/e at ``tau0_s``. $E|z|^2 = 1$.

    Returns
    -------
    np.ndarray
        Complex, shape ``(n_samples, *batch_shape)``.
    """
    n = _check_common(duration_s, sample_rate_hz)
    if tau0_s <= 0:
        raise ConfigError("tau0_s", f"must be > 0, got {tau0_s}")
    if tau0_s * sample_rate_hz < 5:
        raise ConfigError("sample_rate_hz", f"needs at least 5 samples per tau0 ({tau0_s} s), got {sample_rate_hz} Hz")
    from scipy import signal

    K = rice_k_from_s4(s4)
    wn = np.sqrt(2) * _butterworth2_tau0_factor() / tau0_s  # rad/s
    b, a = signal.butter(2, wn / (2 * np.pi), fs=sample_rate_hz)
    warm = int(10 * tau0_s * sample_rate_hz)  # let the filter forget its zero state
    shape = (n + warm,) + tuple(batch_shape)
    w = draw.standard_normal(rng, shape, 1) + 1j * draw.standard_normal(rng, shape, 1)
    xi = signal.lfilter(b, a, w, axis=0)[warm:]
    xi *= np.sqrt(1.0 / (K + 1) / np.mean(np.abs(xi) ** 2, axis=0))
    return np.sqrt(K / (K + 1)) + xi


def _power_law_gaussian(
    n: int, shape: tuple[int, ...], fs: float, corner_hz: float, p: float, rng: np.random.Generator, pair_corr: float
) -> tuple[np.ndarray, np.ndarray]:
    """Two unit-variance Gaussian processes with spectrum $(1 + (f/f_c)^2)^{-p/2}$ and
    correlation ``pair_corr``, shaped by one zero-phase FFT filter."""
    w1 = draw.standard_normal(rng, (n,) + shape, 1)
    w2 = pair_corr * w1 + np.sqrt(1 - pair_corr**2) * draw.standard_normal(rng, (n,) + shape, 1)
    f = np.fft.rfftfreq(n, 1 / fs).reshape((-1,) + (1,) * len(shape))
    gain = (1 + (f / corner_hz) ** 2) ** (-p / 4)
    out = []
    for w in (w1, w2):
        g = np.fft.irfft(np.fft.rfft(w, axis=0) * gain, n=n, axis=0)
        out.append((g - g.mean(axis=0)) / g.std(axis=0))
    return out[0], out[1]


def aj_stanford(
    s4: float,
    sigma_phi_rad: float,
    duration_s: float,
    sample_rate_hz: float,
    rng: np.random.Generator,
    *,
    p: float = 2.5,
    corner_hz: float = 0.1,
    intensity_phase_corr: float = -0.6,
    batch_shape: tuple[int, ...] = (),
) -> np.ndarray:
    """AJ-Stanford scintillation model, as used by Xia et al. (Kalman carrier tracking, undated).

    $z = \\sqrt{I}\\, e^{j\\phi}$ with:

    - intensity $I$ Nakagami-m: Gamma distributed with shape $m = 1/S_4^2$ and mean 1;
    - phase $\\phi$ Gaussian with standard deviation ``sigma_phi_rad``;
    - both with the power-law spectrum $T f^{-p}$ above ``corner_hz`` (flat below);
    - intensity/phase correlation about ``intensity_phase_corr`` (-0.6).

    Construction: two correlated white Gaussian sequences are shaped to the power law,
    normalised, and the intensity driver is mapped to the Gamma distribution through
    the normal CDF (the "Gamma adapter"); the amplitude is its square root. The
    Gaussian correlation is chosen so the *intensity*-phase correlation hits the
    target (the Gamma map shrinks it by $E[g\\,h(g)]/\\sigma_I$).

    The paper shapes the spectra with cascaded Butterworth filters, which realise
    integer slopes. We apply the same target spectrum with one zero-phase FFT filter,
    which is exact for any p in [2, 3].
    """
    n = _check_common(duration_s, sample_rate_hz)
    if not 0 < s4 <= 1.5:
        raise ConfigError("s4", f"must be in (0, 1.5], got {s4}")
    if sigma_phi_rad < 0:
        raise ConfigError("sigma_phi_rad", f"must be >= 0, got {sigma_phi_rad}")
    if not -1 < intensity_phase_corr < 1:
        raise ConfigError("intensity_phase_corr", f"must be in (-1, 1), got {intensity_phase_corr}")
    from scipy import stats

    m = 1.0 / s4**2
    gamma = stats.gamma(a=m, scale=1.0 / m)
    # E[g h(g)] for g ~ N(0,1), h = Gamma quantile of Phi(g): Gauss-Hermite quadrature.
    x, w = special.roots_hermitenorm(40)
    # Clip the CDF: the outer nodes would map to ppf(1.0) = inf and zero the correlation.
    gain = float(np.sum(w / w.sum() * x * gamma.ppf(np.clip(special.ndtr(x), 1e-15, 1 - 1e-15))))
    rho = float(np.clip(intensity_phase_corr * gamma.std() / gain, -0.999, 0.999))
    g_int, g_phase = _power_law_gaussian(n, tuple(batch_shape), sample_rate_hz, corner_hz, p, rng, rho)
    intensity = gamma.ppf(np.clip(special.ndtr(g_int), 1e-15, 1 - 1e-15))
    return np.sqrt(intensity) * np.exp(1j * sigma_phi_rad * g_phase)
