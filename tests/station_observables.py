"""The navigation tests' observables of the station of tests/data/07590920.05o: real
broadcast records (07590920.05n) propagated by an independent light-time loop (the
range in the Earth-fixed frame of the receive time), written here once for
`test_receiver_nav_filter` and `test_receiver_nav_exclusion`."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gnssframework.navigation.ephemeris import read_rinex_nav, satellite_state

DATA = Path(__file__).parent / "data"
NAV = DATA / "07590920.05n"
STATION = np.array([-3976219.5082, 3382372.5671, 3652512.9849])
C = 299_792_458.0
OMEGA_E = 7.2921151467e-5
L1_WAVELENGTH_M = C / 1575.42e6


def geometry(sel, t: float, bias_m: float):
    """Pseudorange without noise (``bias_m`` of receiver clock, the satellite clock
    removed), transmit time (satellite clock), line-of-sight unit vectors and elevations
    (rad) of the records ``sel`` received at GPS time ``t`` by the station."""
    tau = np.full(sel.sv.size, 0.07)
    for _ in range(6):
        st = satellite_state(sel, t - tau)
        th = OMEGA_E * tau
        p = st.position_m
        rot = np.stack([np.cos(th) * p[:, 0] + np.sin(th) * p[:, 1], -np.sin(th) * p[:, 0] + np.cos(th) * p[:, 1],
                        p[:, 2]], axis=1)
        tau = np.linalg.norm(rot - STATION, axis=1) / C
    los = (rot - STATION) / np.linalg.norm(rot - STATION, axis=1)[:, None]
    el = np.arcsin(los @ (STATION / np.linalg.norm(STATION)))
    return C * tau + bias_m - C * st.clock_l1_s, t - tau + st.clock_l1_s, los, el


def visible(t: float, mask_deg: float):
    """The broadcast records in force at ``t`` of the satellites above ``mask_deg`` at the
    station, and the navigation file's records."""
    nav = read_rinex_nav(NAV)
    sel = nav.select(np.unique(nav.sv), t)
    _, _, _, el = geometry(sel, t, 0.0)
    return sel.subset(np.flatnonzero(el > np.radians(mask_deg))), nav
