"""Filter or smooth a logged position track: NMEA in, CSV out (``gnssframework
filter-positions``, ``gnssframework smooth-positions``)."""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pymap3d

from .. import registry
from ..errors import ConfigError
from ..interfaces import BatchPositionFilter
from .nmea import NmeaFixes

__all__ = [
    "CANDIDATES",
    "SmoothedTrack",
    "composition",
    "filter_positions",
    "smooth_positions",
    "write_positions_csv",
    "write_smoothed_positions_csv",
]

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
    "AUKF1": {
        "nav_filter": {"name": "position-ca", "params": {}},
        "estimator": _UKF,
        "augmentation": _COLORED,
        "noise_adapter": _SAGE_HUSA,
    },
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
        raise ConfigError(
            "filter_name",
            f"unknown {filter_name!r}: a paper label ({', '.join(CANDIDATES)}) or "
            f"an estimator ({', '.join(registry.names('estimator'))})"
            f"{did_you_mean(filter_name, options)}",
        )
    for kind, name in (("noise_adapter", noise_adapter), ("augmentation", augmentation)):
        if name is None:
            continue
        if name not in registry.names(kind):
            raise ConfigError(
                kind,
                f"unknown {kind} {name!r}; registered: {', '.join(registry.names(kind))}"
                f"{did_you_mean(name, registry.names(kind))}",
            )
        comp[kind] = {"name": name, "params": {}}
    return comp


def _create(ref: dict | None, kind: str, **given: Any) -> Any:
    """The plugin of a composition's ``{name, params}`` (``None`` for none), with ``given`` parameters."""
    return None if ref is None else registry.create(kind, ref["name"], **{**ref["params"], **given})


def _local_track(fixes: NmeaFixes) -> tuple[np.ndarray, float, float]:
    """North/east metres ``(K, 2)`` about the mean fix (pymap3d), and that origin."""
    lat0, lon0 = float(np.mean(fixes.lat_deg)), float(np.mean(fixes.lon_deg))
    h = np.where(np.isfinite(fixes.height_m), fixes.height_m, 0.0)
    e, n, _ = pymap3d.geodetic2enu(fixes.lat_deg, fixes.lon_deg, h, lat0, lon0, 0.0)
    return np.stack([n, e], axis=-1), lat0, lon0


def _run(fixes: NmeaFixes, candidate: str | dict, psi: float, zs: np.ndarray, **policies: Any):
    """The composition's nav filter run over ``zs`` (north, east per epoch); ``(nav, result)``."""
    comp = candidate if isinstance(candidate, dict) else composition(candidate)
    dt = float(np.median(np.diff(fixes.time_s))) if fixes.time_s.size > 1 else 1.0
    nav = _create(comp["nav_filter"], "nav_filter", dt_s=dt)
    if not isinstance(nav, BatchPositionFilter):
        raise ConfigError("nav_filter", f"{nav.name!r} cannot filter a position sequence (not a BatchPositionFilter)")
    res = nav.filter(
        zs,
        _create(comp["estimator"], "estimator"),
        adapter=_create(comp.get("noise_adapter"), "noise_adapter"),
        augmentation=_create(comp.get("augmentation"), "augmentation", psi=psi),
        **policies,
    )
    return nav, res


