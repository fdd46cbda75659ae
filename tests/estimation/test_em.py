"""Learned noise by EM (`gnssframework.estimation.em`) and the smoother's lag-one covariance.

Independent truths:
- the lag-one covariance against the joint Gaussian posterior of a small time-varying
  model by dense least squares (no recursion);
- the log-likelihood against a plain NumPy Kalman filter written here;
- EM's fixed point against a direct maximum likelihood by ``scipy.optimize`` on that
  independent likelihood;
- the estimates against the simulated Q and R, with the standard error from the spread of
  the per-run estimates (Monte Carlo).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize

import gnssframework as gf
from gnssframework.errors import ConfigError
from gnssframework.estimation import Gaussian, LinearModel, NonlinearModel, learn_noise
from gnssframework.estimation.em import em_step, log_likelihood
from conftest import create, random_pd

F = np.array([[0.95, 0.1], [0.0, 0.9]])
H = np.eye(2)
Q_TRUE = np.diag([0.2, 0.05])
R_TRUE = np.diag([1.0, 0.5])
INITIAL = Gaussian(np.zeros(2), np.eye(2))


def simulate(rng, K: int, B: int) -> np.ndarray:
    """``(K, B, 2)`` measurements of the model above from x_{-1} ~ INITIAL."""
    x = rng.multivariate_normal(INITIAL.mean, INITIAL.cov, B)
    zs = np.empty((K, B, 2))
    for k in range(K):
        x = x @ F.T + rng.multivariate_normal(np.zeros(2), Q_TRUE, B)
        zs[k] = x @ H.T + rng.multivariate_normal(np.zeros(2), R_TRUE, B)
    return zs


def numpy_kf_loglik(zs: np.ndarray, Q: np.ndarray, R: np.ndarray) -> np.ndarray:
    """Innovations log-likelihood per run by a plain Kalman filter (no library code)."""
    K, B, m = zs.shape
    x = np.broadcast_to(INITIAL.mean, (B, 2)).copy()
    P = np.broadcast_to(INITIAL.cov, (B, 2, 2)).copy()
    ll = np.zeros(B)
    for k in range(K):
        x = x @ F.T
        P = F @ P @ F.T + Q
        S = H @ P @ H.T + R
        nu = zs[k] - x @ H.T
        Sinv = np.linalg.inv(S)
        ll += -0.5 * (m * np.log(2 * np.pi) + np.linalg.slogdet(S)[1] + np.einsum("bi,bij,bj->b", nu, Sinv, nu))
        G = P @ H.T @ Sinv
        x = x + np.einsum("bij,bj->bi", G, nu)
        P = P - G @ S @ np.swapaxes(G, -1, -2)
    return ll


def direct_ml(zs: np.ndarray):
    """Maximum likelihood over diagonal Q and R (log parameters) by BFGS on `numpy_kf_loglik`
    of one run, per step; the central-difference gradient's 8 points filtered as one batch."""
    K = zs.shape[0]

    def negative(thetas):  # (P, 4) -> (P,)
        thetas = np.atleast_2d(thetas)
        eye = np.eye(2)
        Q, R = np.exp(thetas[:, :2])[:, None, :] * eye, np.exp(thetas[:, 2:])[:, None, :] * eye
        return -numpy_kf_loglik(np.broadcast_to(zs[:, :1], (K, len(thetas), 2)), Q, R) / K

    def gradient(theta):
        h = 1e-6
        ll = negative(np.concatenate([theta + h * np.eye(4), theta - h * np.eye(4)]))
        return (ll[:4] - ll[4:]) / (2 * h)

    return minimize(
        lambda t: negative(t)[0], np.log([0.5, 0.5, 0.5, 0.5]), jac=gradient, method="BFGS", options={"gtol": 1e-9}
    )


