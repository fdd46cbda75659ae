"""Thermal-noise tracking jitter of closed loops (standard deviation formulas, squared)."""

from __future__ import annotations

import numpy as np

__all__ = ["loop_variance", "pll_thermal_variance_rad2", "code_thermal_std_chips", "lock_indicator"]


def loop_variance(discriminator_variance: np.ndarray, bandwidth_hz: float, update_s: float) -> np.ndarray:
    """Variance of a loop's tracking error from white discriminator noise: $2 B_L T \\sigma_D^2$.

    A loop of noise bandwidth $B_L$ updated every T averages about $1/(2 B_L T)$
    independent discriminator outputs.
    """
    return 2.0 * bandwidth_hz * update_s * np.asarray(discriminator_variance)


def pll_thermal_variance_rad2(cn0_dbhz: np.ndarray | float, bandwidth_hz: float, coherent_time_s: float) -> np.ndarray:
    """Costas PLL thermal jitter (Kaplan & Hegarty): $\\frac{B_L}{c}\\left(1 + \\frac{1}{2 c T}\\right)$, rad²."""
    c = 10.0 ** (np.asarray(cn0_dbhz, float) / 10.0)
    return bandwidth_hz / c * (1 + 1 / (2 * c * coherent_time_s))


def code_thermal_std_chips(channel, cn0_dbhz, T: float, spacing_chips: float) -> float | np.ndarray:
    """The DLL's thermal jitter :math:`\\sqrt{2 B T \\sigma_D^2}` (chips; `loop_variance`) of a
    channel filter with ``dll_bandwidth_hz`` and ``code_discriminator`` parameters, at
    ``cn0_dbhz`` (scalar or array), coherent time ``T`` and early-late spacing; NaN for a
    filter without them."""
    p = getattr(channel, "params", None)
    bw, disc = getattr(p, "dll_bandwidth_hz", None), getattr(p, "code_discriminator", None)
    if bw is None or disc is None:
        return float("nan")
    d = disc.create(coherent_time_s=T, early_late_spacing_chips=spacing_chips)
    return np.sqrt(loop_variance(d.noise_variance(cn0_dbhz), bw, T))


def lock_indicator(prompts: np.ndarray, window: int = 20) -> np.ndarray:
    """Phase lock indicator $\\cos 2\\phi$ estimated over blocks of ``window`` prompts.

    $$
    PLI = \\frac{(\\sum I)^2 - (\\sum Q)^2}{(\\sum I)^2 + (\\sum Q)^2}
    $$

    (Van Dierendonck 1996). 1 in perfect lock, about 0 when the phase wanders. The
    prompts must have their data bits wiped off.
    """
    p = np.asarray(prompts)
    k = p.shape[0] // window
    blocks = p[: k * window].reshape((k, window) + p.shape[1:]).sum(axis=1)
    return (blocks.real**2 - blocks.imag**2) / (np.abs(blocks) ** 2)
