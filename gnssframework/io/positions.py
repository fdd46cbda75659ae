"""Filter a logged position track: NMEA in, CSV out (``gnssframework filter-positions``)."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pymap3d

from .. import registry
from .nmea import NmeaFixes

__all__ = ["CANDIDATES", "filter_positions", "write_positions_csv"]

#: The four filters of Liu et al. (2020), as plugin compositions around ``position-ca``.
CANDIDATES = {
    "UKF": {},
    "UKF1": {"colored": True},
    "AUKF": {"adaptive": True},
    "AUKF1": {"colored": True, "adaptive": True},
}


def filter_positions(fixes: NmeaFixes, candidate: str = "AUKF1", psi: float = 0.95
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Filter the horizontal track of ``fixes`` with a reference-004 candidate.

    Positions are converted to local east/north metres about the mean fix (pymap3d),
    filtered per coordinate with ``position-ca`` + ``ukf`` (alpha 0.01, beta 2, kappa 0),
    optionally ``colored-ar1`` (``psi``) and the improved ``sage-husa``, and converted
    back. With ``colored-ar1`` the last epoch has no estimate (it needs the next
    measurement) and keeps its raw value.

    Returns
    -------
    tuple
        ``(lat_deg, lon_deg, north_m, east_m)`` of the filtered track, one per fix.
    """
    opts = CANDIDATES[candidate]
    lat0, lon0 = float(np.mean(fixes.lat_deg)), float(np.mean(fixes.lon_deg))
    h = np.where(np.isfinite(fixes.height_m), fixes.height_m, 0.0)
    e, n, _ = pymap3d.geodetic2enu(fixes.lat_deg, fixes.lon_deg, h, lat0, lon0, 0.0)
    zs = np.stack([n, e], axis=-1)
    dt = float(np.median(np.diff(fixes.time_s))) if fixes.time_s.size > 1 else 1.0
    nav = registry.create("nav_filter", "position-ca", dt_s=dt)
    est = registry.create("estimator", "ukf", alpha=0.01, beta=2.0, kappa=0.0)
    aug = registry.create("augmentation", "colored-ar1", psi=psi) if opts.get("colored") else None
    ada = registry.create("noise_adapter", "sage-husa", variant="improved", alpha_r=0.5, alpha_q=0.5) \
        if opts.get("adaptive") else None
    res = nav.filter(zs, est, adapter=ada, augmentation=aug)
    out = zs.copy()
    out[res.epochs] = res.mean[..., 0]
    lat, lon, _ = pymap3d.enu2geodetic(out[:, 1], out[:, 0], 0.0, lat0, lon0, 0.0)
    return np.asarray(lat), np.asarray(lon), out[:, 0], out[:, 1]


def write_positions_csv(path: str | Path, fixes: NmeaFixes, lat: np.ndarray, lon: np.ndarray) -> None:
    """CSV with time, line, raw and filtered latitude/longitude (written atomically)."""
    from .files import atomic_open

    with atomic_open(path, "w", newline="") as fh:  # a killed run leaves no half CSV
        w = csv.writer(fh)
        w.writerow(["time_s", "nmea_line", "lat_deg", "lon_deg", "filtered_lat_deg", "filtered_lon_deg"])
        for row in zip(fixes.time_s, fixes.line, fixes.lat_deg, fixes.lon_deg, lat, lon):
            w.writerow([f"{row[0]:.3f}", int(row[1]), f"{row[2]:.9f}", f"{row[3]:.9f}", f"{row[4]:.9f}",
                        f"{row[5]:.9f}"])
