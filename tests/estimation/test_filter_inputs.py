"""Bad filter inputs are refused at the boundary with a library error that names the input."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import gnssframework as gf
from conftest import builtin_names, create

#: Every built-in estimator (a new one is covered without editing this file).
ESTIMATORS = builtin_names("estimator")
F = np.array([[1.0, 1.0], [0.0, 1.0]])
MODEL = gf.LinearModel(F, np.array([[1.0, 0.0]]), 0.01 * np.eye(2), np.eye(1))


def _run(name, mean, cov, zs):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no raw NumPy RuntimeWarning may reach the user
        return gf.filter_sequence(create("estimator", name), MODEL, zs, gf.Gaussian(mean, cov))


@pytest.mark.parametrize("name", ESTIMATORS)
def test_nan_initial_mean_is_named_with_its_batch_element(name):
    assert set(ESTIMATORS) >= {"kf", "ekf", "ukf", "ckf", "svd-ckf"}
    mean = np.zeros((4, 2))
    mean[2, 1] = np.nan
    with pytest.raises(gf.InvalidInitialStateError, match=r"batch element \(2,\): initial mean is NaN or inf"):
        _run(name, mean, np.eye(2), np.zeros((5, 4, 1)))


@pytest.mark.parametrize("bad", [np.diag([1.0, -1.0]), np.full((2, 2), np.nan), np.array([[1.0, 2.0], [0.0, 1.0]])])
def test_indefinite_nan_or_asymmetric_initial_covariance_is_named_with_its_batch_element(bad):
    cov = np.broadcast_to(np.eye(2), (3, 2, 2)).copy()
    cov[1] = bad
    with pytest.raises(gf.InvalidInitialStateError, match=r"batch element \(1,\): initial covariance"):
        _run("ckf", np.zeros((3, 2)), cov, np.zeros((5, 3, 1)))


def test_zero_length_measurement_sequence_is_refused_naming_zs():
    with pytest.raises(gf.InvalidInputError, match=r"kf: zs: is a zero-length measurement sequence"):
        _run("kf", np.zeros(2), np.eye(2), np.zeros((0, 1)))


def test_ukf_on_1e300_measurements_fails_by_name_without_a_numpy_warning():
    zs = np.full((5, 1), 1e300)
    with pytest.raises(gf.NonFiniteError) as err:
        _run("ukf", np.zeros(2), np.eye(2), zs)
    assert err.value.filter_name == "ukf" and err.value.step is not None and "magnitude up to" in str(err.value)
    # The filters whose arithmetic stays finite return finite results.
    res = _run("kf", np.zeros(2), np.eye(2), zs)
    assert np.isfinite(res.mean).all()


# -- Hypothesis: random bad inputs to every estimator ----------------------------------------

BAD_KINDS = [
    "nan_mean",
    "inf_mean",
    "nan_cov",
    "indefinite_cov",
    "mean_dim",
    "cov_shape",
    "zs_dim",
    "zs_batch",
    "zero_length",
    "nan_measurement",
    "zs_rank",
]
#: What the error message must name for each kind.
NAMED = {
    "nan_mean": "initial mean",
    "inf_mean": "initial mean",
    "nan_cov": "initial covariance",
    "indefinite_cov": "initial covariance",
    "mean_dim": "initial mean",
    "cov_shape": "Gaussian.cov",
    "zs_dim": "zs",
    "zs_batch": "zs",
    "zero_length": "zs",
    "nan_measurement": "measurement is NaN",
    "zs_rank": "zs",
}


@settings(max_examples=100, deadline=None)
@given(name=st.sampled_from(ESTIMATORS), kind=st.sampled_from(BAD_KINDS), batch=st.integers(1, 4), data=st.data())
def test_random_bad_inputs_get_a_library_error_naming_the_input(name, kind, batch, data):
    bad = data.draw(st.integers(0, batch - 1), label="bad element")
    steps = data.draw(st.integers(1, 6), label="steps")
    mean, cov = np.zeros((batch, 2)), np.broadcast_to(np.eye(2), (batch, 2, 2)).copy()
    zs = np.zeros((steps, batch, 1))
    if kind == "nan_mean":
        mean[bad, data.draw(st.integers(0, 1))] = np.nan
    elif kind == "inf_mean":
        mean[bad, 0] = data.draw(st.sampled_from([np.inf, -np.inf]))
    elif kind == "nan_cov":
        cov[bad, 1, 1] = data.draw(st.sampled_from([np.nan, np.inf]))
    elif kind == "indefinite_cov":
        cov[bad] = np.diag([1.0, -data.draw(st.floats(1e-6, 1e6))])
    elif kind == "mean_dim":
        mean, cov = np.zeros((batch, 3)), np.eye(3)
    elif kind == "cov_shape":
        cov = np.eye(3)
    elif kind == "zs_dim":
        zs = np.zeros((steps, batch, data.draw(st.integers(2, 3))))
    elif kind == "zs_batch":  # batches of 2+ and 3+ elements do not broadcast
        mean, cov, zs = np.zeros((batch + 1, 2)), np.eye(2), np.zeros((steps, batch + 2, 1))
    elif kind == "zero_length":
        zs = np.zeros((0, batch, 1))
    elif kind == "nan_measurement":
        zs[data.draw(st.integers(0, steps - 1)), bad, 0] = np.nan
    elif kind == "zs_rank":
        zs = np.zeros(steps)
    with pytest.raises(gf.GnssFrameworkError) as err:
        _run(name, mean, cov, zs)
    message = str(err.value)
    assert NAMED[kind] in message, message
    if kind in ("nan_mean", "inf_mean", "nan_cov", "indefinite_cov", "nan_measurement"):
        assert f"batch element ({bad},)" in message, message


# -- noise adapters, augmentations and FilterStep itself ---------------------------------------

#: Every built-in noise adapter.
ADAPTERS = builtin_names("noise_adapter")


@pytest.mark.parametrize("adapter", ADAPTERS)
@pytest.mark.parametrize("name", ESTIMATORS)
def test_an_adapter_overflow_is_refused_naming_filter_adapter_element_and_step(name, adapter):
    assert set(ADAPTERS) >= {"sage-husa", "innovation", "ml-q"}
    zs = np.zeros((40, 3, 1))
    zs[3, 1, 0] = 1e300  # one corrupted sample in element 1; the adapter squares its innovation
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # was: RuntimeWarning overflow, then LinAlgError from eigh
        try:
            res = gf.filter_sequence(
                create("estimator", name),
                MODEL,
                zs,
                gf.Gaussian(np.zeros((3, 2)), np.eye(2)),
                adapter=create("noise_adapter", adapter),
            )
        except gf.NonFiniteError as err:
            e = err
        else:
            e = None
    if name in ("kf", "ekf"):  # finite arithmetic until the adapter squares the innovation
        assert e is not None and f"noise adapter {adapter!r}: its Q or R estimate is not finite" in str(e)
    if e is None:  # a sigma-point filter may keep finite numbers (the adapter clamps at its ceiling)
        assert np.isfinite(res.mean).all() and np.isfinite(res.R).all()
        return
    assert e.filter_name == name and e.batch_indices == [(1,)] and e.step is not None and e.step >= 3, str(e)
    assert "noise adapter" in str(e) or "prediction" in str(e), str(e)  # where the overflow surfaced


@pytest.mark.parametrize("bad", [np.nan, np.inf])
@pytest.mark.parametrize("name", ["kf", "ckf"])
def test_colored_ar1_skips_a_missing_measurement_and_its_decorrelation(name, bad):
    """With ``missing="skip"`` a NaN/inf sample is a missing measurement: both differenced
    measurements that contain it are skipped, and the step after it predicts without the
    w/V* decorrelation (J = 0), instead of failing (NaN) or warning (inf)."""
    rng = np.random.default_rng(4)
    zs = rng.normal(size=(30, 2, 1))
    gap = zs.copy()
    gap[10, 1, 0] = bad  # element 1 only
    kw = dict(augmentation=create("augmentation", "colored-ar1", psi=0.8), missing="skip")
    init = gf.Gaussian(np.zeros((2, 2)), np.eye(2))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        full = gf.filter_sequence(create("estimator", name), MODEL, zs, init, **kw)
        res = gf.filter_sequence(create("estimator", name), MODEL, gap, init, **kw)
    assert np.isfinite(res.mean).all() and np.isfinite(res.cov).all()
    assert res.recoveries["missing"] == 2  # z*_9 = z_10 - psi z_9 and z*_10 = z_11 - psi z_10
    assert res.skipped[:, 1].nonzero()[0].tolist() == [9, 10] and not res.skipped[:, 0].any()
    np.testing.assert_array_equal(res.mean[:, 0], full.mean[:, 0])  # the other element is untouched
    np.testing.assert_array_equal(res.mean[:9, 1], full.mean[:9, 1])  # causal: nothing before the gap moves
    # The prediction over the gap is the plain model's, with the raw Q: P grows by F P F' + Q.
    P9, P10 = res.cov[9, 1], res.cov[10, 1]
    np.testing.assert_allclose(P10, F @ P9 @ F.T + 0.01 * np.eye(2), rtol=1e-12)


STEP_BAD = {  # kind -> (z for a batch of 3, model, what the message must name)
    "z non-numeric": (np.array([["a"], ["b"], ["c"]]), MODEL, "measurement z: is not a numeric array"),
    "z complex": (np.ones((3, 1)) * 1j, MODEL, "measurement z: is complex"),
    "z wrong length": (np.zeros((3, 2)), MODEL, "measurement z: has shape (3, 2)"),
    "z scalar": (np.array(0.0), MODEL, "measurement z: has shape ()"),
    "z wrong batch": (np.zeros((4, 1)), MODEL, "measurement z: has batch shape (4,)"),
    "z empty batch": (np.zeros((0, 1)), MODEL, "measurement z: has batch shape (0,)"),
    "z NaN": (np.array([[0.0], [np.nan], [0.0]]), MODEL, "measurement is NaN or inf at batch element (1,)"),
}


@settings(max_examples=60, deadline=None)
@given(name=st.sampled_from(ESTIMATORS), kind=st.sampled_from(sorted(STEP_BAD)))
def test_filter_step_refuses_bad_step_inputs_naming_them(name, kind):
    """The same inputs through `FilterStep` directly, as a plugin calls it."""
    z, model, named = STEP_BAD[kind]
    step = gf.estimation.FilterStep(create("estimator", name))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(gf.GnssFrameworkError) as err:
            state = step.start(gf.Gaussian(np.zeros((3, 2)), np.eye(2)), model)
            step(state, z, model)
    assert named in str(err.value) and str(err.value).startswith(f"{name}: "), str(err.value)


@pytest.mark.parametrize(
    "where, value, named",
    [
        ("zs", np.array([["a"], ["b"]]), "zs: is not a numeric array"),
        ("zs", [[1.0], [1.0, 2.0]], "zs: is not a numeric array"),  # ragged
        ("zs", np.zeros((3, 1)) + 1j, "zs: is complex"),  # NumPy would drop the imaginary part with a warning
        ("mean", np.array(["a", "b"]), "Gaussian.mean: is not a numeric array"),
        ("cov", np.ones((3, 2, 2)), "Gaussian.cov: batch shape (3,) does not broadcast with the mean's (2,)"),
    ],
)
def test_non_numeric_ragged_or_complex_input_is_named(where, value, named):
    mean, cov, zs = (np.zeros((2, 2)) if where == "cov" else np.zeros(2)), np.eye(2), np.zeros((3, 1))
    with pytest.raises(gf.GnssFrameworkError) as err:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            _run(
                "kf",
                value if where == "mean" else mean,
                value if where == "cov" else cov,
                value if where == "zs" else zs,
            )
    assert named in str(err.value), str(err.value)
