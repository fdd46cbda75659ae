"""The fitted-curve threshold: Firth's estimate against the penalised likelihood's maximum
for every link, the crossing's reading, coverage of a known threshold where interpolation
misses it, the link chosen by the deviance, the deviance test, and a separated curve's
widened interval."""

import numpy as np
import pytest
from scipy import optimize, stats

from gnssframework.experiments.threshold import bootstrap_thresholds
from gnssframework.experiments.threshold_fit import (
    LINKS,
    best_link_fit,
    deviance_test,
    firth_binomial,
    firth_logistic,
    fitted_crossing,
)

X = np.arange(15.0, 45.1, 2.5)
CURVES = {
    "one point in the transition": [60, 60, 60, 60, 29, 0, 0, 0, 0, 0, 0, 0, 0],
    "separated": [60, 60, 60, 60, 60, 0, 0, 0, 0, 0, 0, 0, 0],
    "gradual": [60, 55, 50, 40, 30, 25, 10, 5, 2, 0, 0, 0, 1],
    "never lost": [0] * 13,
    "always lost": [60] * 13,
}


#: Each link's inverse as a distribution of scipy.stats: the oracle's F, 1 - F and F'
#: come from there, not from the module's own formulas.
DISTRIBUTIONS = {"logistic": stats.logistic, "probit": stats.norm, "cloglog": stats.gumbel_l, "loglog": stats.gumbel_r}


def _penalised(beta, z, k, n, link="logistic"):
    r"""Minus Firth's penalised log-likelihood, written from its definition (Firth 1993):
    the binomial log-likelihood plus half the log-determinant of the Fisher information
    :math:`\sum_i n_i f_i^2 / (\pi_i (1 - \pi_i))\, z_i z_i^T`."""
    d = DISTRIBUTIONS[link]
    eta = beta[0] + beta[1] * z
    log_p, log_q, log_f = d.logcdf(eta), d.logsf(eta), d.logpdf(eta)
    loglik = np.sum(k * log_p + (n - k) * log_q)
    w = n * np.exp(2 * log_f - log_p - log_q)
    info = np.array([[w.sum(), (w * z).sum()], [(w * z).sum(), (w * z * z).sum()]])
    return -(loglik + 0.5 * np.linalg.slogdet(info)[1])


def test_the_links_are_the_distributions_they_name():
    eta = np.linspace(-6.0, 6.0, 25)
    for name, d in DISTRIBUTIONS.items():
        link = LINKS[name]
        np.testing.assert_allclose(link.cdf(eta), d.cdf(eta), rtol=1e-12, atol=1e-300)
        np.testing.assert_allclose(link.log_p(eta), d.logcdf(eta), rtol=1e-10)
        np.testing.assert_allclose(link.log_q(eta), d.logsf(eta), rtol=1e-10)
        np.testing.assert_allclose(link.log_f(eta), d.logpdf(eta), rtol=1e-10)
        h = 1e-5  # (log f)' against a central difference of scipy's log-density
        np.testing.assert_allclose(link.dlog_f(eta), (d.logpdf(eta + h) - d.logpdf(eta - h)) / (2 * h), atol=1e-6)
        for level in (0.05, 0.5, 0.9):
            assert link.quantile(level) == pytest.approx(d.ppf(level), rel=1e-12)


@pytest.mark.parametrize("link", list(LINKS))
@pytest.mark.parametrize("name", list(CURVES))
def test_firth_estimate_maximises_the_penalised_likelihood(name, link):
    k = np.array(CURVES[name], float)
    fit = firth_binomial(X, k, 60, link)
    assert fit.converged
    z = (X - fit.centre) / fit.spread
    best = optimize.minimize(
        _penalised,
        [0.0, 0.0],
        args=(z, k, 60.0, link),
        method="Nelder-Mead",
        options={"xatol": 1e-10, "fatol": 1e-13, "maxiter": 20000},
    )
    # the modified score's root and the objective's maximum: the same point (Nelder-Mead's
    # own tolerance on the objective, 1e-13, leaves about 1e-6 in the parameters)
    np.testing.assert_allclose(fit.beta, best.x, atol=1e-5 * max(1.0, np.abs(best.x).max()))
    assert _penalised(fit.beta, z, k, 60.0, link) <= best.fun + 1e-9


