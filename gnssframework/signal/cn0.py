"""C/N0 estimators on prompt correlator outputs."""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError

__all__ = ["cn0_nwpr", "cn0_moments", "MIN_CN0_T"]

#: The smallest :math:`\hat c T` (and moment-estimator power) that reads as a number of dB-Hz.
MIN_CN0_T = 1e-12


def cn0_nwpr(prompt: np.ndarray, coherent_time_s: float, m: int = 20) -> np.ndarray:
    """Narrowband-wideband power ratio C/N0 estimator (Van Dierendonck 1996), dB-Hz.

    The prompts (time on axis 0) are cut into blocks of ``m``. In each block

    $$
    WBP = \\sum_{i=1}^{m} |P_i|^2, \\quad NBP = \\Big|\\sum_{i=1}^{m} P_i\\Big|^2,
    \\quad \\mu = \\overline{NBP / WBP}, \\quad
    \\widehat{C/N_0} = \\frac{1}{T}\\,\\frac{\\mu - 1}{m - \\mu}
    $$

    Blocks must not contain a data-bit transition: wipe the bits off first, or align
    blocks of 20 ms with the bit edges (``m * T = 20 ms``). ``m`` is at least 2: with one
    prompt per block NBP = WBP and the ratio is 0/0.
    """
    if m < 2:
        raise ConfigError(
            "m",
            f"the narrow-wide ratio needs at least 2 prompts per block, got {m} (a signal "
            "whose symbol is one code period: use cn0_moments)",
        )
    p = np.asarray(prompt)
    k = p.shape[0] // m
    if k < 1:
        raise ConfigError("prompt", f"needs at least m = {m} samples on axis 0, got {p.shape[0]}")
    blocks = p[: k * m].reshape((k, m) + p.shape[1:])
    wbp = np.sum(np.abs(blocks) ** 2, axis=1)
    nbp = np.abs(np.sum(blocks, axis=1)) ** 2
    mu = np.mean(nbp / wbp, axis=0)
    ratio = np.clip((mu - 1.0) / (m - mu), MIN_CN0_T, None)
    return 10.0 * np.log10(ratio / coherent_time_s)


def cn0_moments(prompt: np.ndarray, coherent_time_s: float) -> np.ndarray:
    """Second- and fourth-moment C/N0 estimator (Pauluzzi & Beaulieu 2000), dB-Hz.

    $$
    P_d = \\sqrt{2 M_2^2 - M_4}, \\quad P_n = M_2 - P_d, \\quad
    \\widehat{C/N_0} = \\frac{P_d}{P_n T}
    $$

    Insensitive to data bits and phase, but biased at high C/N0 (Pn becomes a small
    difference of large numbers): prefer ``cn0_nwpr`` above about 45 dB-Hz.
    """
    p = np.asarray(prompt)
    m2 = np.mean(np.abs(p) ** 2, axis=0)
    m4 = np.mean(np.abs(p) ** 4, axis=0)
    pd = np.sqrt(np.clip(2 * m2**2 - m4, 0.0, None))
    pn = np.clip(m2 - pd, MIN_CN0_T, None)
    return 10.0 * np.log10(np.clip(pd, MIN_CN0_T, None) / (pn * coherent_time_s))
