"""GPS constellation geometry: satellite position, velocity and acceleration in ECEF.

The nominal constellation is the baseline 24-slot one shipped as
``gnssframework/data/gps_nominal_24.csv``: circular orbits of radius 26 559.7 km at
55 deg inclination. Positions are computed analytically in the Earth-fixed frame,
including Earth rotation, so velocities and accelerations are exact for the model.
"""

from __future__ import annotations

import abc

from dataclasses import dataclass
from importlib import resources

import numpy as np
import pymap3d

from .. import random_streams as draw
from ..errors import ConfigError, DataFileError
from ..io.text import read_input_text

__all__ = [
    "SatelliteSet",
    "Constellation",
    "nominal_constellation",
    "load_almanac",
    "draw_epochs",
    "GM_EARTH",
    "OMEGA_EARTH",
]

GM_EARTH = 3.986005e14  # m^3/s^2, WGS 84 value of IS-GPS-200
OMEGA_EARTH = 7.2921151467e-5  # rad/s
NOMINAL_RADIUS_M = 26_559_700.0
NOMINAL_INCLINATION_DEG = 55.0


class SatelliteSet(abc.ABC):
    """What the scenarios need of satellites: ``prn``, ``subset``, ``state`` (ECEF position,
    velocity, acceleration at times t), and from these elevation and visibility."""

    prn: np.ndarray

    @abc.abstractmethod
    def state(self, t_s) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """ECEF position, velocity and acceleration, shape ``(*t.shape, *S, 3)``."""

    @abc.abstractmethod
    def subset(self, index: np.ndarray) -> SatelliteSet:
        """The satellites at ``index``."""

    def elevation_deg(self, t_s: float, lat_deg: float, lon_deg: float, height_m: float) -> np.ndarray:
        """Elevation of every satellite seen from a geodetic position (pymap3d)."""
        pos, _, _ = self.state(t_s)
        _, el, _ = pymap3d.ecef2aer(pos[..., 0], pos[..., 1], pos[..., 2], lat_deg, lon_deg, height_m)
        return np.asarray(el)

    def visible(
        self, t_s: float, lat_deg: float, lon_deg: float, height_m: float, mask_deg: float, channels: int
    ) -> np.ndarray:
        """Indices of the ``channels`` highest satellites above ``mask_deg`` at ``t_s``.

        Raises
        ------
        ConfigError
            When fewer than ``channels`` satellites are above the mask.
        """
        el = self.elevation_deg(t_s, lat_deg, lon_deg, height_m)
        order = np.argsort(-el)
        above = order[el[order] > mask_deg]
        if above.size < channels:
            raise ConfigError(
                "scenario.channels",
                f"only {above.size} satellites are above the {mask_deg} deg "
                f"mask at this place and time; ask for at most {above.size} channels",
            )
        return above[:channels]


