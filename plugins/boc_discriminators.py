r"""Code discriminators for BOC signals: the early-minus-late envelope scaled to the BOC
main peak, and two side-peak detectors that jump the replica off a false lock.

The autocorrelation of a sine-phased BOC(m, n) signal is a train of triangles
(`gnssframework.signal.spec.Subcarrier.autocorrelation`; Betz 2016, ch. 12): for
BOC(1,1), :math:`R(\tau) = 1 - 3|\tau|` up to half a chip, then :math:`|\tau| - 1`, with
side peaks of :math:`-1/2` at :math:`\pm 1/2` chip. An early-minus-late discriminator is
blind to which peak it sits on: started near a side peak, a DLL can lock there, a
bias of half a chip (about 150 m). Both detectors here read a very-early and a very-late
tap one side-peak distance :math:`\Delta` off the prompt (:math:`\Delta = n/(2m)` chips,
one sub-carrier half-period: 0.5 for BOC(1,1)), declared through
`Discriminator.extra_taps`, and command a jump of :math:`\pm\Delta` through
`Discriminator.code_jump_chips`:

- ``boc-vemlp`` (very-early / very-late peak test; Fine & Wilson 1999): the powers of
  VE, P and VL summed non-coherently over a window of M intervals; at the window's end,
  if the stronger of VE and VL exceeds P, the replica jumps towards it;
- ``bump-jumping`` (Fine & Wilson 1999): an up/down counter per very tap, up when its
  amplitude is the largest of the three, down (not below 0) otherwise; the replica jumps
  towards a tap whose counter reaches N, and both counters restart.

On the main peak both jump only on noise (false jumps, which the next window or count
undoes); their cost is the time to detect, their gain the side-peak locks they leave.
Neither is unambiguous by construction (a detector can miss); the comparison is
``examples/boc_tracking.toml``.

Sign conventions as in `gnssframework_plugins.discriminators`: the output is truth minus
replica code phase, positive means the replica must move forward.

References
----------
P. Fine and W. Wilson, "Tracking algorithm for GPS offset carrier signals", Proc. ION NTM
1999, pp. 671-676. J. W. Betz, *Engineering Satellite-Based Navigation and Timing*,
Wiley-IEEE Press, 2016, ch. 12.
"""

from __future__ import annotations

import numpy as np
from pydantic import Field, model_validator

from gnssframework.interfaces import Discriminator, DiscriminatorParams
from gnssframework.signal.correlators import Correlators

__all__ = ["BocEarlyMinusLate", "BocVemlp", "BumpJumping"]

#: Names of the very-early and very-late taps (`Correlators.extra`).
VERY_EARLY, VERY_LATE = "very_early", "very_late"


def _cn0_linear(cn0_dbhz) -> np.ndarray:
    return 10.0 ** (np.asarray(cn0_dbhz, dtype=float) / 10.0)


class BocCodeParams(DiscriminatorParams):
    early_late_spacing_chips: float = Field(
        0.2, gt=0, le=1.0, description="early-to-late spacing D (chips); below 1/k, on the main peak's linear part"
    )
    autocorrelation_slope: float = Field(
        3.0,
        ge=1.0,
        le=47.0,
        description="k: the main peak's slope, R(tau) = 1 - k |tau| near 0 (1 BPSK, 3 BOC(1,1), 4m/n - 1 BOC(m, n))",
    )

    @model_validator(mode="after")
    def _taps_on_the_main_peak(self) -> BocCodeParams:
        if self.autocorrelation_slope * self.early_late_spacing_chips >= 1.0:
            raise ValueError(
                f"early_late_spacing_chips = {self.early_late_spacing_chips} must be below 1/k = "
                f"{1 / self.autocorrelation_slope:.3g} chips (k = autocorrelation_slope): wider, the "
                "early and late taps leave the main peak"
            )
        return self