def test_fits_are_batched_over_trailing_axes():
    k = np.array(list(CURVES.values()), float).T  # (points, curves)
    both = firth_logistic(X, np.stack([k, k[:, ::-1]], axis=-1), 60)  # (points, curves, 2)
    for j in range(k.shape[1]):
        for half, curve in enumerate((k[:, j], k[:, ::-1][:, j])):
            one = firth_logistic(X, curve, 60)
            np.testing.assert_allclose(both.beta[j, half], one.beta, rtol=1e-9, atol=1e-12)


def test_the_crossing_is_read_as_interpolation_reads_it():
    fit = firth_logistic(X, np.array(CURVES["separated"], float), 60)
    # separated between 25 and 27.5: the penalised curve crosses 0.5 at the gap's middle
    assert float(fitted_crossing(fit, X, 0.5)) == pytest.approx(26.25, abs=1e-9)
    assert fitted_crossing(firth_logistic(X, np.array(CURVES["never lost"], float), 60), X, 0.5) == -np.inf
    assert fitted_crossing(firth_logistic(X, np.array(CURVES["always lost"], float), 60), X, 0.5) == np.inf
    # a curve rising with x: read from the top as interpolation reads it (lost at the top
    # point: above the grid; below the level there: no crossing in the grid, below it)
    rising = firth_logistic(X, np.array(CURVES["gradual"][::-1], float), 60)
    assert rising.beta[1] > 0 and fitted_crossing(rising, X, 0.5) == np.inf
    slight = firth_logistic(X, np.array([0] * 10 + [1, 2, 3], float), 60)
    assert slight.beta[1] > 0 and fitted_crossing(slight, X, 0.5) == -np.inf
    # the crossing is where the fitted curve equals the level
    gradual = firth_logistic(X, np.array(CURVES["gradual"], float), 60)
    for level in (0.1, 0.5, 0.9):
        xt = float(fitted_crossing(gradual, X, level))
        assert gradual.probability(np.array([xt]))[0] == pytest.approx(level, abs=1e-12)


def _coverage(shape, runs, fits=("linear", "logistic"), level=0.1, reps=120, seed=5):
    """Coverage of a known threshold (level 0.1 of a curve of scale 1.5 dB centred at 23 dB-Hz,
    on a 5 dB grid) by each reading's 95 % interval over ``reps`` replications."""
    from scipy import stats

    x = np.array([15.0, 20.0, 25.0, 30.0, 35.0])
    sf = {"logistic": stats.logistic, "gumbel": stats.gumbel_r}[shape]
    truth = 23.0 + 1.5 * sf.isf(level)
    p = sf.sf((x - 23.0) / 1.5)
    rng = np.random.default_rng(seed)
    covered = dict.fromkeys(fits, 0)
    for _ in range(reps):
        lost = (rng.random((x.size, runs)) < p[:, None]).astype(float)
        for fit in covered:
            _, lo, hi = bootstrap_thresholds(x, {"a": lost}, level, 400, rng, fit=fit)["threshold"]["a"]
            covered[fit] += lo <= truth <= hi
    return covered


