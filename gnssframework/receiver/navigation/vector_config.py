"""Settings of vector tracking on samples, and what an assisted start knows.

`VectorConfig` says how the navigation filter takes over from the scalar channels and how
it aids re-acquisition (`vector_config` validates it, naming the field); `Assistance`
(`assistance`) is an approximate position and the recording's start time, which let the
loop start without LNAV (`vector_handover.try_assisted_handover`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import pymap3d
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from ... import registry
from ...errors import ConfigError
from ...interfaces import refuse_fixed_channel_set
from ...navigation.lnav import IonoUtc
from ...plugin import validation_message
from ..engine.closers import check_composition

__all__ = ["VectorConfig", "vector_config", "Assistance", "assistance"]


class VectorConfig(BaseModel):
    """How vector tracking takes over from the scalar channels."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    nav_filter: str = Field("ekf-pv", description="nav_filter plugin closing the loop")
    nav_params: dict[str, Any] = Field(default_factory=dict, description="its parameters")
    channel_filter: str = Field("discriminator", description="error-output channel_filter of the vector channels")
    channel_params: dict[str, Any] = Field(default_factory=dict, description="its parameters")
    earliest_s: float = Field(0.0, ge=0, description="no hand-over before this recording time (s)")
    try_every_s: float = Field(1.0, gt=0, description="interval between hand-over attempts (s)")
    pseudorange_sigma_m: float = Field(
        5.0,
        gt=0,
        description="pseudorange standard deviation of the first fix: its position and clock covariance is "
        "this squared times (G^T G)^-1 of the hand-over geometry",
    )
    range_rate_sigma_mps: float = Field(
        0.2,
        gt=0,
        description="range-rate standard deviation of the Dopplers the initial velocity and clock drift "
        "are solved from",
    )
    assisted_pseudorange_sigma_m: float = Field(
        100.0,
        gt=0,
        description="as pseudorange_sigma_m for an assisted start (code phases of channels still in "
        "pull-in: a quarter chip off)",
    )
    assisted_range_rate_sigma_mps: float = Field(
        5.0,
        gt=0,
        description="as range_rate_sigma_mps for an assisted start (Dopplers of acquisition or of a 1 ms loop)",
    )
    reacquire_coherent_ms: Literal[1, 10] = Field(
        10, description="coherent blocks of the aided re-acquisition (10: summed by parity, as alternate_blocks)"
    )
    reacquire_noncoherent: int = Field(8, ge=2, le=100, description="its blocks (even)")
    reacquire_pfa: float = Field(1e-3, gt=0, lt=1, description="its false-alarm probability over the window")
    reacquire_sigmas: float = Field(
        4.0, gt=0, description="half widths of its window in standard deviations of the predicted range and rate"
    )
    reacquire_elevation_deg: float = Field(5.0, description="satellites predicted below this are not searched")
    min_cn0_dbhz: float = Field(18.0, description="a channel whose C/N0 estimate is below this is not used")
    elevation_mask_deg: float = Field(5.0, description="nor one whose satellite the state sees below this (deg)")
    loss_cn0_dbhz: float = Field(
        18.0,
        description="loss of lock of a vector channel: its C/N0 estimate (over the tracker's full "
        "cn0_window_ms) below this ...",
    )
    loss_ms: int = Field(
        500,
        ge=10,
        description="... for this long: the channel leaves the navigation filter and "
        "is searched again in the window the solution predicts",
    )
    solution_rate_hz: float = Field(1.0, gt=0, description="rows of the position table per second")
    monitor_false_alarm: float | None = Field(
        None,
        gt=0,
        lt=1,
        description="channel fault monitor (gnssframework.receiver.engine.channel_monitor): "
        "probability that a healthy channel's interval fails its innovation test; null: no monitor",
    )
    monitor_consecutive: int = Field(
        3,
        ge=1,
        le=1000,
        description="failed intervals in a row that leave a channel "
        "out of the navigation update (as many passed ones bring it back)",
    )

    time_window_s: float = Field(
        2.0,
        ge=0,
        description="an assisted start's time check in the loop (vector_time): seconds of epochs "
        "pooled per estimate of the start time's error; 0: none",
    )
    time_false_alarm: float = Field(
        1e-4,
        gt=0,
        lt=1,
        description="probability that a window's estimate moves a right start time (Student's t of "
        "its batch means); the first estimate within it ends the check",
    )

    @field_validator("reacquire_noncoherent")
    @classmethod
    def _even_blocks(cls, value: int, info) -> int:
        if info.data.get("reacquire_coherent_ms") == 10 and value % 2:
            raise ValueError(f"must be even with reacquire_coherent_ms 10 (blocks summed by parity), got {value}")
        return value


def vector_config(**values: Any) -> VectorConfig:
    """A `VectorConfig`; a bad value, or a channel and navigation filter that cannot close
    the loop together (`check_composition`), raises `ConfigError` naming the field."""
    try:
        config = VectorConfig(**values)
    except ValidationError as exc:
        raise validation_message(exc, prefix="vector", model=VectorConfig) from None
    nav = registry.create("nav_filter", config.nav_filter, **config.nav_params)
    check_composition(registry.create("channel_filter", config.channel_filter, **config.channel_params), nav)
    refuse_fixed_channel_set(nav, "vector.nav_params")
    return config


@dataclass(frozen=True)
class Assistance:
    """What a receiver knows before any LNAV: where it roughly is and when the recording began.

    ``position_ecef_m`` ``(3,)`` within ~100 km of the truth (the code phases' millisecond
    ambiguity is resolved from it); ``week`` and ``start_tow_s`` the GPS time of the first
    sample, to ~1 ms (a satellite moves ~4 m in 1 ms: a time error becomes a position
    error of that order); ``iono`` Klobuchar coefficients (e.g. a RINEX header's), or None.
    """

    position_ecef_m: np.ndarray
    week: int
    start_tow_s: float
    iono: IonoUtc | None = None


def assistance(
    lat_lon_h: tuple[float, float, float], week: int, start_tow_s: float, iono: IonoUtc | None = None
) -> Assistance:
    """An `Assistance` from a geodetic position (deg, deg, m); bad values raise `ConfigError`."""
    lat, lon, h = (float(v) for v in lat_lon_h)
    if not (-90 <= lat <= 90 and -180 <= lon <= 360 and -1e4 < h < 1e5):
        raise ConfigError("approx_position", f"latitude, longitude (deg) and height (m) out of range: {lat_lon_h}")
    if not (0 <= week < 10_000 and 0 <= start_tow_s < 604_800):
        raise ConfigError(
            "start_time", f"a full GPS week and a time of week in [0, 604800) s, got {week}, {start_tow_s}"
        )
    xyz = np.array(pymap3d.geodetic2ecef(lat, lon, h), float)
    return Assistance(xyz, int(week), float(start_tow_s), iono)