class BocEarlyMinusLate(Discriminator):
    r"""Normalised non-coherent early-minus-late envelope on a BOC main peak.

    With the main peak :math:`R(\tau) = 1 - k|\tau|` (k = 3 for BOC(1,1)) and taps at
    :math:`\pm d`, :math:`d = D/2`, :math:`kD < 1`:

    $$
    D_\tau = \frac{1 - k d}{k}\,\frac{|L| - |E|}{|L| + |E|}
    $$

    returns :math:`\delta\tau` exactly for :math:`|\delta\tau| < d` (both taps on the
    peak's linear flanks), the ``eml-envelope`` formula with k = 1. Thermal noise of one
    output (high C/N0: the I noise of :math:`L - E` has variance :math:`2(1 - R(D)) = 2kD`,
    the denominator is :math:`2 A R(d)`, :math:`A^2 = 2cT`), with the squaring-loss term of
    the BPSK formula (:math:`2 - D = 2R(d)` there) carried over:

    $$
    \sigma^2 = \frac{D}{4 k\, c T}\left(1 + \frac{1}{2 (1 - k d)\, c T}\right)
    $$

    Blind to side peaks: the baseline ``boc-vemlp`` and ``bump-jumping`` extend.
    """

    name = "boc-eml"
    unit = "chips"
    modulation = "boc11"
    description = "Early-minus-late envelope scaled to a BOC main peak (chips); blind to side peaks"
    Params = BocCodeParams
    params: BocCodeParams  # self.params, as validated

    def _eml(self, current: Correlators) -> np.ndarray:
        p = self.params
        k, d = p.autocorrelation_slope, p.early_late_spacing_chips / 2
        e, l = np.abs(current.early), np.abs(current.late)
        num, den = np.broadcast_arrays(l - e, l + e)
        return (1.0 - k * d) / k * np.divide(num, den, out=np.zeros(num.shape), where=den != 0)

    def __call__(self, current: Correlators, previous: Correlators | None = None) -> np.ndarray:
        return self._eml(current)

    def noise_variance(self, cn0_dbhz) -> np.ndarray:
        p = self.params
        k, D = p.autocorrelation_slope, p.early_late_spacing_chips
        cT = _cn0_linear(cn0_dbhz) * p.coherent_time_s
        return D / (4 * k * cT) * (1 + 1 / (2 * (1 - k * D / 2) * cT))


class _SidePeakParams(BocCodeParams):
    side_peak_chips: float = Field(
        0.5,
        gt=0,
        le=1.0,
        description="Delta: offset of the very-early and very-late "
        "taps and size of a jump (chips): the first side peak's, n/(2m) (0.5 for BOC(1,1))",
    )


class _SidePeakDetector(BocEarlyMinusLate):
    """`BocEarlyMinusLate` with very-early / very-late taps and a commanded jump."""

    params: _SidePeakParams  # self.params, as validated

    def __init__(self, **params) -> None:
        super().__init__(**params)
        self._jump: np.ndarray | float = 0.0

    def extra_taps(self) -> dict[str, float]:
        off = self.params.side_peak_chips
        return {VERY_EARLY: -off, VERY_LATE: off}

    def code_jump_chips(self) -> np.ndarray | float:
        return self._jump

    def _very(self, current: Correlators) -> tuple[np.ndarray, np.ndarray]:
        try:
            return current.extra[VERY_EARLY], current.extra[VERY_LATE]
        except KeyError:
            from gnssframework.errors import ConfigError

            raise ConfigError(
                f"discriminator {self.name!r}",
                "needs the very-early and very-late taps of its extra_taps() in the correlators (Correlators.extra)",
            ) from None


