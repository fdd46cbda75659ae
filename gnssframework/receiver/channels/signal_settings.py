"""Tracking settings a signal's description implies, under the settings a user gave.

The loops and taps that suit GPS L1 C/A (`TrackingConfig`'s defaults) do not suit every
signal; what differs follows from the signal's description (`SignalSpec`), as GNSS-SDR's
blocks read their signal's parameters:

* **Coherent time**: after bit synchronisation a channel integrates whole code periods that
  divide a data symbol (`coherent_periods`: 10 of L1 C/A's 20, 1 on Galileo E1-B's 4 ms
  symbol and on L2 CM's 20 ms one).
* **Long code periods** (L2 CM, 20 ms): one period is the shortest interval, so the pull-in
  loops' bandwidths (the defaults', or the ones given) would put :math:`B_L T` past the 0.2
  a discretised analog loop takes. They are narrowed to :math:`B_L T =` `LONG_PERIOD_B_L_T`
  at that period, in the ratios of `LONG_PERIOD_PULL_IN`, and a channel filter's PLL with
  them where it takes a ``pll_bandwidth_hz`` and was not given one.
* **BOC**: BOC(1,1)'s main peak is ±1/3 chip wide, so taps ±0.5 chip apart would sit on its
  side lobes: `BOC_EARLY_LATE_SPACING_CHIPS` (the spacing the E1 tracking was validated
  with, `docs/receiver/galileo-e1.md`).
* **Time slots**: a component sent in 1 of n slots of each chip (L2 CM: 1 of 2) has a peak
  1/n chip wide either side: taps 1/n chip apart.

A setting the user gave (a key of ``given``) is kept as given, but for pull-in loops too
wide for the signal's code period.
"""

from __future__ import annotations

from typing import Any

from ... import registry
from ...errors import ConfigError
from ...signal.spec import SignalSpec
from .config import TrackingConfig, tracking_config

__all__ = [
    "BOC_EARLY_LATE_SPACING_CHIPS",
    "LONG_PERIOD_B_L_T",
    "LONG_PERIOD_PULL_IN",
    "coherent_periods",
    "signal_tracking_settings",
    "signal_tracking_config",
]

#: The early-to-late spacing (chips) on a BOC signal unless told (`docs/receiver/galileo-e1.md`:
#: the spacing the E1 tracking was validated with).
BOC_EARLY_LATE_SPACING_CHIPS = 0.2
#: Loop bandwidth times interval of the pull-in PLL (and the scalar filter's) on a signal
#: whose code period is too long for the defaults (GPS L2 CM, 20 ms: 8 Hz), under the 0.2 a
#: discretised analog loop takes; the FLL and DLL scaled with it from `LONG_PERIOD_PULL_IN`.
LONG_PERIOD_B_L_T = 0.16
#: Ratios of the pull-in loops' bandwidths on such a signal (Hz at a 20 ms period).
LONG_PERIOD_PULL_IN = {"pll_bandwidth_hz": 8.0, "fll_bandwidth_hz": 4.0, "dll_bandwidth_hz": 1.0}
#: Largest B_L T of the default pull-in PLL before a signal counts as long-period.
_MAX_B_L_T = 0.2


def coherent_periods(signal: SignalSpec, requested: int | None, default: int = 10) -> int | None:
    """The tracking's coherent code periods after bit sync on ``signal``: ``requested``
    (None: the largest of 1, 2, 4, 5, ``default`` that divides a data symbol; None on a
    pilot, the tracking's default), refused where it spans data symbols. Under an overlay
    code (E1-C, L5, E5a) one code period: the tracker does not wipe an overlay off, and a
    sum over its chips would cancel (NH10's ten sum to 2), so more is refused."""
    if signal.overlay_length(0):
        if requested not in (None, 1):
            raise ConfigError(
                "tracking.coherent_ms",
                f"{requested} code periods span {signal.name}'s overlay code, which the tracker does not "
                "wipe off: give 1",
            )
        return 1
    per_symbol = signal.code_periods_per_symbol
    if per_symbol is None:
        return requested
    if requested is None:
        return max(k for k in (1, 2, 4, 5, default) if k <= default and per_symbol % k == 0)
    if per_symbol % requested:
        raise ConfigError(
            "tracking.coherent_ms",
            f"{requested} code periods span {signal.name}'s data symbols "
            f"({per_symbol} code period{'s' if per_symbol > 1 else ''} each): "
            "give one that divides it",
        )
    return requested


def signal_tracking_settings(signal: SignalSpec, given: dict[str, Any] | None = None) -> dict[str, Any]:
    """``given`` (keyword arguments of `tracking_config`) completed with what ``signal``'s
    description implies (module text); ``given``'s own settings are kept, and its
    ``channel_params`` copied, not changed."""
    settings = dict(given or {})
    params = dict(settings.get("channel_params") or {})
    coherent = coherent_periods(signal, settings.get("coherent_ms"))
    if coherent is not None:
        settings["coherent_ms"] = coherent
    default = TrackingConfig()
    pull_in = {**default.pull_in_params, **(settings.get("pull_in_params") or {})}
    if signal.code_period_s * pull_in["pll_bandwidth_hz"] > _MAX_B_L_T:
        pll_hz = LONG_PERIOD_B_L_T / signal.code_period_s
        scale = pll_hz / LONG_PERIOD_PULL_IN["pll_bandwidth_hz"]
        settings["pull_in_params"] = {k: v * scale for k, v in LONG_PERIOD_PULL_IN.items()}
        name = settings.get("channel_filter") or default.channel_filter
        if "pll_bandwidth_hz" in registry.get("channel_filter", name).Params.model_fields:
            params.setdefault("pll_bandwidth_hz", pll_hz)
    if "early_late_spacing_chips" not in settings:
        if signal.subcarrier.kind != "bpsk":
            settings["early_late_spacing_chips"] = BOC_EARLY_LATE_SPACING_CHIPS
        slots = signal.tracked.time_slot[1]
        if slots > 1:
            settings["early_late_spacing_chips"] = 1.0 / slots
    if params or "channel_params" in settings:
        settings["channel_params"] = params
    return settings


def signal_tracking_config(signal: SignalSpec, **given: Any) -> TrackingConfig:
    """The `TrackingConfig` of ``signal`` (`signal_tracking_settings`) under the settings
    ``given`` (keyword arguments of `tracking_config`)."""
    return tracking_config(**signal_tracking_settings(signal, given))
