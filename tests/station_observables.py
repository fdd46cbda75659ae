"""The navigation tests' observables of the station of tests/data/07590920.05o: real
broadcast records (07590920.05n) propagated by an independent light-time loop (`light_time.signal_flight`: the
range in the Earth-fixed frame of the receive time), written here once for
`test_receiver_nav_filter` and `test_receiver_nav_exclusion`."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gnssframework.navigation.ephemeris import read_rinex_nav
from light_time import C, signal_flight

DATA = Path(__file__).parent / "data"
NAV = DATA / "07590920.05n"
STATION = np.array([-3976219.5082, 3382372.5671, 3652512.9849])
L1_WAVELENGTH_M = C / 1575.42e6


def geometry(sel, t: float, bias_m: float):
    """Pseudorange without noise (``bias_m`` of receiver clock, the satellite clock
    removed), transmit time (satellite clock), line-of-sight unit vectors and elevations
    (rad) of the records ``sel`` received at GPS time ``t`` by the station."""
    tau, clock_s, rot = signal_flight(sel, t, STATION)
    los = (rot - STATION) / np.linalg.norm(rot - STATION, axis=1)[:, None]
    el = np.arcsin(los @ (STATION / np.linalg.norm(STATION)))
    return C * tau + bias_m - C * clock_s, t - tau + clock_s, los, el


def visible(t: float, mask_deg: float):
    """The broadcast records in force at ``t`` of the satellites above ``mask_deg`` at the
    station, and the navigation file's records."""
    nav = read_rinex_nav(NAV)
    sel = nav.select(np.unique(nav.sv), t)
    _, _, _, el = geometry(sel, t, 0.0)
    return sel.subset(np.flatnonzero(el > np.radians(mask_deg))), nav
