"""RTS smoothers (`gnssframework.estimation.smoother`) against independent truths.

- the linear-Gaussian closed form: the joint Gaussian posterior over every state of a
  small time-varying model, by dense batch least squares (no recursion);
- FilterPy's ``KalmanFilter.rts_smoother`` and ``UnscentedKalmanFilter.rts_smoother``
  (test-only oracles) fed the same filtered states;
- properties: the smoothed covariance never exceeds the filtered one (Loewner order) and
  equals it at the last step; fixed-lag against fixed-interval.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import gnssframework as gf
from gnssframework.errors import ConfigError
from gnssframework.estimation import Gaussian, LinearModel, NonlinearModel
from conftest import create, random_pd

ENGINES = ("kf", "ekf", "ukf", "ckf", "svd-ckf")


def time_varying_models(rng, K: int, n: int = 2, m: int = 1):
    """A different F, H, Q, R, u at every step (so the step indexing is checked)."""
    models = []
    for _k in range(K):
        F = np.eye(n) + 0.3 * rng.standard_normal((n, n))
        H = rng.standard_normal((m, n))
        models.append(
            LinearModel(
                F, H, random_pd(rng, n, scale=0.05), random_pd(rng, m, scale=0.3), u=0.1 * rng.standard_normal(n)
            )
        )
    return models


def joint_posterior(models, zs, m0, P0):
    """Mean and covariance of (x_{-1}, x_0 .. x_{K-1}) given z_0 .. z_{K-1}, by dense weighted
    least squares over the whole trajectory: the information matrix A^T W A of the stacked
    prior, dynamics and measurement residuals (the batch solution of the linear-Gaussian smoothing problem)."""
    K, n = len(models), m0.shape[0]
    N = (K + 1) * n
    rows, rhs, weights = [], [], []
    A0 = np.zeros((n, N))
    A0[:, :n] = np.eye(n)
    rows.append(A0)
    rhs.append(m0)
    weights.append(np.linalg.inv(P0))
    for k, md in enumerate(models):
        i = (k + 1) * n  # x_k's block; x_{k-1} at i - n
        A = np.zeros((n, N))
        A[:, i : i + n] = np.eye(n)
        A[:, i - n : i] = -md.F
        rows.append(A)
        rhs.append(md.u)
        weights.append(np.linalg.inv(md.Q))
        B = np.zeros((md.H.shape[0], N))
        B[:, i : i + n] = md.H
        rows.append(B)
        rhs.append(zs[k])
        weights.append(np.linalg.inv(md.R))
    J = sum(A.T @ W @ A for A, W in zip(rows, weights))
    b = sum(A.T @ W @ r for A, W, r in zip(rows, weights, rhs))
    cov = np.linalg.inv(J)
    mean = cov @ b
    return mean.reshape(K + 1, n), np.stack([cov[i * n : (i + 1) * n, i * n : (i + 1) * n] for i in range(K + 1)])


@pytest.mark.parametrize(
    ("engine", "form"), [(e, None) for e in ENGINES] + [(e, "sqrt") for e in ("kf", "ckf", "svd-ckf")]
)
def test_smoother_equals_the_joint_gaussian_posterior(engine, form, rng):
    """Every engine's own smoother form, and the square-root form (the KF's factors: X the
    root of P, Y = F X; the CKF's points), against the dense batch least-squares posterior."""
    K, B, n = 12, 3, 2
    models = time_varying_models(rng, K, n)
    zs = rng.standard_normal((K, B, 1))
    m0, P0 = np.array([0.5, -0.2]), random_pd(rng, n)
    estimator = create("estimator", engine)
    if form is not None:
        estimator.smoother_gain = form
    result = gf.filter_sequence(estimator, lambda k: models[k], zs, Gaussian(m0, P0), store="smoother")
    smoothed = gf.smooth(result)
    for b in range(B):
        mean, cov = joint_posterior(models, zs[:, b], m0, P0)
        np.testing.assert_allclose(smoothed.mean[:, b], mean[1:], rtol=0, atol=1e-9)
        np.testing.assert_allclose(smoothed.cov[:, b], cov[1:], rtol=0, atol=1e-9)
        np.testing.assert_allclose(smoothed.initial.mean[b], mean[0], rtol=0, atol=1e-9)
        np.testing.assert_allclose(smoothed.initial.cov[b], cov[0], rtol=0, atol=1e-9)
    # the last step is the filter's own estimate
    np.testing.assert_array_equal(smoothed.mean[-1], result.mean[-1])