def joint_cov(models, m0, P0) -> np.ndarray:
    """The covariance of (x_{-1}, x_0 .. x_{K-1}) given every measurement (dense least squares)."""
    K, n = len(models), m0.shape[0]
    N = (K + 1) * n
    J = np.zeros((N, N))
    A0 = np.zeros((n, N))
    A0[:, :n] = np.eye(n)
    J += A0.T @ np.linalg.inv(P0) @ A0
    for k, md in enumerate(models):
        i = (k + 1) * n
        A = np.zeros((n, N))
        A[:, i : i + n] = np.eye(n)
        A[:, i - n : i] = -md.F
        J += A.T @ np.linalg.inv(md.Q) @ A
        B = np.zeros((md.H.shape[0], N))
        B[:, i : i + n] = md.H
        J += B.T @ np.linalg.inv(md.R) @ B
    return np.linalg.inv(J)


@pytest.mark.parametrize("engine", ("kf", "ukf"))
def test_lag_one_covariance_is_the_joint_posteriors_off_diagonal_block(engine, rng):
    K, n = 10, 2
    models = [
        LinearModel(
            np.eye(n) + 0.3 * rng.standard_normal((n, n)),
            rng.standard_normal((1, n)),
            random_pd(rng, n, scale=0.05),
            random_pd(rng, 1, scale=0.3),
        )
        for _ in range(K)
    ]
    zs = rng.standard_normal((K, 2, 1))
    m0, P0 = np.array([0.5, -0.2]), random_pd(rng, n)
    result = gf.filter_sequence(
        create("estimator", engine), lambda k: models[k], zs, Gaussian(m0, P0), store="smoother"
    )
    lag = gf.smooth(result).lag_one_cov()
    cov = joint_cov(models, m0, P0)  # the same for every run (it does not depend on z)
    for k in range(K):  # Cov(x_k, x_{k-1}); row 0 against x_{-1}
        i = (k + 1) * n
        np.testing.assert_allclose(lag[k], np.broadcast_to(cov[i : i + n, i - n : i], (2, n, n)), rtol=0, atol=1e-9)


def test_lag_one_covariance_refuses_a_fixed_lag_result(rng):
    model = LinearModel(np.eye(1), np.eye(1), [[0.1]], [[1.0]])
    result = gf.filter_sequence(
        create("estimator", "kf"),
        model,
        rng.standard_normal((5, 1)),
        Gaussian(np.zeros(1), np.eye(1)),
        store="smoother",
    )
    with pytest.raises(ConfigError, match="fixed-interval"):
        gf.fixed_lag_smooth(result, 2).lag_one_cov()


def test_log_likelihood_equals_a_plain_kalman_filters(rng):
    zs = simulate(rng, 60, 3)
    Q, R = np.diag([0.3, 0.1]), np.diag([0.7, 0.9])
    res = gf.filter_sequence(create("estimator", "kf"), LinearModel(F, H, Q, R), zs, INITIAL)
    np.testing.assert_allclose(
        log_likelihood(res.innovation, res.innovation_cov), numpy_kf_loglik(zs, Q, R), rtol=1e-12
    )


@pytest.mark.parametrize("structure", ("full", "diagonal", "scaled"))
def test_em_log_likelihood_never_decreases(structure, rng):
    zs = simulate(rng, 150, 6)
    start = LinearModel(F, H, np.array([[1.0, 0.3], [0.3, 0.5]]), np.array([[2.0, -0.4], [-0.4, 1.5]]))
    Q, R, ll = learn_noise(
        start,
        zs,
        INITIAL,
        estimator=create("estimator", "kf"),
        iterations=12,
        q_structure=structure,
        r_structure=structure,
        tol=0.0,
    )
    assert ll.shape == (13, 6)
    # every iteration, every run: an increase up to the rounding of sums of ~300 terms of size ~1
    assert np.all(np.diff(ll, axis=0) >= -1e-9 * np.abs(ll[1:])), np.diff(ll, axis=0).min()
    assert np.all(ll[-1] > ll[0] + 1.0)  # and it moved
    # each history row is the filter's likelihood of that iterate: the last of the returned Q, R
    np.testing.assert_allclose(ll[-1], numpy_kf_loglik(zs, Q, R), rtol=1e-10)
    if structure == "diagonal":
        assert np.all(Q[:, 0, 1] == 0) and np.all(R[:, 0, 1] == 0)
    if structure == "scaled":  # the start's shape, scaled per run
        np.testing.assert_allclose(Q / Q[:, :1, :1], np.broadcast_to(start.Q / start.Q[0, 0], Q.shape), rtol=1e-12)


