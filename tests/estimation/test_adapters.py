"""Noise adapters: safeguards, learning R, and never making a stable filter run away.

The setting of the foundation issue: a constant-acceleration model whose true R is 4x
the assumed one, started from P0 = 10 I.
"""

from __future__ import annotations

import numpy as np
import pytest

import gnssframework as gf
from conftest import ca_matrices, create, simulate_linear

R_ASSUMED, R_TRUE = 1.0, 4.0
RUNS, STEPS, SETTLE = 200, 400, 50

ADAPTERS = {
    "innovation": ("innovation", {}),
    "sage-husa classic (R)": ("sage-husa", {"variant": "classic", "estimate_q": False}),
    "sage-husa classic (Q and R)": ("sage-husa", {"variant": "classic"}),
    "sage-husa improved": ("sage-husa", {"variant": "improved", "alpha_r": 0.5, "alpha_q": 0.5}),
    "ml-q": ("ml-q", {}),
}


@pytest.fixture(scope="module")
def ca_problem():
    rng = np.random.default_rng(4)
    F, H, Q = ca_matrices(q=0.01)
    xs, zs = simulate_linear(rng, F, H, Q, np.array([[R_TRUE]]), np.zeros(3), STEPS, (RUNS,))
    init = gf.Gaussian(np.zeros(3), 10 * np.eye(3))
    return F, H, Q, xs, zs, init


def _rmse(res, xs):
    return np.sqrt(np.mean((res.mean[SETTLE:, :, 0] - xs[SETTLE:, :, 0]) ** 2))


@pytest.fixture(scope="module")
def reference_rmse(ca_problem):
    F, H, Q, xs, zs, init = ca_problem
    res = gf.filter_sequence(create("estimator", "ukf", alpha=0.5), gf.LinearModel(F, H, Q, [[R_TRUE]]), zs, init)
    return _rmse(res, xs)


@pytest.fixture(scope="module")
def adapted(ca_problem):
    F, H, Q, xs, zs, init = ca_problem
    model = gf.LinearModel(F, H, Q, [[R_ASSUMED]])
    out = {}
    for label, (name, params) in ADAPTERS.items():
        adapter = create("noise_adapter", name, **params)
        out[label] = gf.filter_sequence(create("estimator", "ukf", alpha=0.5), model, zs, init, adapter=adapter)
    return out


@pytest.mark.slow
@pytest.mark.parametrize("label", ADAPTERS)
def test_adapted_covariances_stay_pd_and_finite(adapted, label):
    res = adapted[label]
    warm = 11  # the estimate after the warm-up (10 updates) is used from step 11
    Q0 = res.Q[0, 0]  # rank-deficient by design (Gamma q Gamma^T); untouched Q may stay so
    adapted_q = res.Q[warm:][~np.all(res.Q[warm:] == Q0, axis=(-2, -1))]
    for cov in (adapted_q, res.R):
        assert np.isfinite(cov).all()
        assert cov.size == 0 or np.linalg.eigvalsh(cov).min() > 0


@pytest.mark.parametrize("label", ["innovation", "sage-husa classic (R)"])
def test_adapters_learn_r_within_30_percent(adapted, label):
    learned = np.median(adapted[label].R[-100:, :, 0, 0].mean(axis=0))
    assert learned == pytest.approx(R_TRUE, rel=0.30)


def test_adapters_actually_moved_r_and_q(adapted):
    # Guards the two tests above against an adapter that silently does nothing.
    assert np.median(adapted["sage-husa improved"].R[-1]) > 1.5 * R_ASSUMED
    q0 = np.trace(adapted["ml-q"].Q[0, 0])
    assert not np.allclose(np.trace(adapted["ml-q"].Q[-1], axis1=-2, axis2=-1), q0)


@pytest.mark.parametrize("label", ADAPTERS)
def test_adapted_error_stays_within_2_5x_of_the_filter_that_knows_r(adapted, reference_rmse, ca_problem, label):
    xs = ca_problem[3]
    assert _rmse(adapted[label], xs) < 2.5 * reference_rmse


def test_without_the_safeguards_the_published_recursion_runs_away(ca_problem, reference_rmse):
    # The same classic Sage-Husa with the Q floor lowered to 1 %: Q collapses, R
    # inflates and the error explodes. This is what the default q_floor prevents.
    F, H, Q, xs, zs, init = ca_problem
    adapter = create("noise_adapter", "sage-husa", variant="classic", q_floor=0.01)
    res = gf.filter_sequence(
        create("estimator", "ukf", alpha=0.5), gf.LinearModel(F, H, Q, [[R_ASSUMED]]), zs, init, adapter=adapter
    )
    assert _rmse(res, xs) > 2.5 * reference_rmse


def test_adapter_estimate_is_used_from_the_next_step(ca_problem):
    F, H, Q, xs, zs, init = ca_problem
    adapter = create("noise_adapter", "innovation", warmup=0, window=5)
    res = gf.filter_sequence(
        create("estimator", "kf"), gf.LinearModel(F, H, Q, [[R_ASSUMED]]), zs[:3], init, adapter=adapter
    )
    assert np.all(res.R[0] == R_ASSUMED)
    assert not np.allclose(res.R[1], R_ASSUMED)


def test_improved_sage_husa_with_zero_weights_is_the_plain_filter(ca_problem):
    F, H, Q, xs, zs, init = ca_problem
    model = gf.LinearModel(F, H, Q, [[R_ASSUMED]])
    kf = create("estimator", "kf")
    plain = gf.filter_sequence(kf, model, zs[:50], init)
    off = gf.filter_sequence(
        kf, model, zs[:50], init, adapter=create("noise_adapter", "sage-husa", alpha_r=0.0, alpha_q=0.0)
    )
    np.testing.assert_allclose(off.mean, plain.mean, rtol=1e-12)
