"""Metric components and the shared metric helpers.

A scenario reports its own metrics (``Scenario.metrics``: name -> unit) and per-epoch
series (``BatchResult.series``). A :class:`Metric` component adds a metric computed from
those series, once per batch in the worker, stored in the result store beside the
scenario's own; a config names it in ``metrics`` like any other::

    from gnssframework import hookimpl
    from gnssframework.experiments.metrics import Metric, MetricValue, max_after_settle

    class PeakCodeError(Metric):
        name = "code_phase_error_peak"
        unit = "chips"
        description = "largest code error after the settle time"
        requires = ("code_error_chips",)          # series of the scenario it reads

        def compute(self, series, time_s, scenario):
            err = series["code_error_chips"]       # (K, runs)
            return MetricValue(max_after_settle(err, time_s, scenario.params.settle_s))

    @hookimpl
    def register_metric(register):
        register(PeakCodeError)

The helpers (:func:`rmse`, :func:`max_after_settle`, :func:`nees_mean`, :func:`fraction`,
:func:`settled`) reduce a ``(K, runs, ...)`` series over time (axis 0) to ``(runs,)``;
:func:`select` (the epochs of a mask, refusing an empty selection) and :func:`magnitude`
(``|e_k|``, or the norm of a vector error) are the steps they share with the metric
components (`gnssframework.experiments.metric_components`). Scenarios use them instead
of writing the reductions inline.
"""

from __future__ import annotations

import abc
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from .. import registry
from ..errors import ConfigError
from ..estimation.consistency import nees
from ..plugin import Plugin

__all__ = [
    "Metric",
    "MetricValue",
    "rmse",
    "max_after_settle",
    "nees_mean",
    "fraction",
    "settled",
    "select",
    "magnitude",
    "metric_component",
    "available_metrics",
    "check_metric",
]


def settled(time_s: np.ndarray | None, settle_s: float, k: int) -> np.ndarray:
    """Boolean mask ``(K,)`` of the epochs at or after ``settle_s`` (all epochs if there is
    no time axis)."""
    if time_s is None or np.size(time_s) == 0:
        return np.ones(k, dtype=bool)
    t = np.asarray(time_s, dtype=float)
    if t.shape != (k,):
        raise ValueError(f"time_s has shape {t.shape}, the series has {k} epochs")
    return t >= settle_s


def select(x: np.ndarray, mask: np.ndarray | None, what: str) -> np.ndarray:
    """The epochs (axis 0) of ``x`` where ``mask`` ``(K,)`` is true, all of them without a mask.

    Raises
    ------
    ValueError
        Naming ``what``, if the mask does not fit the series or selects no epoch.
    """
    x = np.asarray(x, dtype=float)
    if mask is None:
        out = x
    else:
        mask = np.asarray(mask, dtype=bool)
        if mask.shape != x.shape[:1]:
            raise ValueError(f"{what}: the epoch mask has shape {mask.shape}, the series {x.shape}")
        out = x[mask]
    if out.shape[0] == 0:
        raise ValueError(f"{what}: no epoch selected (settle time at or beyond the end of the run?)")
    return out


def magnitude(x: np.ndarray) -> np.ndarray:
    """``|x|`` of a ``(K, runs)`` series; the Euclidean norm per epoch of a ``(K, runs, d...)`` one."""
    x = np.asarray(x, dtype=float)
    out: np.ndarray = np.abs(x) if x.ndim <= 2 else np.sqrt(np.sum(x**2, axis=tuple(range(2, x.ndim))))
    return out


def rmse(err: np.ndarray, mask: np.ndarray | None = None) -> np.ndarray:
    """Root mean square over time (axis 0) of the selected epochs.

    ``err`` is ``(K, runs)``; a vector error ``(K, runs, d)`` is reduced with its norm
    first, ``sqrt(mean_k |e_k|^2)``. Returns ``(runs,)``.

    Examples
    --------
    >>> rmse(np.array([[3.0], [4.0]])).round(4).tolist()
    [3.5355]
    """
    e = select(err, mask, "rmse")
    sq = e**2 if e.ndim <= 2 else np.sum(e**2, axis=tuple(range(2, e.ndim)))
    out: np.ndarray = np.sqrt(np.mean(sq, axis=0))
    return out


def max_after_settle(err: np.ndarray, time_s: np.ndarray | None, settle_s: float) -> np.ndarray:
    """Largest absolute error (norm for vector errors) at or after ``settle_s``, ``(runs,)``."""
    e = np.asarray(err, dtype=float)
    out: np.ndarray = np.max(magnitude(select(e, settled(time_s, settle_s, e.shape[0]), "max_after_settle")), axis=0)
    return out