@dataclass(frozen=True)
class Constellation(SatelliteSet):
    """Circular-orbit satellites; arrays over satellites.

    Attributes
    ----------
    prn
        ``(S,)`` PRN numbers.
    raan_rad
        Earth-fixed longitude of the ascending node at t = 0.
    arg_lat_rad
        Argument of latitude at t = 0.
    radius_m, inclination_rad
        Orbit radius and inclination (shared).
    """

    prn: np.ndarray
    raan_rad: np.ndarray
    arg_lat_rad: np.ndarray
    radius_m: float = NOMINAL_RADIUS_M
    inclination_rad: float = np.radians(NOMINAL_INCLINATION_DEG)

    @property
    def mean_motion_rad_s(self) -> float:
        return float(np.sqrt(GM_EARTH / self.radius_m**3))

    def subset(self, index: np.ndarray) -> Constellation:
        """The satellites at ``index`` (any integer array shape)."""
        return Constellation(
            self.prn[index], self.raan_rad[index], self.arg_lat_rad[index], self.radius_m, self.inclination_rad
        )

    def state(self, t_s: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """ECEF position (m), velocity (m/s) and acceleration (m/s^2), shape ``(*t.shape, *S, 3)``.

        In the orbital plane $r = R[\\cos u, \\sin u, 0]$ with $u = u_0 + n t$; the
        plane is rotated by the inclination and by the node longitude
        $\\Omega_0 - \\omega_E t$. Velocity and acceleration are the exact time
        derivatives of that rotating-frame position.
        """
        return self.state_at(np.asarray(t_s, dtype=float)[(...,) + (None,) * self.prn.ndim])

    def state_at(self, t_s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """As `state`, with ``t_s`` already broadcastable against the satellite arrays
        (e.g. ``(*t.shape, runs, 1)`` for satellites ``(runs, ch)`` whose runs each have
        their own epoch): shape ``broadcast(t_s, prn) + (3,)``."""
        t = np.asarray(t_s, dtype=float)
        n, w, R, i = self.mean_motion_rad_s, OMEGA_EARTH, self.radius_m, self.inclination_rad
        u = self.arg_lat_rad + n * t
        lon = self.raan_rad - w * t
        cu, su, cl, sl = np.cos(u), np.sin(u), np.cos(lon), np.sin(lon)
        # Node frame: q = R [cos u, sin u cos i, sin u sin i]; ECEF: p = Rz(lon) q.
        q = R * np.stack([cu, su * np.cos(i), su * np.sin(i)], -1)
        dq = n * R * np.stack([-su, cu * np.cos(i), cu * np.sin(i)], -1)
        ddq = -n * n * q

        def rot(v):  # Rz(lon) v
            return np.stack([cl * v[..., 0] - sl * v[..., 1], sl * v[..., 0] + cl * v[..., 1], v[..., 2]], -1)

        def J(v):  # d Rz / d lon = J Rz, J v = [-v_y, v_x, 0]
            return np.stack([-v[..., 1], v[..., 0], np.zeros_like(v[..., 2])], -1)

        p, dp_rot, ddp_rot = rot(q), rot(dq), rot(ddq)
        # lon' = -w: p' = Rz q' - w J Rz q;  p'' = Rz q'' - 2 w J Rz q' + w^2 J J Rz q.
        v = dp_rot - w * J(p)
        a = ddp_rot - 2 * w * J(dp_rot) + w * w * J(J(p))
        return p, v, a


def draw_epochs(
    sats: Constellation,
    rng,
    runs: int,
    lat_deg: float,
    lon_deg: float,
    height_m: float,
    mask_deg: float,
    channels: int,
    tries: int = 64,
) -> tuple[np.ndarray, np.ndarray]:
    """Each run's start epoch, uniform over the constellation's repeat period, and its satellites.

    The circular-orbit constellation's geometry seen from the ground repeats every
    sidereal day, 2 pi / omega_E = 86 164.1 s (two orbits of 11 h 58 min), so an epoch
    uniform on that day is a geometry drawn uniformly over the day. Run r draws ``tries``
    candidate epochs from its own stream (``draw.uniform`` with the runs on axis 0) and
    keeps the first at which ``channels`` satellites are above ``mask_deg``: the epoch is
    uniform over the instants with enough satellites, and run r's epoch does not depend
    on its batch.

    Returns
    -------
    epochs_s ``(runs,)`` and satellite indices ``(runs, channels)`` (highest first).

    Raises
    ------
    ConfigError
        ``scenario.channels`` when some run found no epoch with enough satellites.
    """
    day_s = 2 * np.pi / OMEGA_EARTH
    cand = draw.uniform(rng, 0.0, day_s, (runs, tries), 0)
    pos, _, _ = sats.state(cand)  # (runs, tries, S, 3)
    _, el, _ = pymap3d.ecef2aer(pos[..., 0], pos[..., 1], pos[..., 2], lat_deg, lon_deg, height_m)
    el = np.asarray(el)
    enough = np.sum(el > mask_deg, axis=-1) >= channels  # (runs, tries)
    if not np.all(enough.any(axis=1)):
        raise ConfigError(
            "scenario.channels",
            f"no epoch of {tries} drawn has {channels} satellites above the "
            f"{mask_deg} deg mask here; ask for fewer channels",
        )
    first = np.argmax(enough, axis=1)
    rows = np.arange(runs)
    order = np.argsort(-el[rows, first], axis=-1)
    return cand[rows, first], order[:, :channels]


def load_almanac(path) -> Constellation:
    """Read a circular-orbit almanac CSV (columns ``prn, raan_deg, arg_lat_deg``; ``#`` comments).

    Raises
    ------
    DataFileError
        Naming the file and line of a missing column or a bad number.
    """
    rows = []
    text = read_input_text(path)
    lines = [(no, line) for no, line in enumerate(text.splitlines(), 1) if line.strip() and not line.startswith("#")]
    if not lines:
        raise DataFileError(str(path), None, "no almanac rows")
    header = [h.strip() for h in lines[0][1].strip().split(",")]
    missing = {"prn", "raan_deg", "arg_lat_deg"} - set(header)
    if missing:
        raise DataFileError(str(path), lines[0][0], f"header lacks {', '.join(sorted(missing))}")
    for no, line in lines[1:]:
        row = dict(zip(header, (c.strip() for c in line.strip().split(","))))
        try:
            rows.append((int(row["prn"]), float(row["raan_deg"]), float(row["arg_lat_deg"])))
        except (KeyError, TypeError, ValueError) as exc:
            raise DataFileError(str(path), no, f"bad almanac row {line.strip()!r}: {exc}") from None
    prn, raan, u = map(np.array, zip(*rows))
    return Constellation(prn, np.radians(raan), np.radians(u))


def nominal_constellation() -> Constellation:
    """The shipped baseline 24-slot constellation."""
    with resources.as_file(resources.files("gnssframework") / "data" / "gps_nominal_24.csv") as path:
        return load_almanac(path)