def test_a_wrong_cross_covariance_is_caught_by_the_closed_form(rng):
    """The closed-form test can fail: a smoother fed P F (not P F^T) misses it."""
    K, n = 8, 2
    models = time_varying_models(rng, K, n)
    zs = rng.standard_normal((K, 1))
    m0, P0 = np.zeros(n), np.eye(n)
    result = gf.filter_sequence(create("estimator", "kf"), lambda k: models[k], zs, Gaussian(m0, P0), store="smoother")
    inputs = result.smoother_inputs
    inputs.cross_cov = np.swapaxes(inputs.cross_cov, -1, -2)
    mean, _ = joint_posterior(models, zs, m0, P0)
    assert np.abs(gf.smooth(result).mean - mean[1:]).max() > 1e-6


def pendulum_model(Q, R, dt: float = 0.1) -> NonlinearModel:
    def f(x):
        return np.stack([x[..., 0] + dt * x[..., 1], x[..., 1] - dt * 9.81 * np.sin(x[..., 0])], -1)

    def h(x):
        return np.stack([np.sin(x[..., 0]), x[..., 1] ** 2 / 10.0], -1)

    return NonlinearModel(f, h, Q, R)


def pendulum_data(rng, K: int, model: NonlinearModel):
    x = np.array([0.8, 0.0])
    zs = []
    for _ in range(K):
        x = model.f(x) + rng.multivariate_normal(np.zeros(2), model.Q)
        zs.append(model.h(x) + rng.multivariate_normal(np.zeros(2), model.R))
    return np.array(zs)


@pytest.mark.parametrize(
    "engine, alpha, beta, kappa", [("ukf", 0.5, 2.0, 0.0), ("ukf", 0.9, 2.0, 1.0), ("ckf", 1.0, 0.0, 0.0)]
)
def test_sigma_point_smoother_matches_filterpy_ukf_rts_smoother(engine, alpha, beta, kappa, rng):
    kalman = pytest.importorskip("filterpy.kalman")
    Q, R = np.diag([1e-4, 4e-3]), np.diag([0.01, 0.02])
    model = pendulum_model(Q, R)
    zs = pendulum_data(rng, 40, model)
    params = dict(alpha=alpha, beta=beta, kappa=kappa) if engine == "ukf" else {}
    result = gf.filter_sequence(
        create("estimator", engine, **params),
        model,
        zs,
        Gaussian(np.array([0.6, 0.1]), np.diag([0.1, 0.1])),
        store="smoother",
    )
    smoothed = gf.smooth(result)
    points = kalman.MerweScaledSigmaPoints(2, alpha=alpha, beta=beta, kappa=kappa)
    ref = kalman.UnscentedKalmanFilter(dim_x=2, dim_z=2, dt=1.0, hx=model.h, fx=lambda x, dt: model.f(x), points=points)
    ref.Q = Q  # FilterPy's UKF rts_smoother uses self.Q at every step
    xs, ps, gains = ref.rts_smoother(result.mean.copy(), result.cov.copy())
    np.testing.assert_allclose(smoothed.mean, xs, rtol=0, atol=1e-9)
    np.testing.assert_allclose(smoothed.cov, ps, rtol=0, atol=1e-9)
    np.testing.assert_allclose(smoothed.gain, gains[:-1], rtol=0, atol=1e-9)
    assert np.abs(smoothed.mean - result.mean).max() > 1e-3  # the backward pass did something


