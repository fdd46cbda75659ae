"""filter_sequence: stacking, failure naming, recovery policies."""

from __future__ import annotations

import numpy as np
import pytest

import gnssframework as gf
from conftest import ca_matrices, create, simulate_linear


def _problem(rng, batch=(4,), steps=30):
    F, H, Q = ca_matrices(q=0.01)
    R = np.array([[1.0]])
    xs, zs = simulate_linear(rng, F, H, Q, R, np.zeros(3), steps, batch)
    return gf.LinearModel(F, H, Q, R), xs, zs


def test_sequence_equals_a_hand_written_loop_and_stacks_on_axis_0(rng):
    model, _, zs = _problem(rng)
    init = gf.Gaussian(np.zeros(3), 10 * np.eye(3))
    est = create("estimator", "kf")
    res = gf.filter_sequence(est, model, zs, init)
    assert res.mean.shape == (30, 4, 3) and res.cov.shape == (30, 4, 3, 3)
    assert res.innovation.shape == (30, 4, 1) and res.R.shape == (30, 4, 1, 1)
    state = init
    for k in range(30):
        state = est.update(est.predict(state, model), zs[k], model).state
        np.testing.assert_allclose(res.mean[k], state.mean, rtol=1e-12)
    assert res.recoveries == {"missing": 0, "skip_update": 0, "symmetrize": 0, "clip_eigenvalues": 0}


def test_nan_measurement_raises_naming_filter_batch_element_and_step(rng):
    model, _, zs = _problem(rng)
    zs[7, 2, 0] = np.nan
    with pytest.raises(gf.InvalidMeasurementError) as err:
        gf.filter_sequence(create("estimator", "ukf"), model, zs, gf.Gaussian(np.zeros(3), np.eye(3)))
    assert (err.value.filter_name, err.value.batch_indices, err.value.step) == ("ukf", [(2,)], 7)
    assert "ukf" in str(err.value) and "(2,)" in str(err.value) and "step 7" in str(err.value)


def test_missing_measurements_are_skipped_and_counted(rng):
    model, _, zs = _problem(rng)
    zs[5, 1, 0] = np.nan
    zs[9, 3, 0] = np.inf
    res = gf.filter_sequence(create("estimator", "ckf"), model, zs, gf.Gaussian(np.zeros(3), np.eye(3)), missing="skip")
    assert res.recoveries["missing"] == 2
    assert res.skipped[5, 1] and res.skipped[9, 3] and res.skipped.sum() == 2
    # A skipped element keeps its prediction: its covariance grows instead of shrinking.
    assert np.trace(res.cov[5, 1]) > np.trace(res.cov[4, 1])
    assert np.isfinite(res.mean).all()


def _singular_r_model():
    F, H, Q = ca_matrices()
    R = np.zeros((2, 1, 1))
    R[0] = 1.0
    R[1] = -1e3  # a corrupt (negative) R for batch element 1
    return gf.LinearModel(F, H, Q, R)


def test_singular_innovation_covariance_raises_or_is_skipped(rng):
    model = _singular_r_model()
    zs = rng.standard_normal((5, 2, 1))
    init = gf.Gaussian(np.zeros(3), 0.1 * np.eye(3))
    with pytest.raises(gf.NotPositiveDefiniteError) as err:
        gf.filter_sequence(create("estimator", "ekf"), model, zs, init)
    assert err.value.batch_indices == [(1,)] and err.value.step == 0 and "innovation" in str(err.value)
    res = gf.filter_sequence(create("estimator", "ekf"), model, zs, init, on_failure="skip")
    assert res.recoveries["skip_update"] == 5 and res.skipped[:, 1].all() and not res.skipped[:, 0].any()


class _BrokenCovFilter(type(create("estimator", "kf"))):
    """A KF whose posterior covariance is made indefinite for batch element 0."""

    name = "broken-kf"

    def posterior_cov(self, prior, gain, S, model):
        cov = super().posterior_cov(prior, gain, S, model).copy()
        cov[0, 0, 0] = -1.0
        return cov


