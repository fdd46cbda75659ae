"""Iterated updates (IEKF, iterated posterior linearisation) against independent truths:
the exact Bayes posterior on a dense grid, a Gauss-Newton MAP by scipy's least squares, and
the Kalman filter on a linear model."""

from __future__ import annotations

import functools

import numpy as np
import pytest
from scipy.optimize import least_squares

from gnssframework import registry
from gnssframework.estimation import Gaussian, LinearModel, NonlinearModel

BEACONS = np.array([[0.0, 0.0], [0.4, 2.2]])
SIGMA_M = 0.05
PRIOR_MEAN = np.array([1.2, 0.9])
PRIOR_COV = np.diag([0.09, 0.04])


def _ranges(x: np.ndarray, beacons: np.ndarray) -> np.ndarray:
    return np.linalg.norm(x[..., None, :] - beacons, axis=-1)


def _range_jacobian(x: np.ndarray, beacons: np.ndarray) -> np.ndarray:
    d = x[..., None, :] - beacons
    return d / np.linalg.norm(d, axis=-1)[..., None]


def range_model(beacons: np.ndarray) -> NonlinearModel:
    m = len(beacons)
    return NonlinearModel(
        f=lambda x: x,
        h=lambda x: _ranges(x, beacons),
        Q=np.eye(2) * 1e-6,
        R=np.eye(m) * SIGMA_M**2,
        h_jacobian=lambda x: _range_jacobian(x, beacons),
    )


def grid_posterior(z: np.ndarray, beacons: np.ndarray, half_width: float = 3.5, n: int = 801):
    """Mean and covariance of the exact posterior on a dense grid (Bayes' rule, no linearisation)."""
    std = np.sqrt(np.diag(PRIOR_COV))
    axes = [np.linspace(PRIOR_MEAN[i] - half_width * std[i], PRIOR_MEAN[i] + half_width * std[i], n) for i in range(2)]
    X = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)
    d = X - PRIOR_MEAN
    log_p = -0.5 * np.einsum("...i,ij,...j->...", d, np.linalg.inv(PRIOR_COV), d)
    log_p = log_p - 0.5 * np.sum((z - _ranges(X, beacons)) ** 2, axis=-1) / SIGMA_M**2
    w = np.exp(log_p - log_p.max())
    w /= w.sum()
    mean = np.einsum("ij,ijk->k", w, X)
    dx = X - mean
    return mean, np.einsum("ij,ijk,ijl->kl", w, dx, dx)


def map_least_squares(z: np.ndarray, beacons: np.ndarray, start: np.ndarray = PRIOR_MEAN) -> np.ndarray:
    """The MAP by scipy's least squares on the cost the IEKF minimises (Bell & Cathey 1993)."""
    Li = np.linalg.inv(np.linalg.cholesky(PRIOR_COV))

    def residual(x):
        return np.concatenate([Li @ (x - PRIOR_MEAN), (z - _ranges(x, beacons)) / SIGMA_M])

    return least_squares(residual, start, xtol=1e-15, ftol=1e-15, gtol=1e-15).x


def _update(name: str, z: np.ndarray, beacons: np.ndarray, **params):
    engine = registry.create("estimator", name, **params)
    engine.backend = "numpy"
    return engine.update(Gaussian(PRIOR_MEAN, PRIOR_COV), z, range_model(beacons))


# a true position 0.66 m from the first beacon, about 2 prior sigmas from the prior mean:
# the ranges' curvature over the prior's spread dominates the linearisation error
TRUE_POSITION = np.array([0.55, 0.35])


@functools.lru_cache(maxsize=1)
def _grid_truth():
    return grid_posterior(_ranges(TRUE_POSITION, BEACONS), BEACONS)


@pytest.mark.parametrize("name", ["ekf", "ukf", "ckf", "svd-ckf"])
def test_iterated_update_is_closer_to_the_grid_posterior(name):
    """Two ranges in good geometry: the posterior is tight and nearly Gaussian, while the
    prior spans the ranges' curvature. (With one range the posterior is a crescent whose
    mean is not its mode; there the Gauss-Newton MAP below is the check.)"""
    grid_mean, grid_cov = _grid_truth()
    z = _ranges(TRUE_POSITION, BEACONS)
    plain = _update(name, z, BEACONS).state
    iterated = _update(name, z, BEACONS, iterations=30).state
    err_plain = np.linalg.norm(plain.mean - grid_mean)
    err_iter = np.linalg.norm(iterated.mean - grid_mean)
    assert err_iter < 0.2 * err_plain, (err_iter, err_plain)
    cov_plain = np.linalg.norm(plain.cov - grid_cov)
    cov_iter = np.linalg.norm(iterated.cov - grid_cov)
    assert cov_iter < cov_plain, (cov_iter, cov_plain)


