"""A scenario's own metrics as components: declared once, computed once.

A scenario lists its metrics as `Metric` components (the same interface an outside
package's ``metric`` plugin has) that each reduce one named per-epoch series of the run
over time; ``run_batch`` hands the raw series to `evaluate`, which computes every
component once and returns the `BatchResult`. The metric's name, unit and series are
then written in one place, the component, and the scenario's ``metrics`` table is
derived from the list with `units`::

    METRICS = (Rmse("lat_error_rmse", "m", of="lat_error_m"),
               ConvergenceEpoch("convergence_epoch", of="horizontal_error_m", window="convergence_window"))

    class MyScenario(Scenario):
        metrics = units(METRICS)
        outputs = {"lat_error_m": "m", "horizontal_error_m": "m"}

        def run_batch(self, case, plugins, runs, rng):
            ...
            return evaluate(METRICS, {"lat_error_m": lat, "horizontal_error_m": h}, time_s, self)

Each metric's series (stored beside its value and plotted by the report) is what it
reduces: ``|e_k|`` for an RMSE or a mean absolute error, and for `ConvergenceEpoch` 1
while the run has not yet converged.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from .metrics import Metric, MetricValue, rmse, settled

__all__ = ["SeriesMetric", "Rmse", "MeanAbs", "ConvergenceEpoch", "convergence_epoch", "evaluate", "units"]


def _magnitude(x: np.ndarray) -> np.ndarray:
    """``|x|`` of a ``(K, runs)`` series; the Euclidean norm of a ``(K, runs, d)`` one."""
    x = np.asarray(x, dtype=float)
    return np.abs(x) if x.ndim <= 2 else np.sqrt(np.sum(x**2, axis=tuple(range(2, x.ndim))))


def _scenario_value(value: Any, scenario: Any, what: str) -> Any:
    """``value``, or the scenario parameter it names (a string)."""
    if not isinstance(value, str):
        return value
    try:
        return getattr(scenario.params, value)
    except AttributeError:
        raise AttributeError(f"{what}: scenario {getattr(scenario, 'kind', '?')!r} has no parameter {value!r}") \
            from None


class SeriesMetric(Metric):
    """A metric that reduces one per-epoch series ``of`` of the scenario over time.

    Parameters
    ----------
    name
        The metric's name in configs, reports and ``summary.json``.
    unit
        Its unit.
    of
        The name of the series it reads, ``(K, runs)`` or ``(K, runs, d)``.
    settle
        Optional: epochs before this time (seconds; or the name of the scenario parameter
        holding it, e.g. ``"settle_s"``) are left out of the value.
    description
        One line for the docs.
    """

    def __init__(self, name: str, unit: str, of: str, *, settle: float | str | None = None,
                 description: str = "") -> None:
        super().__init__()
        self.name = name
        self.unit = unit
        self.of = of
        self.settle = settle
        self.description = description
        self.requires = (of,)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r}, {self.unit!r}, of={self.of!r})"

    def _mask(self, k: int, time_s: np.ndarray | None, scenario: Any) -> np.ndarray | None:
        if self.settle is None:
            return None
        return settled(time_s, float(_scenario_value(self.settle, scenario, self.name)), k)


class Rmse(SeriesMetric):
    """Root mean square over time of the series (its norm per epoch for a vector error).

    Examples
    --------
    >>> m = Rmse("e_rmse", "m", of="e")
    >>> m.compute({"e": np.array([[3.0, 1.0], [4.0, 1.0]])}, None, None).value.round(4).tolist()
    [3.5355, 1.0]
    """

    def compute(self, series: dict[str, np.ndarray], time_s: np.ndarray | None, scenario: Any) -> MetricValue:
        x = np.asarray(series[self.of], dtype=float)
        return MetricValue(rmse(x, self._mask(x.shape[0], time_s, scenario)), _magnitude(x))


class MeanAbs(SeriesMetric):
    """Mean over time of the absolute error (its norm per epoch for a vector error).

    Examples
    --------
    >>> MeanAbs("e_mean", "m", of="e").compute({"e": np.array([[3.0], [-5.0]])}, None, None).value.tolist()
    [4.0]
    """

    def compute(self, series: dict[str, np.ndarray], time_s: np.ndarray | None, scenario: Any) -> MetricValue:
        x = np.asarray(series[self.of], dtype=float)
        mag = _magnitude(x)
        mask = self._mask(x.shape[0], time_s, scenario)
        return MetricValue(np.mean(mag if mask is None else mag[mask], axis=0), mag)


def convergence_epoch(err: np.ndarray, window: int, factor: float = 2.0) -> np.ndarray:
    """First epoch after which the running RMS error (the last ``window`` epochs) stays below
    ``factor`` times the RMS error of the second half of the run.

    ``err`` is ``(K, runs)``; returns ``(runs,)`` (0 for a run that is converged from the
    start). A run that never settles returns K.
    """
    err = np.asarray(err, dtype=float)
    K = err.shape[0]
    # Trailing sum of the last `window` squared errors (fewer at the start), over all runs at once.
    cs = np.cumsum(err**2, axis=0)
    lagged = np.concatenate([np.zeros((min(window, K),) + err.shape[1:]), cs[: max(K - window, 0)]], axis=0)
    running = np.sqrt((cs - lagged) / window)
    bound = factor * np.sqrt(np.mean(err[K // 2:] ** 2, axis=0))
    above = running > bound
    last = np.where(above.any(axis=0), K - 1 - np.argmax(above[::-1], axis=0), -1)
    return (last + 1).astype(float)


class ConvergenceEpoch(SeriesMetric):
    """The epoch after which a run has converged (`convergence_epoch`), in epochs.

    Its series is 1 at the epochs where the run has not yet converged and 0 afterwards:
    its mean over runs is the fraction still unconverged, its median drops to 0 once half
    the runs have converged.

    Parameters
    ----------
    name, of
        As for `SeriesMetric` (the unit is ``"epochs"``).
    window
        Epochs of the running RMS, or the name of the scenario parameter holding it.
    factor
        The running RMS must stay below ``factor`` times the second half's RMS.
    """

    def __init__(self, name: str, of: str, *, window: int | str, factor: float = 2.0, description: str = "") -> None:
        super().__init__(name, "epochs", of, description=description)
        self.window = window
        self.factor = factor

    def compute(self, series: dict[str, np.ndarray], time_s: np.ndarray | None, scenario: Any) -> MetricValue:
        mag = _magnitude(series[self.of])
        conv = convergence_epoch(mag, int(_scenario_value(self.window, scenario, self.name)), self.factor)
        unconverged = (np.arange(mag.shape[0])[:, None] < conv[None, :]).astype(float)
        return MetricValue(conv, unconverged)


def units(components: Sequence[Metric]) -> dict[str, str]:
    """The ``Scenario.metrics`` table (name -> unit) of a list of components.

    Raises
    ------
    ValueError
        If two components have the same name.
    """
    out: dict[str, str] = {}
    for c in components:
        if c.name in out:
            raise ValueError(f"two metric components are named {c.name!r}")
        out[c.name] = c.unit
    return out


def evaluate(components: Sequence[Metric], series: dict[str, np.ndarray], time_s: np.ndarray | None,
             scenario: Any) -> "BatchResult":
    """Compute every component once from the raw ``series`` of one batch.

    Returns the batch's `BatchResult`: each component's value ``(runs,)``, and the raw
    series together with each component's own series (under the component's name).

    Raises
    ------
    ValueError
        If a component's series name clashes with a raw series, or a value is not one per run.
    """
    from .scenarios import BatchResult

    metrics: dict[str, np.ndarray] = {}
    out_series = dict(series)
    for c in components:
        value = c.compute(series, time_s, scenario)
        v = np.asarray(value.value, dtype=float)
        runs = np.shape(series[c.requires[0]])[1] if c.requires else v.shape[0]
        if v.shape != (runs,):
            raise ValueError(f"metric {c.name!r} returned shape {v.shape}, expected ({runs},)")
        metrics[c.name] = v
        if value.series is not None:
            if c.name in series:
                raise ValueError(f"metric {c.name!r}: a raw series has the same name")
            out_series[c.name] = value.series
    return BatchResult(metrics, out_series, time_s)


# --- Components added for the deep-integration scenario (issue 12) ---------------------------

__all__ += ["PostSettleMax", "TimeMean"]


class PostSettleMax(SeriesMetric):
    """Largest absolute value over time of the series (its norm per epoch for a vector
    error), from ``settle`` on: the ``_max`` metrics of reference 002's bounds.

    A run whose series holds NaN after settling (no estimate of that quantity) gets NaN.

    Examples
    --------
    >>> PostSettleMax("e_max", "m", of="e").compute({"e": np.array([[3.0, -1.0], [-4.0, 0.5]])}, None,
    ...                                             None).value.tolist()
    [4.0, 1.0]
    """

    def compute(self, series: dict[str, np.ndarray], time_s: np.ndarray | None, scenario: Any) -> MetricValue:
        mag = _magnitude(series[self.of])
        mask = self._mask(mag.shape[0], time_s, scenario)
        return MetricValue(np.max(mag if mask is None else mag[mask], axis=0), mag)


class TimeMean(SeriesMetric):
    """Mean over time of the series itself (signed, not its magnitude), from ``settle`` on:
    a per-epoch fraction (loss of lock) or a per-epoch NEES, whose time mean is the metric
    (`gnssframework.experiments.metrics.nees_mean` without a covariance).

    Examples
    --------
    >>> TimeMean("lol", "-", of="f").compute({"f": np.array([[0.0, 1.0], [0.5, 1.0]])}, None, None).value.tolist()
    [0.25, 1.0]
    """

    def compute(self, series: dict[str, np.ndarray], time_s: np.ndarray | None, scenario: Any) -> MetricValue:
        x = np.asarray(series[self.of], dtype=float)
        if x.ndim != 2:
            raise ValueError(f"metric {self.name!r}: series {self.of!r} must be (K, runs), got {x.shape}")
        mask = self._mask(x.shape[0], time_s, scenario)
        return MetricValue(np.mean(x if mask is None else x[mask], axis=0), x)
