"""Built-in discriminators: code (chips), frequency (Hz), phase (rad).

Every output has unit slope in its linear region: for a small true error e, the
output is e plus noise. ``noise_variance(cn0_dbhz)`` is the thermal-noise variance of
one output for the correlator normalisation of
`gnssframework.signal.correlator_model` (unit-variance I and Q noise, amplitude
``A = sqrt(2 c T)``, ``c`` = C/N0 in Hz). The formulas are the first-order term times
the squaring loss, for an infinite front-end bandwidth and an error near zero. They
hold within a few percent down to ``c T`` of about 3 (35 dB-Hz at 1 ms). Below that,
and near the edge of the linear range, the outputs saturate and the true variance
falls below the formula.

Sign conventions: code error = true minus replica delay; frequency and phase error =
true minus replica. A positive output means the replica must move forward.
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from gnssframework.errors import ConfigError
from gnssframework.interfaces import Discriminator, DiscriminatorParams
from gnssframework.signal.correlators import Correlators

__all__ = [
    "EarlyMinusLateEnvelope",
    "EarlyMinusLatePower",
    "DotProduct",
    "CrossProductFLL",
    "Atan2FLL",
    "CostasAtan",
    "Atan2PLL",
]


def _ratio(num: np.ndarray, den: np.ndarray) -> np.ndarray:
    """``num / den``, 0 where ``den`` is 0: no signal in the taps carries no error information."""
    num, den = np.broadcast_arrays(np.asarray(num, float), np.asarray(den, float))
    return np.divide(num, den, out=np.zeros(num.shape), where=den != 0)


def _cn0_linear(cn0_dbhz) -> np.ndarray:
    return 10.0 ** (np.asarray(cn0_dbhz, dtype=float) / 10.0)


class CodeParams(DiscriminatorParams):
    early_late_spacing_chips: float = Field(1.0, gt=0, le=1.0, description="early-to-late spacing D")


class _CodeDiscriminator(Discriminator):
    unit = "chips"
    Params = CodeParams
    params: CodeParams  # self.params, as validated

    @property
    def half_spacing(self) -> float:
        return self.params.early_late_spacing_chips / 2


class EarlyMinusLateEnvelope(_CodeDiscriminator):
    r"""Normalised non-coherent early-minus-late envelope.

    $$
    D = (1 - d)\,\frac{|L| - |E|}{|L| + |E|}, \qquad d = D_{EL}/2
    $$

    Linear for $|\delta\tau| < d$, where it returns $\delta\tau$ exactly (triangle
    autocorrelation). It is independent of amplitude and carrier phase. Thermal noise
    of one output, with $D_{EL}$ the early-late spacing:

    $$
    \sigma^2 = \frac{D_{EL}}{4 c T}\left(1 + \frac{1}{(2 - D_{EL})\, c T}\right)
    $$
    """

    name = "eml-envelope"
    description = "Normalised non-coherent early-minus-late envelope DLL discriminator (chips)"

    def __call__(self, current: Correlators, previous: Correlators | None = None) -> np.ndarray:
        e, l = np.abs(current.early), np.abs(current.late)
        return (1.0 - self.half_spacing) * _ratio(l - e, l + e)

    def noise_variance(self, cn0_dbhz) -> np.ndarray:
        cT = _cn0_linear(cn0_dbhz) * self.params.coherent_time_s
        D = self.params.early_late_spacing_chips
        return D / (4 * cT) * (1 + 1 / ((2 - D) * cT))


class EarlyMinusLatePower(_CodeDiscriminator):
    r"""Normalised non-coherent early-minus-late power.

    $$
    D = \frac{1 - d}{2}\,\frac{|L|^2 - |E|^2}{|L|^2 + |E|^2}
    $$

    Its S-curve is not linear: $S(e) = e (1-d)^2 / ((1-d)^2 + e^2) \approx e - e^3/(1-d)^2$,
    unit slope at zero only. Noise: the non-coherent early-minus-late power formula of
    Kaplan & Hegarty (*Understanding GPS/GNSS*, 3rd ed.), divided by the loop's
    $2 B_L T$, divided by the S-curve's compression $1 + 6\sigma_1^2/(1-d)^2$:

    $$
    \sigma_1^2 = \frac{D_{EL}}{4 c T}\left(1 + \frac{2}{(2 - D_{EL})\, c T}\right), \qquad
    \sigma^2 = \sigma_1^2 \Big/ \left(1 + \frac{6 \sigma_1^2}{(1-d)^2}\right)
    $$

    The compression term is 6 % at 50 dB-Hz with T = 1 ms, and the formula leaves it out.
    """

    name = "eml-power"
    description = "Normalised non-coherent early-minus-late power DLL discriminator (chips)"

    def __call__(self, current: Correlators, previous: Correlators | None = None) -> np.ndarray:
        e2, l2 = np.abs(current.early) ** 2, np.abs(current.late) ** 2
        return 0.5 * (1.0 - self.half_spacing) * _ratio(l2 - e2, l2 + e2)

    def noise_variance(self, cn0_dbhz) -> np.ndarray:
        cT = _cn0_linear(cn0_dbhz) * self.params.coherent_time_s
        D = self.params.early_late_spacing_chips
        s1 = D / (4 * cT) * (1 + 2 / ((2 - D) * cT))
        # 1/(1+x) rather than 1-x: equal to first order, and never zero at low C/N0,
        # where a vector loop would otherwise be handed R = 0.
        return s1 / (1 + 6 * s1 / (1 - D / 2) ** 2)


class DotProduct(_CodeDiscriminator):
    r"""Normalised dot-product power (quasi-coherent: needs carrier phase lock).

    $$
    D = \frac{\mathrm{Re}[(L - E)\, P^*]}{2 |P|^2}, \qquad
    \sigma^2 = \frac{D_{EL}}{4 c T}\left(1 + \frac{1}{c T}\right)
    $$
    """

    name = "dot-product"
    description = "Normalised early-minus-late dot-product DLL discriminator (chips)"

    def __call__(self, current: Correlators, previous: Correlators | None = None) -> np.ndarray:
        p = current.prompt
        return _ratio(np.real((current.late - current.early) * np.conj(p)), 2.0 * np.abs(p) ** 2)

    def noise_variance(self, cn0_dbhz) -> np.ndarray:
        cT = _cn0_linear(cn0_dbhz) * self.params.coherent_time_s
        return self.params.early_late_spacing_chips / (4 * cT) * (1 + 1 / cT)


def _phase_diff_variance(cT: np.ndarray) -> np.ndarray:
    """Variance of arg(P2 P1*) for two independent prompts: 2/A^2 (1 + 1/A^2), A^2 = 2cT."""
    return (1.0 / cT) * (1.0 + 1.0 / (2.0 * cT))


class _FrequencyDiscriminator(Discriminator):
    unit = "Hz"
    needs_previous = True

    def _pair(self, current: Correlators, previous: Correlators | None) -> np.ndarray:
        if previous is None:
            raise ConfigError(
                f"discriminator {self.name!r}", "needs the previous prompt: call disc(current, previous=prev)"
            )
        return current.prompt * np.conj(previous.prompt)


class CrossProductFLL(_FrequencyDiscriminator):
    r"""Normalised cross-product FLL on two consecutive prompts $P_1$, $P_2$.

    $$
    D = \frac{\mathrm{Im}(P_2 P_1^*)}{2\pi T\, |P_1|\,|P_2|} = \frac{\sin\Delta\phi}{2\pi T}
    $$

    Linear for $|\delta f| \ll 1/(4T)$. With $\sigma_\phi^2 = \frac{1}{cT}(1 + \frac{1}{2cT})$
    the variance of the noisy phase difference, the output variance is
    $\mathrm{Var}(\sin\phi)/(2\pi T)^2 = (1 - e^{-2\sigma_\phi^2}) / (2 (2\pi T)^2)$.
    A data-bit transition between the two prompts flips the sign: wipe the bits off or
    keep pairs inside a bit.
    """

    name = "cross-product"
    description = "Normalised cross-product FLL discriminator on consecutive prompts (Hz)"

    def __call__(self, current: Correlators, previous: Correlators | None = None) -> np.ndarray:
        z = self._pair(current, previous)
        return _ratio(np.imag(z), 2 * np.pi * self.params.coherent_time_s * np.abs(z))

    def noise_variance(self, cn0_dbhz) -> np.ndarray:
        T = self.params.coherent_time_s
        s2 = _phase_diff_variance(_cn0_linear(cn0_dbhz) * T)
        return (1 - np.exp(-2 * s2)) / 2 / (2 * np.pi * T) ** 2


class Atan2FLL(_FrequencyDiscriminator):
    r"""Four-quadrant arctangent FLL: $D = \mathrm{atan2}(\mathrm{Im}\, P_2P_1^*, \mathrm{Re}\, P_2P_1^*) / (2\pi T)$.

    Linear over $|\delta f| < 1/(2T)$ with known bits. Variance
    $\frac{1}{(2\pi T)^2}\frac{1}{cT}\left(1 + \frac{1}{2cT}\right)$.
    """

    name = "atan2-fll"
    description = "Four-quadrant arctangent FLL discriminator on consecutive prompts (Hz)"

    def __call__(self, current: Correlators, previous: Correlators | None = None) -> np.ndarray:
        return np.angle(self._pair(current, previous)) / (2 * np.pi * self.params.coherent_time_s)

    def noise_variance(self, cn0_dbhz) -> np.ndarray:
        T = self.params.coherent_time_s
        return _phase_diff_variance(_cn0_linear(cn0_dbhz) * T) / (2 * np.pi * T) ** 2


def _phase_variance(cn0_dbhz, T: float) -> np.ndarray:
    cT = _cn0_linear(cn0_dbhz) * T
    return 1.0 / (2 * cT) * (1 + 1 / (2 * cT))


class CostasAtan(Discriminator):
    r"""Two-quadrant Costas arctangent $D = \arctan(Q_P / I_P)$, blind to the data bit.

    Linear over $|\delta\theta| < \pi/2$ (then wraps by $\pi$). Variance
    $\frac{1}{2cT}\left(1 + \frac{1}{2cT}\right)$ (Kaplan & Hegarty's Costas formula
    divided by the loop's $2 B_L T$).
    """

    name = "costas-atan"
    unit = "rad"
    description = "Two-quadrant Costas arctangent PLL discriminator, data-bit insensitive (rad)"

    def __call__(self, current: Correlators, previous: Correlators | None = None) -> np.ndarray:
        p = current.prompt
        return np.arctan(p.imag / np.where(p.real == 0, np.finfo(float).tiny, p.real))

    def noise_variance(self, cn0_dbhz) -> np.ndarray:
        return _phase_variance(cn0_dbhz, self.params.coherent_time_s)


class Atan2PLL(Discriminator):
    r"""Four-quadrant arctangent $D = \mathrm{atan2}(Q_P, I_P)$; needs the data bit wiped.

    Linear over $|\delta\theta| < \pi$. Variance as `costas-atan`.
    """

    name = "atan2-pll"
    unit = "rad"
    description = "Four-quadrant arctangent PLL discriminator, needs data wipe-off (rad)"

    def __call__(self, current: Correlators, previous: Correlators | None = None) -> np.ndarray:
        return np.angle(current.prompt)

    def noise_variance(self, cn0_dbhz) -> np.ndarray:
        return _phase_variance(cn0_dbhz, self.params.coherent_time_s)
