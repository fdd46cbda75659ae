"""The compiled seam: one backend switch, a model's own jitted f/h, overrides honoured.

* A third-party model that brings its own jitted ``f``/``h`` (`gnssframework.backend.jit`,
  `CompiledFunctions`) runs the fused compiled path and equals the NumPy path.
* An engine subclass that overrides ``measurement_moments``, ``posterior_cov`` or
  ``square_root`` is never bypassed by a fused compiled update.
* The strapdown loop follows the process-wide backend (``GNSSFRAMEWORK_BACKEND``).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from gnssframework import backend
from gnssframework.estimation import CompiledFunctions, Gaussian, NonlinearModel
from gnssframework_plugins.estimators import CubatureKalmanFilter, SvdCubatureKalmanFilter

from test_kernels import REL, _close, _engine
from turn_target import DT, OMEGA, Q, SENSOR, prior, turn, turn_f


# -- a third-party model: a 2-D constant-turn target seen by range and bearing ----------


@backend.jit
def range_bearing_h(params, X, k, Z, kz):
    """Range and bearing of [x, y] from the sensor at params[0, :2]."""
    dx, dy = X[k, 0] - params[0, 0], X[k, 1] - params[0, 1]
    Z[kz, 0] = math.sqrt(dx * dx + dy * dy)
    Z[kz, 1] = math.atan2(dy, dx)


def _model(calls: list, compiled: bool) -> NonlinearModel:
    sensor = np.array(SENSOR)

    def f(x):
        calls.append("f")
        return turn(x)

    def h(x):
        calls.append("h")
        d = x[..., :2] - sensor
        return np.stack([np.hypot(d[..., 0], d[..., 1]), np.arctan2(d[..., 1], d[..., 0])], axis=-1)

    twins = CompiledFunctions(turn_f, [[DT, OMEGA]], range_bearing_h, [sensor]) if compiled else None
    return NonlinearModel(f, h, Q, np.diag([0.5, 1e-4]), compiled=twins)


def _state(batch: int, seed: int = 0) -> tuple[Gaussian, np.ndarray]:
    rng = np.random.default_rng(seed)
    state = prior(batch, rng)
    z = np.stack([np.full(batch, 160.0), np.full(batch, 0.12)], axis=-1) + 0.01 * rng.standard_normal((batch, 2))
    return state, z


@pytest.mark.slow
@pytest.mark.parametrize("name", ("ukf", "ckf", "svd-ckf"))
@pytest.mark.parametrize("batch", (3, 300))
def test_a_third_party_model_with_its_own_jitted_f_and_h_runs_fused_and_equals_numpy(name, batch):
    state, z = _state(batch)
    est = _engine(name)  # ukf with alpha 0.5: weights of order 1, as tests/estimation/test_kernels.py
    numpy_calls: list = []
    est.backend = "numpy"
    ref = est.update(est.predict(state, _model(numpy_calls, True)), z, _model(numpy_calls, True))
    assert numpy_calls == ["f", "h"]  # the reference path evaluates the NumPy functions
    compiled_calls: list = []
    est.backend = "numba"
    model = _model(compiled_calls, True)
    upd = est.update(est.predict(state, model), z, model)
    assert compiled_calls == []  # both steps ran in compiled code on the model's own f and h
    for field in ("innovation_cov", "gain", "cross_cov", "predicted_measurement"):
        _close(getattr(ref, field), getattr(upd, field))
    # z - z_hat carries z_hat's rounding, at the scale of z (not of the difference).
    assert np.max(np.abs(ref.innovation - upd.innovation)) <= REL * np.max(np.abs(z))
    _close(ref.state.mean, upd.state.mean)
    _close(ref.state.cov, upd.state.cov)


def test_compiled_functions_refuse_what_the_kernels_cannot_call():
    from gnssframework.errors import ConfigError

    with pytest.raises(ConfigError, match="CompiledFunctions.h"):
        CompiledFunctions(turn_f, [[DT, OMEGA]], "range", [[0.0, 0.0]])
    with pytest.raises(ConfigError, match="CompiledFunctions.f_params"):
        CompiledFunctions(turn_f, [DT, OMEGA], range_bearing_h, [[0.0, 0.0]])
    with pytest.raises(ConfigError, match="CompiledFunctions.sizes"):
        CompiledFunctions(turn_f, [[DT, OMEGA]], range_bearing_h, [[0.0, 0.0]], sizes=(4,))
    # Equal (so two channels' filters holding one merge into a batch) when the functions
    # are the same and the parameters equal; never by walking the jitted functions' state.
    one = CompiledFunctions(turn_f, [[DT, OMEGA]], range_bearing_h, [[0.0, 0.0]])
    assert one == CompiledFunctions(turn_f, np.array([[DT, OMEGA]]), range_bearing_h, [[0.0, 0.0]])
    assert one != CompiledFunctions(turn_f, [[DT, 2 * OMEGA]], range_bearing_h, [[0.0, 0.0]])
    assert one != CompiledFunctions(turn_f, [[DT, OMEGA]], range_bearing_h, [[0.0, 0.0]], sizes=(4, 2))
    assert not hasattr(one, "__dict__")


# -- overrides are honoured -------------------------------------------------------------


class InflatedCkf(CubatureKalmanFilter):
    """Doubles the innovation covariance (a research variant: a fading-memory S)."""

    name = "ckf-inflated-s"

    def measurement_moments(self, prior, model):
        z_hat, S, C = super().measurement_moments(prior, model)
        return z_hat, 2.0 * S, C


class ShrunkPosteriorCkf(CubatureKalmanFilter):
    """Keeps 10 % more of the prior covariance than the textbook posterior."""

    name = "ckf-shrunk-posterior"

    def posterior_cov(self, prior, gain, S, model):
        return 1.1 * super().posterior_cov(prior, gain, S, model)


class ScaledRootCkf(CubatureKalmanFilter):
    """A root 1.5 times Cholesky's: points the compiled rule does not describe."""

    name = "ckf-scaled-root"

    def square_root(self, cov):
        return 1.5 * super().square_root(cov)


