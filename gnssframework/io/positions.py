"""Filter a logged position track: NMEA in, CSV out (``gnssframework filter-positions``)."""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Any

import numpy as np
import pymap3d

from .. import registry
from ..errors import ConfigError
from ..interfaces import BatchPositionFilter
from .nmea import NmeaFixes

__all__ = ["CANDIDATES", "composition", "filter_positions", "write_positions_csv"]

#: The paper's engine: the unscented Kalman filter with alpha 0.01, beta 2, kappa 0.
_UKF = {"name": "ukf", "params": {"alpha": 0.01, "beta": 2.0, "kappa": 0.0}}
#: The improved Sage-Husa adapter of the adaptive filters.
_SAGE_HUSA = {"name": "sage-husa", "params": {"variant": "improved", "alpha_r": 0.5, "alpha_q": 0.5}}
#: The colored-noise augmentation; its ``psi`` is the command's ``--psi``.
_COLORED = {"name": "colored-ar1", "params": {}}

#: The four filters of Liu et al. (2020), as plugin compositions (kind -> ``{name, params}``)
#: around a `~gnssframework.interfaces.BatchPositionFilter`; ``filter_positions`` sets the
#: nav filter's ``dt_s`` and the augmentation's ``psi``.
CANDIDATES = {
    "UKF": {"nav_filter": {"name": "position-ca", "params": {}}, "estimator": _UKF},
    "UKF1": {"nav_filter": {"name": "position-ca", "params": {}}, "estimator": _UKF, "augmentation": _COLORED},
    "AUKF": {"nav_filter": {"name": "position-ca", "params": {}}, "estimator": _UKF, "noise_adapter": _SAGE_HUSA},
    "AUKF1": {"nav_filter": {"name": "position-ca", "params": {}}, "estimator": _UKF, "augmentation": _COLORED,
              "noise_adapter": _SAGE_HUSA},
}


#: The nav filter a registry-named composition runs in (the paper's constant-acceleration
#: position model, a `~gnssframework.interfaces.BatchPositionFilter`).
POSITION_NAV_FILTER = {"name": "position-ca", "params": {}}


def composition(filter_name: str, noise_adapter: str | None = None, augmentation: str | None = None) -> dict:
    """The plugin composition of ``filter-positions``: a paper label (``UKF``, ``UKF1``,
    ``AUKF``, ``AUKF1``; any case) or a registered estimator's name (``ckf``, ``ekf``...)
    in ``position-ca``, plus, by registry name, a noise adapter and an augmentation
    (which replace a label's own).

    Raises
    ------
    ConfigError
        Naming the parameter: ``filter_name`` (the labels and estimators it takes, and
        the closest one), ``noise_adapter`` or ``augmentation``.
    """
    from ..suggest import did_you_mean

    labels = {k.casefold(): k for k in CANDIDATES}
    if filter_name.casefold() in labels:
        comp = dict(CANDIDATES[labels[filter_name.casefold()]])
    elif filter_name in registry.names("estimator"):
        comp = {"nav_filter": POSITION_NAV_FILTER, "estimator": {"name": filter_name, "params": {}}}
    else:
        options = [*CANDIDATES, *registry.names("estimator")]
        raise ConfigError("filter_name", f"unknown {filter_name!r}: a paper label ({', '.join(CANDIDATES)}) or "
                                           f"an estimator ({', '.join(registry.names('estimator'))})"
                                           f"{did_you_mean(filter_name, options)}")
    for kind, name in (("noise_adapter", noise_adapter), ("augmentation", augmentation)):
        if name is None:
            continue
        if name not in registry.names(kind):
            raise ConfigError(kind, f"unknown {kind} {name!r}; registered: {', '.join(registry.names(kind))}"
                                    f"{did_you_mean(name, registry.names(kind))}")
        comp[kind] = {"name": name, "params": {}}
    return comp


def _create(ref: dict | None, kind: str, **given: Any) -> Any:
    """The plugin of a composition's ``{name, params}`` (``None`` for none), with ``given`` parameters."""
    return None if ref is None else registry.create(kind, ref["name"], **{**ref["params"], **given})


def filter_positions(fixes: NmeaFixes, candidate: str | dict = "AUKF1", psi: float = 0.95
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Filter the horizontal track of ``fixes`` with a reference-004 candidate.

    Positions are converted to local east/north metres about the mean fix (pymap3d),
    filtered per coordinate with the composition ``CANDIDATES[candidate]``
    (``position-ca`` + ``ukf`` with alpha 0.01, beta 2, kappa 0, optionally ``colored-ar1``
    with ``psi`` and the improved ``sage-husa``), or a composition from `composition`
    (registry names), and converted back. With ``colored-ar1`` the last epoch has no estimate (it needs the next
    measurement) and keeps its raw value.

    Returns
    -------
    tuple
        ``(lat_deg, lon_deg, north_m, east_m)`` of the filtered track, one per fix.
    """
    comp = candidate if isinstance(candidate, dict) else composition(candidate)
    lat0, lon0 = float(np.mean(fixes.lat_deg)), float(np.mean(fixes.lon_deg))
    h = np.where(np.isfinite(fixes.height_m), fixes.height_m, 0.0)
    e, n, _ = pymap3d.geodetic2enu(fixes.lat_deg, fixes.lon_deg, h, lat0, lon0, 0.0)
    zs = np.stack([n, e], axis=-1)
    dt = float(np.median(np.diff(fixes.time_s))) if fixes.time_s.size > 1 else 1.0
    nav = _create(comp["nav_filter"], "nav_filter", dt_s=dt)
    if not isinstance(nav, BatchPositionFilter):
        raise ConfigError("nav_filter", f"{nav.name!r} cannot filter a position sequence (not a BatchPositionFilter)")
    res = nav.filter(zs, _create(comp["estimator"], "estimator"),
                     adapter=_create(comp.get("noise_adapter"), "noise_adapter"),
                     augmentation=_create(comp.get("augmentation"), "augmentation", psi=psi))
    out = zs.copy()
    out[res.epochs] = res.mean[..., nav.position_index]
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
