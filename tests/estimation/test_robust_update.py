"""Robust updates (plugin kind ``robust_update``): Huber and Cauchy M-estimation, the
Student-t variational Bayes update, checked against their defining equations and a
Monte Carlo with contaminated Gaussian noise."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize

from gnssframework import registry
from gnssframework.estimation import Gaussian, LinearModel

H = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0], [1.0, -1.0]])
R = np.diag([1.0, 1.5, 0.8, 1.2])
PRIOR = Gaussian(np.zeros(2), np.eye(2) * 4.0)
MODEL = LinearModel(np.eye(2), H, np.eye(2) * 1e-3, R)


def _engine(name="ekf", robust=None, **params):
    engine = registry.create("estimator", name, robust=robust, **params)
    engine.backend = "numpy"
    return engine


def test_huber_with_a_large_threshold_is_the_standard_update_bit_for_bit():
    z = np.array([0.3, -0.2, 0.4, 0.1])
    for name in ("kf", "ekf", "ukf", "ckf", "svd-ckf"):
        plain = _engine(name).update(PRIOR, z, MODEL).state
        huber = _engine(name, {"name": "huber", "params": {"threshold": 1e6}}).update(PRIOR, z, MODEL).state
        assert np.array_equal(plain.mean, huber.mean) and np.array_equal(plain.cov, huber.cov), name


def test_huber_weight_formula():
    from gnssframework_plugins.robust_updates import cauchy_weight, huber_weight

    r = np.array([-5.0, -1.0, 0.0, 0.5, 1.345, 3.0])
    assert np.array_equal(huber_weight(r, 1.345), [1.345 / 5, 1, 1, 1, 1, 1.345 / 3])
    assert np.allclose(cauchy_weight(r, 2.0), 1 / (1 + r**2 / 4), rtol=1e-15)


def test_a_gross_outlier_is_weighted_down_to_the_huber_fixed_point():
    """The Huber update's fixed point minimises the M-estimation MAP cost (checked by scipy),
    and the outlier's effective variance is R_jj |r_j| / c at that point."""
    z = np.array([0.3, -0.2, 40.0, 0.1])  # the third range carries a 40-sigma error
    c = 1.345
    out = _engine("kf", {"name": "huber", "params": {"iterations": 200, "tol": 0.0}}).update(PRIOR, z, MODEL)
    sig = np.sqrt(np.diag(R))

    def cost(x):
        r = (z - H @ x) / sig
        a = np.abs(r)
        rho = np.where(a <= c, 0.5 * r**2, c * a - 0.5 * c**2)
        return 0.5 * x @ np.linalg.solve(PRIOR.cov, x) + rho.sum()

    best = minimize(cost, np.zeros(2), method="Nelder-Mead", options=dict(xatol=1e-12, fatol=1e-14, maxiter=20000)).x
    assert np.allclose(out.state.mean, best, atol=1e-6)
    r = (z - H @ out.state.mean) / sig
    assert abs(r[2]) > 10 * c
    # the update's S holds H P H^T + R_eff: the outlier's R_eff = R_jj |r| / c
    r_eff = out.innovation_cov - H @ PRIOR.cov @ H.T
    assert np.isclose(r_eff[2, 2], R[2, 2] * abs(r[2]) / c, rtol=1e-6)
    assert np.allclose(np.diag(r_eff)[[0, 1, 3]], np.diag(R)[[0, 1, 3]], rtol=1e-12)


def test_student_t_vb_converges_to_its_fixed_point():
    """At the returned posterior N(x, P), lambda = (nu + m) / (nu + tr(R^-1 D)) with
    D = (z - Hx)(z - Hx)^T + H P H^T (Piché, Särkkä & Hartikainen 2012), and the Kalman
    update with R / lambda gives back (x, P)."""
    nu = 4.0
    z = np.array([0.3, -0.2, 12.0, 0.1])
    out = (
        _engine("ekf", {"name": "student-t", "params": {"dof": nu, "iterations": 200, "tol": 0.0}})
        .update(PRIOR, z, MODEL)
        .state
    )
    e = z - H @ out.mean
    D = np.outer(e, e) + H @ out.cov @ H.T
    lam = (nu + 4) / (nu + np.trace(np.linalg.solve(R, D)))
    S = H @ PRIOR.cov @ H.T + R / lam
    K = PRIOR.cov @ H.T @ np.linalg.inv(S)
    assert np.allclose(PRIOR.mean + K @ z, out.mean, rtol=0, atol=1e-10)
    assert np.allclose(PRIOR.cov - K @ S @ K.T, out.cov, rtol=0, atol=1e-10)
    assert lam < 0.5  # the outlier inflates R