class BocVemlp(_SidePeakDetector):
    r"""Very-early / very-late peak test (VEMLP; Fine & Wilson 1999) on ``boc-eml``.

    The output is ``boc-eml``'s. Beside it, the powers of the very-early, prompt and
    very-late taps (:math:`\mp\Delta`, 0) are summed over a window of M intervals,
    :math:`S_X = \sum |X|^2`; at the window's end, if :math:`\max(S_{VE}, S_{VL}) > S_P`
    the replica jumps :math:`-\Delta` (VE the stronger) or :math:`+\Delta` (VL) through
    `Discriminator.code_jump_chips`, and the sums restart. On a BOC(1,1) side peak at
    :math:`\delta\tau = \pm 1/2` the tap on the far side sits on the main peak (:math:`|R|
    = 1` against the prompt's 1/2), so the test's mean gap is :math:`3/4 A^2` per
    interval; on the main peak the very taps see :math:`|R| = 1/2`, and a false jump needs
    the noise to close the same gap. Thermal noise of the output: ``boc-eml``'s (the jumps
    are outside the loop filter).
    """

    name = "boc-vemlp"
    description = "BOC early-minus-late with the very-early/very-late peak test over a window, jumping off side peaks"

    class Params(_SidePeakParams):
        window_intervals: int = Field(
            10, ge=1, le=1000, description="M: intervals whose tap powers are summed before each test"
        )

    params: Params  # self.params, as validated
    _sums: np.ndarray | None = None
    _count: int = 0

    def __call__(self, current: Correlators, previous: Correlators | None = None) -> np.ndarray:
        ve, vl = self._very(current)
        powers = np.stack(np.broadcast_arrays(np.abs(ve) ** 2, np.abs(current.prompt) ** 2, np.abs(vl) ** 2))
        if self._sums is None or self._sums.shape != powers.shape:
            self._sums, self._count = np.zeros(powers.shape), 0
        self._sums += powers
        self._count += 1
        self._jump = 0.0
        if self._count >= self.params.window_intervals:
            s_ve, s_p, s_vl = self._sums
            off = self.params.side_peak_chips
            self._jump = np.where(np.maximum(s_ve, s_vl) > s_p, np.where(s_vl > s_ve, off, -off), 0.0)
            self._sums[:] = 0.0
            self._count = 0
        return self._eml(current)


class BumpJumping(_SidePeakDetector):
    r"""Bump-jumping (Fine & Wilson 1999): up/down counters on the very taps, on ``boc-eml``.

    The output is ``boc-eml``'s. Every interval the amplitudes :math:`|VE|`, :math:`|P|`,
    :math:`|VL|` (taps at :math:`-\Delta, 0, +\Delta`) are compared: the counter of a very
    tap that is the largest of the three counts up, the other counts down; both count down
    when the prompt is the largest (never below 0). When a counter reaches N the replica
    jumps towards its tap (:math:`-\Delta` for VE, :math:`+\Delta` for VL) through
    `Discriminator.code_jump_chips`, and both counters restart at 0. A false jump on the
    main peak needs a very tap to win about N more intervals than it loses in a row; on a
    side peak the detection takes about N intervals. Thermal noise of the output:
    ``boc-eml``'s.
    """

    name = "bump-jumping"
    description = "BOC early-minus-late with bump-jumping: very-early/very-late counters jumping off side peaks"

    class Params(_SidePeakParams):
        counter_threshold: int = Field(
            8, ge=1, le=1000, description="N: the count at which a very tap's counter commands a jump"
        )

    params: Params  # self.params, as validated
    _counts: np.ndarray | None = None

    def __call__(self, current: Correlators, previous: Correlators | None = None) -> np.ndarray:
        ve, vl = self._very(current)
        a_ve, a_p, a_vl = np.broadcast_arrays(np.abs(ve), np.abs(current.prompt), np.abs(vl))
        if self._counts is None or self._counts.shape[1:] != a_p.shape:
            self._counts = np.zeros((2,) + a_p.shape, np.int64)
        ve_wins = (a_ve > a_p) & (a_ve >= a_vl)
        vl_wins = (a_vl > a_p) & (a_vl > a_ve)
        c = self._counts
        c[0] = np.where(ve_wins, c[0] + 1, np.maximum(c[0] - 1, 0))
        c[1] = np.where(vl_wins, c[1] + 1, np.maximum(c[1] - 1, 0))
        n, off = self.params.counter_threshold, self.params.side_peak_chips
        jump_early, jump_late = c[0] >= n, c[1] >= n
        self._jump = np.where(jump_late, off, np.where(jump_early, -off, 0.0))
        fired = jump_early | jump_late
        c[:, fired] = 0
        return self._eml(current)
