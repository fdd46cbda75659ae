"""Carrier-smooth recorded observations arc by arc (``gnssframework smooth``).

A smoother (a ``channel_filter`` with inputs ``pseudorange_m``, ``carrier_m``) runs over
each satellite's valid epochs; at every arc start (:func:`~gnssframework.io.observations.arc_starts`:
the receiver's loss-of-lock flag or a gap) it gets ``arc_start=True`` and restarts from the
code. The filter's own slip detections come back beside the receiver's flags.
"""

from __future__ import annotations

from dataclasses import dataclass
from collections.abc import Callable

import numpy as np

from .. import names
from ..interfaces import ChannelFilter, RunContext
from .observations import Observations, arc_starts

__all__ = ["SmoothedObservations", "smooth_observations", "default_max_gap_s", "MAX_CMC_RATE_MPS", "SMOOTHERS"]

#: The ``smooth`` command's ``--filter`` choices: a channel filter and its fixed parameters;
#: the command adds its ``--window`` or ``--q`` and ``--r``, whichever the filter takes.
SMOOTHERS = {
    "hatch": {"name": "hatch", "params": {}},
    "kf": {"name": "kf-smoother", "params": {}},
    "adaptive-kf": {
        "name": "kf-smoother",
        "params": {"adapter": "ml-q", "adapter_params": {"window": 10, "warmup": 20, "q_ceiling": 1e4}},
    },
}

#: Fastest plausible drift of code minus carrier (m/s), its least-squares slope over an
#: arc. Physically it is twice the ionospheric delay's rate: below 0.1 m/s even in strong
#: ionospheric storms. A phone whose accumulated delta range does not follow its code clock (Pixel 6
#: RINEX from GnssLogger: about 44 m/s) would drag a smoother kilometres away.
MAX_CMC_RATE_MPS = 1.0


def default_max_gap_s(interval_s: float) -> float:
    """Default longest step inside an arc: 1.5 epoch intervals, so one missing epoch ends
    the arc. A receiver that stops writing a satellite has usually stopped tracking it, and
    re-acquisition restarts the carrier's ambiguity whether or not it sets the LLI flag."""
    return 1.5 * interval_s


@dataclass
class SmoothedObservations:
    """``(T, S)`` outputs over the observations' epochs and satellites; NaN/False where a
    satellite has no observation."""

    smoothed_m: np.ndarray
    slip_detected: np.ndarray
    arc_start: np.ndarray
    max_gap_s: float
    reset_at_lli: bool
    inconsistent: list[tuple[str, int, float]]  # (satellite, first epoch row, |slope of code - carrier| m/s)

    @property
    def arcs(self) -> int:
        return int(self.arc_start.sum())


def smooth_observations(
    obs: Observations,
    make_smoother: Callable[[], ChannelFilter],
    max_gap_s: float | None = None,
    reset_at_lli: bool = True,
    max_cmc_rate_mps: float = MAX_CMC_RATE_MPS,
) -> SmoothedObservations:
    """Run a fresh smoother from ``make_smoother`` over each satellite of ``obs``.

    Parameters
    ----------
    obs
        Observations (:func:`~gnssframework.io.observations.read_observations`).
    make_smoother
        Builds one smoother (``registry.create("channel_filter", "hatch", window=100)``).
    max_gap_s
        Longest step between two epochs of one arc; default :func:`default_max_gap_s`.
    reset_at_lli
        Restart at the receiver's loss-of-lock flags (default). False keeps the filter
        running through them (gaps still end arcs), to see what the filter alone detects.
    max_cmc_rate_mps
        Arcs whose code minus carrier drifts faster than this (least-squares slope) are
        not smoothed (NaN) and are listed in ``inconsistent``: their carrier does not
        measure the code's range (default :data:`MAX_CMC_RATE_MPS`).
    """
    gap = default_max_gap_s(obs.interval_s) if max_gap_s is None else float(max_gap_s)
    lli = obs.lli if reset_at_lli else np.zeros_like(obs.lli)
    valid = obs.valid
    starts = arc_starts(obs.time_s, valid, lli, gap)
    steps = np.diff(obs.time_s)
    context = RunContext(epoch_interval_s=float(np.median(steps)) if steps.size else None)
    smoothed = np.full(valid.shape, np.nan)
    slips = np.zeros(valid.shape, bool)
    inconsistent: list[tuple[str, int, float]] = []
    for j in range(valid.shape[1]):  # satellites; epochs are the filter's own sequence
        rows = np.flatnonzero(valid[:, j])
        if not rows.size:
            continue
        smoother = make_smoother()
        smoother.reset((), context)
        for k in rows:
            out = smoother.checked_step(
                {
                    "pseudorange_m": np.asarray(obs.pseudorange_m[k, j]),
                    "carrier_m": np.asarray(obs.carrier_m[k, j]),
                    names.ARC_START: np.asarray(starts[k, j]),
                }
            )
            smoothed[k, j] = float(out["smoothed_m"])
            slips[k, j] = bool(out["slip_detected"])
        arc = np.cumsum(starts[rows, j])  # arc number of each valid epoch
        for a in np.unique(arc):
            members = rows[arc == a]
            if members.size < 2:
                continue
            # Least-squares slope of code minus carrier: code noise averages out over the arc.
            t = obs.time_s[members] - obs.time_s[members].mean()
            cmc = obs.pseudorange_m[members, j] - obs.carrier_m[members, j]
            rate = abs(float(np.sum(t * (cmc - cmc.mean())) / np.sum(t * t)))
            if rate > max_cmc_rate_mps:
                smoothed[members, j] = np.nan
                inconsistent.append((str(obs.sv[j]), int(members[0]), rate))
    return SmoothedObservations(smoothed, slips, starts, gap, reset_at_lli, inconsistent)
