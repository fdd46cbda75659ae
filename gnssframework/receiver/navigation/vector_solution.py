"""What vector tracking on samples produced: the navigation filter's states after the hand-over."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pymap3d

from ...navigation.geometry import line_of_sight
from ...navigation.pvt import dop
from ...signal.gps_l1ca import GPS_L1CA
from ...signal.spec import SignalSpec
from .fixes import PositionTable
from .observables import SPEED_OF_LIGHT_MPS

__all__ = ["VectorSolution"]

_C = SPEED_OF_LIGHT_MPS


@dataclass
class VectorSolution:
    """The navigation filter's states, one per nav epoch after the hand-over.

    ``sample_time_s`` ``(K,)`` recording time of each epoch; ``state`` ``(K, 8)``
    ``[x, y, z, vx, vy, vz, b, d]`` (ECEF m, m/s; clock in m and m/s, against the
    receiver time ``sample_time_s + rx_offset_s``); ``cov`` ``(K, 8, 8)`` its covariance;
    ``prns`` the vector channels (those that joined later included); ``used``
    ``(K, slots)`` whether the output of the channel at each tracker slot (the PRN
    ``slot_prns[slot]``) entered the update; ``used_sat_pos_m`` ``(K,)`` of ``(n, 3)``:
    the positions of those satellites (the table's HDOP and VDOP come from them, for its
    rows only); ``monitor_excluded`` ``(K, slots)`` the channels the channel fault monitor
    left out of the update (empty without a monitor); ``handover_s`` the recording time of the hand-over fix; ``events`` what
    happened (``(time_s, text)``).
    """

    prns: tuple[int, ...] = ()
    handover_s: float | None = None
    rx_offset_s: float = 0.0
    week: int = -1
    sample_time_s: list[float] = field(default_factory=list)
    state: list[np.ndarray] = field(default_factory=list)
    cov: list[np.ndarray] = field(default_factory=list)
    used: list[np.ndarray] = field(default_factory=list)
    used_sat_pos_m: list[np.ndarray] = field(default_factory=list)
    monitor_excluded: list[np.ndarray] = field(default_factory=list)
    events: list[tuple[float, str]] = field(default_factory=list)
    #: Per vector channel's PRN at the end of the run: the recording time of its next
    #: interval's start and its replica's transmit time there (s of week, SV time).
    replica_tx: dict[int, tuple[float, float]] = field(default_factory=dict)
    #: The signal tracked: its PRN list is the PRN of each tracker slot (`slot_prns`).
    signal: SignalSpec = GPS_L1CA

    @property
    def slot_prns(self) -> tuple[int, ...]:
        """The PRN of each tracker slot (``signal.prns``; `used`'s columns)."""
        return self.signal.prns

    def table(self, rate_hz: float = 1.0, integrity_risk: float | None = None) -> PositionTable | None:
        """The epochs nearest whole multiples of ``1 / rate_hz`` of recording time as a
        position table (the columns of `fixes.POSITION_COLUMNS`; DOPs of the vector channels), or None
        before any epoch.

        With ``integrity_risk`` the rows also carry `fixes.INTEGRITY_COLUMNS`: the
        protection levels of the navigation filter's position covariance rotated to east,
        north, up at the estimate (`integrity.covariance_protection_levels`: fault-free
        levels, as honest as that covariance), and ``raim`` ``excluded`` where the channel
        monitor left a channel out of that epoch's update (its PRN, the lowest if several,
        in ``excluded_prn``), ``ok`` otherwise, ``unavailable`` without a finite covariance.
        """
        if not self.sample_time_s:
            return None
        t = np.asarray(self.sample_time_s)
        x = np.asarray(self.state)
        grid = np.arange(np.ceil(t[0] * rate_hz), np.floor(t[-1] * rate_hz) + 1) / rate_hz
        k = np.unique(np.clip(np.searchsorted(t, grid), 0, t.size - 1))
        x, t = x[k], t[k]
        lat, lon, h = (np.asarray(v, float) for v in pymap3d.ecef2geodetic(x[:, 0], x[:, 1], x[:, 2]))
        ve, vn, vu = (np.asarray(v, float) for v in pymap3d.ecef2enuv(x[:, 3], x[:, 4], x[:, 5], lat, lon))
        n_used = np.asarray(self.used)[k].sum(axis=1)  # (rows over the PRN slots)
        dops = np.array([_dops(self.used_sat_pos_m[j], x[i, :3]) for i, j in enumerate(k)]).reshape(-1, 2)
        columns = {
            "gps_week": np.full(k.size, self.week),
            "tow_s": t + self.rx_offset_s - x[:, 6] / _C,
            "lat_deg": lat,
            "lon_deg": lon,
            "height_m": h,
            "vel_e_mps": ve,
            "vel_n_mps": vn,
            "vel_u_mps": vu,
            "clock_bias_m": x[:, 6],
            "n_sats": n_used.astype(int),
            "hdop": dops[:, 0],
            "vdop": dops[:, 1],
        }
        used = [tuple(self.slot_prns[int(i)] for i in np.flatnonzero(row)) for row in np.asarray(self.used)[k]]
        excluded_prn = np.zeros(k.size, int)
        if self.monitor_excluded:
            out = np.asarray(self.monitor_excluded)[k]
            prns = np.asarray(self.slot_prns)
            excluded_prn = np.where(out.any(axis=1), np.min(np.where(out, prns, np.iinfo(int).max), axis=1), 0)
        if integrity_risk is not None:
            columns.update(
                self._integrity(x, np.asarray(self.cov)[k][:, :3, :3], lat, lon, integrity_risk, excluded_prn)
            )
        return PositionTable(columns, x[:, :3].copy(), t, used, excluded_prn)

    @staticmethod
    def _integrity(
        x: np.ndarray,
        cov_ecef: np.ndarray,
        lat_deg: np.ndarray,
        lon_deg: np.ndarray,
        integrity_risk: float,
        excluded_prn: np.ndarray,
    ) -> dict[str, np.ndarray]:
        """`fixes.INTEGRITY_COLUMNS` of rows with states ``x`` and position covariances
        ``cov_ecef`` ``(rows, 3, 3)`` at ``lat_deg``, ``lon_deg`` (see `table`)."""
        from ...navigation.integrity import covariance_protection_levels

        lat, lon = np.radians(lat_deg), np.radians(lon_deg)
        sl, cl, so, co = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
        R = np.stack(
            [
                np.stack([-so, co, np.zeros_like(lat)], -1),
                np.stack([-sl * co, -sl * so, cl], -1),
                np.stack([cl * co, cl * so, sl], -1),
            ],
            -2,
        )  # rows east, north, up
        finite = np.all(np.isfinite(cov_ecef), axis=(-1, -2))
        C = R @ np.where(finite[:, None, None], cov_ecef, 0.0) @ np.swapaxes(R, -1, -2)
        hpl, vpl = covariance_protection_levels(C, integrity_risk)
        status = np.where(~finite, "unavailable", np.where(excluded_prn > 0, "excluded", "ok"))
        return {
            "hpl_m": np.where(finite, hpl, np.inf),
            "vpl_m": np.where(finite, vpl, np.inf),
            "raim": status.astype("<U11"),
        }


def _dops(sat_pos: np.ndarray, r: np.ndarray) -> tuple[float, float]:
    """HDOP and VDOP of satellites ``sat_pos`` seen from ``r`` (NaN with fewer than four)."""
    if sat_pos.shape[0] < 4:
        return np.nan, np.nan
    _, e = line_of_sight(sat_pos, r)
    lat, lon, _ = pymap3d.ecef2geodetic(*r)
    east, north, up = pymap3d.ecef2enuv(e[:, 0], e[:, 1], e[:, 2], lat, lon)
    _, _, hdop, vdop = dop(np.stack([east, north, up], axis=-1))
    return hdop, vdop
