"""Range-bias states for the vector-tracking nav filters (``ekf-pv``, ``ekf-pva``): the
range-error budget a nav filter carries instead of assuming its pseudoranges unbiased.

A real sky adds to every pseudorange errors that are nearly constant over minutes: the
broadcast orbit and clock error (SISRE, independent per satellite), the residual of the
ionospheric model (one vertical value mapped to each line of sight by the obliquity factor)
and the residual of the tropospheric model (one zenith value mapped by the tropospheric
mapping function). Thermal noise in R cannot stand for them: they do not average out, so a
filter that leaves them out is overconfident in position (its NEES far above the state
count) however its R is scaled. Here they are states (Brown and Hwang 2012, section 8.2,
random constants or first-order Gauss-Markov processes), appended after the filter's own:

$$
\\rho_i = \\lVert s_i - r \\rVert + b + F(E_i)\\, I_v + m(E_i)\\, T_z + \\epsilon_i,
\\qquad I_v \\sim N(0, \\sigma_I^2),\\; T_z \\sim N(0, \\sigma_T^2),\\; \\epsilon_i \\sim N(0, \\sigma_S^2)
$$

with $F$ the Klobuchar obliquity factor (IS-GPS-200, 20.3.3.5.2.5) and $m$ the mapping
function $1.001/\\sqrt{0.002001 + \\sin^2 E}$ (RTCA DO-229). A state group whose standard
deviation is zero is left out; with all three zero the filter is unchanged.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from pydantic import Field

from gnssframework.errors import ConfigError
from gnssframework.navigation.geometry import enu_rotation, line_of_sight
from gnssframework.plugin import PluginParams
from gnssframework.simulation.propagation import klobuchar_obliquity, least_squares_gain, tropo_mapping

__all__ = [
    "RangeBiasBudget",
    "RangeBiasParams",
    "RangeBiasStates",
    "budget_assumptions",
    "check_channels",
    "elevation_deg",
    "least_squares_prior",
    "up_vector",
]


class RangeBiasStates(PluginParams):
    """The range-error budget of a nav filter as states (all zero: no bias states)."""

    sisre_std_m: float = Field(
        0.0, ge=0, description="broadcast orbit and clock error per satellite (SISRE), one state per channel (m)"
    )
    iono_vertical_std_m: float = Field(
        0.0, ge=0, description="vertical ionospheric residual, one state mapped by the obliquity factor (m)"
    )
    tropo_zenith_std_m: float = Field(
        0.0, ge=0, description="zenith tropospheric residual, one state mapped by the tropospheric mapping (m)"
    )
    range_bias_time_s: float | None = Field(
        None,
        gt=0,
        description="correlation time of the range-bias states (first-order Gauss-Markov, s); None: constant",
    )


class RangeBiasParams(RangeBiasStates):
    """The range-error budget of a nav filter whose initial estimate may be a fix from the
    same ranges (``ekf-pv``, ``ekf-pva``)."""

    initial_fix_from_ranges: bool = Field(
        False,
        description="the run's initial estimate is a least-squares fix from the same biased pseudoranges: "
        "its position and clock error is correlated with the bias states (plugins/range_bias.py)",
    )


def budget_assumptions(params: RangeBiasStates) -> dict[str, tuple[float, str]]:
    """The range-error budget as a filter's assumptions (none when it is off)."""
    if not RangeBiasBudget.wanted(params):
        return {}
    return {
        "range-error budget: SISRE per satellite": (params.sisre_std_m, "m"),
        "range-error budget: vertical ionospheric residual": (params.iono_vertical_std_m, "m"),
        "range-error budget: zenith tropospheric residual": (params.tropo_zenith_std_m, "m"),
    }