@pytest.mark.parametrize("robust", ["huber", "cauchy", "student-t"])
def test_robust_beats_the_gaussian_update_on_contaminated_noise(robust):
    """Monte Carlo, 400 paired runs: 10 % of the measurements carry a 30-sigma error; the
    robust RMSE is below the Gaussian update's by more than 3 paired standard errors."""
    rng = np.random.default_rng(7)
    runs = 400
    x_true = rng.multivariate_normal(PRIOR.mean, PRIOR.cov, size=runs)
    sig = np.sqrt(np.diag(R))
    noise = rng.normal(size=(runs, 4)) * sig
    outlier = rng.random((runs, 4)) < 0.1
    noise = np.where(outlier, 30 * sig * rng.choice([-1, 1], size=(runs, 4)), noise)
    z = x_true @ H.T + noise
    prior = Gaussian(np.broadcast_to(PRIOR.mean, (runs, 2)), np.broadcast_to(PRIOR.cov, (runs, 2, 2)))
    plain = _engine("ekf").update(prior, z, MODEL).state.mean
    rob = _engine("ekf", {"name": robust, "params": {"iterations": 30}}).update(prior, z, MODEL).state.mean
    d = np.sum((rob - x_true) ** 2, axis=-1) - np.sum((plain - x_true) ** 2, axis=-1)
    se = d.std(ddof=1) / np.sqrt(runs)
    assert d.mean() + 3 * se < 0, (d.mean(), se)


def test_robust_update_is_a_registered_kind():
    assert {"huber", "cauchy", "student-t"} <= set(registry.names("robust_update"))
    from gnssframework.errors import ConfigError

    with pytest.raises(ConfigError, match="robust"):
        registry.create("estimator", "ekf", robust="hubber")


def test_the_gate_rejects_exactly_the_measurements_beyond_the_chi_square_quantile():
    from scipy.stats import chi2

    S = H @ PRIOR.cov @ H.T + R
    gate = chi2.ppf(1 - 1e-3, 4)
    # two measurements on either side of the gate: NIS = 0.9 and 1.1 times the quantile
    direction = np.array([1.0, -0.5, 2.0, 0.3])
    unit_nis = direction @ np.linalg.solve(S, direction)
    z = np.stack([direction * np.sqrt(f * gate / unit_nis) for f in (0.9, 1.1)])
    prior = Gaussian(np.zeros((2, 2)), np.broadcast_to(PRIOR.cov, (2, 2, 2)))
    plain = _engine("kf").update(prior, z, MODEL).state
    gated = _engine("kf", {"name": "gate", "params": {"false_alarm": 1e-3}}).update(prior, z, MODEL).state
    assert np.array_equal(gated.mean[0], plain.mean[0]) and np.array_equal(gated.cov[0], plain.cov[0])
    assert np.allclose(gated.mean[1], 0.0, atol=1e-9) and np.allclose(gated.cov[1], PRIOR.cov, rtol=1e-9)


def test_a_missing_measurement_is_skipped_by_the_iterated_update():
    from gnssframework.errors import InvalidMeasurementError

    z = np.array([[0.3, -0.2, 0.4, 0.1], [0.3, np.nan, 0.4, 0.1]])
    prior = Gaussian(np.zeros((2, 2)), np.broadcast_to(PRIOR.cov, (2, 2, 2)))
    engine = _engine("ekf", "huber", iterations=3)
    out = engine.update(prior, z, MODEL, missing="skip")
    assert out.skipped.tolist() == [False, True]
    assert np.array_equal(out.state.mean[1], prior.mean[1]) and np.array_equal(out.state.cov[1], prior.cov[1])
    alone = engine.update(Gaussian(np.zeros(2), PRIOR.cov), z[0], MODEL).state
    assert np.allclose(out.state.mean[0], alone.mean, rtol=0, atol=1e-14)
    with pytest.raises(InvalidMeasurementError):
        engine.update(prior, z, MODEL)


