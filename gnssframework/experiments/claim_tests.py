"""The statistics behind claims: p-values, multiplicity adjustment, equivalence, resampling, NEES bands.

Every function here is a textbook procedure, written from its definition:

- :func:`holm` — Holm's step-down adjusted p-values (S. Holm, "A simple sequentially
  rejective multiple test procedure", Scand. J. Statist. 6, 1979): with the ``m``
  p-values sorted, ``p~_(i) = max_{j <= i} min(1, (m - j + 1) p_(j))``; rejecting where
  ``p~ < alpha`` keeps the family-wise error rate at ``alpha``.
- :func:`benjamini_hochberg` — the Benjamini-Hochberg adjusted p-values (J. R. Statist.
  Soc. B 57, 1995): ``p~_(i) = min_{j >= i} min(1, m p_(j) / j)``; the false discovery rate
  at ``alpha``.
- :func:`t_p_value` — the p-value of the one-sided t-test of a mean against a bound.
- :func:`tost` — two one-sided tests of equivalence (D. J. Schuirmann, J. Pharmacokin.
  Biopharm. 15, 1987): ``|mean difference| < margin`` is shown when both ``H0: d <= -margin``
  and ``H0: d >= margin`` are rejected at ``alpha``, i.e. when the ``1 - 2 alpha``
  t-interval lies inside ``(-margin, margin)``; its p-value is the larger of the two.
- :func:`bootstrap_means` — the paired (case-resampling) bootstrap of means over runs
  (B. Efron and R. Tibshirani, "An Introduction to the Bootstrap", 1993, ch. 13),
  reproducible from a seed.
- :func:`wilcoxon_p` — the one-sided Wilcoxon signed-rank test of the paired differences
  (scipy's exact or normal-approximation distribution).
- :func:`nees_band` — the two-sided 95 % chi-square band of the averaged NEES
  (Bar-Shalom, Li and Kirubarajan 2001, sec. 5.4.2): ``N`` runs of an ``n``-state
  consistent filter give ``N * ANEES ~ chi2(N n)``, so the band is
  ``[chi2_{0.025}(N n) / N, chi2_{0.975}(N n) / N]``.
- :func:`detectable_difference` — the minimum detectable difference (MDD): the true
  paired mean difference the t-test at ``alpha`` detects with a given power (80 % by
  default) over ``n`` runs whose differences have the standard error ``se = sd / sqrt(n)``
  (J. Cohen, "Statistical Power Analysis for the Behavioral Sciences", 2nd ed., 1988,
  ch. 2): the noncentrality ``delta`` with ``P(T'_{n-1, delta} > t_{1 - alpha/s, n-1}) =
  power`` for the noncentral t ``T'`` (``s = 2`` for the two-sided test, 1 for one-sided),
  times ``se``. The familiar closed form ``(t_{1 - alpha/s, n-1} + t_{power, n-1}) se``
  (the normal-theory sample-size formula with t quantiles in place of z) replaces the
  noncentral t by a shifted central one and falls short of the power at few runs (78.4 %
  instead of 80 % at n = 4, 79.5 % at n = 6), so the exact form is used. The two-sided test's opposite tail (below ``1e-6`` at 80 % power) is left out,
  so the stated difference is conservative by that much. What a claim over few runs can
  see; the power against the difference observed (post-hoc power) is a function of the
  p-value alone and says nothing more (J. M. Hoenig and D. M. Heisey, "The abuse of
  power", Am. Statist. 55(1), 2001), so it is not computed.
- :func:`equivalence_margin_for_power` — the TOST's counterpart of the MDD: the smallest
  margin its two one-sided tests at ``alpha`` show with a given power when the true paired
  difference is 0. With ``Z = mean / se ~ N(0, 1)`` and ``V = s / sigma ~
  sqrt(chi2(n-1) / (n-1))`` independent, TOST rejects iff ``|Z| < k - t_{1-alpha, n-1} V``
  (``k = margin / se``), so its power is ``E_V[max(0, 2 Phi(k - t V) - 1)]`` (the exact
  power at zero difference, as in D. B. Owen, "A special case of a bivariate non-central
  t-distribution", Biometrika 52, 1965, integrated numerically here), solved for ``k``.
- :func:`all_runs_bound` — the exact (Clopper-Pearson) one-sided 95 % upper bound on the
  chance of a run outside a range when none of ``n`` runs was: ``1 - 0.05^(1/n)``.
"""

