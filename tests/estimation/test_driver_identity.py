"""The Gaussian rules are written once: every driver that composes them gives the same numbers.

The plain drivers (points, moments, gain and posterior as separate calls, the model's
f/h in NumPy between them), the fused drivers (one compiled pass with the model's
jitted f/h) and their size-specialised twins compose the same per-element steps
(`gnssframework.estimation.compiled.drivers.element_steps`). On a model whose NumPy and
jitted functions are the same arithmetic (only +, -, *, / and sqrt, all correctly
rounded in both, in the same order), the three must agree bit for bit, for every
sigma-point estimator, on a serial and a parallel batch, with a missing measurement.
Where the arithmetic differs (the NumPy path's BLAS/LAPACK products and factorisations;
the KF/EKF compiled moments against NumPy matmul) they agree to rounding: 1e-12
relative, as `test_kernels` holds the kernels to the NumPy reference.
"""

from __future__ import annotations

import numpy as np
import pytest

from gnssframework import backend
from gnssframework.estimation import CompiledFunctions, Gaussian, LinearModel, NonlinearModel
from gnssframework.estimation import compiled as kernels
from gnssframework.estimation.compiled_model import linear_f

from test_kernels import _close, _engine
from turn_target import COS, OMEGA, SENSOR, SIN, TURN_F, prior, turn, turn_row

SIGMA_ENGINES = ("ukf", "ckf", "svd-ckf")
FIELDS = ("innovation", "innovation_cov", "gain", "cross_cov", "predicted_measurement", "skipped")
BATCHES = (5, kernels.PARALLEL_MIN_BATCH + 3)  # serial drivers; parallel/split drivers
STEPS = 3


@backend.jit
def range_row(params, X, k, Z, kz):
    """Range, slope and range rate of [x, y, vx, vy] from the sensor at params[0]."""
    dx, dy = X[k, 0] - params[0, 0], X[k, 1] - params[0, 1]
    r = np.sqrt(dx * dx + dy * dy)
    Z[kz, 0] = r
    Z[kz, 1] = dy / dx
    Z[kz, 2] = (X[k, 2] * dx + X[k, 3] * dy) / r


@backend.jit
def range_jacobian(params, X, k, J):
    dx, dy = X[k, 0] - params[0, 0], X[k, 1] - params[0, 1]
    vx, vy = X[k, 2], X[k, 3]
    r = np.sqrt(dx * dx + dy * dy)
    rr = (vx * dx + vy * dy) / r
    J[0, 0], J[0, 1], J[0, 2], J[0, 3] = dx / r, dy / r, 0.0, 0.0
    J[1, 0], J[1, 1], J[1, 2], J[1, 3] = -dy / (dx * dx), 1.0 / dx, 0.0, 0.0
    J[2, 0], J[2, 1] = (vx - rr * dx / r) / r, (vy - rr * dy / r) / r
    J[2, 2], J[2, 3] = dx / r, dy / r


def ranges(x):
    dx, dy = x[..., 0] - SENSOR[0], x[..., 1] - SENSOR[1]
    r = np.sqrt(dx * dx + dy * dy)
    return np.stack([r, dy / dx, (x[..., 2] * dx + x[..., 3] * dy) / r], axis=-1)


def ranges_jacobian(x):
    J = np.zeros(x.shape[:-1] + (3, 4))
    X = np.ascontiguousarray(x.reshape(-1, 4))
    Jf = J.reshape(-1, 3, 4)
    params = np.array([SENSOR])
    for k in range(X.shape[0]):  # the test's reference Jacobian, not a hot path
        range_jacobian.py_func(params, X, k, Jf[k])
    return J


def model(twins: str) -> NonlinearModel:
    """``twins``: "none" (plain drivers), "generic" (fused drivers), "sized" (their
    twins specialised to 4 states and 3 measurements), "linear-f" (``F x`` compiled as
    `linear_f`: the KF/EKF compiled predict and moments)."""
    Q = np.diag([0.01, 0.01, 0.1, 0.1])
    R = np.diag([0.5, 1e-3, 0.05]) + 0.01
    f_row, f_params = (linear_f, TURN_F) if twins == "linear-f" else (turn_row, [[SIN, COS, OMEGA]])
    compiled = (
        None
        if twins == "none"
        else CompiledFunctions(
            f_row, f_params, range_row, [SENSOR], h_jacobian=range_jacobian, sizes=(4, 3) if twins == "sized" else None
        )
    )
    return NonlinearModel(
        turn,
        ranges,
        Q,
        R,
        f_jacobian=lambda x: np.broadcast_to(TURN_F, x.shape[:-1] + (4, 4)),
        h_jacobian=ranges_jacobian,
        compiled=compiled,
    )