def test_a_fitted_curve_covers_a_tail_threshold_that_interpolation_misses():
    """Level 0.1 of a logistic curve on a 5 dB grid: the interpolated curve crosses 1.4 dB
    above the truth (27.7 against 26.3), so with 200 runs a point the interpolation's
    interval covers the truth in about 20 % of replications (21 of 120 measured), the
    fitted curve's in about 95 % (115 of 120), the best link's too (115 of 120). Bounds: 85 %
    for the fits (the binomial 1 % tail of 120 at 95 %), below half for interpolation."""
    covered = _coverage("logistic", runs=200, fits=("linear", "logistic", "best"))
    assert covered["logistic"] >= 0.85 * 120 and covered["best"] >= 0.85 * 120, covered
    assert covered["linear"] <= 0.5 * 120, covered


def test_a_wrong_shape_costs_the_fit_coverage_and_the_deviance_test_sees_it():
    """A Gumbel-shaped curve (asymmetric; the cloglog link's shape): the logistic fit's
    interval covers the truth less often than 95 % (66 of 120 measured) but still far more
    often than interpolation's (4 of 120); the cloglog fit's covers it (120 of 120), and so
    does the best link's more often than the logistic one's (103 of 120: the choice's noise
    on a five-point grid costs it some). The deviance test rejects the logistic shape on
    such data more often than it rejects a logistic curve's (at 5 %)."""
    covered = _coverage("gumbel", runs=200, fits=("linear", "logistic", "cloglog", "best"))
    assert covered["logistic"] < 0.85 * 120 and covered["logistic"] > 2 * covered["linear"], covered
    assert covered["cloglog"] >= 0.85 * 120, covered
    assert covered["best"] >= 0.75 * 120 and covered["best"] > covered["logistic"], covered
    from scipy import stats

    x = np.arange(15.0, 35.1, 2.5)
    rng = np.random.default_rng(8)
    rejected = {}
    for shape, dist in {"logistic": stats.logistic, "gumbel": stats.gumbel_r}.items():
        p = dist.sf((x - 23.0) / 1.5)
        k = rng.binomial(400, p[:, None], size=(x.size, 200)).astype(float)
        fits = firth_logistic(x, k, 400)
        pv = np.array([deviance_test(firth_logistic(x, k[:, j], 400), x, k[:, j], 400)[2] for j in range(k.shape[1])])
        assert fits.converged
        rejected[shape] = float(np.mean(pv < 0.05))
    # a right shape: rejected at about the test's level (the saturated points make it
    # conservative); the wrong one: rejected in most data sets
    assert rejected["logistic"] <= 0.12, rejected
    assert rejected["gumbel"] >= 0.5, rejected


def test_the_best_link_is_the_shape_of_the_data():
    """400 runs a point on a 2.5 dB grid, 200 data sets per shape: a Gumbel-shaped curve is
    fitted best by cloglog (200 of 200 measured), a logistic one by a symmetric link
    (logistic 183, probit 17, never an asymmetric one); the right link's deviance test
    rejects at about its level (1 of 50 at 5 %)."""
    x = np.arange(15.0, 35.1, 2.5)
    rng = np.random.default_rng(9)
    chosen = {}
    for shape, dist in {"logistic": stats.logistic, "gumbel": stats.gumbel_r}.items():
        k = rng.binomial(400, dist.sf((x - 23.0) / 1.5)[:, None], size=(x.size, 200)).astype(float)
        fit = best_link_fit(x, k, 400)
        assert fit.converged and fit.link.shape == (200,)
        chosen[shape] = {name: float(np.mean(fit.link == name)) for name in LINKS}
        # each curve's fit is its link's own fit
        j = int(np.argmax(fit.link == fit.link[0]))
        np.testing.assert_allclose(fit.beta[j], firth_binomial(x, k[:, j], 400, fit.link[j]).beta, atol=1e-9)
        if shape == "gumbel":
            pv = [deviance_test(firth_binomial(x, k[:, j], 400, "cloglog"), x, k[:, j], 400)[2] for j in range(50)]
            assert np.mean(np.array(pv) < 0.05) <= 0.16, pv
    assert chosen["gumbel"]["cloglog"] >= 0.9, chosen
    assert chosen["logistic"]["cloglog"] + chosen["logistic"]["loglog"] <= 0.1, chosen
    assert chosen["logistic"]["logistic"] + chosen["logistic"]["probit"] >= 0.9, chosen