@pytest.mark.parametrize("engine", ("kf", "ekf"))
def test_linear_smoother_matches_filterpy_kalman_rts_smoother(engine, rng):
    kalman = pytest.importorskip("filterpy.kalman")
    K, n = 30, 2
    models = time_varying_models(rng, K, n)
    models = [LinearModel(md.F, md.H, md.Q, md.R) for md in models]  # FilterPy's smoother has no u
    zs = rng.standard_normal((K, 4, 1))
    result = gf.filter_sequence(
        create("estimator", engine), lambda k: models[k], zs, Gaussian(np.zeros(n), np.eye(n)), store="smoother"
    )
    smoothed = gf.smooth(result)
    ref = kalman.KalmanFilter(dim_x=n, dim_z=1)
    Fs = np.stack([md.F for md in models])
    Qs = np.stack([md.Q for md in models])
    for b in range(zs.shape[1]):
        xs, ps, gains, _ = ref.rts_smoother(result.mean[:, b].copy(), result.cov[:, b].copy(), Fs=Fs, Qs=Qs)
        np.testing.assert_allclose(smoothed.mean[:, b], xs, rtol=0, atol=1e-9)
        np.testing.assert_allclose(smoothed.cov[:, b], ps, rtol=0, atol=1e-9)
        np.testing.assert_allclose(smoothed.gain[:, b], gains[:-1], rtol=0, atol=1e-9)


