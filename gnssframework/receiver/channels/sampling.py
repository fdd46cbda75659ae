"""Sample rates commensurate with a signal's chip rate, which leave code tracking a dead band.

With :math:`f_s / f_{chip} = p / q` (lowest terms), sample :math:`n` falls
:math:`n q / p` chips into the code: the samples meet the chips at only :math:`p` distinct
fractional phases, :math:`k / p`. The sampled correlation of replica and signal is then a
staircase of steps :math:`1/p` chip wide, and a code error inside :math:`\\pm 1/(2p)` chip
moves no sample from one chip to the next: the discriminator does not see it (Akos and
Pini, "Effect of sampling frequency on GNSS receiver performance", *NAVIGATION* 53(2),
2006). At 2.046 MHz, exactly two samples a GPS L1 C/A chip, that is a quarter chip, 73 m:
the code error wanders in it, slowly (the code Doppler moves the alignment), and a
filter fed the discriminator's output as white noise is overconfident (measured in
``tests/receiver/test_assisted_observables.py``: the assisted vector start's pseudorange
errors reach 5 of its filter's sigmas at 2.046 MHz, under 2 at 2.2 MHz).
"""

from __future__ import annotations

import warnings
from fractions import Fraction

from ...errors import GnssFrameworkWarning
from ...signal.spec import SignalSpec

__all__ = ["CommensurateSamplingWarning", "code_alignments", "warn_if_commensurate", "MIN_ALIGNMENTS"]

#: Largest denominator ``q`` searched: a rate that is a ratio with a larger one meets the
#: chips at more alignments than a tracking loop resolves.
MAX_DENOMINATOR = 64
#: Fewest alignments per chip without a warning: a dead band of at most ±1/40 chip (7 m on C/A).
MIN_ALIGNMENTS = 20


class CommensurateSamplingWarning(GnssFrameworkWarning):
    """The sample rate is a ratio of small integers with the chip rate (`code_alignments`)."""


def code_alignments(sample_rate_hz: float, signal: SignalSpec) -> int | None:
    """Distinct phases ``p`` at which the samples meet ``signal``'s replica chips (sub-chips
    for BOC) when ``sample_rate_hz`` is ``p / q`` of their rate with ``q <=``
    `MAX_DENOMINATOR` (to 1e-9), else None (the alignments are dense)."""
    rate_hz = signal.chip_rate_hz * signal.subchips_per_chip
    ratio = sample_rate_hz / rate_hz
    f = Fraction(ratio).limit_denominator(MAX_DENOMINATOR)
    return f.numerator if abs(float(f) - ratio) <= 1e-9 * ratio else None


def warn_if_commensurate(sample_rate_hz: float, signal: SignalSpec) -> None:
    """Warn (`CommensurateSamplingWarning`) where ``sample_rate_hz`` meets ``signal``'s chips
    at fewer than `MIN_ALIGNMENTS` phases (see the module text)."""
    p = code_alignments(sample_rate_hz, signal)
    if p is None or p >= MIN_ALIGNMENTS:
        return
    unit = "sub-chip" if signal.subchips_per_chip > 1 else "chip"
    band_chips = 0.5 / (p * signal.subchips_per_chip)
    warnings.warn(
        f"sample rate {sample_rate_hz / 1e6:g} MHz meets {signal.name}'s {unit}s at {p} phases only: "
        f"code errors within ±{band_chips:.3g} chip are not seen by the discriminator (a dead band, "
        f"Akos and Pini 2006), so code tracking wanders in it and a navigation filter's covariance is "
        f"overconfident; a rate that is no ratio of small integers with the chip rate avoids it",
        CommensurateSamplingWarning,
        stacklevel=3,
    )
