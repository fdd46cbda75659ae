"""Paired statistics of a comparison run on common random numbers.

Every candidate of a case sees the same signals and noise in every run (see
:mod:`gnssframework.experiments.runner`), so a candidate's advantage over a reference is
measured by the per-run differences ``d_r = x_r - y_r``: their mean, with the standard
error ``s_d / sqrt(n)`` of a paired comparison (Student 1908; common random numbers:
Law 2015, ch. 11). When the runs of
two candidates are positively correlated, which common random numbers achieve, this is
much smaller than the unpaired ``sqrt(s_x^2/n + s_y^2/n)``.

Significance rule (stated in every report): a difference is *significant* when the 95 %
paired t-interval ``mean(d) ± t_{0.975, n-1} SE`` excludes zero, i.e.
``|mean(d)| > t_{0.975, n-1} SE`` (about 2 SE for 30 runs or more, 2.26 SE for 10).
An SE that is zero or at floating-point rounding level of the values (the same bound in
every run) leaves nothing to test: such a difference is never significant.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from scipy import special as _sc  # not scipy.stats: its import costs every run of the CLI a second

from .number_format import at_rounding_level

__all__ = ["PairedDifference", "paired_difference", "mean_and_se", "SIGNIFICANCE_RULE", "finite_or_none", "t_quantile"]

SIGNIFICANCE_RULE = (
    "significant: the 95 % paired t-interval of the per-run differences excludes 0, "
    "|mean difference| > t(0.975, n-1) x SE, SE = std of the per-run differences / sqrt(n); "
    "a difference with no spread over the runs (SE zero or at rounding level) is not tested"
)


def finite_or_none(x: float | None) -> float | None:
    """``x`` as a float, or ``None`` if it is missing or not finite (strict JSON has no NaN)."""
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else None


@dataclass(frozen=True)
class PairedDifference:
    """A candidate's paired difference to a reference over the runs both completed.

    Attributes
    ----------
    n
        Runs where both values are finite (the pairs).
    diff
        Mean of the per-run differences, candidate minus reference.
    se
        Standard error of ``diff``: sample std (ddof 1) of the differences over ``sqrt(n)``.
    ci95
        The 95 % paired t-interval of the mean difference.
    ratio
        Ratio of the means (candidate / reference) when both metrics are non-negative and
        the reference mean is positive (an RMSE, a NEES, a fraction); else ``None``.
    ratio_se
        Delta-method standard error of ``ratio`` from the paired sample covariance.
    significant
        Whether ``ci95`` excludes zero (see :data:`SIGNIFICANCE_RULE`).
    reason
        Why a statistic is ``None`` (fewer than two pairs, zero spread...), else ``""``.
    """

    n: int
    diff: float | None
    se: float | None
    ci95: tuple[float, float] | None
    ratio: float | None
    ratio_se: float | None
    significant: bool
    reason: str = ""

    def to_json(self) -> dict:
        """A dict with no NaN (missing statistics are ``None``)."""
        out = asdict(self)
        out["ci95"] = None if self.ci95 is None else [finite_or_none(v) for v in self.ci95]
        for k in ("diff", "se", "ratio", "ratio_se"):
            out[k] = finite_or_none(out[k])
        return out


def t_quantile(n: int, level: float = 0.95) -> float:
    """The two-sided ``level`` Student-t quantile of ``n`` values: ``t_{0.5 + level/2, n-1}``
    (``= scipy.stats.t.ppf(0.5 + level / 2, n - 1)``), the half-width of a t-interval in SEs."""
    return float(_sc.stdtrit(n - 1, 0.5 + level / 2))


def mean_and_se(values: np.ndarray) -> tuple[float | None, float | None, int]:
    """Mean, standard error (std ddof 1 over sqrt(n)) and n of the finite values."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    n = int(v.size)
    if n == 0:
        return None, None, 0
    se = float(np.std(v, ddof=1) / np.sqrt(n)) if n > 1 else None
    return float(np.mean(v)), se, n