@pytest.mark.parametrize("variant", (InflatedCkf, ShrunkPosteriorCkf, ScaledRootCkf))
def test_an_engine_override_is_honoured_on_the_compiled_backend(variant):
    # The model carries compiled twins, so the plain engine would run fused; the variant's
    # override must change the result exactly as it does on the NumPy path.
    state, z = _state(5)
    model = _model([], True)
    results = {}
    for bk in ("numpy", "numba"):
        for cls in (CubatureKalmanFilter, variant):
            est = cls()
            est.backend = bk
            results[bk, cls] = est.update(est.predict(state, model), z, model)
    plain, changed = results["numba", CubatureKalmanFilter], results["numba", variant]
    assert not np.allclose(plain.state.cov, changed.state.cov)  # the override made a difference
    ref = results["numpy", variant]
    _close(ref.innovation_cov, changed.innovation_cov)
    _close(ref.state.mean, changed.state.mean)
    _close(ref.state.cov, changed.state.cov)


def test_which_class_a_compiled_rule_describes():
    # A rule stands for the points of the class that declares it: svd-ckf declares its
    # root; a subclass overriding the root without declaring one gets no rule.
    assert SvdCubatureKalmanFilter().kernel_rule(3)[0] == 1
    assert CubatureKalmanFilter().kernel_rule(3)[0] == 0
    assert not ScaledRootCkf._kernel_rule_ok and ScaledRootCkf()._cached_rule(3) is None
    assert not InflatedCkf._fused_update_ok and InflatedCkf._kernel_rule_ok
    assert CubatureKalmanFilter._fused_update_ok and SvdCubatureKalmanFilter._fused_update_ok


# -- the backend is chosen once, when an engine is built ----------------------------------


def _path_taken(est) -> str:
    """``"numba"`` when a predict and update ran without the model's NumPy f and h."""
    calls: list = []
    state, z = _state(3)
    model = _model(calls, True)
    est.update(est.predict(state, model), z, model)
    return "numpy" if calls == ["f", "h"] else "numba" if calls == [] else f"mixed {calls}"


@pytest.mark.parametrize("built_under", ("numba", "numpy"))
def test_an_engine_keeps_the_backend_it_was_built_under(monkeypatch, built_under):
    flipped = {"numba": "numpy", "numpy": "numba"}[built_under]
    try:
        monkeypatch.setenv("GNSSFRAMEWORK_BACKEND", built_under)
        backend.set_backend(None)  # reads the environment again
        est = CubatureKalmanFilter()
        assert est.uses_compiled is (built_under == "numba") and est.backend is None
        assert _path_taken(est) == built_under
        monkeypatch.setenv("GNSSFRAMEWORK_BACKEND", flipped)
        backend.set_backend(None)
        assert _path_taken(est) == built_under  # the flip moves engines built after it only
        assert _path_taken(CubatureKalmanFilter()) == flipped
        backend.set_backend(built_under)
        assert _path_taken(_engine("ckf")) == built_under  # built through the registry
        est.backend = flipped  # the instance's own choice chooses again
        assert _path_taken(est) == flipped
    finally:
        monkeypatch.undo()  # the environment as it was (a CI job may run under numpy)...
        backend.set_backend(None)  # ...read again


def test_an_engine_refuses_an_unknown_backend_naming_the_field():
    from gnssframework.errors import ConfigError

    est = CubatureKalmanFilter()
    with pytest.raises(ConfigError, match="estimator.backend"):
        est.backend = "fortran"
    assert est.backend is None  # the refused value is not kept


# -- the strapdown loop follows the process-wide backend --------------------------------


def test_the_strapdown_loop_follows_the_process_wide_backend(monkeypatch):
    from gnssframework.inertial import mechanisation as mech

    calls = []
    real = mech.integrate_kernel
    monkeypatch.setattr(mech, "integrate_kernel", lambda *a, **k: (calls.append(1), real(*a, **k))[1])
    start = mech.NavState(np.array([1.0, 0.0, 0.0, 0.0]), np.zeros(3), np.array([6378137.0, 0.0, 0.0]))
    dth, dv = np.full((4, 3), 1e-4), np.full((4, 3), 1e-3)
    options = mech.MechanisationOptions()
    assert options.backend is None
    try:
        backend.set_backend("numpy")
        ref = mech.integrate(start, dth, dv, 0.005, options)
        assert calls == []  # the NumPy reference, as GNSSFRAMEWORK_BACKEND=numpy asks
        backend.set_backend("numba")
        got = mech.integrate(start, dth, dv, 0.005, options)
        assert calls == [1]
        mech.integrate(start, dth, dv, 0.005, mech.MechanisationOptions(backend="numpy"))
        assert calls == [1]  # an explicit choice wins over the process-wide one
    finally:
        backend.set_backend(None)
    np.testing.assert_allclose(got.velocity_ecef_mps, ref.velocity_ecef_mps, rtol=0, atol=1e-11)