def test_iekf_is_the_gauss_newton_map():
    """Two ranges (one minimum): the IEKF converges to scipy's MAP from the prior mean."""
    z = _ranges(TRUE_POSITION, BEACONS)
    iekf = _update("ekf", z, BEACONS, iterations=50, iteration_tol=0.0).state
    assert np.allclose(iekf.mean, map_least_squares(z, BEACONS), rtol=0, atol=1e-8)


@pytest.mark.parametrize("n_ranges", [1, 2])
def test_the_damped_iekf_reaches_the_map_on_one_range_too(n_ranges):
    """One range: the MAP cost has a crescent of near-minima, along which the undamped
    Gauss-Newton iteration crawls; with the line search it reaches scipy's MAP."""
    beacons = BEACONS[:n_ranges]
    z = _ranges(TRUE_POSITION, beacons)
    iekf = _update("ekf", z, beacons, iterations=30, iteration_tol=0.0, line_search=True).state
    assert np.allclose(iekf.mean, map_least_squares(z, beacons), rtol=0, atol=1e-8)


def test_one_iteration_is_the_plain_update_bit_for_bit():
    z = _ranges(TRUE_POSITION, BEACONS)
    for name in ("ekf", "ukf", "ckf", "svd-ckf"):
        a = _update(name, z, BEACONS).state
        b = _update(name, z, BEACONS, iterations=1).state
        assert np.array_equal(a.mean, b.mean) and np.array_equal(a.cov, b.cov)


@pytest.mark.parametrize("name, tol", [("ekf", 1e-12), ("ckf", 1e-12), ("svd-ckf", 1e-12), ("ukf", 1e-8)])
def test_iterations_on_a_linear_model_give_the_kalman_filter(name, tol):
    """To rounding: the ukf's default alpha = 1e-3 gives weights of 1e6, whose cancellation
    costs about six digits."""
    rng = np.random.default_rng(3)
    H = rng.normal(size=(3, 4))
    model = LinearModel(np.eye(4), H, np.eye(4) * 0.01, np.diag([0.5, 1.0, 2.0]))
    A = rng.normal(size=(5, 4, 4))
    prior = Gaussian(rng.normal(size=(5, 4)), A @ np.swapaxes(A, -1, -2) + np.eye(4))
    z = rng.normal(size=(5, 3))
    # the KF by hand (independent of the engines)
    S = H @ prior.cov @ H.T + model.R
    K = prior.cov @ H.T @ np.linalg.inv(S)
    mean = prior.mean + np.einsum("bij,bj->bi", K, z - prior.mean @ H.T)
    cov = prior.cov - K @ S @ np.swapaxes(K, -1, -2)
    engine = registry.create("estimator", name, iterations=8)
    engine.backend = "numpy"
    out = engine.update(prior, z, model).state
    assert np.allclose(out.mean, mean, rtol=tol, atol=tol)
    assert np.allclose(out.cov, cov, rtol=tol, atol=tol)


def test_batch_elements_stop_on_their_own():
    """A batch of a linear element (converged at once) and a nonlinear one: each gives
    what it gives alone, so a converged element is frozen, not iterated further."""
    zs = np.stack([_ranges(TRUE_POSITION, BEACONS), _ranges(np.array([1.1, 0.8]), BEACONS)])
    engine = registry.create("estimator", "ekf", iterations=6, iteration_tol=1e-3)
    engine.backend = "numpy"
    prior = Gaussian(np.broadcast_to(PRIOR_MEAN, (2, 2)), np.broadcast_to(PRIOR_COV, (2, 2, 2)))
    both = engine.update(prior, zs, range_model(BEACONS)).state
    for k in range(2):
        alone = engine.update(Gaussian(PRIOR_MEAN, PRIOR_COV), zs[k], range_model(BEACONS)).state
        assert np.allclose(both.mean[k], alone.mean, rtol=0, atol=1e-13)