def filter_positions(
    fixes: NmeaFixes, candidate: str | dict = "AUKF1", psi: float = 0.95
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
    zs, lat0, lon0 = _local_track(fixes)
    nav, res = _run(fixes, candidate, psi, zs)
    out = zs.copy()
    out[res.epochs] = res.mean[..., nav.position_index]
    lat, lon, _ = pymap3d.enu2geodetic(out[:, 1], out[:, 0], 0.0, lat0, lon0, 0.0)
    return np.asarray(lat), np.asarray(lon), out[:, 0], out[:, 1]


@dataclass
class SmoothedTrack:
    """`smooth_positions`'s output, one row per fix.

    Attributes
    ----------
    lat_deg, lon_deg, north_m, east_m
        The smoothed track (geodetic, and local metres about ``origin``).
    filtered_north_m, filtered_east_m
        The forward filter's track, the pass the smoother started from.
    var_north_m2, var_east_m2, filtered_var_north_m2, filtered_var_east_m2
        The position variances (smoothed; filtered) of each coordinate; the coordinates
        are filtered independently, so the north-east covariance is zero. NaN where a
        fix has no estimate (the last epoch under ``colored-ar1``).
    origin
        ``(lat_deg, lon_deg)`` of the local frame (the mean fix).
    """

    lat_deg: np.ndarray
    lon_deg: np.ndarray
    north_m: np.ndarray
    east_m: np.ndarray
    filtered_north_m: np.ndarray
    filtered_east_m: np.ndarray
    var_north_m2: np.ndarray
    var_east_m2: np.ndarray
    filtered_var_north_m2: np.ndarray
    filtered_var_east_m2: np.ndarray
    origin: tuple[float, float]


def smooth_positions(fixes: NmeaFixes, candidate: str | dict = "UKF", psi: float = 0.95) -> SmoothedTrack:
    r"""Forward-backward smoothing of the horizontal track of ``fixes``.

    The composition's nav filter (as `filter_positions`) runs forward with
    ``store="smoother"``, then the fixed-interval RTS pass
    (`gnssframework.estimation.smooth`) gives each position given the whole log, with its
    variance. A noise adapter's per-step Q and R enter the backward pass as the forward
    pass used them. Epochs without an estimate keep their raw value (NaN variance).
    """
    from ..estimation import smooth

    zs, lat0, lon0 = _local_track(fixes)
    nav, res = _run(fixes, candidate, psi, zs, store="smoother")
    sm = smooth(res)
    i = nav.position_index
    K = zs.shape[0]

    def place(values: np.ndarray, fill: np.ndarray) -> np.ndarray:
        out = fill.copy()
        out[res.epochs] = values
        return out

    nan = np.full((K, 2), np.nan)
    pos, fpos = place(sm.mean[..., i], zs), place(res.mean[..., i], zs)
    var, fvar = place(sm.cov[..., i, i], nan), place(res.cov[..., i, i], nan)
    lat, lon, _ = pymap3d.enu2geodetic(pos[:, 1], pos[:, 0], 0.0, lat0, lon0, 0.0)
    return SmoothedTrack(
        np.asarray(lat),
        np.asarray(lon),
        pos[:, 0],
        pos[:, 1],
        fpos[:, 0],
        fpos[:, 1],
        var[:, 0],
        var[:, 1],
        fvar[:, 0],
        fvar[:, 1],
        (lat0, lon0),
    )


def write_positions_csv(path: str | Path, fixes: NmeaFixes, lat: np.ndarray, lon: np.ndarray) -> None:
    """CSV with time, line, raw and filtered latitude/longitude (written atomically)."""
    from .files import atomic_open

    with atomic_open(path, "w", newline="") as fh:  # a killed run leaves no half CSV
        w = csv.writer(fh)
        w.writerow(["time_s", "nmea_line", "lat_deg", "lon_deg", "filtered_lat_deg", "filtered_lon_deg"])
        for row in zip(fixes.time_s, fixes.line, fixes.lat_deg, fixes.lon_deg, lat, lon):
            w.writerow(
                [f"{row[0]:.3f}", int(row[1]), f"{row[2]:.9f}", f"{row[3]:.9f}", f"{row[4]:.9f}", f"{row[5]:.9f}"]
            )


def write_smoothed_positions_csv(path: str | Path, fixes: NmeaFixes, track: SmoothedTrack) -> None:
    """CSV with time, line, raw and smoothed latitude/longitude, the smoothed and filtered
    north/east positions (m, about the mean fix) and their variances (m²), atomically."""
    from .files import atomic_open

    def cell(v: float, digits: int) -> str:
        return f"{v:.{digits}f}" if np.isfinite(v) else ""

    with atomic_open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(
            [
                "time_s",
                "nmea_line",
                "lat_deg",
                "lon_deg",
                "smoothed_lat_deg",
                "smoothed_lon_deg",
                "smoothed_north_m",
                "smoothed_east_m",
                "smoothed_var_north_m2",
                "smoothed_var_east_m2",
                "filtered_north_m",
                "filtered_east_m",
                "filtered_var_north_m2",
                "filtered_var_east_m2",
            ]
        )
        for k in range(fixes.time_s.size):
            w.writerow(
                [
                    f"{fixes.time_s[k]:.3f}",
                    int(fixes.line[k]),
                    f"{fixes.lat_deg[k]:.9f}",
                    f"{fixes.lon_deg[k]:.9f}",
                    f"{track.lat_deg[k]:.9f}",
                    f"{track.lon_deg[k]:.9f}",
                    cell(track.north_m[k], 4),
                    cell(track.east_m[k], 4),
                    cell(track.var_north_m2[k], 6),
                    cell(track.var_east_m2[k], 6),
                    cell(track.filtered_north_m[k], 4),
                    cell(track.filtered_east_m[k], 4),
                    cell(track.filtered_var_north_m2[k], 6),
                    cell(track.filtered_var_east_m2[k], 6),
                ]
            )
