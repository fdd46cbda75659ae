"""The plugin testing kit passes the built-ins and catches planted bugs."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import gnssframework as gf
from gnssframework import testing


@pytest.mark.parametrize("name", ["kf", "ekf", "ukf", "ckf", "svd-ckf"])
def test_builtin_estimators_pass_the_estimator_checks(name):
    est = gf.registry.create("estimator", name)
    testing.check_exact_on_linear(est)
    testing.check_batched_equals_one_by_one(est)


def test_exact_on_linear_catches_a_wrong_covariance():
    ckf = gf.registry.create("estimator", "ckf")

    class Inflated(type(ckf)):
        def update(self, prior, z, model, **kw):
            out = super().update(prior, z, model, **kw)
            return dataclasses.replace(out, state=gf.Gaussian(out.state.mean, 1.01 * out.state.cov))  # 1 % off

    with pytest.raises(AssertionError, match="cov differs from the KF"):
        testing.check_exact_on_linear(Inflated())


def test_batched_check_catches_cross_talk_between_batch_elements():
    kf = gf.registry.create("estimator", "kf")

    class CrossTalk(type(kf)):
        def update(self, prior, z, model, **kw):
            out = super().update(prior, z, model, **kw)
            mean = out.state.mean + 1e-6 * out.state.mean.mean(axis=tuple(range(out.state.mean.ndim - 1)))
            return dataclasses.replace(out, state=gf.Gaussian(mean, out.state.cov))

    with pytest.raises(AssertionError, match="batch element"):
        testing.check_batched_equals_one_by_one(CrossTalk())


def test_psd_check_refuses_asymmetric_indefinite_and_nan():
    testing.check_covariance_psd(np.diag([1.0, 0.0]))
    for bad, words in (
        (np.array([[1.0, 0.5], [0.0, 1.0]]), "not symmetric"),
        (np.diag([1.0, -1e-3]), "not PSD"),
        (np.diag([np.nan, 1.0]), "NaN"),
    ):
        with pytest.raises(AssertionError, match=words):
            testing.check_covariance_psd(bad)


@pytest.mark.parametrize(
    "name, errors", [("eml-envelope", [-1e-3, 1e-3]), ("costas-atan", [-0.05, 0.05]), ("atan2-fll", [-0.2, 0.2])]
)
def test_builtin_discriminators_pass_the_slope_and_noise_checks(name, errors):
    d = gf.registry.create("discriminator", name, coherent_time_s=0.01)
    testing.check_unit_slope(d, errors)
    testing.check_noise_variance(d, 45.0, np.random.default_rng(3), runs=20_000)


def test_slope_and_noise_checks_catch_a_wrong_scale_and_a_wrong_variance():
    d = gf.registry.create("discriminator", "costas-atan", coherent_time_s=0.01)

    class Doubled(type(d)):
        def __call__(self, current, previous=None):
            return 2 * super().__call__(current, previous)

    class Optimistic(type(d)):
        def noise_variance(self, cn0_dbhz):
            return 0.5 * super().noise_variance(cn0_dbhz)

    with pytest.raises(AssertionError, match="slope"):
        testing.check_unit_slope(Doubled(coherent_time_s=0.01), [0.05])
    with pytest.raises(AssertionError, match="Monte Carlo variance"):
        testing.check_noise_variance(Optimistic(coherent_time_s=0.01), 45.0, np.random.default_rng(4), runs=20_000)


def test_rounding_yardstick_passes_a_reordered_recursion_and_catches_a_dropped_term():
    # A scalar Riccati-like recursion with a strong dependence on its start: the same
    # formula with its two sums reordered stays within the measured rounding, one with a
    # term scaled by 1 + 1e-9 does not.
    def run(p0, variant="plain"):
        p, out = p0, []
        for k in range(200):
            a, b, c = 1.01 * p, 1e-3 * (k % 7), 1.1e-7 * k
            p = a + (b + c) if variant == "reordered" else (a + b) + c
            if variant == "biased":
                p = a * (1 + 1e-9) + b + c
            p = p / (1 + 1e-3 * p)
            out.append(p)
        return np.array(out)

    p0 = np.array(123.456)
    reference = run(p0)
    nudged = [run(p) for p in testing.ulp_nudges(p0)]
    diff, moved = testing.assert_within_rounding(run(p0, "reordered"), reference, nudged)
    assert 0 < diff <= moved * 10  # the reordering does change the rounding
    with pytest.raises(AssertionError, match="differs from the reference by"):
        testing.assert_within_rounding(run(p0, "biased"), reference, nudged, what="biased")
    # parts are normalised one by one; a dict or tuple of arrays is one result
    assert testing.relative_change({"a": np.ones(3), "b": np.zeros(2)}, {"a": np.ones(3), "b": np.ones(2)}) == 1.0
    assert testing.relative_change((np.ones(2), 2 * np.ones(2)), (np.ones(2), 3 * np.ones(2))) == 0.5
    with pytest.raises(AssertionError, match="shapes differ"):
        testing.relative_change(np.ones(2), np.ones(3))
    up, down = testing.ulp_nudges(np.array([1.0, -2.0]))
    assert np.all(up > [1.0, -2.0]) and np.all(down < [1.0, -2.0])