def test_eigh_form_agrees_with_the_plain_form_and_stays_psd(rng):
    """The ``"eigh"`` gain and PSD-sum covariance equal the plain form on a
    well-conditioned nonlinear problem, and stay PSD where P^- is nearly singular (the
    SVD-CKF's default square-root form: test_smoother_sqrt.py)."""
    Q, R = np.diag([1e-4, 4e-3]), np.diag([0.01, 0.02])
    model = pendulum_model(Q, R)
    zs = pendulum_data(rng, 30, model)
    result = gf.filter_sequence(
        create("estimator", "svd-ckf"), model, zs, Gaussian(np.array([0.6, 0.1]), np.diag([0.1, 0.1])), store="smoother"
    )
    careful, plain = gf.smooth(result, form="eigh"), gf.smooth(result, form="solve")
    np.testing.assert_allclose(careful.mean, plain.mean, rtol=0, atol=1e-10)
    np.testing.assert_allclose(careful.cov, plain.cov, rtol=0, atol=1e-12)
    # A nearly deterministic state (Q ~ 1e-14 on a constant) makes P^- nearly singular.
    F = np.array([[1.0, 1.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    lin = LinearModel(F, np.array([[1.0, 0.0, 1.0]]), np.diag([1e-3, 1e-3, 1e-14]), [[1e-2]])
    z = rng.standard_normal((200, 1))
    res = gf.filter_sequence(create("estimator", "svd-ckf"), lin, z, Gaussian(np.zeros(3), np.eye(3)), store="smoother")
    cov = gf.smooth(res, form="eigh").cov
    assert np.isfinite(cov).all()
    np.testing.assert_array_equal(cov, np.swapaxes(cov, -1, -2))
    assert np.linalg.eigvalsh(cov).min() >= -1e-12 * np.abs(cov).max()


@st.composite
def linear_problems(draw):
    n = draw(st.integers(1, 3))
    m = draw(st.integers(1, 2))
    K = draw(st.integers(2, 8))
    seed = draw(st.integers(0, 2**31 - 1))
    engine = draw(st.sampled_from(ENGINES))
    return n, m, K, seed, engine


@settings(max_examples=40, deadline=None)
@given(linear_problems())
def test_smoothed_covariance_never_exceeds_the_filtered_one(problem):
    n, m, K, seed, engine = problem
    rng = np.random.default_rng(seed)
    model = LinearModel(
        np.eye(n) + 0.5 * rng.standard_normal((n, n)),
        rng.standard_normal((m, n)),
        random_pd(rng, n, scale=0.1),
        random_pd(rng, m),
    )
    zs = rng.standard_normal((K, 2, m))
    result = gf.filter_sequence(
        create("estimator", engine), model, zs, Gaussian(np.zeros(n), random_pd(rng, n)), store="smoother"
    )
    smoothed = gf.smooth(result)
    gap = np.linalg.eigvalsh(result.cov - smoothed.cov)  # P_f - P_s >= 0 (Loewner order)
    assert gap.min() >= -1e-10 * max(1.0, np.abs(result.cov).max())
    np.testing.assert_array_equal(smoothed.cov[-1], result.cov[-1])
    np.testing.assert_array_equal(smoothed.mean[-1], result.mean[-1])


def test_smooth_refuses_a_result_without_stored_predictions(rng):
    model = LinearModel(np.eye(1), np.eye(1), [[0.1]], [[1.0]])
    result = gf.filter_sequence(create("estimator", "kf"), model, np.zeros((3, 1)), Gaussian(np.zeros(1), np.eye(1)))
    with pytest.raises(ConfigError, match="store='smoother'"):
        gf.smooth(result)
    with pytest.raises(ConfigError, match="store"):
        gf.filter_sequence(
            create("estimator", "kf"), model, np.zeros((3, 1)), Gaussian(np.zeros(1), np.eye(1)), store="everything"
        )
    with pytest.raises(ConfigError, match="store_cov"):
        gf.filter_sequence(
            create("estimator", "kf"),
            model,
            np.zeros((3, 1)),
            Gaussian(np.zeros(1), np.eye(1)),
            store="smoother",
            store_cov=False,
        )


# -- fixed lag ------------------------------------------------------------------------------


def _lag_problem(rng, K=25, B=3):
    model = LinearModel(np.array([[1.0, 0.5], [0.0, 0.9]]), np.array([[1.0, 0.0]]), np.diag([0.01, 0.05]), [[0.3]])
    return model, rng.standard_normal((K, B, 1)), Gaussian(np.zeros(2), np.eye(2))


@pytest.mark.parametrize("engine", ("kf", "ukf", "svd-ckf"))
def test_fixed_lag_is_the_fixed_interval_smoother_of_the_data_seen(engine, rng):
    """E[x_j | z_0..z_{j+L}] equals the fixed-interval smoother run on z_0..z_{j+L} alone."""
    model, zs, init = _lag_problem(rng)
    K, lag = zs.shape[0], 4
    full = gf.filter_sequence(create("estimator", engine), model, zs, init, store="smoother")
    lagged = gf.fixed_lag_smooth(full, lag)
    for j in range(K):
        end = min(j + lag, K - 1)
        part = gf.smooth(gf.filter_sequence(create("estimator", engine), model, zs[: end + 1], init, store="smoother"))
        np.testing.assert_allclose(lagged.mean[j], part.mean[j], rtol=0, atol=1e-10)
        np.testing.assert_allclose(lagged.cov[j], part.cov[j], rtol=0, atol=1e-10)


def test_fixed_lag_spanning_the_window_is_the_fixed_interval_smoother(rng):
    model, zs, init = _lag_problem(rng)
    result = gf.filter_sequence(create("estimator", "ckf"), model, zs, init, store="smoother")
    smoothed = gf.smooth(result)
    for lag in (zs.shape[0] - 1, zs.shape[0] + 5):
        lagged = gf.fixed_lag_smooth(result, lag)
        np.testing.assert_allclose(lagged.mean, smoothed.mean, rtol=0, atol=1e-12)
        np.testing.assert_allclose(lagged.cov, smoothed.cov, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(gf.fixed_lag_smooth(result, 0).mean, result.mean)
    np.testing.assert_allclose(gf.fixed_lag_smooth(result, 2).gain, smoothed.gain, rtol=0, atol=1e-14)


def test_fixed_lag_approaches_the_fixed_interval_smoother_as_the_lag_grows(rng):
    """P_{j|j+L} decreases in the Loewner order towards P_{j|K-1} as L grows (a theorem:
    more data), and the mean difference over 200 runs shrinks with it."""
    model, zs, init = _lag_problem(rng, K=40, B=200)
    result = gf.filter_sequence(create("estimator", "kf"), model, zs, init, store="smoother")
    smoothed = gf.smooth(result)
    early = slice(0, 25)  # windows that end before the last step for every lag below
    previous_cov, previous_rms = None, np.inf
    for lag in (0, 1, 2, 4, 8):
        lagged = gf.fixed_lag_smooth(result, lag)
        excess = lagged.cov[early] - smoothed.cov[early]
        assert np.linalg.eigvalsh(excess).min() >= -1e-12
        if previous_cov is not None:
            assert np.linalg.eigvalsh(previous_cov - lagged.cov[early]).min() >= -1e-12
        rms = np.sqrt(np.mean((lagged.mean[early] - smoothed.mean[early]) ** 2))
        assert rms < previous_rms
        previous_cov, previous_rms = lagged.cov[early], rms
    assert previous_rms < 0.05 * np.sqrt(np.mean((result.mean[early] - smoothed.mean[early]) ** 2))


@pytest.mark.parametrize("engine", ("ekf", "ukf", "svd-ckf"))
def test_streaming_fixed_lag_smoother_matches_the_batch_one(engine, rng):
    Q, R = np.diag([1e-4, 4e-3]), np.diag([0.01, 0.02])
    model = pendulum_model(Q, R)
    zs = pendulum_data(rng, 20, model)
    init = Gaussian(np.array([0.6, 0.1]), np.diag([0.1, 0.1]))
    lag = 3
    batch = gf.fixed_lag_smooth(gf.filter_sequence(create("estimator", engine), model, zs, init, store="smoother"), lag)
    fls = gf.FixedLagSmoother(create("estimator", engine), lag)
    fls.start(init, model)
    outputs = [fls.step(z, model) for z in zs]
    assert outputs[:lag] == [None] * lag
    outputs = outputs[lag:] + fls.flush()
    assert [o.step for o in outputs] == list(range(zs.shape[0]))
    np.testing.assert_allclose(np.stack([o.state.mean for o in outputs]), batch.mean, rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.stack([o.state.cov for o in outputs]), batch.cov, rtol=0, atol=1e-12)


def test_fixed_lag_refuses_a_bad_lag():
    with pytest.raises(ConfigError, match="lag"):
        gf.FixedLagSmoother(create("estimator", "kf"), -1)
    with pytest.raises(ConfigError, match="lag"):
        gf.FixedLagSmoother(create("estimator", "kf"), 1.5)


# -- adapters and augmentations -------------------------------------------------------------


def _simulate(rng, model: LinearModel, K: int, B: int, P0):
    x = rng.multivariate_normal(np.zeros(model.dim_state), P0, size=B)
    xs, zs = [], []
    for _ in range(K):
        x = x @ model.F.T + rng.multivariate_normal(np.zeros(model.dim_state), model.Q, size=B)
        xs.append(x)
        zs.append(x @ model.H.T + rng.multivariate_normal(np.zeros(model.dim_meas), model.R, size=B))
    return np.array(xs), np.array(zs)


def _nees(truth, mean, cov):
    e = truth - mean
    return np.einsum("...i,...i->...", e, np.linalg.solve(cov, e[..., None])[..., 0])


def test_adaptive_smoother_uses_the_stored_per_step_noise_and_is_consistent(rng):
    """With a noise adapter the smoother is the smoother of the model with the Q and R the
    filter had in force at each step (exactly: a non-adaptive rerun on those reproduces it),
    and on a linear model with the true noise its NEES stays near the state dimension."""
    model = LinearModel(np.array([[1.0, 1.0], [0.0, 1.0]]), np.array([[1.0, 0.0]]), np.diag([0.01, 0.01]), [[1.0]])
    P0 = np.eye(2)
    truth, zs = _simulate(rng, model, K=60, B=400, P0=P0)
    init = Gaussian(np.zeros(2), P0)
    adaptive = gf.filter_sequence(
        create("estimator", "kf"), model, zs, init, adapter=create("noise_adapter", "innovation"), store="smoother"
    )
    assert np.ptp(adaptive.R) > 0  # the adapter did move R, per run and step
    rerun = gf.filter_sequence(
        create("estimator", "kf"),
        lambda k: LinearModel(model.F, model.H, adaptive.Q[k], adaptive.R[k]),
        zs,
        init,
        store="smoother",
    )
    smoothed, reference = gf.smooth(adaptive), gf.smooth(rerun)
    np.testing.assert_allclose(smoothed.mean, reference.mean, rtol=0, atol=1e-10)
    np.testing.assert_allclose(smoothed.cov, reference.cov, rtol=0, atol=1e-10)
    # Consistency. 400 runs x 60 steps: sampling alone leaves the mean NEES within ~1% of n;
    # the adapter's windowed R (20 innovations: ~30 % relative error per run) inflates both
    # the filter's and the smoother's NEES by about as much, so each is held to 15 % of n
    # and to each other within 10 % of n.
    n = 2
    nees_s = _nees(truth, smoothed.mean, smoothed.cov).mean()
    nees_f = _nees(truth, adaptive.mean, adaptive.cov).mean()
    assert abs(nees_s - n) < 0.15 * n
    assert abs(nees_s - nees_f) < 0.10 * n
    # and the smoother is better than the filter, as it must be
    assert np.mean((truth - smoothed.mean) ** 2) < 0.5 * np.mean((truth - adaptive.mean) ** 2)


def test_smoother_with_true_noise_is_consistent(rng):
    """Without adaptation the smoothed NEES averages to n within its sampling band."""
    model = LinearModel(np.array([[1.0, 1.0], [0.0, 1.0]]), np.array([[1.0, 0.0]]), np.diag([0.01, 0.01]), [[1.0]])
    truth, zs = _simulate(rng, model, K=60, B=400, P0=np.eye(2))
    smoothed = gf.smooth(
        gf.filter_sequence(create("estimator", "ukf"), model, zs, Gaussian(np.zeros(2), np.eye(2)), store="smoother")
    )
    per_step = _nees(truth, smoothed.mean, smoothed.cov).mean(axis=1)  # chi2(2 B)/B at each step
    # each step's mean over 400 runs: sd sqrt(2 n / B) = 0.1; 4.5 sd covers all 60 steps
    assert np.abs(per_step - 2).max() < 4.5 * np.sqrt(4 / 400)


def test_smoother_of_a_colored_ar1_augmentation_is_the_augmented_problems_posterior(rng):
    """``colored-ar1`` rewrites the problem (differenced measurements, decorrelated
    dynamics); the smoother of that run is the joint posterior of the rewritten model."""
    model = LinearModel(np.array([[1.0, 0.5], [0.0, 0.95]]), np.array([[1.0, 0.0]]), np.diag([0.02, 0.01]), [[0.2]])
    zs = rng.standard_normal((14, 1))
    aug = create("augmentation", "colored-ar1", psi=0.7)
    init = Gaussian(np.array([0.1, 0.0]), np.eye(2))
    result = gf.filter_sequence(create("estimator", "kf"), model, zs, init, augmentation=aug, store="smoother")
    problem = aug.apply(model, zs)
    models = [problem.model_at(k) for k in range(problem.zs.shape[0])]
    models = [LinearModel(md.F, md.H, md.Q, md.R, u=np.zeros(2) if md.u is None else md.u) for md in models]
    mean, cov = joint_posterior(models, problem.zs, init.mean, init.cov)
    smoothed = gf.smooth(result)
    np.testing.assert_array_equal(smoothed.epochs, np.arange(13))
    np.testing.assert_allclose(smoothed.mean, mean[1:], rtol=0, atol=1e-9)
    np.testing.assert_allclose(smoothed.cov, cov[1:], rtol=0, atol=1e-9)


def test_the_smoothers_page_shows_what_its_example_prints():
    """docs/estimators/smoothers.md's RMSE table is docs/smoother_example.py's output, and
    the smoother beats the fixed-lag smoother, which beats the filter, for every engine."""
    import importlib.util
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    spec = importlib.util.spec_from_file_location("smoother_example", root / "docs" / "smoother_example.py")
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    page = (root / "docs" / "estimators" / "smoothers.md").read_text(encoding="utf-8")
    assert example.table() in page, "run: python docs/smoother_example.py and paste its table"
    for engine, filtered, lagged, smoothed in example.rmse_rows():
        assert smoothed < lagged < filtered, engine


@pytest.mark.parametrize("engine", ("ukf", "ckf"))
def test_smoothing_an_angle_state_across_the_wrap(engine, rng):
    """A heading near +-pi, smoothed with the angle hooks, equals (mod 2 pi) the same
    problem turned by pi, where no wrap occurs."""
    from gnssframework.estimation.angles import angle_mean, angle_residual, wrap_angle

    def f(x):
        return np.stack([wrap_angle(x[..., 0] + 0.1 * x[..., 1]), x[..., 1]], -1)

    def h(x):
        return np.stack([wrap_angle(x[..., 0]), 0.5 * x[..., 1] ** 2 + x[..., 1]], -1)

    Q, R = np.diag([1e-3, 1e-3]), np.diag([0.05**2, 0.1**2])
    hooks = dict(residual_x=angle_residual(0), mean_x=angle_mean(0), residual_z=angle_residual(0), mean_z=angle_mean(0))
    model = NonlinearModel(f, h, Q, R, **hooks)
    K = 30
    heading = np.pi - 0.05 + 0.01 * np.arange(K)  # crosses +pi at step 5
    rate = 0.1 * np.ones(K)
    noise = rng.standard_normal((K, 2)) * np.sqrt(np.diag(R))
    z_wrapped = np.stack([wrap_angle(heading + noise[:, 0]), 0.5 * rate**2 + rate + noise[:, 1]], -1)
    z_turned = np.stack([wrap_angle(heading - np.pi + noise[:, 0]), z_wrapped[:, 1]], -1)
    init_w = Gaussian(np.array([np.pi - 0.06, 0.1]), np.diag([0.01, 0.01]))
    init_t = Gaussian(np.array([-0.06, 0.1]), np.diag([0.01, 0.01]))
    res_w = gf.filter_sequence(create("estimator", engine), model, z_wrapped, init_w, store="smoother")
    res_t = gf.filter_sequence(create("estimator", engine), model, z_turned, init_t, store="smoother")
    sw = gf.smooth(res_w, residual_x=angle_residual(0))
    st_ = gf.smooth(res_t, residual_x=angle_residual(0))
    np.testing.assert_allclose(wrap_angle(sw.mean[:, 0] - st_.mean[:, 0] - np.pi), 0.0, atol=1e-9)
    np.testing.assert_allclose(sw.mean[:, 1], st_.mean[:, 1], atol=1e-9)
    np.testing.assert_allclose(sw.cov, st_.cov, atol=1e-9)
    # The same states written in [-pi, pi) (a filter may wrap its means): the hook gives the
    # same smoothed headings mod 2 pi; plain subtraction is 2 pi off across the wrap.
    res_w.mean[:, 0] = wrap_angle(res_w.mean[:, 0])
    res_w.smoother_inputs.prior_mean[:, 0] = wrap_angle(res_w.smoother_inputs.prior_mean[:, 0])
    rewrapped = gf.smooth(res_w, residual_x=angle_residual(0))
    np.testing.assert_allclose(wrap_angle(rewrapped.mean[:, 0] - sw.mean[:, 0]), 0.0, atol=1e-9)
    np.testing.assert_allclose(rewrapped.cov, sw.cov, atol=1e-12)
    plain = gf.smooth(res_w)
    assert np.abs(wrap_angle(plain.mean[:, 0] - sw.mean[:, 0])).max() > 0.5


@pytest.mark.parametrize("engine", ("kf", "ckf"))
def test_smoother_across_missing_measurements_is_the_posterior_without_them(engine, rng):
    """With ``missing="skip"`` a NaN measurement's update is skipped (the posterior is the
    prior there); the smoother is then the joint posterior of the measurements present."""
    K, n = 12, 2
    models = time_varying_models(rng, K, n)
    zs = rng.standard_normal((K, 2, 1))
    zs[[3, 4, 9], 0] = np.nan  # run 0 misses three epochs, run 1 none
    m0, P0 = np.zeros(n), np.eye(n)
    result = gf.filter_sequence(
        create("estimator", engine), lambda k: models[k], zs, Gaussian(m0, P0), missing="skip", store="smoother"
    )
    smoothed = gf.smooth(result)
    for b in range(2):
        keep = [k for k in range(K) if np.isfinite(zs[k, b]).all()]
        # no measurement at a missing epoch: an infinitely uncertain one (R -> inf) there
        mdl = [md if k in keep else LinearModel(md.F, md.H, md.Q, [[1e30]], u=md.u) for k, md in enumerate(models)]
        mean, cov = joint_posterior(mdl, np.nan_to_num(zs[:, b]), m0, P0)
        np.testing.assert_allclose(smoothed.mean[:, b], mean[1:], rtol=0, atol=1e-9)
        np.testing.assert_allclose(smoothed.cov[:, b], cov[1:], rtol=0, atol=1e-9)


@pytest.mark.parametrize("lag", (0, 5))
def test_streaming_fixed_lag_smoother_with_a_noise_adapter_matches_the_batch_one(lag, rng):
    model = LinearModel(np.array([[1.0, 1.0], [0.0, 1.0]]), np.array([[1.0, 0.0]]), np.diag([0.01, 0.01]), [[1.0]])
    _, zs = _simulate(rng, model, K=30, B=4, P0=np.eye(2))
    init = Gaussian(np.zeros(2), np.eye(2))
    result = gf.filter_sequence(
        create("estimator", "kf"), model, zs, init, adapter=create("noise_adapter", "sage-husa"), store="smoother"
    )
    assert np.ptp(result.Q) > 0
    batch = gf.fixed_lag_smooth(result, lag)
    fls = gf.FixedLagSmoother(create("estimator", "kf"), lag, create("noise_adapter", "sage-husa"))
    fls.start(init, model)
    outputs = [o for o in (fls.step(z, model) for z in zs) if o is not None] + fls.flush()
    np.testing.assert_allclose(np.stack([o.state.mean for o in outputs]), batch.mean, rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.stack([o.state.cov for o in outputs]), batch.cov, rtol=0, atol=1e-12)
    if lag == 0:
        np.testing.assert_allclose(batch.mean, result.mean, rtol=0, atol=0)


@pytest.mark.parametrize("engine", ("ekf", "ukf", "ckf", "svd-ckf"))  # a nonlinear model: no kf
def test_storing_for_the_smoother_leaves_the_forward_pass_unchanged(engine, rng):
    Q, R = np.diag([1e-4, 4e-3]), np.diag([0.01, 0.02])
    model = pendulum_model(Q, R)
    zs = pendulum_data(rng, 15, model)
    init = Gaussian(np.array([0.6, 0.1]), np.diag([0.1, 0.1]))
    plain = gf.filter_sequence(create("estimator", engine), model, zs, init)
    stored = gf.filter_sequence(create("estimator", engine), model, zs, init, store="smoother")
    assert plain.smoother_inputs is None
    np.testing.assert_array_equal(stored.mean, plain.mean)
    np.testing.assert_array_equal(stored.cov, plain.cov)
    # the stored prediction of step k+1 is the engine's predict of step k's posterior
    prior = create("estimator", engine).predict(Gaussian(stored.mean[4], stored.cov[4]), model)
    np.testing.assert_allclose(stored.smoother_inputs.prior_mean[5], prior.mean, rtol=0, atol=1e-14)
    np.testing.assert_allclose(stored.smoother_inputs.prior_cov[5], prior.cov, rtol=0, atol=1e-14)
