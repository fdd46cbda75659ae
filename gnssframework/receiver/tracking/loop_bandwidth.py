"""Equivalent noise bandwidth of a carrier loop, measured from its closed-loop response.

Any channel filter that closes a carrier loop (a PLL, a Kalman carrier loop) is, once its
gains have settled, a linear time-invariant filter from the discriminator's input to the
NCO phase. Its one-sided noise bandwidth

$$
B_L = \\frac{1}{2T} \\frac{\\sum_n h_n^2}{\\left(\\sum_n h_n\\right)^2}
$$

(h the impulse response from the true carrier phase to the NCO phase, T the update
interval) is what sets the thermal jitter, $\\sigma^2 = 2 B_L T \\sigma_D^2$ for a
discriminator variance $\\sigma_D^2$ (Kaplan & Hegarty, *Understanding GPS*, 2006, ch. 5).
For a Kalman loop this is the bandwidth of its steady-state gain: the loop is run until
its covariance has converged, then probed. It lets a Kalman loop be compared with the
PLL of the same bandwidth.
"""

from __future__ import annotations

import copy
import json

import numpy as np

from ...errors import ConfigError
from ...interfaces import ChannelFilter
from ...plugin_ref import recreated
from .scalar import SignalTruth, run_closed_loop

__all__ = ["equivalent_bandwidth_hz"]

_CACHE: dict[tuple, float] = {}


def at_interval(channel: ChannelFilter, coherent_time_s: float) -> ChannelFilter:
    """``channel`` re-created with interval ``coherent_time_s`` (itself if it already has it,
    or takes the harness's: no ``coherent_time_s`` of its own)."""
    own_s = getattr(channel.params, "coherent_time_s", None)
    if own_s is None or abs(own_s - coherent_time_s) < 1e-12:
        return channel
    return recreated(channel, coherent_time_s=coherent_time_s)


def equivalent_bandwidth_hz(
    channel: ChannelFilter,
    coherent_time_s: float,
    *,
    settle_s: float = 8.0,
    response_s: float = 6.0,
    step_rad: float = 0.02,
) -> float:
    """One-sided noise bandwidth (Hz) of ``channel``'s carrier loop at its steady state.

    The loop tracks a noise-free signal (120 dB-Hz, no Doppler) for ``settle_s`` (its
    gains converge), then the carrier phase steps by ``step_rad`` (small: the
    discriminator is linear there) and the NCO's mid-interval phase is recorded for
    ``response_s``; the step response's differences are the impulse response h. A copy of
    ``channel`` is used, and the result is cached per plugin, parameters and T.

    Raises
    ------
    ConfigError
        If the response has not settled within ``response_s`` (the loop is too narrow for
        the probe, or unstable).
    """
    params = channel.params.model_dump(mode="json") if getattr(channel, "params", None) is not None else {}
    key = (
        type(channel).__qualname__,
        getattr(channel, "name", ""),
        json.dumps(params, sort_keys=True, default=str),
        float(coherent_time_s),
        settle_s,
        response_s,
        step_rad,
    )
    if key in _CACHE:
        return _CACHE[key]
    T = coherent_time_s
    n0 = int(round(settle_s / T))
    duration = settle_s + response_s
    K = int(round(duration / T))
    extra = np.zeros((K + 1, 1))
    extra[n0:] = step_rad
    truth = SignalTruth.from_dynamics(duration, T, 120.0, doppler_hz=np.zeros(1), extra_phase_rad=extra)
    rec = run_closed_loop(copy.deepcopy(channel), truth, np.random.default_rng(0))
    # True mid-interval phase: 0 before the step, half of it in the interval it falls in.
    true_mid = 0.5 * (extra[:-1, 0] + extra[1:, 0])
    nco_mid = true_mid - rec.phase_error_rad[:, 0]
    h = np.diff(nco_mid[n0 - 2 :]) / step_rad
    dc = np.sum(h)
    if not abs(dc - 1.0) < 0.02:
        raise ConfigError(
            f"channel_filter {getattr(channel, 'name', type(channel).__name__)!r}",
            f"its carrier loop did not settle on a phase step within {response_s} s "
            f"(DC gain {dc:.3f}); the equivalent bandwidth is undefined",
        )
    b = float(np.sum(h**2) / (2 * T * dc**2))
    _CACHE[key] = b
    return b