def nees_mean(err: np.ndarray, cov: np.ndarray | None = None, mask: np.ndarray | None = None) -> np.ndarray:
    """Mean normalized estimation error squared over time, ``(runs,)``.

    With ``cov`` (``(K, runs, n, n)``) and ``err`` (``(K, runs, n)``): ``mean_k e_k^T P_k^-1 e_k``
    (Bar-Shalom, Li and Kirubarajan 2001, sec. 5.4; its expectation is ``n`` for a
    consistent filter). Without ``cov``, ``err`` is the per-epoch NEES ``(K, runs)``.
    """
    per_epoch = (
        select(err, mask, "nees_mean")
        if cov is None
        else nees(select(err, mask, "nees_mean"), select(cov, mask, "nees_mean"))
    )
    out: np.ndarray = np.mean(per_epoch, axis=0)
    return out


def fraction(flags: np.ndarray, mask: np.ndarray | None = None) -> np.ndarray:
    """Fraction of the selected epochs where ``flags`` is true (e.g. loss of lock), ``(runs,)``."""
    out: np.ndarray = np.mean(select(np.asarray(flags, dtype=bool), mask, "fraction"), axis=0)
    return out


@dataclass
class MetricValue:
    """A metric of one batch: ``value`` ``(runs,)`` and optionally a per-epoch ``series`` ``(K, runs)``."""

    value: np.ndarray
    series: np.ndarray | None = None


class Metric(Plugin, abc.ABC):
    """Base class of metric components (plugin kind ``metric``).

    Attributes
    ----------
    name
        The metric's name in configs, reports and ``summary.json`` (snake_case).
    unit
        Its unit (``"m"``, ``"chips"``, ``"-"``).
    description
        One line for ``gnssframework plugins`` and the docs.
    requires
        Names of the scenario series the metric reads (``Scenario.metrics`` keys or
        ``Scenario.outputs`` keys); a config naming the metric with a scenario that lacks
        one is refused when it is loaded.
    scenarios
        Scenario kinds the metric applies to (empty: any scenario providing ``requires``).
    """

    kind = "metric"
    unit: ClassVar[str] = "-"
    requires: ClassVar[tuple[str, ...]] = ()
    scenarios: ClassVar[tuple[str, ...]] = ()

    @abc.abstractmethod
    def compute(self, series: dict[str, np.ndarray], time_s: np.ndarray | None, scenario: Any) -> MetricValue:
        """The metric of one batch from the scenario's series ``(K, runs, ...)``.

        Called once per batch, in the worker that simulated it; the value is stored.
        """

    def applies_to(self, scenario: Any) -> str:
        """Why the metric cannot be computed in ``scenario`` (``""`` if it can)."""
        if self.scenarios and scenario.kind not in self.scenarios:
            return f"applies to scenarios {', '.join(self.scenarios)}, not {scenario.kind!r}"
        available = set(scenario.metrics) | set(getattr(scenario, "outputs", {}) or {})
        missing = [r for r in self.requires if r not in available]
        if missing:
            return f"needs series {', '.join(missing)}, which scenario {scenario.kind!r} does not provide"
        return ""


registry.register_kind("metric", Metric)  # this layer owns the kind's base


def metric_component(name: str, scenario: Any) -> Metric | None:
    """The metric component that computes ``name`` in ``scenario``: the scenario's own
    (a component of its ``metrics`` table, `metric_components.units`), else a registered
    ``metric`` plugin; ``None`` for a metric the scenario computes without a component, or
    an unknown name. The one lookup of a metric by name, for the config, the workers and
    the report."""
    own = getattr(scenario.metrics, "components", {}).get(name)
    if own is not None or name in scenario.metrics:
        return own
    return registry.create("metric", name) if name in registry.names("metric") else None


def available_metrics(scenario: Any) -> list[str]:
    """Every metric ``scenario`` can report: its own, then the registered ``metric``
    plugins that apply to it (`Metric.applies_to`)."""
    plugins = []
    for n in registry.names("metric"):
        if n in scenario.metrics:
            continue
        component = metric_component(n, scenario)  # a registered name outside the scenario's: never None
        if component is not None and not component.applies_to(scenario):
            plugins.append(n)
    return list(scenario.metrics) + plugins


def check_metric(name: str, scenario: Any, field: str) -> str:
    """Unit of metric ``name`` in ``scenario`` (its own or a component's); a ``ConfigError``
    naming ``field`` and the allowed metrics otherwise."""
    if name in scenario.metrics:
        unit: str = scenario.metrics[name]
        return unit
    component = metric_component(name, scenario)
    allowed = ", ".join(available_metrics(scenario))
    if component is None:
        raise ConfigError(field, f"unknown {name!r}; allowed: {allowed}")
    why = component.applies_to(scenario)
    if why:
        raise ConfigError(field, f"metric {name!r} {why}; allowed: {allowed}")
    return component.unit
