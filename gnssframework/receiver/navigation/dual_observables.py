"""Ionosphere-free positions from two recordings of one front end on two carriers (GPS
L1 C/A and L2C, say).

Each recording is received on its own (`receive.receive`); the second's channels are then
dated again on the first's receiver clock (`second_observables`: the same epochs, the same
clock offset), so the two pseudoranges of a satellite at an epoch differ only by what the
two signals' paths and satellite clocks do. `ionosphere_free_observables` takes their
combination (`navigation.dual_frequency.DualFrequency`), and `ionosphere_free_fixes`
solves it (`fixes.solve_epochs` with the combination's satellite clock and no ionospheric
model).

The two recordings must start at the same instant of one sample clock (two channels of one
front end). A start offset :math:`\\Delta` between them moves every combined pseudorange by
:math:`-c\\Delta/(\\gamma - 1)` alike, which the receiver clock takes; but each satellite's
range also moves by :math:`\\dot\\rho_i \\Delta` meanwhile, which enters its combined
pseudorange times :math:`1/(\\gamma - 1) = 1.55` on L1 and L2: up to 1.2 m per millisecond
of offset (800 m/s). Two sample clocks that differ in rate would add a drift.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ...errors import ConfigError
from ...navigation.dual_frequency import DualFrequency
from ...navigation.ephemeris import Ephemerides
from .decoded import navigation_message
from .fixes import PositionTable, solve_epochs
from .observables import Observables, observables

__all__ = ["second_observables", "ionosphere_free_observables", "ionosphere_free_fixes"]


def second_observables(tracking, dual: DualFrequency, first: Observables, rate_hz: float = 1.0) -> Observables | None:
    """The observables of the second signal's tracking (a `TrackingResult` of
    ``dual.second``), each channel dated from its own message, at the epochs and on the
    receiver clock of ``first`` (the first signal's); None where no channel has a transmit
    time."""
    message = navigation_message(dual.second)
    timings = [message.timing(ch, dual.second) for ch in tracking.channels.values()]
    if not any(t is not None and t.time_s.size > 1 for t in timings):
        return None
    offset = float(first.rx_time_s[0] - first.sample_time_s[0])
    return observables(timings, rate_hz, rx_offset_s=offset)


def ionosphere_free_observables(first: Observables, second: Observables, dual: DualFrequency) -> Observables:
    """The combination of the two signals' observables at their common epochs and
    satellites: pseudoranges combined (NaN where either is), the first's transmit times,
    Dopplers, carrier phases, C/N0 and loss-of-lock bits, the decoded records of both (for
    each satellite, in the order they became known) and the first's Klobuchar and week
    (the second's where the first has none).

    Raises
    ------
    ConfigError
        Where the two share no epoch or no satellite (recordings of other times, or of
        other satellites).
    """
    t1 = np.round(first.sample_time_s, 6)
    t2 = np.round(second.sample_time_s, 6)
    _, e1, e2 = np.intersect1d(t1, t2, return_indices=True)
    prns, j1, j2 = np.intersect1d(first.prn, second.prn, return_indices=True)
    if e1.size == 0 or prns.size == 0:
        raise ConfigError(
            "ionosphere_free",
            f"the two recordings share {e1.size} epochs and {prns.size} satellites: "
            "they must be of one front end, started together",
        )
    pick = np.ix_(e1, j1)
    pr = dual.combine(first.pseudorange_m[pick], second.pseudorange_m[np.ix_(e2, j2)])
    records: dict[int, list[tuple[float, Ephemerides]]] = {}
    for p in prns:
        both = first.ephemeris.get(int(p), []) + second.ephemeris.get(int(p), [])
        if both:
            records[int(p)] = sorted(both, key=lambda item: item[0])
    return replace(
        first,
        rx_time_s=first.rx_time_s[e1],
        sample_time_s=first.sample_time_s[e1],
        prn=prns,
        transmit_s=first.transmit_s[pick],
        pseudorange_m=pr,
        doppler_hz=first.doppler_hz[pick],
        carrier_cycles=first.carrier_cycles[pick],
        cn0_dbhz=first.cn0_dbhz[pick],
        ephemeris=records,
        iono_utc=first.iono_utc if first.iono_utc is not None else second.iono_utc,
        week=first.week if first.week is not None else second.week,
        week_bits=first.week_bits if first.week is not None else second.week_bits,
        lli=None if first.lli is None else first.lli[pick],
    )


def ionosphere_free_fixes(
    first: Observables,
    second: Observables,
    dual: DualFrequency,
    rinex: Ephemerides | None = None,
    **solve,
) -> tuple[Observables, PositionTable]:
    """The combined observables (`ionosphere_free_observables`) and their fixes
    (`fixes.solve_epochs` with ``dual``, ``signal`` the first, ``ionosphere`` off; ``solve``
    its other options: ``troposphere``, ``reference_week``, ``weighting``...)."""
    for name in ("dual", "signal", "ionosphere", "iono"):
        if name in solve:
            raise ConfigError(name, "is set by the ionosphere-free solution itself")
    obs = ionosphere_free_observables(first, second, dual)
    table = solve_epochs(obs, rinex, ionosphere=False, signal=dual.first, dual=dual, **solve)
    return obs, table