def paired_difference(candidate: np.ndarray, reference: np.ndarray, level: float = 0.95) -> PairedDifference:
    """Paired difference of two metrics over the same runs (common random numbers).

    Parameters
    ----------
    candidate, reference
        Per-run values ``(runs,)``, run ``r`` of both seeing the same random numbers. Runs
        where either is not finite (a metric undefined in that run) are left out.
    level
        Confidence level of the t-interval (0.95 in reports).

    Returns
    -------
    PairedDifference
        ``diff = mean(x - y)``, ``se = std(x - y, ddof=1) / sqrt(n)``, the t-interval,
        the ratio of means ``mean(x) / mean(y)`` with its delta-method SE
        ``sqrt(var(x) - 2 R cov(x, y) + R^2 var(y)) / (mean(y) sqrt(n))``.

    Examples
    --------
    >>> pd = paired_difference(np.array([1.0, 2.0, 3.0, 4.0]), np.array([0.5, 1.5, 2.0, 3.5]))
    >>> pd.n, pd.diff, pd.se, pd.significant
    (4, 0.625, 0.125, True)
    """
    x = np.asarray(candidate, dtype=float)
    y = np.asarray(reference, dtype=float)
    if x.shape != y.shape:
        raise ValueError(f"paired values need the same runs: shapes {x.shape} and {y.shape}")
    ok = np.isfinite(x) & np.isfinite(y)
    x, y = x[ok], y[ok]
    n = int(x.size)
    if n == 0:
        return PairedDifference(0, None, None, None, None, None, False, "no run where both values are defined")
    d = x - y
    diff = float(np.mean(d))
    ratio = ratio_se = None
    if np.all(x >= 0) and np.all(y >= 0) and np.mean(y) > 0:
        ratio = float(np.mean(x) / np.mean(y))
    if n < 2:
        return PairedDifference(n, diff, None, None, ratio, None, False, "one pair: no standard error")
    se = float(np.std(d, ddof=1) / np.sqrt(n))
    t = t_quantile(n, level)
    ci = (diff - t * se, diff + t * se)
    if ratio is not None:
        c = np.cov(x, y, ddof=1)
        var_r = c[0, 0] - 2 * ratio * c[0, 1] + ratio**2 * c[1, 1]
        ratio_se = float(np.sqrt(max(var_r, 0.0)) / (np.mean(y) * np.sqrt(n)))
    if at_rounding_level(se, float(np.max(np.abs(np.concatenate([x, y]))))):
        # No spread beyond floating-point rounding (e.g. the same bound in every run): the
        # t-test has nothing to test, so nothing is called significant.
        return PairedDifference(
            n,
            diff,
            0.0,
            (diff, diff),
            ratio,
            ratio_se,
            False,
            "identical values in every run"
            if diff == 0.0
            else "identical values in every run up to floating-point rounding"
            if at_rounding_level(abs(diff), float(np.max(np.abs(np.concatenate([x, y])))))
            else "the same difference in every run (no spread): no significance test",
        )
    return PairedDifference(n, diff, se, ci, ratio, ratio_se, bool(abs(diff) > t * se))


def paired_values(a: dict[int, float], b: dict[int, float]) -> tuple[np.ndarray, np.ndarray]:
    """Values of the runs present in both ``{run: value}`` maps, in run order."""
    runs = sorted(set(a) & set(b))
    return np.array([a[r] for r in runs], dtype=float), np.array([b[r] for r in runs], dtype=float)


def paired_rows(config, store, key: str | None = None) -> list[dict]:
    """One row per case, non-reference candidate and metric: the paired difference to
    ``config.reference_name`` (``PairedDifference.to_json`` plus case/candidate/metric/reference).

    ``config`` is a :class:`~gnssframework.experiments.config.ComparisonConfig`, ``store``
    a :class:`~gnssframework.experiments.store.ResultStore`; ``key`` defaults to the
    config's identity.
    """
    key = key or config.identity()
    ref = config.reference_name
    rows = []
    for case in config.cases:
        for metric in config.metric_names:
            y = store.run_values(key, case.name, ref, metric, config.runs)
            for cand in config.candidates:
                if cand.name == ref:
                    continue
                x = store.run_values(key, case.name, cand.name, metric, config.runs)
                pd = paired_difference(*paired_values(x, y))
                rows.append(
                    {"case": case.name, "candidate": cand.name, "metric": metric, "reference": ref, **pd.to_json()}
                )
    return rows