def test_em_fixed_point_is_the_direct_maximum_likelihood(rng):
    """scipy.optimize maximises the independent likelihood over diagonal Q and R; one EM step
    from that optimum stays there, and a long EM run from elsewhere reaches it."""
    zs = simulate(rng, 300, 1)
    opt = direct_ml(zs)
    q_ml, r_ml = np.exp(opt.x[:2]), np.exp(opt.x[2:])
    start = LinearModel(F, H, np.diag(q_ml), np.diag(r_ml))
    Q1, R1, ll = em_step(
        create("estimator", "kf"), start, zs, INITIAL, start.Q, start.R, q_structure="diagonal", r_structure="diagonal"
    )
    np.testing.assert_allclose(ll, -opt.fun * zs.shape[0], rtol=1e-12)
    # a stationary point of the likelihood is a fixed point of EM: relative move at the optimiser's tolerance
    np.testing.assert_allclose(np.diag(Q1[0]), q_ml, rtol=1e-5)
    np.testing.assert_allclose(np.diag(R1[0]), r_ml, rtol=1e-5)


@pytest.mark.slow
def test_em_from_far_reaches_the_direct_maximum_likelihood(rng):
    zs = simulate(rng, 300, 1)
    opt = direct_ml(zs)
    Q, R, ll = learn_noise(
        LinearModel(F, H, np.eye(2), 2 * np.eye(2)),
        zs,
        INITIAL,
        estimator=create("estimator", "kf"),
        iterations=400,
        tol=1e-11,
        q_structure="diagonal",
        r_structure="diagonal",
    )
    assert ll[-1, 0] <= -opt.fun * zs.shape[0] + 1e-6  # EM never beats the maximum
    assert ll[-1, 0] >= -opt.fun * zs.shape[0] - 1e-3
    np.testing.assert_allclose(np.diag(Q[0]), np.exp(opt.x[:2]), rtol=2e-2)
    np.testing.assert_allclose(np.diag(R[0]), np.exp(opt.x[2:]), rtol=2e-2)


@pytest.mark.slow
def test_em_estimates_are_within_a_few_standard_errors_of_the_truth(rng):
    """32 runs of 400 steps, Q and R per run: the mean estimate is within 4 Monte Carlo
    standard errors of the simulated Q and R (ML is consistent; its O(1/K) bias is far
    below the SE here), and the shared estimate over all runs too."""
    zs = simulate(rng, 400, 32)
    kf = create("estimator", "kf")
    start = LinearModel(F, H, np.eye(2), 2 * np.eye(2))
    Q, R, ll = learn_noise(
        start, zs, INITIAL, estimator=kf, iterations=60, q_structure="diagonal", r_structure="diagonal"
    )
    for est, truth in (
        (np.diagonal(Q, axis1=-2, axis2=-1), np.diag(Q_TRUE)),
        (np.diagonal(R, axis1=-2, axis2=-1), np.diag(R_TRUE)),
    ):
        se = est.std(axis=0, ddof=1) / np.sqrt(est.shape[0])
        assert np.all(np.abs(est.mean(axis=0) - truth) < 4 * se), (est.mean(axis=0), truth, se)
        assert np.all(se < 0.1 * truth)  # and the test has power: the SE is small against the values
    Qs, Rs, lls = learn_noise(
        start, zs, INITIAL, estimator=kf, iterations=60, shared=True, q_structure="diagonal", r_structure="diagonal"
    )
    assert lls.shape == (61,) and Qs.shape == (2, 2)
    se_q = np.diagonal(Q, axis1=-2, axis2=-1).std(axis=0, ddof=1) / np.sqrt(32)
    se_r = np.diagonal(R, axis1=-2, axis2=-1).std(axis=0, ddof=1) / np.sqrt(32)
    assert np.all(np.abs(np.diag(Qs) - np.diag(Q_TRUE)) < 4 * se_q)
    assert np.all(np.abs(np.diag(Rs) - np.diag(R_TRUE)) < 4 * se_r)


