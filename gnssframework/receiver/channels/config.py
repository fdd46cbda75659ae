"""Settings of sample-driven tracking (validated; errors name the field)."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from ...plugin import validation_message
from ...suggest import did_you_mean
from .lock import cn0_estimator_names

__all__ = ["TrackingConfig", "tracking_config", "WEAK_SIGNAL_SETTINGS", "weak_signal_settings", "weak_signal_tracking"]


class TrackingConfig(BaseModel):
    """How channels are pulled in, tracked, declared locked or lost.

    The channel state machine: ``pull-in`` (the ``pull_in_filter``, an FLL-assisted PLL
    at 1 ms) until the lock detectors hold for ``lock_window_ms``; then ``track`` (the
    chosen ``channel_filter`` at 1 ms) while bit synchronisation collects its histogram
    (or, with ``bit_sync = "energy"``, a full prompt ring of whole-bit energies);
    then ``extended`` (the same filter re-started with ``coherent_ms`` integrations
    aligned to the bit edges, its FLL assist switched off where it has one: PLL only);
    ``lost`` after ``loss_ms`` without lock, when the channel goes back to acquisition.
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    channel_filter: str = Field("scalar", description="channel_filter plugin of the tracking stages")
    channel_params: dict[str, Any] = Field(default_factory=dict, description="its parameters")
    pull_in_filter: str = Field("scalar", description="channel_filter plugin of the pull-in stage")
    pull_in_params: dict[str, Any] = Field(
        default_factory=lambda: {"pll_bandwidth_hz": 18.0, "fll_bandwidth_hz": 10.0, "dll_bandwidth_hz": 2.0},
        description="its parameters (an FLL-assisted PLL with wide bandwidths)",
    )
    early_late_spacing_chips: float = Field(1.0, gt=0, le=1.0, description="early-to-late correlator spacing")
    coherent_ms: Literal[1, 2, 4, 5, 10, 20] = Field(
        10, description="coherent integration after bit synchronisation (divides a 20 ms bit)"
    )
    pull_in_ms: int = Field(500, ge=20, description="time allowed to reach lock before the channel is dropped")
    lock_window_ms: int = Field(40, ge=10, description="window of the phase-lock indicator")
    pli_threshold: float = Field(0.5, ge=-1, le=1, description="phase lock: PLI above this")
    cn0_threshold_dbhz: float = Field(27.0, description="lock: C/N0 estimate above this")
    cn0_estimator: str = Field(
        "nwpr",
        description="C/N0 estimator: nwpr (bit-aligned after bit sync, moments "
        "before), moments, or a bit-blind cn0_estimator plugin reading the prompt only (snv, "
        "beaulieu, m2m4)",
    )
    cn0_window_ms: int = Field(400, ge=40, description="window of the C/N0 estimate")
    loss_ms: int = Field(200, ge=10, description="time out of lock after which a channel is lost")
    bit_sync_votes: int = Field(6, ge=2, description="sign changes needed to decide the bit edge")
    bit_sync: Literal["histogram", "energy"] = Field(
        "histogram",
        description="bit synchronisation: histogram (of sign changes between 1 ms prompts, bit_sync_votes of "
        "them; in 400 ms right in 64 % of windows at 36 dB-Hz, none at 34) or energy (the edge maximising "
        "whole-bit coherent energy over the cn0_window_ms of prompts after lock; weak signals)",
    )
    reacquire_every_ms: int = Field(1000, ge=10, description="interval of re-acquisition of lost satellites")
    closure_fll_bandwidth_hz: float = Field(10.0, gt=0, description="FLL closing an error-output filter")
    closure_dll_bandwidth_hz: float = Field(2.0, gt=0, description="DLL closing an error-output filter")
    block_ms: int = Field(100, ge=10, description="samples read at a time (memory bound)")

    @field_validator("cn0_estimator")
    @classmethod
    def _known_cn0_estimator(cls, value: str) -> str:
        names = cn0_estimator_names()
        if value not in names:
            raise ValueError(
                f"unknown C/N0 estimator {value!r}; the lock detector takes {', '.join(names)}"
                f"{did_you_mean(value, names)}"
            )
        return value


def tracking_config(**values: Any) -> TrackingConfig:
    """A `TrackingConfig`; a bad value raises `ConfigError` naming the field."""
    try:
        return TrackingConfig(**values)
    except ValidationError as exc:
        raise validation_message(exc, prefix="tracking", model=TrackingConfig) from None


#: Tracking settings for signals near 30 dB-Hz, with an unassisted start (issue 40): each
#: value from what it must survive there (docs/receiver/navigation.md, "An unassisted cold
#: start at 30 dB-Hz", where the default settings lock 0-2 % of the time and never
#: synchronise a bit). At 1 ms and 30 dB-Hz (:math:`(C/N_0) T = 1`):
#:
#: - no FLL assist: a cross-product FLL's frequency noise there is tens of hertz, more than
#:   it corrects; the weak search's fine Doppler (5 Hz steps at 10 ms coherent) is within
#:   the reach of a 15 Hz second-order PLL, and a 10 Hz third-order one tracks;
#: - the phase-lock indicator's mean locked is :math:`(C/N_0)T / ((C/N_0)T + 1) = 0.5`
#:   (`lock`), its spread on noise :math:`1/\sqrt{200} = 0.07` over 200 ms: 0.3 between;
#:   3 s to pull in, 2 s out of lock before a channel is dropped;
#: - bit synchronisation by whole-bit energy over 1 s of prompts (49 bits a candidate): the
#:   histogram of 1 ms sign changes does not decide at 30 dB-Hz, and with 19 bits one
#:   channel in eleven took an edge one period off (300 km of pseudorange) on the
#:   validation's file.
WEAK_SIGNAL_SETTINGS: dict[str, Any] = {
    "pull_in_params": {"pll_bandwidth_hz": 15.0, "pll_order": 2, "fll_bandwidth_hz": 0.0, "dll_bandwidth_hz": 1.0},
    "channel_params": {"pll_bandwidth_hz": 10.0, "pll_order": 3, "fll_bandwidth_hz": 0.0, "dll_bandwidth_hz": 0.5},
    "pull_in_ms": 3000,
    "lock_window_ms": 200,
    "pli_threshold": 0.3,
    "loss_ms": 2000,
    "bit_sync": "energy",
    "cn0_window_ms": 1000,
}


def weak_signal_settings(values: dict[str, Any]) -> dict[str, Any]:
    """`WEAK_SIGNAL_SETTINGS` with ``values`` over them. The preset's ``channel_params`` are the
    default channel filter's: another ``channel_filter`` without ``channel_params`` takes its
    own defaults, and empty ``channel_params`` (none given) take the preset's."""
    settings = dict(WEAK_SIGNAL_SETTINGS)
    default = TrackingConfig.model_fields["channel_filter"].default
    values = {k: v for k, v in values.items() if v is not None and not (k == "channel_params" and not v)}
    if values.get("channel_filter", default) != default and "channel_params" not in values:
        settings.pop("channel_params")
    return {**settings, **values}


def weak_signal_tracking(**values: Any) -> TrackingConfig:
    """A `TrackingConfig` of `weak_signal_settings` (``values`` over the preset)."""
    return tracking_config(**weak_signal_settings(values))
