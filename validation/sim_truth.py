"""The truth of a gps-sdr-sim recording from its geometry: satellite orbits and clocks from
the broadcast ephemeris (IS-GPS-200, 20.3.3.4.3 and 20.3.3.3.3.1), pseudorange with light
time and Earth rotation, the code phase and Doppler gps-sdr-sim gives each satellite.

gps-sdr-sim (gpssim.c, ``computeCodePhase``) sets the code phase at receive time
``t`` after the start ``g0`` from the pseudorange ``rho``: the transmit time in
milliseconds is ``(t + 6 - rho / c) * 1000`` and the code phase is its fraction times 1023
chips; its carrier frequency is ``-d(rho)/dt / lambda_L1``. Its pseudorange is the
geometric range minus ``c`` times the satellite clock plus its Klobuchar delay.
"""

from __future__ import annotations

import numpy as np

MU = 3.986005e14  # WGS-84 GM (m^3/s^2), IS-GPS-200
OMEGA_E = 7.2921151467e-5  # rad/s
C = 299_792_458.0
F_REL = -4.442807633e-10  # s/m^(1/2)
L1_WAVELENGTH = C / 1575.42e6
SECONDS_IN_WEEK = 604800.0


def _wrap_week(dt: np.ndarray) -> np.ndarray:
    return (dt + SECONDS_IN_WEEK / 2) % SECONDS_IN_WEEK - SECONDS_IN_WEEK / 2


def satellite_position_clock(eph: dict, tow_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """ECEF position ``(n, 3)`` (m) at GPS time of week ``tow_s`` and the clock offset (s).

    ``eph`` holds the RINEX navigation fields (georinex names) of one satellite.
    """
    t = np.asarray(tow_s, float)
    a = eph["sqrtA"] ** 2
    n = np.sqrt(MU / a**3) + eph["DeltaN"]
    tk = _wrap_week(t - eph["Toe"])
    M = eph["M0"] + n * tk
    e = eph["Eccentricity"]
    E = M.copy()
    for _ in range(20):  # Kepler's equation by fixed-point iteration (e < 0.03)
        E = M + e * np.sin(E)
    nu = np.arctan2(np.sqrt(1 - e * e) * np.sin(E), np.cos(E) - e)
    phi = nu + eph["omega"]
    du = eph["Cus"] * np.sin(2 * phi) + eph["Cuc"] * np.cos(2 * phi)
    dr = eph["Crs"] * np.sin(2 * phi) + eph["Crc"] * np.cos(2 * phi)
    di = eph["Cis"] * np.sin(2 * phi) + eph["Cic"] * np.cos(2 * phi)
    u = phi + du
    r = a * (1 - e * np.cos(E)) + dr
    i = eph["Io"] + di + eph["IDOT"] * tk
    x, y = r * np.cos(u), r * np.sin(u)
    Omega = eph["Omega0"] + (eph["OmegaDot"] - OMEGA_E) * tk - OMEGA_E * eph["Toe"]
    pos = np.stack(
        [
            x * np.cos(Omega) - y * np.cos(i) * np.sin(Omega),
            x * np.sin(Omega) + y * np.cos(i) * np.cos(Omega),
            y * np.sin(i),
        ],
        axis=-1,
    )
    dtc = _wrap_week(t - eph["toc_tow"])
    clock = (
        eph["SVclockBias"]
        + eph["SVclockDrift"] * dtc
        + eph["SVclockDriftRate"] * dtc**2
        + F_REL * e * eph["sqrtA"] * np.sin(E)
        - eph["TGD"]
    )
    return pos, clock


def pseudorange_m(eph: dict, receiver_ecef: np.ndarray, tow_rx_s: np.ndarray, iono_m: float = 0.0) -> np.ndarray:
    """Pseudorange at receive times: geometric range (light time iterated, Earth rotated
    during the flight) minus c times the satellite clock, plus ``iono_m``."""
    tow_rx_s = np.asarray(tow_rx_s, float)
    tau = np.full(tow_rx_s.shape, 0.07)
    for _ in range(4):
        pos, clock = satellite_position_clock(eph, tow_rx_s - tau)
        theta = OMEGA_E * tau
        rot = np.stack(
            [
                pos[:, 0] * np.cos(theta) + pos[:, 1] * np.sin(theta),
                -pos[:, 0] * np.sin(theta) + pos[:, 1] * np.cos(theta),
                pos[:, 2],
            ],
            axis=-1,
        )
        geometric = np.linalg.norm(rot - receiver_ecef, axis=-1)
        tau = geometric / C
    return geometric - C * clock + iono_m, geometric


def code_phase_chips(pseudorange: np.ndarray, t_s: np.ndarray) -> np.ndarray:
    """gps-sdr-sim's code phase at ``t_s`` after its start for these pseudoranges."""
    ms = (np.asarray(t_s) + 6.0 - pseudorange / C) * 1000.0
    return (ms - np.floor(ms)) * 1023.0


def doppler_hz(eph: dict, receiver_ecef: np.ndarray, tow_rx_s: np.ndarray, iono_m: float = 0.0) -> np.ndarray:
    """-d(pseudorange)/dt / lambda, by a central difference over 10 ms."""
    h = 5e-3
    ahead, _ = pseudorange_m(eph, receiver_ecef, np.asarray(tow_rx_s) + h, iono_m)
    behind, _ = pseudorange_m(eph, receiver_ecef, np.asarray(tow_rx_s) - h, iono_m)
    return -(ahead - behind) / (2 * h) / L1_WAVELENGTH
