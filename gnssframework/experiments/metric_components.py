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

from typing import Any, ClassVar
from collections.abc import Callable, Sequence

import numpy as np

from .batch import BatchResult
from .metrics import Metric, MetricValue, magnitude, metric_component, rmse, select, settled

__all__ = [
    "SeriesMetric",
    "Rmse",
    "MeanAbs",
    "ConvergenceEpoch",
    "convergence_epoch",
    "evaluate",
    "units",
    "Mean",
    "Std",
    "LockLossFraction",
    "SlipRecovery",
    "FalseResets",
    "slip_recovery",
    "false_resets",
    "undefined_reasons",
    "MetricTable",
    "series_label",
]


def _scenario_value(value: Any, scenario: Any, what: str) -> Any:
    """``value``, the scenario parameter it names (a string), or what it returns for the
    scenario (a callable, for a value derived from several parameters)."""
    if callable(value):
        return value(scenario)
    if not isinstance(value, str):
        return value
    try:
        return getattr(scenario.params, value)
    except AttributeError:
        raise AttributeError(
            f"{what}: scenario {getattr(scenario, 'kind', '?')!r} has no parameter {value!r}"
        ) from None


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
        holding it, e.g. ``"settle_s"``; or a function of the scenario) are left out of the
        value.
    skip_epochs
        Optional: this many leading epochs (or the scenario parameter holding the number)
        are left out of the value; for scenarios that count settling in epochs.
    optional
        If true, `evaluate` leaves the metric out of a batch whose series lack ``of``
        (a metric the scenario computes only in some configurations).
    undefined
        Why the value can be undefined (NaN) in a run, for ``summary.json`` and the
        report (see `undefined_reasons`).
    description
        One line for the docs.
    """

    #: What the stored per-epoch series is (``{of}``: the name of the series read).
    series_template: ClassVar[str] = "{of}"

    def __init__(
        self,
        name: str,
        unit: str,
        of: str,
        *,
        settle: float | str | Callable[[Any], float] | None = None,
        skip_epochs: int | str | None = None,
        optional: bool = False,
        undefined: str = "",
        description: str = "",
    ) -> None:
        super().__init__()
        self.undefined = undefined
        self.name = name
        self.unit = unit
        self.of = of
        self.settle = settle
        self.skip_epochs = skip_epochs
        self.optional = optional
        self.description = description
        self.requires = (of,)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r}, {self.unit!r}, of={self.of!r})"

    @property
    def series_label(self) -> str:
        """What the metric's per-epoch series holds, for plot labels (``series_template``
        with the series read as ``{of}``)."""
        return self.series_template.format(of=self.of)

    def _mask(self, k: int, time_s: np.ndarray | None, scenario: Any) -> np.ndarray | None:
        mask = None
        if self.settle is not None:
            mask = settled(time_s, float(_scenario_value(self.settle, scenario, self.name)), k)
        if self.skip_epochs is not None:
            late = np.arange(k) >= int(_scenario_value(self.skip_epochs, scenario, self.name))
            mask = late if mask is None else mask & late
        return mask


class Rmse(SeriesMetric):
    """Root mean square over time of the series (its norm per epoch for a vector error).

    Examples
    --------
    >>> m = Rmse("e_rmse", "m", of="e")
    >>> m.compute({"e": np.array([[3.0, 1.0], [4.0, 1.0]])}, None, None).value.round(4).tolist()
    [3.5355, 1.0]
    """

    series_template = "|{of}|"

    def compute(self, series: dict[str, np.ndarray], time_s: np.ndarray | None, scenario: Any) -> MetricValue:
        x = np.asarray(series[self.of], dtype=float)
        return MetricValue(rmse(x, self._mask(x.shape[0], time_s, scenario)), magnitude(x))


class MeanAbs(SeriesMetric):
    """Mean over time of the absolute error (its norm per epoch for a vector error).

    Examples
    --------
    >>> MeanAbs("e_mean", "m", of="e").compute({"e": np.array([[3.0], [-5.0]])}, None, None).value.tolist()
    [4.0]
    """

    series_template = "|{of}|"

    def compute(self, series: dict[str, np.ndarray], time_s: np.ndarray | None, scenario: Any) -> MetricValue:
        x = np.asarray(series[self.of], dtype=float)
        mag = magnitude(x)
        return MetricValue(np.mean(select(mag, self._mask(x.shape[0], time_s, scenario), self.name), axis=0), mag)


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
    bound = factor * np.sqrt(np.mean(err[K // 2 :] ** 2, axis=0))
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

    series_template = "not yet converged (1) or converged (0)"

    def __init__(self, name: str, of: str, *, window: int | str, factor: float = 2.0, description: str = "") -> None:
        super().__init__(name, "epochs", of, description=description)
        self.window = window
        self.factor = factor

    def compute(self, series: dict[str, np.ndarray], time_s: np.ndarray | None, scenario: Any) -> MetricValue:
        mag = magnitude(series[self.of])
        conv = convergence_epoch(mag, int(_scenario_value(self.window, scenario, self.name)), self.factor)
        unconverged = (np.arange(mag.shape[0])[:, None] < conv[None, :]).astype(float)
        return MetricValue(conv, unconverged)


# --- Reductions of the tracking and smoothing scenarios (carrier-smoothing, scintillation,
# vector-tracking): each metric declared once in its scenario's METRICS.


class Mean(SeriesMetric):
    """Mean over time of the series itself (signed), e.g. a per-epoch NEES whose mean a
    consistent filter keeps at the state dimension (Bar-Shalom, Li and Kirubarajan 2001,
    sec. 5.4), or a per-run constant. Its series is the series itself.

    Examples
    --------
    >>> Mean("nees", "-", of="e").compute({"e": np.array([[1.0], [2.0], [6.0]])}, None, None).value.tolist()
    [3.0]
    """

    def compute(self, series: dict[str, np.ndarray], time_s: np.ndarray | None, scenario: Any) -> MetricValue:
        x = np.asarray(series[self.of], dtype=float)
        return MetricValue(np.mean(select(x, self._mask(x.shape[0], time_s, scenario), self.name), axis=0), x)


class Std(SeriesMetric):
    """Standard deviation over time (about the run's own mean, ``1/n``) of the series,
    e.g. a discriminator's output noise. Its series is ``|x_k|``.

    Examples
    --------
    >>> Std("d_std", "rad", of="d").compute({"d": np.array([[1.0], [3.0]])}, None, None).value.tolist()
    [1.0]
    """

    series_template = "|{of}|"

    def compute(self, series: dict[str, np.ndarray], time_s: np.ndarray | None, scenario: Any) -> MetricValue:
        x = np.asarray(series[self.of], dtype=float)
        return MetricValue(np.std(select(x, self._mask(x.shape[0], time_s, scenario), self.name), axis=0), np.abs(x))


class LockLossFraction(SeriesMetric):
    """Fraction of blocks out of phase lock, from the phase error ``of`` (rad).

    The settled epochs are cut into blocks of ``window`` seconds (whole blocks only, at
    least one epoch each; the epoch interval is read from ``time_s``); a block is out of
    lock when its mean ``cos(2 e_k)``, the phase lock indicator of a Costas loop (Van
    Dierendonck 1996), is below ``threshold``. Its series is the same test epoch by epoch
    (1 out of lock).

    Parameters
    ----------
    window, threshold
        Seconds per block and the lock threshold, or the scenario parameters holding them.
    """

    series_template = "out of phase lock (1) or in lock (0)"

    def __init__(
        self,
        name: str,
        of: str,
        *,
        window: float | str,
        threshold: float | str,
        settle: float | str | None = None,
        description: str = "",
    ) -> None:
        super().__init__(name, "-", of, settle=settle, description=description)
        self.window = window
        self.threshold = threshold

    def compute(self, series: dict[str, np.ndarray], time_s: np.ndarray | None, scenario: Any) -> MetricValue:
        err = np.asarray(series[self.of], dtype=float)
        threshold = float(_scenario_value(self.threshold, scenario, self.name))
        if time_s is None or len(time_s) < 2:
            raise ValueError(f"{self.name}: needs the epochs' times (two or more) for the block length")
        interval_s = (time_s[-1] - time_s[0]) / (len(time_s) - 1)
        block = max(1, int(round(float(_scenario_value(self.window, scenario, self.name)) / interval_s)))
        e = select(err, self._mask(err.shape[0], time_s, scenario), self.name)
        n_blocks = e.shape[0] // block
        if n_blocks == 0:  # the mean of no block would be a NumPy warning and a NaN
            raise ValueError(
                f"{self.name}: the {e.shape[0]} settled epochs hold no whole block of {block} epochs "
                f"(window {self.window!r}); use a shorter window or a longer run"
            )
        pli = np.cos(2 * e[: n_blocks * block]).reshape((n_blocks, block) + e.shape[1:]).mean(axis=1)
        return MetricValue(np.mean(pli < threshold, axis=0), (np.cos(2 * err) < threshold).astype(float))


def slip_recovery(
    err: np.ndarray,
    slips: np.ndarray,
    before: int = 30,
    window: int = 5,
    band: float = 2.0,
    isolation: int = 400,
    start: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """Recovery after isolated cycle slips, per run: (mean epochs to recover, censored slips).

    A slip at epoch s is *measured* if its ``before`` epochs of reference start at or
    after ``start`` and no earlier slip lies within ``isolation`` epochs before s (so the
    reference level is not the tail of an earlier slip). Its reference sigma is the RMS
    error over ``[s - before, s)``; it has recovered at the first j where the RMS over
    ``[s+j, s+j+window)`` is at most ``band`` sigma. A measured slip that has not
    recovered before the next slip or the end of the run is *censored*: it is left out
    of the mean (counting the epochs until the next slip would bias the mean low) and
    counted in the second output. The mean is NaN for a run without an uncensored
    measured slip.

    For a Hatch filter of window tau, a slip of N cycles leaves an error
    N lambda a^(j+1), a = 1 - 1/tau, on top of the smoothing noise sigma; with the 2-sigma
    band it recovers after about tau ln(N lambda / (sqrt(3) sigma)) epochs (the noise
    takes sigma^2 of the 4 sigma^2 budget), which the tests check.

    ``err`` and ``slips`` (boolean, True at a slip epoch) are ``(K, runs)``.
    """
    K, runs = err.shape
    mean = np.full(runs, np.nan)
    censored = np.zeros(runs)
    for r in range(runs):  # slips are rare events: a loop over runs and slips, not over epochs
        at = np.flatnonzero(slips[:, r])
        rec = []
        for i, s in enumerate(at):
            prev_slip = at[i - 1] if i else -(10**9)
            if s - before < start or s - prev_slip <= isolation:
                continue
            sigma = np.sqrt(np.mean(err[s - before : s, r] ** 2))
            end = at[i + 1] if i + 1 < at.size else K
            sq = err[s:end, r] ** 2
            run_rms = np.sqrt(np.convolve(sq, np.ones(window) / window, mode="valid")) if sq.size >= window else sq[:0]
            ok = np.flatnonzero(run_rms <= band * sigma)
            if ok.size:
                rec.append(ok[0])
            else:
                censored[r] += 1
        if rec:
            mean[r] = float(np.mean(rec))
    return mean, censored


def false_resets(detected: np.ndarray, slips: np.ndarray) -> np.ndarray:
    """False resets per run, ``(runs,)``, from ``(K, runs)`` booleans (detections, true slips).

    A detection is true if a slip happened since the previous detection (or the start),
    which counts a slip caught a few epochs late (a slip below the threshold whose
    decaying error later crosses it) as caught, not as a false alarm.
    """
    slips = np.asarray(slips, dtype=bool)
    detected = np.asarray(detected, dtype=bool)
    pending = np.zeros(slips.shape[1], bool)
    false = np.zeros(slips.shape[1])
    for k in range(slips.shape[0]):  # a scan over epochs, vectorised over runs
        pending |= slips[k]
        false += detected[k] & ~pending
        pending &= ~detected[k]
    return false


class SlipRecovery(SeriesMetric):
    """Recovery after isolated cycle slips (`slip_recovery`) of the error ``of``, given the
    slip epochs ``slips`` (a boolean series): ``output="mean"`` is the mean epochs to
    recover (NaN for a run without a measured, uncensored slip), ``"censored"`` the number
    of censored slips. Its series is the slip indicator.

    Parameters
    ----------
    isolation, start
        As for `slip_recovery`, in epochs, or the scenario parameters holding them.
    band
        Recovered within ``band`` times the reference sigma.
    """

    series_template = "cycle slip (1) or none (0)"

    def __init__(
        self,
        name: str,
        of: str,
        *,
        slips: str,
        output: str = "mean",
        isolation: int | str = 400,
        start: int | str = 0,
        band: float = 2.0,
        description: str = "",
    ) -> None:
        if output not in ("mean", "censored"):
            raise ValueError(f"output must be 'mean' or 'censored', not {output!r}")
        super().__init__(
            name,
            "epochs" if output == "mean" else "slips/run",
            of,
            description=description,
            undefined="no isolated slips" if output == "mean" else "",
        )
        self.slips, self.output, self.isolation, self.start, self.band = slips, output, isolation, start, band
        self.requires = (of, slips)

    def compute(self, series: dict[str, np.ndarray], time_s: np.ndarray | None, scenario: Any) -> MetricValue:
        slips = np.asarray(series[self.slips], dtype=bool)
        mean, censored = slip_recovery(
            np.asarray(series[self.of], dtype=float),
            slips,
            band=self.band,
            isolation=int(_scenario_value(self.isolation, scenario, self.name)),
            start=int(_scenario_value(self.start, scenario, self.name)),
        )
        return MetricValue(mean if self.output == "mean" else censored, slips.astype(float))


class FalseResets(SeriesMetric):
    """False resets per run (`false_resets`) from the detections ``of`` and the true slips
    ``slips`` (boolean series). Its series is 1 at a detection without a slip at that epoch.

    Examples
    --------
    >>> d = np.array([[True], [False], [True]]); s = np.array([[False], [True], [False]])
    >>> FalseResets("fr", of="d", slips="s").compute({"d": d, "s": s}, None, None).value.tolist()
    [1.0]
    """

    series_template = "reset without a slip (1) or not (0)"

    def __init__(self, name: str, of: str, *, slips: str, description: str = "") -> None:
        super().__init__(name, "resets/run", of, description=description)
        self.slips = slips
        self.requires = (of, slips)

    def compute(self, series: dict[str, np.ndarray], time_s: np.ndarray | None, scenario: Any) -> MetricValue:
        detected = np.asarray(series[self.of], dtype=bool)
        slips = np.asarray(series[self.slips], dtype=bool)
        return MetricValue(false_resets(detected, slips), (detected & ~slips).astype(float))


class MetricTable(dict):
    """A scenario's ``metrics`` table (name -> unit) that also holds the components by name
    (``components``), so a report can say what each metric's series is."""

    def __init__(self, units: dict[str, str], components: dict[str, Metric]) -> None:
        super().__init__(units)
        self.components = components


def units(components: Sequence[Metric]) -> MetricTable:
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
    return MetricTable(out, {c.name: c for c in components})


def undefined_reasons(components: Sequence[Metric]) -> dict[str, str]:
    """The ``Scenario.undefined_reasons`` table (name -> why the value can be NaN) of the
    components that declare one."""
    return {c.name: c.undefined for c in components if getattr(c, "undefined", "")}


def evaluate(
    components: Sequence[Metric],
    series: dict[str, np.ndarray],
    time_s: np.ndarray | None,
    scenario: Any,
    runs: int | None = None,
) -> BatchResult:
    """Compute every component once from the raw ``series`` of one batch: a scenario's own
    components in its ``run_batch``, the registered ``metric`` plugins a config adds in
    the worker (`gnssframework.experiments.runner`), the same way.

    Returns the batch's `BatchResult`: each component's value ``(runs,)``, and the raw
    series together with each component's own series (under the component's name).
    ``runs`` is the batch's number of runs (default: read from the series).

    Raises
    ------
    ValueError
        If a component's series name clashes with a raw series, or a value is not one per run.
    """
    metrics: dict[str, np.ndarray] = {}
    out_series = dict(series)
    for c in components:
        if getattr(c, "optional", False) and any(r not in series for r in c.requires):
            continue  # a metric this configuration of the scenario does not compute
        value = c.compute(series, time_s, scenario)
        v = np.asarray(value.value, dtype=float)
        expected = runs if runs is not None else np.shape(series[c.requires[0]])[1] if c.requires else v.shape[0]
        if v.shape != (expected,):
            raise ValueError(f"metric {c.name!r} returned shape {v.shape}, expected ({expected},), one value per run")
        metrics[c.name] = v
        if value.series is not None:
            if c.name in series:
                raise ValueError(f"metric {c.name!r}: a raw series has the same name")
            out_series[c.name] = value.series
    return BatchResult(metrics, out_series, time_s)


# --- Components added for the deep-integration scenario (issue 12) ---------------------------

__all__ += ["PostSettleMax"]


class PostSettleMax(SeriesMetric):
    """Largest absolute value over time of the series (its norm per epoch for a vector
    error), from ``settle`` on: the ``_max`` metrics of Cai and Guo's (2017) bounds.

    A run whose series holds NaN after settling (no estimate of that quantity) gets NaN.

    Examples
    --------
    >>> PostSettleMax("e_max", "m", of="e").compute({"e": np.array([[3.0, -1.0], [-4.0, 0.5]])}, None,
    ...                                             None).value.tolist()
    [4.0, 1.0]
    """

    def compute(self, series: dict[str, np.ndarray], time_s: np.ndarray | None, scenario: Any) -> MetricValue:
        mag = magnitude(series[self.of])
        return MetricValue(np.max(select(mag, self._mask(mag.shape[0], time_s, scenario), self.name), axis=0), mag)


def series_label(scenario: Any, metric: str) -> str:
    """What the per-epoch series stored for ``metric`` holds (for a plot's axis): the
    component's ``series_label``, or the metric's name when nothing says more."""
    component = metric_component(metric, scenario)
    return getattr(component, "series_label", None) or f"{metric} per epoch"


# --- Integrity outcomes of protection levels (issue 43) ---------------------------------------

__all__ += ["IntegrityOutcome", "integrity_outcome", "INTEGRITY_OUTCOMES"]

#: What `IntegrityOutcome` counts (`integrity_outcome`).
INTEGRITY_OUTCOMES = ("misleading", "hazardous", "available")


def integrity_outcome(error_m: np.ndarray, level_m: np.ndarray, alert_limit_m: float, outcome: str) -> np.ndarray:
    """Per-epoch integrity outcome of a position error against its protection level, the
    regions of the Stanford-ESA integrity diagram (Tossaint et al. 2007, "The Stanford-ESA
    integrity diagram: a new tool for the user domain SBAS integrity assessment",
    Navigation 54(2); RTCA DO-229 for the terms), ``(K, runs)`` booleans:

    - ``"misleading"`` (MI): the error exceeds the protection level, ``|e| > PL``;
    - ``"hazardous"`` (HMI): the system declares itself available and the error exceeds
      the alert limit, ``PL < AL < |e|`` (so also ``|e| > PL``); an error above both the
      PL and the AL while ``PL >= AL`` is MI while unavailable, not HMI;
    - ``"available"``: ``PL < AL``.

    ``error_m`` is the magnitude of the error (``|e|``; a signed error is taken in
    absolute value) and ``level_m`` the PL, both ``(K, runs)``; a NaN PL (none computed) is
    neither available nor an MI.

    Examples
    --------
    >>> e = np.array([1.0, 3.0, 12.0, 12.0, 30.0]); pl = np.array([2.0, 2.0, 5.0, 20.0, 25.0])
    >>> [integrity_outcome(e, pl, 10.0, o).astype(int).tolist() for o in INTEGRITY_OUTCOMES]
    [[0, 1, 1, 0, 1], [0, 0, 1, 0, 0], [1, 1, 1, 0, 0]]
    """
    if outcome not in INTEGRITY_OUTCOMES:
        raise ValueError(f"outcome must be one of {', '.join(INTEGRITY_OUTCOMES)}, not {outcome!r}")
    err = np.abs(np.asarray(error_m, dtype=float))
    pl = np.asarray(level_m, dtype=float)
    available = pl < alert_limit_m
    if outcome == "available":
        return available
    misleading = err > pl
    return misleading if outcome == "misleading" else available & (err > alert_limit_m)


class IntegrityOutcome(SeriesMetric):
    """Fraction of the settled epochs with an integrity outcome (`integrity_outcome`) of the
    error ``of`` (m) against the protection level ``level`` (m, a series of the same
    shape) and the alert limit ``alert_limit`` (m, or the scenario parameter holding it).
    Its series is the outcome epoch by epoch (1 where it holds).

    A run's value is a rate per epoch: ``misleading`` and ``hazardous`` estimate the
    probabilities of MI and HMI (compare with the integrity risk the PL was computed at),
    ``available`` the availability at that alert limit.

    Examples
    --------
    >>> m = IntegrityOutcome("mi", of="e", level="pl", outcome="misleading", alert_limit=10.0)
    >>> m.compute({"e": np.array([[1.0], [3.0]]), "pl": np.array([[2.0], [2.0]])}, None, None).value.tolist()
    [0.5]
    """

    def __init__(
        self,
        name: str,
        of: str,
        *,
        level: str,
        outcome: str,
        alert_limit: float | str | Callable[[Any], float],
        settle: float | str | None = None,
        optional: bool = False,
        description: str = "",
    ) -> None:
        if outcome not in INTEGRITY_OUTCOMES:
            raise ValueError(f"outcome must be one of {', '.join(INTEGRITY_OUTCOMES)}, not {outcome!r}")
        super().__init__(name, "-", of, settle=settle, optional=optional, description=description)
        self.level, self.outcome, self.alert_limit = level, outcome, alert_limit
        self.requires = (of, level)

    @property
    def series_label(self) -> str:
        what = {
            "misleading": f"|{self.of}| > {self.level}",
            "hazardous": f"{self.level} < alert limit < |{self.of}|",
            "available": f"{self.level} < alert limit",
        }[self.outcome]
        return f"{what} (1) or not (0)"

    def compute(self, series: dict[str, np.ndarray], time_s: np.ndarray | None, scenario: Any) -> MetricValue:
        err = np.asarray(series[self.of], dtype=float)
        pl = np.asarray(series[self.level], dtype=float)
        if pl.shape != err.shape:
            raise ValueError(f"{self.name}: the level {self.level!r} has shape {pl.shape}, the error {err.shape}")
        limit = float(_scenario_value(self.alert_limit, scenario, self.name))
        flags = integrity_outcome(err, pl, limit, self.outcome).astype(float)
        return MetricValue(np.mean(select(flags, self._mask(err.shape[0], time_s, scenario), self.name), axis=0), flags)
