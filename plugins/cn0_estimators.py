r"""Built-in C/N0 estimators (plugin kind ``cn0_estimator``).

Every estimator reads prompts ``(..., K)`` over K coherent intervals of T s and returns
the linear C/N0 in Hz (`gnssframework.signal.cn0_estimator.CN0Estimator`). Notation: the
prompt :math:`P_k = I_k + j Q_k`, unit noise variance in I and in Q, amplitude
:math:`A = \sqrt{2 c T}`, so that :math:`\rho = c T = A^2 / 2` is the SNR per interval
and :math:`\hat c = \hat\rho / T`. The moment-based estimators follow the comparison of
Falletti, Pini & Lo Presti (2011), "Low complexity carrier-to-noise ratio estimators for
GNSS digital receivers", IEEE Trans. Aerospace and Electronic Systems 47(1), 420-437.
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from gnssframework.signal.cn0_estimator import MIN_CN0_T, CN0Estimator, CN0EstimatorParams

__all__ = ["NarrowWidePowerRatio", "MomentsM2M4", "SignalNoiseVariance", "Beaulieu", "NoiseChannel"]


class NarrowWidePowerRatio(CN0Estimator):
    r"""Narrow-wide power ratio (Van Dierendonck 1996, in Parkinson & Spilker vol. I, ch. 8).

    The K prompts are cut into :math:`K_b = \lfloor K/m \rfloor` blocks of ``m``; in block
    :math:`b`

    $$
    \mathrm{WBP}_b = \sum_{i=1}^{m} |P_i|^2, \quad
    \mathrm{NBP}_b = \Big|\sum_{i=1}^{m} P_i\Big|^2, \quad
    \mu = \frac{1}{K_b}\sum_b \frac{\mathrm{NBP}_b}{\mathrm{WBP}_b}, \quad
    \hat c = \frac{1}{T}\,\frac{\mu - 1}{m - \mu}.
    $$

    :math:`(\mu - 1)/(m - \mu) = \rho` where :math:`\mu = E[\mathrm{NBP}]/E[\mathrm{WBP}]
    = (m\rho + 1)/(\rho + 1)`; the mean of the ratio is not the ratio of the means, whence
    its bias at low C/N0. On pure noise :math:`\mathrm{NBP}/\mathrm{WBP} = m\,B` with
    :math:`B \sim \mathrm{Beta}(1, m-1)` (a uniform direction in :math:`\mathbb{C}^m`):
    :math:`E[\mu] = 1` and :math:`\mathrm{Var}[\mathrm{NBP}_b/\mathrm{WBP}_b] = (m-1)/(m+1)`,
    so the linear estimate is centred on zero. Blocks are coherent sums: data bits must be
    wiped off (or the blocks aligned with the bits). Same arithmetic as
    `gnssframework.signal.cn0.cn0_nwpr` (time on the last axis here).
    """

    name = "narrow-wide"
    bit_blind = False
    description = "narrow-wide power ratio (Van Dierendonck 1996): blocks of m coherent intervals, bits wiped"

    class Params(CN0EstimatorParams):
        m: int = Field(20, ge=2, le=10_000, description="intervals per narrowband block (20 at T = 1 ms: one bit)")

    def required_intervals(self) -> int:
        return self.params.m

    def _estimate_hz(self, prompt, coherent_time_s, noise):
        m = self.params.m
        kb = prompt.shape[-1] // m
        blocks = prompt[..., : kb * m].reshape(prompt.shape[:-1] + (kb, m))
        wbp = np.sum(blocks.real**2 + blocks.imag**2, axis=-1)
        nbp = np.abs(np.sum(blocks, axis=-1)) ** 2
        mu = np.mean(nbp / wbp, axis=-1)
        return (mu - 1.0) / (m - mu) / coherent_time_s


class MomentsM2M4(CN0Estimator):
    r"""Second- and fourth-moment estimator, M2M4 (Pauluzzi & Beaulieu 2000, "A comparison of
    SNR estimation techniques for the AWGN channel", IEEE Trans. Commun. 48(10), 1681-1691).

    $$
    M_2 = \frac{1}{K}\sum_k |P_k|^2, \quad M_4 = \frac{1}{K}\sum_k |P_k|^4, \quad
    \hat P_d = \sqrt{2 M_2^2 - M_4}, \quad \hat P_n = M_2 - \hat P_d, \quad
    \hat c = \frac{\hat P_d}{\hat P_n\,T}.
    $$

    With complex Gaussian noise :math:`E[M_2] = A^2 + 2`, :math:`E[M_4] = A^4 + 8A^2 + 8`
    and, exactly, :math:`E[2M_2^2 - M_4] = A^4 + 8(A^2 + 1)/K`: the term :math:`8/K` left
    on pure noise is the estimator's floor (:math:`\hat P_d \approx \sqrt{8/K}`, reading
    about :math:`10\log_{10}(\sqrt{8/K}/(2-\sqrt{8/K})/T)` dB-Hz). Insensitive to bits and
    to the carrier phase. Same arithmetic as `gnssframework.signal.cn0.cn0_moments`.
    """

    name = "m2m4"
    description = "second- and fourth-moment (M2M4) estimator (Pauluzzi & Beaulieu 2000); bit- and phase-blind"

    def _estimate_hz(self, prompt, coherent_time_s, noise):
        power = prompt.real**2 + prompt.imag**2
        m2 = np.mean(power, axis=-1)
        m4 = np.mean(power**2, axis=-1)
        pd = np.sqrt(np.clip(2 * m2**2 - m4, 0.0, None))
        pn = np.clip(m2 - pd, MIN_CN0_T, None)
        return pd / (pn * coherent_time_s)


class SignalNoiseVariance(CN0Estimator):
    r"""Signal-to-noise variance (SNV) estimator (Pauluzzi & Beaulieu 2000; Falletti et al.
    2011, the "SNV" of their comparison), on phase-locked prompts (signal in I).

    $$
    \hat P_s = \Big(\frac{1}{K}\sum_k |I_k|\Big)^2, \quad
    \hat P_t = \frac{1}{K}\sum_k (I_k^2 + Q_k^2), \quad
    \hat c = \frac{\hat P_s}{(\hat P_t - \hat P_s)\,T}.
    $$

    With :math:`I_k \sim N(a, 1)` the folded-normal mean is
    :math:`\nu = \sqrt{2/\pi}\,e^{-a^2/2} + a\,(1 - 2\Phi(-a))`, and exactly
    :math:`E[\hat P_s] = \nu^2 + (1 + a^2 - \nu^2)/K`. On pure noise
    :math:`\hat P_s \to 2/\pi` and :math:`\hat P_t \to 2`: the floor tends to
    :math:`10\log_{10}(1/((\pi - 1) T))` dB-Hz (26.7 dB-Hz at T = 1 ms) as K grows, and sits
    above it for short windows.
    """

    name = "snv"
    description = "signal-to-noise variance estimator (Pauluzzi & Beaulieu 2000) on phase-locked prompts"

    def _estimate_hz(self, prompt, coherent_time_s, noise):
        ps = np.mean(np.abs(prompt.real), axis=-1) ** 2
        pt = np.mean(prompt.real**2 + prompt.imag**2, axis=-1)
        return ps / (np.clip(pt - ps, MIN_CN0_T, None) * coherent_time_s)


class Beaulieu(CN0Estimator):
    r"""Beaulieu's estimator (Beaulieu, Toms & Pauluzzi 2000, "Comparison of four SNR
    estimators for QPSK modulations", IEEE Commun. Lett. 4(2), 43-45; Falletti et al.
    2011, "BL"), on phase-locked prompts.

    $$
    \hat P_{n,k} = (|I_k| - |I_{k-1}|)^2, \quad
    \hat P_{d,k} = \tfrac12 (I_k^2 + I_{k-1}^2), \quad
    \hat c = \frac{1}{T}\Big[\frac{1}{K-1}\sum_{k=2}^{K}
    \frac{\hat P_{n,k}}{\hat P_{d,k}}\Big]^{-1}.
    $$

    At high SNR :math:`E[\hat P_{n,k}] \to 2` and :math:`\hat P_{d,k} \to a^2`, so
    :math:`\hat c \to a^2 / (2T) = c`. No closed form for its mean at low SNR; its noise
    floor is measured (docs/receiver/cn0-estimators.md).
    """

    name = "beaulieu"
    description = "Beaulieu's estimator (Beaulieu, Toms & Pauluzzi 2000) on phase-locked prompts"

    def _estimate_hz(self, prompt, coherent_time_s, noise):
        i = prompt.real
        a = np.abs(i)
        pn = (a[..., 1:] - a[..., :-1]) ** 2
        pd = 0.5 * (i[..., 1:] ** 2 + i[..., :-1] ** 2)
        ratio = np.mean(pn / np.clip(pd, MIN_CN0_T, None), axis=-1)
        return 1.0 / (np.clip(ratio, MIN_CN0_T, None) * coherent_time_s)


class NoiseChannel(CN0Estimator):
    r"""N0 measured on a noise-only correlator, bias-corrected: unbiased in linear terms at
    every C/N0, down to and including pure noise.

    A receiver correlates against a replica that holds no signal (an unused PRN, or a tap
    far off the peak) to measure the noise power (Groves 2013, *Principles of GNSS,
    Inertial, and Multisensor Integrated Navigation Systems*, 2nd ed., ch. 9, on C/N0
    measurement; ch. 7 of the 2008 1st ed.). With :math:`M_2 = \frac1K\sum|P_k|^2` and
    :math:`N_2 = \frac1K\sum|N_k|^2` of the noise correlator :math:`N_k` (the prompt's noise
    variance, independent of it):

    $$
    \hat c = \frac{1}{T}\Big(\frac{K-1}{K}\,\frac{M_2}{N_2} - 1\Big),
    \qquad E[\hat c] = c \text{ exactly.}
    $$

    Proof: :math:`K N_2` is a sum of K exponentials of mean 2, a Gamma(K, 2), so
    :math:`E[1/N_2] = K / (2(K-1))`; with :math:`E[M_2] = A^2 + 2` and independence,
    :math:`E[\hat c] T = (A^2 + 2)/2 - 1 = A^2/2 = cT`. Insensitive to bits and carrier
    phase (it measures the power in the prompt). Its variance:
    :math:`\mathrm{Var}[M_2] = (4A^2 + 4)/K`. On pure noise it reads below zero half the
    time; its floor is where it reads on noise alone at a stated percentile.
    """

    name = "noise-channel"
    description = "unbiased (linear) C/N0: N0 from a noise-only correlator, Gamma bias removed (Groves 2013)"
    needs = ("prompt", "noise")

    def _estimate_hz(self, prompt, coherent_time_s, noise):
        k = prompt.shape[-1]
        m2 = np.mean(prompt.real**2 + prompt.imag**2, axis=-1)
        n2 = np.mean(noise.real**2 + noise.imag**2, axis=-1)
        return ((k - 1) / k * m2 / np.clip(n2, MIN_CN0_T, None) - 1.0) / coherent_time_s