def problem(batch: int, seed: int = 3):
    rng = np.random.default_rng(seed)
    state = prior(batch, rng)
    z = ranges(state.mean) + 0.05 * rng.standard_normal((batch, 3))
    z[1, 0] = np.nan  # a missing measurement: that element keeps its prior
    return state, z


def run(name: str, backend_name: str, mdl, state: Gaussian, z: np.ndarray) -> list[dict]:
    """Every output of ``STEPS`` predict + update cycles."""
    est = _engine(name)  # the UKF at alpha 0.5 (see test_kernels: no cancellation in its weights)
    est.backend = backend_name
    out = []
    for _ in range(STEPS):
        prior = est.predict(state, mdl)
        upd = est.update(prior, z, mdl, missing="skip")
        out.append(
            {
                "prior_mean": prior.mean,
                "prior_cov": prior.cov,
                "mean": upd.state.mean,
                "cov": upd.state.cov,
                **{f: np.asarray(getattr(upd, f)) for f in FIELDS},
            }
        )
        state = upd.state
    return out


def assert_identical(a: list[dict], b: list[dict]) -> None:
    for step_a, step_b in zip(a, b):
        for key, value in step_a.items():
            assert value.shape == step_b[key].shape, key
            assert value.tobytes() == step_b[key].tobytes(), f"{key} differs"


def assert_rounding(a: list[dict], b: list[dict]) -> None:
    for step_a, step_b in zip(a, b):
        for key, value in step_a.items():
            if key == "skipped":
                assert np.array_equal(value, step_b[key])
            else:
                _close(value, step_b[key])


def test_the_model_functions_are_the_same_arithmetic_in_numpy_and_compiled():
    # The premise of the bitwise comparisons below: f and h give the same bits both ways.
    state, _ = problem(7)
    x = np.ascontiguousarray(state.mean)
    Y, Z = np.empty_like(x), np.empty((7, 3))
    for k in range(7):
        turn_row(np.array([[SIN, COS, OMEGA]]), x, k, Y)
        range_row(np.array([SENSOR]), x, k, Z, k)
    assert Y.tobytes() == turn(x).tobytes()
    assert Z.tobytes() == ranges(x).tobytes()


@pytest.mark.slow
@pytest.mark.parametrize("batch", BATCHES)
@pytest.mark.parametrize("name", SIGMA_ENGINES)
def test_plain_fused_and_specialised_drivers_agree_bit_for_bit(name, batch):
    state, z = problem(batch)
    plain = run(name, "numba", model("none"), state, z)
    fused = run(name, "numba", model("generic"), state, z)
    sized = run(name, "numba", model("sized"), state, z)
    assert plain[0]["skipped"][1] and not plain[0]["skipped"][0]
    assert_identical(plain, fused)
    assert_identical(fused, sized)


@pytest.mark.parametrize("batch", BATCHES)
@pytest.mark.parametrize("name", SIGMA_ENGINES)
def test_compiled_drivers_equal_the_numpy_path_to_rounding(name, batch):
    state, z = problem(batch)
    reference = run(name, "numpy", model("none"), state, z)
    assert_rounding(reference, run(name, "numba", model("none"), state, z))
    assert_rounding(reference, run(name, "numba", model("sized"), state, z))


@pytest.mark.parametrize("batch", BATCHES)
def test_ekf_compiled_moments_and_update_equal_the_numpy_path_to_rounding(batch):
    # Plain: NumPy moments, compiled gain and posterior; with twins: compiled h, Jacobian
    # and moments too. Different products from NumPy's matmul: to rounding.
    state, z = problem(batch)
    reference = run("ekf", "numpy", model("none"), state, z)
    assert_rounding(reference, run("ekf", "numba", model("none"), state, z))
    assert_rounding(reference, run("ekf", "numba", model("linear-f"), state, z))


@pytest.mark.parametrize("batch", BATCHES)
def test_kf_compiled_predict_and_joseph_update_equal_the_numpy_path_to_rounding(batch):
    state, z = problem(batch)
    H = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 1.0]])
    linear = LinearModel(TURN_F, H, np.diag([0.01, 0.01, 0.1, 0.1]), np.diag([0.5, 0.2, 0.05]) + 0.01)
    z = state.mean @ H.T + 0.05 * np.arange(3)
    z[1, 0] = np.nan
    reference = run("kf", "numpy", linear, state, z)
    compiled = run("kf", "numba", linear, state, z)
    assert compiled[0]["skipped"][1]
    assert_rounding(reference, compiled)
