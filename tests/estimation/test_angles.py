"""Angle-aware residuals and means (the model's residual/mean hooks) on a bearing model
across +-pi: with the hooks every engine tracks a target behind the sensor, without them
the 2 pi jumps of the innovation wreck the estimate; away from the cut the hooks change
nothing."""

from __future__ import annotations

import numpy as np
import pytest

import gnssframework as gf
from gnssframework.estimation import Gaussian, NonlinearModel, filter_sequence
from gnssframework.estimation.angles import angle_mean, angle_residual, wrap_angle

SIGMA_RANGE_M = 0.5
SIGMA_BEARING_RAD = 0.02
K = 60


def _h(x):
    return np.stack([np.hypot(x[..., 0], x[..., 1]), np.arctan2(x[..., 1], x[..., 0])], axis=-1)


def _model(hooks: bool) -> NonlinearModel:
    extra = {"residual_z": angle_residual(1), "mean_z": angle_mean(1)} if hooks else {}
    return NonlinearModel(
        f=lambda x: x, h=_h, Q=np.eye(2) * 1e-6, R=np.diag([SIGMA_RANGE_M**2, SIGMA_BEARING_RAD**2]), **extra
    )


def _bearing_run(target, seed=4):
    """Range and bearing of a fixed target, measured K times (bearing wrapped)."""
    rng = np.random.default_rng(seed)
    truth = _h(np.asarray(target, dtype=float))
    z = truth + rng.standard_normal((K, 2)) * [SIGMA_RANGE_M, SIGMA_BEARING_RAD]
    z[:, 1] = wrap_angle(z[:, 1])
    return z[:, None, :]  # (K, batch 1, m)


def _final_error_m(estimator, target, hooks, initial_mean):
    initial = Gaussian(np.array([initial_mean], dtype=float), np.eye(2)[None] * 4.0)
    result = filter_sequence(estimator, _model(hooks), _bearing_run(target), initial)
    return float(np.hypot(*(result.mean[-1, 0] - target)))


TARGET_BEHIND = np.array([-20.0, 0.05])  # bearing 3.139 rad: the noise crosses +-pi


@pytest.mark.parametrize("name", ["ekf", "ukf", "ckf", "svd-ckf"])
def test_with_the_hooks_every_engine_tracks_a_bearing_across_pi(name):
    estimator = gf.registry.create("estimator", name)
    z = _bearing_run(TARGET_BEHIND)
    assert (z[:, 0, 1] > 0).any() and (z[:, 0, 1] < 0).any()  # the measurements do cross the cut
    # Range 0.5 m / sqrt(60) and cross-range 20 m x 0.02 rad / sqrt(60): well under 0.5 m.
    assert _final_error_m(estimator, TARGET_BEHIND, True, [-19.0, -1.0]) < 0.5


@pytest.mark.slow
@pytest.mark.parametrize("name", ["ekf", "ukf"])
def test_without_the_hooks_the_same_run_goes_wrong(name):
    estimator = gf.registry.create("estimator", name)
    assert _final_error_m(estimator, TARGET_BEHIND, False, [-19.0, -1.0]) > 2.0


@pytest.mark.parametrize("name", ["ekf", "ukf", "ckf"])
def test_away_from_the_cut_the_residual_hook_changes_nothing(name):
    estimator = gf.registry.create("estimator", name)
    target = np.array([20.0, 3.0])
    initial = Gaussian(np.array([[19.0, 2.0]]), np.eye(2)[None] * 4.0)
    z = _bearing_run(target)
    residual_only = NonlinearModel(
        f=lambda x: x, h=_h, Q=_model(False).Q, R=_model(False).R, residual_z=angle_residual(1)
    )
    hooked = filter_sequence(estimator, residual_only, z, initial)
    plain = filter_sequence(estimator, _model(False), z, initial)
    # Equal up to rounding: the hooked model runs on NumPy, the plain one may run compiled,
    # and the UKF's default alpha = 1e-3 gives weights near 1e6 that amplify the rounding.
    np.testing.assert_allclose(hooked.mean, plain.mean, rtol=0, atol=1e-6)
    np.testing.assert_allclose(hooked.cov, plain.cov, rtol=1e-6, atol=1e-9)
    # The circular mean of the bearing's sigma points is another (close) estimator of it.
    circular = filter_sequence(estimator, _model(True), z, initial)
    np.testing.assert_allclose(circular.mean, plain.mean, rtol=0, atol=1e-3)


def test_an_angle_state_keeps_its_circular_mean_through_the_sigma_points():
    """A heading at pi: the sigma points straddle the cut; their mean must stay at pi."""
    model = NonlinearModel(
        f=lambda x: x,
        h=lambda x: x,
        Q=np.eye(1) * 1e-4,
        R=np.eye(1) * 0.01,
        residual_x=angle_residual(0),
        residual_z=angle_residual(0),
        mean_x=angle_mean(0),
        mean_z=angle_mean(0),
    )
    prior = Gaussian(np.array([[np.pi - 0.01]]), np.array([[[0.04]]]))
    predicted = gf.registry.create("estimator", "ukf", alpha=1.0).predict(prior, model)
    assert abs(wrap_angle(predicted.mean[0, 0] - (np.pi - 0.01))) < 1e-9
    assert predicted.cov[0, 0, 0] == pytest.approx(0.04 + 1e-4, rel=1e-9)


def test_helpers_against_hand_worked_values():
    res = angle_residual(1)
    d = res(np.array([5.0, np.pi - 0.1]), np.array([2.0, -np.pi + 0.1]))
    assert d[0] == 3.0 and d[1] == pytest.approx(-0.2)
    mean = angle_mean(1)
    m = mean(np.array([[1.0, np.pi - 0.2], [3.0, -np.pi + 0.1]]), np.array([0.5, 0.5]))
    assert m[0] == 2.0 and wrap_angle(m[1] - (np.pi - 0.05)) == pytest.approx(0.0, abs=1e-12)