def test_a_nav_filter_takes_a_robust_update_through_its_estimator():
    """position-ca's streaming step with robust = huber: one 50 sigma fix moves the
    estimate far less than under the plain Kalman filter (Huber's influence is bounded,
    not nil: the fix still moves it by the gain times about c sigma), and cauchy's, which
    redescends, less still."""
    from gnssframework.interfaces import RunContext

    moved = {}
    for robust in (None, "huber", "cauchy"):
        nav = registry.create(
            "nav_filter", "position-ca", r0=1.0, estimator={"name": "kf", "params": {"robust": robust}}
        )
        nav.reset((1,), RunContext(epoch_interval_s=1.0))
        for _ in range(30):
            out = nav.step({"position_m": np.zeros((1, 2))})
        out = nav.step({"position_m": np.array([[50.0, 0.0]])})
        moved[robust] = float(out["position_m"][0, 0])
    assert moved["huber"] < 0.2 * moved[None], moved
    assert moved["cauchy"] < 0.5 * moved["huber"], moved


ROBUST_SPECS = {
    "huber": {"name": "huber", "params": {"iterations": 30}},
    "cauchy": {"name": "cauchy", "params": {"iterations": 30}},
    "student-t": {"name": "student-t", "params": {"iterations": 30}},
    "gate": {"name": "gate", "params": {"false_alarm": 1e-3}},
}


@pytest.mark.parametrize("robust", sorted(ROBUST_SPECS))
def test_robust_updates_give_the_same_numbers_on_the_compiled_path(robust, monkeypatch):
    """Under the numba backend the iterates' moments come from the compiled kernels (the
    KF/EKF's compiled Jacobian moments of the linear model's twins, the sigma-point engines'
    compiled points); the robust update and a 25-step filter_sequence through it give the
    NumPy path's numbers. The ukf's weights of 1e6 (alpha = 1e-3) amplify the kernels'
    different rounding (as in test_iterated_update.py)."""
    from gnssframework.estimation import estimator as estimator_module
    from gnssframework.estimation import filter_sequence

    calls = []
    for kernel in ("ekf_moments", "sigma_points"):
        original = getattr(estimator_module.kernels, kernel)
        monkeypatch.setattr(estimator_module.kernels, kernel, lambda *a, _f=original: calls.append(1) or _f(*a))
    rng = np.random.default_rng(3)
    # a batch of 3: no outlier, a 40-sigma error on range 3, a 15-sigma one on range 1
    z = np.array([[0.3, -0.2, 0.4, 0.1], [0.3, -0.2, 40.0, 0.1], [0.3, -18.0, 0.4, 0.1]])
    prior = Gaussian(np.zeros((3, 2)), np.broadcast_to(PRIOR.cov, (3, 2, 2)))
    zs = rng.normal(size=(25, 3, 4)) * np.sqrt(np.diag(R))
    zs[rng.random((25, 3, 4)) < 0.1] += 30.0
    for name in ("kf", "ekf", "ukf", "ckf", "svd-ckf"):
        out, seq = {}, {}
        for backend in ("numpy", "numba"):
            engine = registry.create("estimator", name, robust=ROBUST_SPECS[robust])
            engine.backend = backend
            calls.clear()
            out[backend] = engine.update(prior, z, MODEL).state
            assert bool(calls) == (backend == "numba"), (name, backend)  # the compiled kernels ran
            seq[backend] = filter_sequence(engine, MODEL, zs, PRIOR)
        atol = 1e-8 if name == "ukf" else 1e-12
        np.testing.assert_allclose(out["numba"].mean, out["numpy"].mean, rtol=0, atol=atol, err_msg=name)
        np.testing.assert_allclose(out["numba"].cov, out["numpy"].cov, rtol=0, atol=atol, err_msg=name)
        np.testing.assert_allclose(seq["numba"].mean, seq["numpy"].mean, rtol=0, atol=atol, err_msg=name)
        np.testing.assert_allclose(seq["numba"].cov, seq["numpy"].cov, rtol=0, atol=atol, err_msg=name)
        # the robust update did act: the outlier's element is far from the plain update's
        plain = _engine(name).update(prior, z, MODEL).state.mean
        assert np.abs(out["numpy"].mean[1] - plain[1]).max() > 1.0, name