from __future__ import annotations

import zlib
from collections.abc import Callable

import numpy as np
from scipy import special as _sc  # not scipy.stats: its import costs every run of the CLI a second

__all__ = [
    "holm",
    "benjamini_hochberg",
    "adjust",
    "ADJUSTMENTS",
    "t_p_value",
    "tost",
    "bootstrap_means",
    "BOOTSTRAP_RESAMPLES",
    "wilcoxon_p",
    "nees_band",
    "all_runs_bound",
    "claim_rng",
    "detectable_difference",
    "equivalence_margin_for_power",
]

#: Resamples of every bootstrap interval (the Monte Carlo error of a 2.5 % tail estimate
#: from 10 000 resamples is about 0.16 %).
BOOTSTRAP_RESAMPLES = 10_000


def _in_input_order(p_values, adjusted_sorted: Callable[[np.ndarray, int], np.ndarray]) -> np.ndarray:
    """``adjusted_sorted(p_sorted, m)`` (the adjusted p-values of the ``m`` p-values sorted
    ascending, stably) put back in the input order; an empty input as is."""
    p = np.asarray(p_values, dtype=float)
    m = p.size
    if m == 0:
        return p.copy()
    order = np.argsort(p, kind="stable")
    out = np.empty(m)
    out[order] = adjusted_sorted(p[order], m)
    return out


def holm(p_values) -> np.ndarray:
    """Holm's step-down adjusted p-values, in the input order.

    Examples
    --------
    >>> holm([0.01, 0.04, 0.03]).tolist()
    [0.03, 0.06, 0.06]
    """
    return _in_input_order(p_values, lambda p, m: np.maximum.accumulate(np.minimum(1.0, (m - np.arange(m)) * p)))


def benjamini_hochberg(p_values) -> np.ndarray:
    """Benjamini-Hochberg adjusted p-values (false discovery rate), in the input order.

    Examples
    --------
    >>> benjamini_hochberg([0.01, 0.04, 0.03]).tolist()
    [0.03, 0.04, 0.04]
    """
    return _in_input_order(
        p_values, lambda p, m: np.minimum.accumulate(np.minimum(1.0, p * m / np.arange(1, m + 1))[::-1])[::-1]
    )


#: The multiplicity adjustments a config may choose (``claims_adjustment``).
ADJUSTMENTS = {"holm": holm, "benjamini-hochberg": benjamini_hochberg}


def adjust(p_values, method: str) -> np.ndarray:
    """Adjusted p-values by ``method`` (a key of :data:`ADJUSTMENTS`)."""
    return ADJUSTMENTS[method](p_values)


def t_p_value(estimate: float, se: float, n: int, bound: float, below: bool) -> float:
    """One-sided p-value of "the mean is below (above) ``bound``" from a t-statistic with
    ``n - 1`` degrees of freedom: ``P(T >= t)`` under ``H0: mean >= bound`` (``below``),
    ``t = (estimate - bound) / se`` taken with the sign that makes small p support the claim."""
    t = (bound - estimate) / se if below else (estimate - bound) / se
    return float(_sc.stdtr(n - 1, -t))  # = scipy.stats.t.sf(t, n - 1)


def tost(diff: float, se: float, n: int, margin: float) -> float:
    """The TOST p-value of ``|d| < margin`` (the larger of the two one-sided p-values)."""
    return max(t_p_value(diff, se, n, margin, below=True), t_p_value(diff, se, n, -margin, below=False))


def claim_rng(seed: int, claim: int, where: str) -> np.random.Generator:
    """The generator of one claim's resampling in one case: from the comparison's seed, the
    claim's index and where it is evaluated, so every report reproduces it."""
    return np.random.default_rng([seed, claim, zlib.crc32(where.encode())])


def bootstrap_means(
    x: np.ndarray, y: np.ndarray | None, rng: np.random.Generator, resamples: int = BOOTSTRAP_RESAMPLES
) -> tuple[np.ndarray, np.ndarray | None]:
    """Means of ``resamples`` paired resamples of the runs: ``(mean x*, mean y*)`` (``y``
    resampled with the same run indices as ``x``; ``None`` without ``y``)."""
    n = x.size
    idx = rng.integers(0, n, size=(resamples, n))
    return x[idx].mean(axis=1), (None if y is None else y[idx].mean(axis=1))


