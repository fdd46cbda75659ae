"""Kaplan-Meier estimator against a hand-computed example and the exponential closed form."""

import numpy as np
import pytest

from gnssframework.experiments.survival import exponential_mean_mle, kaplan_meier


def test_kaplan_meier_matches_a_hand_computed_product_limit():
    # times 1, 2+, 3, 3, 4+, 5: at 1: 6 at risk, 1 event -> 5/6; at 3: 4 at risk, 2 events -> 5/6 * 2/4;
    # at 5: 1 at risk, 1 event -> 0.
    km = kaplan_meier([1, 2, 3, 3, 4, 5], [1, 0, 1, 1, 0, 1])
    np.testing.assert_allclose(km.times, [1, 3, 5])
    np.testing.assert_allclose(km.at_risk, [6, 4, 1])
    np.testing.assert_allclose(km.survival, [5 / 6, 5 / 12, 0.0])
    # Greenwood at t = 3: S^2 (1/(6*5) + 2/(4*2))
    assert km.variance[1] == pytest.approx((5 / 12) ** 2 * (1 / 30 + 2 / 8))
    np.testing.assert_allclose(km([0.5, 1.0, 2.9, 3.0, 10.0]), [1.0, 5 / 6, 5 / 6, 5 / 12, 0.0])
    # area under the steps up to 4: 1*1 + 5/6*2 + 5/12*1
    assert km.restricted_mean(4.0) == pytest.approx(1 + 5 / 3 + 5 / 12)


def test_kaplan_meier_recovers_exponential_survival_under_random_censoring():
    rng = np.random.default_rng(5)
    n, rate, censor_rate = 4000, 0.5, 0.3
    life = rng.exponential(1 / rate, n)
    censor = rng.exponential(1 / censor_rate, n)
    t, seen = np.minimum(life, censor), life <= censor
    km = kaplan_meier(t, seen)
    for x in (0.5, 1.0, 2.0, 4.0):
        s = km(x)
        sd = np.sqrt(km.variance[np.searchsorted(km.times, x, side="right") - 1])
        assert abs(s - np.exp(-rate * x)) < 4 * sd, (x, s, sd)
    tau = 3.0
    closed = (1 - np.exp(-rate * tau)) / rate  # restricted mean of an exponential lifetime
    assert km.restricted_mean(tau) == pytest.approx(closed, abs=0.05)  # SE about 0.015 at n = 4000
    # the exponential MLE: time at risk / events, SE about mean / sqrt(events)
    events = seen.sum()
    assert abs(exponential_mean_mle(t, seen) - 1 / rate) < 4 * (1 / rate) / np.sqrt(events)


def test_restricted_mean_with_a_common_horizon_is_the_mean_of_truncated_lifetimes():
    rng = np.random.default_rng(1)
    life = rng.exponential(2.0, 300)
    tau = 1.5
    km = kaplan_meier(np.minimum(life, tau), life <= tau)
    assert km.restricted_mean(tau) == pytest.approx(np.mean(np.minimum(life, tau)), rel=1e-12)


def test_kaplan_meier_refuses_bad_input():
    with pytest.raises(ValueError, match="one shape"):
        kaplan_meier([1.0, 2.0], [1])
    with pytest.raises(ValueError, match="non-negative"):
        kaplan_meier([-1.0], [1])