def test_every_link_reads_its_own_crossing():
    k = np.array(CURVES["gradual"], float)
    for name in LINKS:
        fit = firth_binomial(X, k, 60, name)
        for level in (0.1, 0.5, 0.9):
            xt = float(fitted_crossing(fit, X, level))
            if xt == -np.inf:  # the curve is below the level at the grid's bottom already
                assert fit.probability(X[:1])[0] < level, (name, level)
            else:
                assert fit.probability(np.array([xt]))[0] == pytest.approx(level, abs=1e-12)
    # a batch of curves with different links: each read with its own
    both = best_link_fit(X, np.stack([k, np.array(CURVES["one point in the transition"], float)], axis=-1), 60)
    xt = fitted_crossing(both, X, 0.2)
    p = both.probability(xt)  # (2 values, 2 curves): the diagonal is each curve at its own crossing
    np.testing.assert_allclose(np.diag(p), 0.2, atol=1e-12)


def test_deviance_is_zero_for_a_curve_the_model_fits_exactly():
    x = np.array([20.0, 25.0])  # two points, two parameters: the saturated model itself
    fit = firth_logistic(x, np.array([45.0, 15.0]), 60)
    dev, df, p = deviance_test(fit, x, np.array([45.0, 15.0]), 60)
    # Firth's estimate shrinks toward 1/2 by O(1/n): not exactly the saturated fit
    assert df == 0 and np.isnan(p) and 0 <= dev < 0.1


def test_a_separated_curve_gets_its_grid_interval_and_a_widened_difference():
    x = np.array([20.0, 25.0, 30.0, 35.0])
    a = np.array([np.ones(40), np.ones(40), np.zeros(40), np.zeros(40)])  # separated in [25, 30]
    u = np.random.default_rng(1).random(40)
    b = np.array([np.ones(40), (u < 0.5) * 1.0, np.zeros(40), np.zeros(40)])
    out = bootstrap_thresholds(x, {"a": a, "b": b}, 0.5, 300, np.random.default_rng(0), fit="logistic")
    est, lo, hi = out["threshold"]["a"]
    assert 25.0 < est < 30.0
    assert (lo, hi) == (25.0, 30.0)  # every resample is the same curve: the gap is the interval
    assert out["fit"]["a"]["separated"] and out["fit"]["a"]["gap"] == (25.0, 30.0)
    assert not out["fit"]["b"]["separated"]
    from gnssframework.experiments.threshold import _difference_bounds, _differences

    d = _differences(out["samples"]["b"], out["samples"]["a"])
    narrow = _difference_bounds(d, out["threshold"]["b"][1:], (lo, hi), separated=False)
    wide = _difference_bounds(d, out["threshold"]["b"][1:], (lo, hi), separated=True)
    assert wide[0] <= narrow[0] and wide[1] >= narrow[1]
    assert wide[0] <= out["threshold"]["b"][1] - 30.0 and wide[1] >= out["threshold"]["b"][2] - 25.0


def test_bad_input_is_refused_in_one_line():
    with pytest.raises(ValueError, match="two distinct"):
        firth_logistic(np.array([20.0, 20.0]), np.array([1.0, 2.0]), 10)
    with pytest.raises(ValueError, match="3 points, x 2"):
        firth_logistic(np.array([20.0, 25.0]), np.array([1.0, 2.0, 3.0]), 10)
    with pytest.raises(ValueError, match="outside"):
        firth_logistic(np.array([20.0, 25.0]), np.array([1.0, 11.0]), 10)
    with pytest.raises(ValueError, match="unknown link 'weibull'"):
        firth_binomial(np.array([20.0, 25.0]), np.array([1.0, 2.0]), 10, "weibull")
