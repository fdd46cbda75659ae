"""The truth of the navigation-filter integrity tests (`navigation/test_filter_integrity.py`,
`receiver/test_filter_bank.py`): the ``ekf-pv`` model's own dynamics on seven satellites of
the nominal constellation seen from one place, moving over the run, with measurement noise
of the variances the filter is told; and the binomial intervals the checks use."""

import numpy as np
import pymap3d
from scipy.stats import binom

from gnssframework.interfaces import RunContext
from gnssframework.signal.gps_l1ca import GPS_L1CA
from gnssframework.simulation.constellation import nominal_constellation

CONF = 1e-4  # probability of a correct implementation failing one check
LAT, LON, H = 45.0, 7.0, 300.0
T_S = 1.0
CH = 7
SIGMA_RANGE_M, SIGMA_RATE_M_S = 3.0, 0.1  # zenith
P0_DIAG = np.array([10.0, 10.0, 10.0, 0.5, 0.5, 0.5, 30.0, 1.0]) ** 2


def _interval(n: int, p: float) -> tuple[float, float]:
    lo, hi = binom.interval(1 - CONF, n, p)
    return lo / n, hi / n


def _upper(n: int, p: float) -> float:
    return binom.ppf(1 - CONF, n, p) / n


def _sqrtm(Q: np.ndarray) -> np.ndarray:
    w, v = np.linalg.eigh(Q)
    return v * np.sqrt(np.maximum(w, 0.0))


def _enu(lat_deg: float, lon_deg: float) -> np.ndarray:
    """Rows east, north, up in ECEF (pymap3d, independent of the package's rotations)."""
    return np.stack([np.array(pymap3d.enu2uvw(*u, lat_deg, lon_deg)) for u in np.eye(3)])


def _geometry(epochs: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Receiver ECEF, satellites' ECEF positions and velocities ``(epochs, CH, 3)``, and
    the measurements' standard deviations ``(2 CH,)`` (``σ / sin E`` at the start)."""
    sats = nominal_constellation()
    t0 = 3600.0
    pick = sats.visible(t0, LAT, LON, H, 10.0, CH)
    sub = sats.subset(pick)
    pos, vel, _ = sub.state(t0 + T_S * np.arange(epochs))
    el = np.radians(sub.elevation_deg(t0, LAT, LON, H))
    r = np.array(pymap3d.geodetic2ecef(LAT, LON, H))
    sigma = np.r_[SIGMA_RANGE_M / np.sin(el), SIGMA_RATE_M_S / np.sin(el)]
    return r, pos, vel, sigma


def _h(x: np.ndarray, sp: np.ndarray, sv: np.ndarray) -> np.ndarray:
    """Ranges then rates ``(..., 2 CH)``: ``|s - r| + b``, ``(v_s - v)·e + d``."""
    los = sp - x[..., None, 0:3]
    dist = np.linalg.norm(los, axis=-1)
    e = los / dist[..., None]
    rate = np.einsum("...ci,...ci->...c", sv - x[..., None, 3:6], e)
    return np.concatenate([dist + x[..., 6:7], rate + x[..., 7:8]], -1)


def _jacobian(r: np.ndarray, sp: np.ndarray) -> np.ndarray:
    """``H`` ``(2 CH, 8)`` at receiver ``r`` (the theory's linear model)."""
    e = (sp - r) / np.linalg.norm(sp - r, axis=-1)[:, None]
    H = np.zeros((2 * CH, 8))
    H[:CH, 0:3], H[:CH, 6] = -e, 1.0
    H[CH:, 3:6], H[CH:, 7] = -e, 1.0
    return H


def _inputs(pos, vel, z, sigma, runs):
    """An ``ekf-pv`` step's inputs from ranges then rates ``z`` ``(runs, 2 CH)`` of
    standard deviations ``sigma``: zero channel errors, the measurements as the replica's."""
    zero = np.zeros((runs, CH))
    return {
        "sat_pos_m": pos,
        "sat_vel_m_s": vel,
        "next_sat_pos_m": pos,
        "next_sat_vel_m_s": vel,
        "replica_range_m": z[:, :CH],
        "replica_rate_m_s": z[:, CH:],
        "code_error_chips": zero,
        "code_error_var_chips2": np.broadcast_to(sigma[:CH] ** 2 / GPS_L1CA.chip_length_m**2, (runs, CH)),
        "freq_error_hz": zero,
        "freq_error_var_hz2": np.broadcast_to(sigma[CH:] ** 2 / GPS_L1CA.wavelength_m**2, (runs, CH)),
    }


def _context(runs, r):
    """The filter's prior at the start (station ``r``, clock 100 m) and its run context."""
    x_hat0 = np.r_[r, np.zeros(3), 100.0, 0.0]
    return x_hat0, RunContext(
        coherent_time_s=T_S,
        epoch_interval_s=T_S,
        initial_state=np.broadcast_to(x_hat0, (runs, 8)).copy(),
        initial_cov=np.diag(P0_DIAG),
    )


def _epochs(rng, runs, epochs, x_hat0, F, Q, pos, vel, sigma, fault_m=None):
    """The truth drawn from the filter's model, epoch by epoch: ``(k, x, z)`` with the true
    states ``x`` ``(runs, 8)`` (prior draw, then white process noise of ``Q``) and the
    ranges then rates ``z`` ``(runs, 2 CH)`` with noise ``sigma``, plus the range fault
    ``fault_m[k]`` ``(runs, CH)`` if given."""
    x = x_hat0 + rng.standard_normal((runs, 8)) * np.sqrt(P0_DIAG)
    Lq = _sqrtm(Q)
    for k in range(epochs):
        if k:
            x = x @ F.T + rng.standard_normal((runs, 8)) @ Lq.T
        z = _h(x, pos[k], vel[k]) + rng.standard_normal((runs, 2 * CH)) * sigma
        if fault_m is not None:
            z[:, :CH] += fault_m[k]
        yield k, x, z
