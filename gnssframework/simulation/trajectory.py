"""Receiver trajectories: static, constant velocity, a figure-eight vehicle track, or
tabulated (ECEF or geodetic CSV)."""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pymap3d

from ..errors import DataFileError
from ..io.text import read_input_text

__all__ = ["Trajectory", "FigureEight", "load_trajectory"]


@dataclass(frozen=True)
class Trajectory:
    """ECEF positions at tabulated times; position and velocity anywhere between.

    Position is a cubic Hermite interpolation whose node velocities are the tabulated
    ones (or centred differences of the positions), so position and velocity are
    consistent to the interpolation order.
    """

    time_s: np.ndarray  # (N,)
    position_m: np.ndarray  # (N, 3)
    velocity_m_s: np.ndarray  # (N, 3)

    def state(self, t_s: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        """ECEF position and velocity at ``t_s``, shape ``(*t.shape, 3)`` (clamped to the table)."""
        t = np.clip(np.asarray(t_s, dtype=float), self.time_s[0], self.time_s[-1])
        i = np.clip(np.searchsorted(self.time_s, t, side="right") - 1, 0, self.time_s.size - 2)
        t0, t1 = self.time_s[i], self.time_s[i + 1]
        h = (t1 - t0)[..., None]
        s = ((t - t0) / (t1 - t0))[..., None]
        p0, p1 = self.position_m[i], self.position_m[i + 1]
        m0, m1 = self.velocity_m_s[i] * h, self.velocity_m_s[i + 1] * h
        h00, h10, h01, h11 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2
        pos = h00 * p0 + h10 * m0 + h01 * p1 + h11 * m1
        dh00, dh10, dh01, dh11 = 6 * s**2 - 6 * s, 3 * s**2 - 4 * s + 1, -6 * s**2 + 6 * s, 3 * s**2 - 2 * s
        vel = (dh00 * p0 + dh10 * m0 + dh01 * p1 + dh11 * m1) / h
        return pos, vel


@dataclass(frozen=True)
class FigureEight:
    r"""A vehicle driving a figure-eight in the local horizontal plane: the lemniscate of
    Gerono, one lap every ``lap_s`` seconds,

    $$
    e(t) = A \sin \omega t, \qquad n(t) = \tfrac{A}{2} \sin 2 \omega t, \qquad
    u(t) = 0, \qquad \omega = 2 \pi / T_{lap},
    $$

    with ``A = half_length_m``. It starts at the crossing heading north-east, turns right
    round the east lobe, then left round the west one (each lobe half a lap), and its
    speed and heading change all the time: speed
    $A\omega (\cos^2\omega t + \cos^2 2\omega t)^{1/2}$, from
    $\tfrac{\sqrt 7}{4} A\omega$ to $\sqrt{2} A\omega$ (at the crossing), acceleration
    $A\omega^2 (\sin^2\omega t + 4 \sin^2 2\omega t)^{1/2}$, at most $\tfrac{17}{8} A \omega^2$.
    The defaults of the vector-tracking scenario (A = 25 m, 20 s) give 5.2-11.1 m/s and up
    to 5.2 m/s² (0.53 g), a car on a 50 m by 25 m figure-eight.
    """

    half_length_m: float
    lap_s: float

    def enu(self, t_s: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """East/north/up position (m), velocity (m/s) and acceleration (m/s²) from the
        start, each ``(*t.shape, 3)``: the closed form above and its derivatives."""
        t = np.asarray(t_s, dtype=float)
        a, w = self.half_length_m, 2 * np.pi / self.lap_s
        s1, c1, s2, c2 = np.sin(w * t), np.cos(w * t), np.sin(2 * w * t), np.cos(2 * w * t)
        zero = np.zeros_like(t)
        pos = np.stack([a * s1, a / 2 * s2, zero], axis=-1)
        vel = np.stack([a * w * c1, a * w * c2, zero], axis=-1)
        acc = np.stack([-a * w**2 * s1, -2 * a * w**2 * s2, zero], axis=-1)
        return pos, vel, acc


def load_trajectory(path: str | Path) -> Trajectory:
    """Read a trajectory CSV: ``t_s`` and either ``x_m, y_m, z_m`` (ECEF) or
    ``lat_deg, lon_deg, height_m`` (WGS 84, converted with pymap3d); optional velocity
    columns ``vx_m_s, vy_m_s, vz_m_s`` (ECEF).

    Raises
    ------
    DataFileError
        Naming the file and line of a missing column, a bad number or a time that does
        not increase.
    """
    path = Path(path)
    lines = read_input_text(path).splitlines()
    rows = [(no, line) for no, line in enumerate(lines, 1) if line.strip() and not line.startswith("#")]
    if len(rows) < 3:
        raise DataFileError(str(path), None, "needs a header and at least two rows")
    header = [h.strip() for h in next(csv.reader([rows[0][1]]))]
    if {"x_m", "y_m", "z_m"} <= set(header):
        cols = ("x_m", "y_m", "z_m")
    elif {"lat_deg", "lon_deg", "height_m"} <= set(header):
        cols = ("lat_deg", "lon_deg", "height_m")
    else:
        raise DataFileError(str(path), rows[0][0], "header needs t_s and x_m,y_m,z_m or lat_deg,lon_deg,height_m")
    if "t_s" not in header:
        raise DataFileError(str(path), rows[0][0], "header lacks t_s")
    vel_cols = ("vx_m_s", "vy_m_s", "vz_m_s")
    has_vel = set(vel_cols) <= set(header)
    data: list[tuple[list[float], int]] = []  # (values, line number)
    for no, line in rows[1:]:
        rec = dict(zip(header, (c.strip() for c in next(csv.reader([line])))))
        try:
            vals = [float(rec["t_s"])] + [float(rec[c]) for c in cols]
            vals += [float(rec[c]) for c in vel_cols] if has_vel else []
        except (KeyError, ValueError) as exc:
            raise DataFileError(str(path), no, f"bad row {line.strip()!r}: {exc}") from None
        if data and vals[0] <= data[-1][0][0]:
            raise DataFileError(str(path), no, f"time {vals[0]} does not increase")
        data.append((vals, no))
    table = np.array([v for v, _ in data])
    t = table[:, 0]
    if cols[0] == "x_m":
        pos = table[:, 1:4]
    else:
        pos = np.stack(pymap3d.geodetic2ecef(table[:, 1], table[:, 2], table[:, 3]), axis=-1)
    vel = table[:, 4:7] if has_vel else np.gradient(pos, t, axis=0)
    return Trajectory(t, pos, vel)
