"""The ``sample-receiver`` scenario's per-epoch series and the metric components reducing them.

A receiver run gives fixes at its own epochs (those of the receiver clock) and channel
records at their own rows; `run_series` puts both on the scenario's grid of epochs
``k / rate_hz`` (``k = 0 .. K-1``), one slot per epoch: a fix lands in the slot holding its
sample time, a channel contributes its last row at or before the slot's time. Epochs
without a fix hold NaN in the fix series, which the components below read as "no fix".
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ...receiver.navigation.receive import ReceiveResult, position_errors
from ..metric_components import SeriesMetric
from ..metrics import MetricValue

__all__ = ["run_series", "FiniteRms", "FirstFinite", "FiniteFraction", "Last", "SERIES"]

#: The raw series of one run (name -> unit), each ``(K,)``; the scenario stacks runs on axis 1.
SERIES = {
    "fix_time_s": "s",
    "horizontal_error_m": "m",
    "vertical_error_m": "m",
    "locked_channels": "-",
    "locked_false_channels": "-",
    "cn0_error_db": "dB",
}


def run_series(
    result: ReceiveResult, prns: tuple[int, ...], cn0_dbhz: float, truth_lat_lon_h: tuple, time_s: np.ndarray
) -> dict[str, np.ndarray]:
    """The series of one run on the epochs ``time_s`` (``(K,)``, s from the first sample).

    ``fix_time_s``: the sample time of the fix in the slot ``[t_k, t_k + dt)`` (NaN: none);
    ``horizontal_error_m`` and ``vertical_error_m``: its horizontal distance and signed up
    error from ``truth_lat_lon_h`` (NaN: no fix); ``locked_channels`` and
    ``locked_false_channels``: channels in lock at ``t_k`` of the generated satellites
    ``prns`` and of the others (false detections); ``cn0_error_db``: RMS over the locked
    generated channels of their C/N0 estimate minus ``cn0_dbhz`` (NaN: none locked).
    """
    k = time_s.size
    dt = float(time_s[1] - time_s[0]) if k > 1 else 1.0
    fix_t, horiz, vert = (np.full(k, np.nan) for _ in range(3))
    table = result.positions
    if table is not None and len(table):
        enu = position_errors(table, truth_lat_lon_h)
        slot = np.floor((table.sample_time_s - time_s[0]) / dt + 1e-9).astype(int)
        ok = (slot >= 0) & (slot < k)
        fix_t[slot[ok]] = table.sample_time_s[ok]
        horiz[slot[ok]] = np.hypot(enu[ok, 0], enu[ok, 1])
        vert[slot[ok]] = enu[ok, 2]
    locked, false_locked = np.zeros(k), np.zeros(k)
    sq_sum, n_sq = np.zeros(k), np.zeros(k)
    for prn, ch in result.tracking.channels.items():
        if not ch.rows:
            continue
        row = np.searchsorted(ch.column("time_s"), time_s, side="right") - 1
        lock = np.where(row >= 0, ch.column("lock").astype(bool)[np.maximum(row, 0)], False)
        if prn in prns:
            locked += lock
            err = ch.column("cn0_dbhz").astype(float)[np.maximum(row, 0)] - cn0_dbhz
            sq_sum += np.where(lock, err**2, 0.0)
            n_sq += lock
        else:
            false_locked += lock
    cn0_err = np.full(k, np.nan)
    np.sqrt(sq_sum / np.maximum(n_sq, 1), out=cn0_err, where=n_sq > 0)
    return {
        "fix_time_s": fix_t,
        "horizontal_error_m": horiz,
        "vertical_error_m": vert,
        "locked_channels": locked,
        "locked_false_channels": false_locked,
        "cn0_error_db": cn0_err,
    }


def _per_run(x: np.ndarray, reduce) -> np.ndarray:
    """``reduce`` of each run's finite epochs (NaN for a run without any)."""
    out = np.full(x.shape[1], np.nan)
    for r in range(x.shape[1]):  # runs, not epochs: a handful per batch
        good = x[np.isfinite(x[:, r]), r]
        if good.size:
            out[r] = reduce(good)
    return out


class FiniteRms(SeriesMetric):
    """Root mean square over the epochs where the series is finite (a fix, a locked
    channel); NaN for a run without one. Its series is ``|x_k|``.

    Examples
    --------
    >>> x = np.array([[3.0], [np.nan], [4.0]])
    >>> FiniteRms("e", "m", of="x").compute({"x": x}, None, None).value.round(4).tolist()
    [3.5355]
    """

    series_template = "|{of}|"

    def compute(self, series: dict[str, np.ndarray], time_s: np.ndarray | None, scenario: Any) -> MetricValue:
        x = np.asarray(series[self.of], dtype=float)
        return MetricValue(_per_run(x, lambda g: np.sqrt(np.mean(g**2))), np.abs(x))


class FirstFinite(SeriesMetric):
    """The first finite value of the series over time (the first fix's time); NaN for a
    run without one. Its series is 1 before that epoch and 0 from it on.

    Examples
    --------
    >>> FirstFinite("t", "s", of="x").compute({"x": np.array([[np.nan], [0.7], [0.9]])}, None, None).value.tolist()
    [0.7]
    """

    series_template = "no fix yet (1) or fixed (0)"

    def compute(self, series: dict[str, np.ndarray], time_s: np.ndarray | None, scenario: Any) -> MetricValue:
        x = np.asarray(series[self.of], dtype=float)
        found = np.isfinite(x)
        first = np.where(found.any(axis=0), np.argmax(found, axis=0), x.shape[0])
        value = np.where(first < x.shape[0], x[np.minimum(first, x.shape[0] - 1), np.arange(x.shape[1])], np.nan)
        return MetricValue(value, (np.arange(x.shape[0])[:, None] < first[None, :]).astype(float))


class FiniteFraction(SeriesMetric):
    """Fraction of the epochs where the series is finite (epochs with a fix). Its series
    is that indicator.

    Examples
    --------
    >>> FiniteFraction("f", "-", of="x").compute({"x": np.array([[np.nan], [1.0], [2.0], [np.nan]])}, None,
    ...                                         None).value.tolist()
    [0.5]
    """

    series_template = "fix (1) or none (0)"

    def compute(self, series: dict[str, np.ndarray], time_s: np.ndarray | None, scenario: Any) -> MetricValue:
        ok = np.isfinite(np.asarray(series[self.of], dtype=float))
        return MetricValue(ok.mean(axis=0), ok.astype(float))


class Last(SeriesMetric):
    """The series' value at the last epoch (channels in lock at the end of the run). Its
    series is the series itself.

    Examples
    --------
    >>> Last("n", "-", of="x").compute({"x": np.array([[4.0, 5.0], [6.0, 3.0]])}, None, None).value.tolist()
    [6.0, 3.0]
    """

    def compute(self, series: dict[str, np.ndarray], time_s: np.ndarray | None, scenario: Any) -> MetricValue:
        x = np.asarray(series[self.of], dtype=float)
        return MetricValue(x[-1].copy(), x)