@dataclasses.dataclass(frozen=True)
class RangeBiasBudget:
    """The bias states of a budget for ``channels`` channels, in the order
    ``[I_v, T_z, eps_1 .. eps_ch]`` (a group of zero standard deviation left out)."""

    sisre_std_m: float
    iono_vertical_std_m: float
    tropo_zenith_std_m: float
    time_s: float | None
    channels: int

    @classmethod
    def of(cls, params: RangeBiasStates, channels: int) -> RangeBiasBudget:
        return cls(
            params.sisre_std_m,
            params.iono_vertical_std_m,
            params.tropo_zenith_std_m,
            params.range_bias_time_s,
            channels,
        )

    @staticmethod
    def wanted(params: RangeBiasStates) -> bool:
        """Whether ``params`` asks for any bias state."""
        return params.sisre_std_m > 0 or params.iono_vertical_std_m > 0 or params.tropo_zenith_std_m > 0

    def std_m(self) -> np.ndarray:
        """Prior standard deviation of each bias state ``(n,)``."""
        parts = []
        if self.iono_vertical_std_m > 0:
            parts.append([self.iono_vertical_std_m])
        if self.tropo_zenith_std_m > 0:
            parts.append([self.tropo_zenith_std_m])
        if self.sisre_std_m > 0:
            parts.append([self.sisre_std_m] * self.channels)
        return np.concatenate(parts).astype(float)

    @property
    def size(self) -> int:
        return int(self.std_m().size)

    def transition(self, interval_s: float) -> tuple[np.ndarray, np.ndarray]:
        """Diagonals of F and Q of the bias states over ``interval_s``: 1 and 0 for random
        constants; $e^{-T/\\tau}$ and $\\sigma^2 (1 - e^{-2T/\\tau})$ for Gauss-Markov."""
        var = self.std_m() ** 2
        if self.time_s is None:
            return np.ones_like(var), np.zeros_like(var)
        psi = np.exp(-interval_s / self.time_s)
        return np.full_like(var, psi), var * (1.0 - psi**2)

    def rows(self, elevation_deg: np.ndarray) -> np.ndarray:
        """How the bias states enter each channel's pseudorange ``(..., ch, n)`` at
        elevations ``(..., ch)``: the obliquity factor, the mapping function, one."""
        e = np.asarray(elevation_deg, float)
        cols = []
        if self.iono_vertical_std_m > 0:
            cols.append(klobuchar_obliquity(e)[..., None])
        if self.tropo_zenith_std_m > 0:
            cols.append(tropo_mapping(e)[..., None])
        if self.sisre_std_m > 0:
            cols.append(np.broadcast_to(np.eye(self.channels), e.shape + (self.channels,)))
        return np.concatenate(cols, axis=-1)


def up_vector(position_ecef_m: np.ndarray) -> np.ndarray:
    """Local up ``(..., 3)`` at ECEF positions ``(..., 3)`` (geodetic, WGS-84)."""
    return enu_rotation(position_ecef_m)[..., 2, :]


def elevation_deg(sat_pos_m: np.ndarray, position_ecef_m: np.ndarray, up: np.ndarray) -> np.ndarray:
    """Elevations ``(..., ch)`` of satellites ``(ch, 3)`` or ``(..., ch, 3)`` seen from
    positions ``(..., 3)`` with local up ``(..., 3)``."""
    _, e = line_of_sight(np.asarray(sat_pos_m, float), np.asarray(position_ecef_m, float)[..., None, :])
    return np.degrees(np.arcsin(np.clip(np.einsum("...ci,...i->...c", e, up), -1.0, 1.0)))


def check_channels(budget: RangeBiasBudget, channels: int, who: str, step: int) -> None:
    """Refuse a step whose channel count is not the one the per-channel bias states were
    made for (the ionospheric and tropospheric states fit any channel set)."""
    if budget.sisre_std_m > 0 and channels != budget.channels:
        raise ConfigError(
            f"{who}.sisre_std_m",
            f"range-bias states need a fixed channel set: step {step} has {channels} channels, "
            f"the first had {budget.channels}",
        )


def least_squares_prior(
    P: np.ndarray, P_bias: np.ndarray, rows: np.ndarray, los: np.ndarray, n_core: int
) -> np.ndarray:
    """The joint prior ``(..., n_core + n_b, n_core + n_b)`` of a filter whose initial
    estimate is a least-squares fix from pseudoranges that carry the bias states.

    The fix's position and clock error is $A b$ plus the independent error of covariance
    ``P`` ``(..., n_core, n_core)``, with $A = (G^T G)^{-1} G^T M$, $G_i = [-e_i^T, 1]$ (``los``
    ``(..., ch, 3)`` the unit vectors $e_i$) and $M$ the bias rows ``(..., ch, n_b)``
    (`RangeBiasBudget.rows`). The bias estimate starts at zero, so its error is $-b$:

    $$
    P_{xx} = P + A P_b A^T, \\qquad P_{xb} = -A P_b, \\qquad P_{bb} = P_b
    $$

    (``P_bias`` the diagonal prior ``(n_b, n_b)``; A fills the position, 0-2, and clock
    bias, 6, rows of the state).
    """
    A4 = least_squares_gain(los) @ rows  # (..., 4, n_b)
    lead = A4.shape[:-2]
    nb = P_bias.shape[-1]
    A = np.zeros(lead + (n_core, nb))
    A[..., 0:3, :], A[..., 6, :] = A4[..., 0:3, :], A4[..., 3, :]
    AP = A @ P_bias
    out = np.zeros(np.broadcast_shapes(np.shape(P)[:-2], lead) + (n_core + nb,) * 2)
    out[..., :n_core, :n_core] = P + AP @ np.swapaxes(A, -1, -2)
    out[..., :n_core, n_core:] = -AP
    out[..., n_core:, :n_core] = -np.swapaxes(AP, -1, -2)
    out[..., n_core:, n_core:] = P_bias
    return out