def bootstrap_p(draws: np.ndarray, bound: float, below: bool) -> float:
    """One-sided bootstrap p-value of "the statistic is below (above) ``bound``": the share
    of resampled statistics on the other side (``(k + 1) / (B + 1)``, never 0)."""
    other = np.count_nonzero(draws >= bound) if below else np.count_nonzero(draws <= bound)
    return float((other + 1) / (draws.size + 1))


def wilcoxon_p(d: np.ndarray, below: bool) -> float:
    """One-sided Wilcoxon signed-rank p-value of "the differences ``d`` lie below (above) 0"
    (their pseudo-median; zero differences dropped as Wilcoxon did)."""
    from scipy.stats import wilcoxon  # only for claims that ask for it

    return float(wilcoxon(d, alternative="less" if below else "greater", zero_method="wilcox").pvalue)


def nees_band(runs: int, states: int, level: float = 0.95) -> tuple[float, float]:
    """The two-sided ``level`` band of the averaged NEES of ``runs`` runs of a consistent
    ``states``-dimensional estimate: ``[chi2_{a/2}(N n) / N, chi2_{1-a/2}(N n) / N]``."""
    dof = runs * states
    tail = (1.0 - level) / 2
    # chdtri(k, q) is the chi-square quantile of the upper tail q (= scipy.stats.chi2.isf(q, k)).
    return float(_sc.chdtri(dof, 1.0 - tail)) / runs, float(_sc.chdtri(dof, tail)) / runs


def all_runs_bound(runs: int, level: float = 0.95) -> float:
    """Exact one-sided ``level`` upper bound on the chance of a run outside a range when
    none of ``runs`` runs was (Clopper-Pearson with 0 events: ``1 - (1 - level)^(1/n)``)."""
    return float(1.0 - (1.0 - level) ** (1.0 / runs))


def detectable_difference(se: float, n: int, power: float = 0.8, alpha: float = 0.05, sides: int = 2) -> float:
    """The minimum detectable difference: the true paired mean difference the ``sides``-sided
    t-test at ``alpha`` detects with probability ``power`` over ``n`` runs of standard
    error ``se`` (see the module docstring).

    .. math:: \\mathrm{MDD} = \\delta\\,\\mathrm{se}, \\quad
              P(T'_{n-1,\\delta} > t_{1-\\alpha/s,\\,n-1}) = \\text{power}

    A claim's 95 % interval on the claimed side is the two-sided test at 5 % (``sides = 2``,
    the default); a one-sided test at ``alpha`` is ``sides = 1``.
    """
    if sides not in (1, 2):
        raise ValueError(f"sides = {sides!r}: a t-test is one-sided (1) or two-sided (2)")
    t_crit = float(_sc.stdtrit(n - 1, 1.0 - alpha / sides))
    return float(se) * float(_sc.nctdtrinc(n - 1, 1.0 - power, t_crit))


def equivalence_margin_for_power(se: float, n: int, power: float = 0.8, alpha: float = 0.05) -> float:
    """The smallest margin the TOST at ``alpha`` per side shows with probability ``power``
    over ``n`` runs of standard error ``se`` when the true difference is 0 (see the module
    docstring): ``k se`` with ``E_V[max(0, 2 Phi(k - t_{1-alpha,n-1} V) - 1)] = power``."""
    from scipy import integrate, optimize  # only for an equivalence claim over few runs

    dof = n - 1
    t_crit = float(_sc.stdtrit(dof, 1.0 - alpha))

    def tost_power(k: float) -> float:
        # Over q = chi2(dof) draws: V = sqrt(q / dof); the integrand is 0 beyond V = k / t.
        top = dof * (k / t_crit) ** 2
        value, _ = integrate.quad(
            lambda q: (
                (2.0 * _sc.ndtr(k - t_crit * np.sqrt(q / dof)) - 1.0)
                * np.exp(_sc.xlogy(dof / 2 - 1, q) - q / 2 - _sc.gammaln(dof / 2) - dof / 2 * np.log(2.0))
            ),
            0.0,
            top,
            limit=200,
        )
        return float(value)

    k = optimize.brentq(lambda k: tost_power(k) - power, t_crit, t_crit + 60.0, xtol=1e-10)
    return float(se) * float(k)