@pytest.mark.parametrize("policy, counter", [("skip", "skip_update"), ("clip", "clip_eigenvalues")])
def test_posterior_recovery_policies_are_counted(rng, policy, counter):
    model, _, zs = _problem(rng, batch=(2,), steps=6)
    init = gf.Gaussian(np.zeros(3), np.eye(3))
    with pytest.raises(gf.NotPositiveDefiniteError, match=r"broken-kf: .*batch element \(0,\), step 0"):
        gf.filter_sequence(_BrokenCovFilter(), model, zs, init)
    res = gf.filter_sequence(_BrokenCovFilter(), model, zs, init, on_failure=policy)
    assert res.recoveries[counter] == 6
    assert np.all(np.linalg.eigvalsh(res.cov) > 0)


def test_symmetrize_policy_repairs_an_asymmetric_covariance(rng):
    class Asym(_BrokenCovFilter):
        def posterior_cov(self, prior, gain, S, model):
            cov = super(_BrokenCovFilter, self).posterior_cov(prior, gain, S, model).copy()
            cov[0, 0, 1] += 5.0  # the lower triangle is what Cholesky reads: upper is off
            cov[0, 1, 0] -= 5.0
            return cov

    model, _, zs = _problem(rng, batch=(2,), steps=3)
    res = gf.filter_sequence(Asym(), model, zs, gf.Gaussian(np.zeros(3), np.eye(3)), on_failure="symmetrize")
    assert res.recoveries["symmetrize"] >= 1
    np.testing.assert_allclose(res.cov, np.swapaxes(res.cov, -1, -2))


def test_bad_policy_names_the_field_and_the_allowed_values(rng):
    model, _, zs = _problem(rng)
    with pytest.raises(gf.ConfigError, match="on_failure.*allowed: raise, skip, symmetrize, clip"):
        gf.filter_sequence(
            create("estimator", "kf"), model, zs, gf.Gaussian(np.zeros(3), np.eye(3)), on_failure="ignore"
        )


def test_time_varying_model_callable(rng):
    model, _, zs = _problem(rng, batch=(), steps=10)
    calls = []

    def model_at(k):
        calls.append(k)
        return model

    res = gf.filter_sequence(create("estimator", "kf"), model_at, zs, gf.Gaussian(np.zeros(3), np.eye(3)))
    ref = gf.filter_sequence(create("estimator", "kf"), model, zs, gf.Gaussian(np.zeros(3), np.eye(3)))
    assert calls == list(range(10))
    np.testing.assert_array_equal(res.mean, ref.mean)


@pytest.mark.parametrize(
    "engine, linear",
    [(e, True) for e in ("kf", "ekf", "ukf", "ckf", "svd-ckf")]
    + [(e, False) for e in ("ekf", "ukf", "ckf", "svd-ckf")],
)
def test_one_q_per_run_with_a_shared_initial_state_compiled_equals_numpy(engine, linear):
    """A per-run Q ``(B, n, n)`` with an unbatched initial state: the compiled predict
    broadcasts the state to Q's batch as the NumPy reference does (it raised a raw
    ValueError in the kernels' operand flattening)."""
    rng = np.random.default_rng(3)
    B = 5
    F, H = np.array([[1.0, 1.0], [0.0, 1.0]]), np.array([[1.0, 0.0]])
    Qb = np.stack([np.eye(2) * 0.01 * (i + 1) for i in range(B)])
    model = (
        gf.LinearModel(F, H, Qb, [[1.0]])
        if linear
        else gf.NonlinearModel(
            lambda x: x @ F.T,
            lambda x: x[..., :1],
            Qb,
            np.array([[1.0]]),
            f_jacobian=lambda x: np.broadcast_to(F, x.shape[:-1] + (2, 2)),
            h_jacobian=lambda x: np.broadcast_to(H, x.shape[:-1] + (1, 2)),
        )
    )
    zs = rng.standard_normal((4, B, 1))
    out = {}
    for backend in ("numba", "numpy"):
        # (ukf at alpha 0.5: the default 1e-3 weights amplify rounding ~1e6-fold, 1e-10 here)
        est = gf.registry.create("estimator", engine, **({"alpha": 0.5} if engine == "ukf" else {}))
        est.backend = backend
        out[backend] = gf.filter_sequence(est, model, zs, gf.Gaussian(np.zeros(2), np.eye(2)))
    np.testing.assert_allclose(out["numba"].mean, out["numpy"].mean, rtol=0, atol=1e-12)
    np.testing.assert_allclose(out["numba"].cov, out["numpy"].cov, rtol=0, atol=1e-12)
    # the runs differ by their Q: a state shared by the runs did not swallow it
    assert np.ptp(out["numpy"].cov[-1, :, 0, 0]) > 1e-3
