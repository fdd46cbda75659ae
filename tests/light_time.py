"""The tests' signal geometry, independent of the library's solver: the flight time of a
signal received at a true GPS time, light time iterated with the Earth rotated during the
flight (IS-GPS-200 20.3.3.4.3.3.2), and the satellite clock at transmission."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from gnssframework.navigation.ephemeris import Ephemerides, satellite_state

C = 299_792_458.0
OMEGA_E = 7.2921151467e-5  # WGS 84 Earth rotation rate (rad/s)


class Flight(NamedTuple):
    """``tau_s`` the flight times (s), ``clock_s`` the satellites' clock offsets at
    transmission (s: a satellite's clock reads ``t_rx - tau + clock`` when it sends) and
    ``position_m`` ``(n, 3)`` the satellites at transmission in the ECEF frame of reception."""

    tau_s: np.ndarray
    clock_s: np.ndarray
    position_m: np.ndarray


def signal_flight(eph: Ephemerides, t_rx: float | np.ndarray, receiver: np.ndarray) -> Flight:
    """The flight of each satellite's signal received at true GPS time ``t_rx`` by
    ``receiver`` (ECEF m)."""
    tau = np.full(eph.sv.size, 0.07)
    for _ in range(6):
        st = satellite_state(eph, t_rx - tau)
        th = OMEGA_E * tau
        p = st.position_m
        rot = np.stack(
            [np.cos(th) * p[:, 0] + np.sin(th) * p[:, 1], -np.sin(th) * p[:, 0] + np.cos(th) * p[:, 1], p[:, 2]], axis=1
        )
        tau = np.linalg.norm(rot - receiver, axis=1) / C
    return Flight(tau, st.clock_l1_s, rot)


def visible_records(nav: Ephemerides, t_rx: float, receiver: np.ndarray, min_elevation_deg: float = 10.0):
    """Each satellite's record nearest ``t_rx`` of ``nav``, of those above
    ``min_elevation_deg`` seen from ``receiver`` (ECEF m), and their elevations (rad)."""
    sel = nav.select(np.unique(nav.sv), t_rx)
    up = receiver / np.linalg.norm(receiver)
    los = satellite_state(sel, t_rx).position_m - receiver
    el = np.arcsin(los @ up / np.linalg.norm(los, axis=1))
    keep = np.flatnonzero(el > np.radians(min_elevation_deg))
    return sel.subset(keep), el[keep]


def transmit_errors_m(obs, sats: Ephemerides, t0: float, sv_time) -> np.ndarray:
    """Every dated transmit time of ``obs`` (`observables.Observables`) less the truth,
    ``sv_time(record, t0 + recording time)`` (the signal's SV time at true time), in metres;
    ``sats`` the records sent, named ``G05``/``E11`` for their PRN."""
    prns = [int(s[1:]) for s in sats.sv]
    errors = []
    for j, prn in enumerate(obs.prn):
        k = prns.index(int(prn))
        ok = np.isfinite(obs.transmit_s[:, j])
        truth = sv_time(sats.subset(np.array([k])), t0 + obs.sample_time_s[ok])
        errors.append((obs.transmit_s[ok, j] - truth) * C)
    return np.concatenate(errors)


def position_dop(sats: Ephemerides, t: float, receiver: np.ndarray) -> float:
    """The PDOP of ``sats`` seen from ``receiver`` (ECEF m) at GPS time ``t``."""
    import pymap3d

    from gnssframework.navigation.pvt import dop

    lat, lon, h = pymap3d.ecef2geodetic(*receiver)
    up = np.array([pymap3d.ecef2enu(*p, lat, lon, h) for p in satellite_state(sats, t).position_m])
    return float(dop(up / np.linalg.norm(up, axis=1)[:, None])[1])


def assert_one_signal_fixes(path, sats, signal, rinex, week, t0, sv_time, station, *, fixes, chip_fraction):
    """`receive` on one signal of the recording ``path`` (the satellites ``sats`` sent from
    true time ``t0``, ``rinex`` the records given, ``week`` the GPS week): at least ``fixes``
    fixes, every satellite in each; every dated transmit time within ``chip_fraction`` of a
    chip rms of ``sv_time``'s truth (`transmit_errors_m`); the fixes within three PDOPs of
    that from ``station``. The L5, E5a and B1I end-to-end tests' check. Returns the
    transmit times' and the fixes' rms (m), the PDOP and the `receive` result."""
    from gnssframework import registry
    from gnssframework.receiver.channels import signal_tracking_config
    from gnssframework.receiver.frontend import open_recording
    from gnssframework.receiver.navigation.receive import receive

    result = receive(
        open_recording(path),
        registry.create("acquisition", "pcps"),
        signal_tracking_config(signal),
        prns=tuple(int(s[1:]) for s in sats.sv),
        rinex=rinex,
        signal=signal,
        reference_week=week,
    )
    obs, table = result.observables, result.positions
    assert table is not None and len(table) >= fixes
    assert all(len(u) == sats.sv.size for u in table.used_prns)
    sigma_pr = float(np.std(transmit_errors_m(obs, sats, t0, sv_time)))
    assert sigma_pr < chip_fraction * signal.chip_length_m, sigma_pr
    pdop = position_dop(sats, t0 + 4.0, station)
    rms = float(np.sqrt(np.mean(np.linalg.norm(table.ecef_m - station, axis=1) ** 2)))
    assert rms < 3 * pdop * sigma_pr, (rms, pdop, sigma_pr)
    return sigma_pr, rms, pdop, result