def test_iterations_on_the_compiled_sigma_points_match_numpy():
    """The sigma-point engines draw their points with the compiled kernels under numba."""
    z = _ranges(TRUE_POSITION, BEACONS)
    for name in ("ukf", "ckf", "svd-ckf"):
        ref = _update(name, z, BEACONS, iterations=20).state
        engine = registry.create("estimator", name, iterations=20)
        engine.backend = "numba"
        out = engine.update(Gaussian(PRIOR_MEAN, PRIOR_COV), z, range_model(BEACONS)).state
        # the ukf's weights of 1e6 (alpha = 1e-3) amplify the kernels' different rounding
        assert np.allclose(out.mean, ref.mean, rtol=0, atol=1e-8 if name == "ukf" else 1e-12)


def test_bad_iterations_are_refused_by_name():
    from gnssframework.errors import ConfigError

    with pytest.raises(ConfigError, match="iterations"):
        registry.create("estimator", "ekf", iterations=0)


def _compiled_range_model(beacons: np.ndarray) -> NonlinearModel:
    """The range model with compiled twins of f (linear) and h and its Jacobian (the
    KF/EKF's compiled moments, the sigma-point engines' fused path)."""
    import math

    from gnssframework.backend import jit
    from gnssframework.estimation import CompiledFunctions, linear_f

    @jit
    def h_rows(params, X, k, Z, kz):
        for i in range(params.shape[0]):
            Z[kz, i] = math.sqrt((X[k, 0] - params[i, 0]) ** 2 + (X[k, 1] - params[i, 1]) ** 2)

    @jit
    def h_jac(params, X, k, J):
        for i in range(params.shape[0]):
            dx, dy = X[k, 0] - params[i, 0], X[k, 1] - params[i, 1]
            r = math.sqrt(dx * dx + dy * dy)
            J[i, 0] = dx / r
            J[i, 1] = dy / r

    compiled = CompiledFunctions(linear_f, np.eye(2), h_rows, np.array(beacons, dtype=float), h_jacobian=h_jac)
    base = range_model(beacons)
    return NonlinearModel(
        base.f,
        base.h,
        base.Q,
        base.R,
        f_jacobian=lambda x: np.broadcast_to(np.eye(2), x.shape + (2,)),
        h_jacobian=base.h_jacobian,
        compiled=compiled,
    )


@pytest.mark.slow
@pytest.mark.parametrize("name", ["ekf", "ckf"])
def test_iterations_on_a_model_with_compiled_twins_match_numpy(name, monkeypatch):
    """Under numba the ekf's moments at every iterate come from the compiled Jacobian
    kernel (and the ckf's from the compiled points): the same numbers as NumPy."""
    from gnssframework.estimation import estimator as estimator_module

    calls = []
    kernel = "ekf_moments" if name == "ekf" else "sigma_points"
    original = getattr(estimator_module.kernels, kernel)
    monkeypatch.setattr(estimator_module.kernels, kernel, lambda *a: calls.append(1) or original(*a))
    z = _ranges(TRUE_POSITION, BEACONS)
    model = _compiled_range_model(BEACONS)
    out = {}
    for backend in ("numpy", "numba"):
        engine = registry.create("estimator", name, iterations=20)
        engine.backend = backend
        out[backend] = engine.update(Gaussian(PRIOR_MEAN, PRIOR_COV), z, model).state
    assert len(calls) > 2  # the compiled kernel ran at the iterates, not only at the prior
    assert np.allclose(out["numba"].mean, out["numpy"].mean, rtol=0, atol=1e-12)
    assert np.allclose(out["numba"].cov, out["numpy"].cov, rtol=0, atol=1e-12)


def test_a_filter_sequence_runs_the_iterated_update():
    """Through FilterStep (the seam every filter uses): an iterated ekf on a linear model
    over 50 steps gives the Kalman filter's sequence."""
    from gnssframework.estimation import filter_sequence

    rng = np.random.default_rng(1)
    model = LinearModel([[1.0, 1.0], [0.0, 1.0]], [[1.0, 0.0]], np.diag([0.01, 0.001]), [[0.5]])
    zs = np.cumsum(rng.normal(size=(50, 3, 1)), axis=0)
    initial = Gaussian(np.zeros((3, 2)), np.broadcast_to(np.eye(2) * 10.0, (3, 2, 2)))
    kf = filter_sequence(registry.create("estimator", "kf"), model, zs, initial)
    iekf = filter_sequence(registry.create("estimator", "ekf", iterations=4), model, zs, initial)
    assert np.allclose(iekf.mean, kf.mean, rtol=0, atol=1e-9)
    assert np.allclose(iekf.cov, kf.cov, rtol=0, atol=1e-9)