def test_linearised_em_on_a_linear_model_is_the_linear_em(rng):
    """The EKF E-step with the model written as a NonlinearModel (Jacobians by central
    differences) takes the same EM step as the KF on the LinearModel."""
    zs = simulate(rng, 80, 3)
    zs[5, 1] = np.nan  # a missing measurement: left out of the R step in both
    Q, R = np.diag([0.4, 0.2]), np.diag([0.8, 0.6])
    lin = em_step(create("estimator", "kf"), LinearModel(F, H, Q, R), zs, INITIAL, Q, R)
    nonlin = NonlinearModel(lambda x: x @ F.T, lambda x: x @ H.T, Q, R)
    ekf = em_step(create("estimator", "ekf"), nonlin, zs, INITIAL, Q, R)
    for a, b in zip(lin, ekf):
        np.testing.assert_allclose(a, b, rtol=1e-7, atol=1e-9)


def test_learn_noise_refuses_bad_options(rng):
    model = LinearModel(F, H, Q_TRUE, R_TRUE)
    zs = simulate(rng, 5, 1)
    kf = create("estimator", "kf")
    with pytest.raises(ConfigError, match="q_structure"):
        learn_noise(model, zs, INITIAL, estimator=kf, q_structure="banded")
    with pytest.raises(ConfigError, match="iterations"):
        learn_noise(model, zs, INITIAL, estimator=kf, iterations=-1)
    with pytest.raises(ConfigError, match="scaled"):
        learn_noise(model, zs, INITIAL, estimator=kf, Q=np.zeros((2, 2)), q_structure="scaled")


@pytest.mark.slow
def test_linearised_em_learns_the_measurement_noise_of_a_pendulum(rng):
    """The approximate (linearised) M-step with a UKF E-step: R of a pendulum seen through
    sin(angle), Q known, 16 runs of 300 steps from R0 = 4 R: the mean estimate within 4
    Monte Carlo SE of the truth (the first-order error is far below the SE at these
    small smoothed variances)."""
    dt, g = 0.05, 9.81

    def f(x):
        return np.stack([x[..., 0] + dt * x[..., 1], x[..., 1] - g * dt * np.sin(x[..., 0])], axis=-1)

    def h(x):
        return np.sin(x[..., :1])

    Q, r = np.diag([1e-5, 1e-3]), 0.01
    B, K = 16, 300
    x = np.broadcast_to([1.0, 0.0], (B, 2)).copy()
    zs = np.empty((K, B, 1))
    for k in range(K):
        x = f(x) + rng.multivariate_normal(np.zeros(2), Q, B)
        zs[k] = h(x) + rng.normal(0.0, np.sqrt(r), (B, 1))
    model = NonlinearModel(f, h, Q, [[4 * r]])
    _, R, ll = learn_noise(
        model,
        zs,
        Gaussian(np.array([1.0, 0.0]), np.diag([0.01, 0.01])),
        estimator=create("estimator", "ukf"),
        iterations=30,
        q_structure="fixed",
    )
    est = R[:, 0, 0]
    se = est.std(ddof=1) / np.sqrt(B)
    assert abs(est.mean() - r) < 4 * se and se < 0.1 * r, (est.mean(), se)
