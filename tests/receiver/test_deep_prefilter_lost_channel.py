"""Why the tuned `vector` prefilter stopped with C/N0 from elevation (issue 22, reference 002).

With ``cn0_model = "elevation"`` the lowest channel of the 35 dB-Hz case is at about
27 dB-Hz; the tuned `vector` loop (`iq-filter`, ``ukf``, q[4] = 51.9) loses it in the
20 g boost, and some 3 s later the library refused the prefilter's innovation
covariance S as not positive definite (`examples/deep_integration_ci.toml` with
``cn0_model = "elevation"``, seed 2222, case 35dBHz, run 6, channel 6, step 13303).
The prior of that step, copied below (rounded) as this test's input, is a lost channel's:
its frequency error is 6.5 kHz and its phase variance 3.8e6 rad² (the phase is unknown).

The cause is the unscented transform's scaled points at a spread they were not made for.
With alpha = 1e-3 the points sit at ±0.0022 sigma and the central covariance weight is
about -1e6, so the transform is a local second-order Taylor expansion: for the bounded
correlator outputs (|h| <= A) at a phase spread of thousands of radians its predicted
mean moves by 5e4 (against A = 1.6), and S is the difference of terms of size
|W0c| |z0 - z_hat|^2 ~ 1e15, whose rounding reaches the correlators' R (about 0.3):
whether S is then positive definite is down to the rounding of the machine. The exact S
of the same points (the centred form, algebraically equal and free of the cancellation,
van der Merwe 2004 eq. 3.172 rearranged about the central point) is positive definite.
A locked channel's prior is far from this regime. The independent truths: the bound
|E[h]| <= A of a bounded measurement, the algebraic identity of the two forms (checked
against the library at a locked prior), and the rounding bound eps * sum |W_i| |dZ_i|^2.

The fix is the prefilter's: a phase is an angle, and a variance beyond a uniform phase's
(pi^2/3) says nothing more; `iq-filter` keeps its phase variance within it (scaling the
phase's row and column, so P stays positive definite), which brings the rounding of S a
billion times below R on the lost channel and leaves a locked channel bitwise untouched.
"""

import numpy as np
import pytest

import gnssframework as gf
from gnssframework.estimation import Gaussian
from gnssframework.interfaces import RunContext
from gnssframework.signal.correlator_model import CorrelatorSimulator, amplitude_from_cn0
from gnssframework_plugins.channel_filters import PHASE_VAR_UNIFORM_RAD2, _phase_spread_within_circle

T = 0.001
# The failing step's prior (run 6, channel 6; rounded to 7 digits): [A, dtau, dtheta, df, dfdot].
LOST_MEAN = np.array([1.630965, -0.36156, 3553.299, -6501.333, 423.607])
LOST_COV = np.array(
    [
        [2.884378e-03, 8.797204e-03, -8.502085e01, -1.301623e01, -6.322290e00],
        [8.797204e-03, 4.123431e-02, -3.982761e02, -6.075051e01, -2.943727e01],
        [-8.502085e01, -3.982761e02, 3.847358e06, 5.870169e05, 2.845178e05],
        [-1.301623e01, -6.075051e01, 5.870169e05, 2.435869e05, 1.558921e05],
        [-6.322290e00, -2.943727e01, 2.845178e05, 1.558921e05, 1.349594e05],
    ]
)
# A locked channel at the same amplitude: tenths of a radian and a few Hz.
LOCKED_MEAN = np.array([1.630965, 0.01, 0.1, 0.5, 2.0])
LOCKED_COV = np.diag([2.9e-3, 1e-4, 1e-2, 1.0, 25.0])


def _vector_prefilter():
    """The tuned `vector` candidate's prefilter of examples/deep_integration_ci.toml."""
    channel = gf.registry.create(
        "channel_filter",
        "iq-filter",
        estimator="ukf",
        adaptive=False,
        output="equivalent",
        q=[0.001, 1e-8, 1e-5, 1e-4, 51.9],
    )
    channel.reset(
        (1, 1),
        RunContext(coherent_time_s=T, early_late_spacing_chips=1.0, epoch_interval_s=T, cn0_dbhz=np.full((1, 1), 35.0)),
    )
    return channel


def _transform(channel, mean, cov):
    """The UKF's points, weights and transformed points of the prior (the library's NumPy path)."""
    X, wm, wc = channel.engine.sigma_points(Gaussian(mean[None], cov[None]))
    return X, wm, wc, np.asarray(channel.model.h(X))[:, 0]


def _exact_innovation_cov(Z, wm, wc, R):
    """S about the central point: sum_{i>0} W_i D_i D_i^T - g d^T - d g^T + (sum W^c) d d^T + R,
    D_i = Z_i - Z_0, d = z_hat - Z_0 = sum W^m_i D_i, g = sum W^c_i D_i; no weight multiplies
    a large central deviation, so no cancellation."""
    D = Z - Z[0]
    d, g = wm @ D, wc @ D
    return (D.T * wc) @ D - np.outer(g, d) - np.outer(d, g) + wc.sum() * np.outer(d, d) + R


def _rounding_bound(Z, wm, wc):
    """eps times the size of the terms the direct form sum W^c_i (Z_i - z_hat)(Z_i - z_hat)^T adds."""
    dZ = Z - wm @ Z
    return np.finfo(float).eps * float(np.abs(wc) @ np.sum(dZ**2, axis=1))


def test_the_exact_form_is_the_librarys_innovation_covariance_on_a_locked_channel():
    channel = _vector_prefilter()
    _, wm, wc, Z = _transform(channel, LOCKED_MEAN, LOCKED_COV)
    _, S, _ = channel.engine.measurement_moments(Gaussian(LOCKED_MEAN[None], LOCKED_COV[None]), channel.model)
    np.testing.assert_allclose(S[0], _exact_innovation_cov(Z, wm, wc, channel.model.R), rtol=1e-9, atol=1e-9)


def test_a_lost_channels_innovation_covariance_is_positive_definite_only_up_to_rounding():
    channel = _vector_prefilter()
    X, wm, wc, Z = _transform(channel, LOST_MEAN, LOST_COV)
    amplitude = LOST_MEAN[0]
    r_min = np.linalg.eigvalsh(channel.model.R).min()
    assert wc[0] < -1e5  # alpha = 1e-3: the central weight that makes the direct form a cancellation
    # The transform is a local Taylor expansion here: a bounded measurement (|h| <= A) gets a
    # predicted mean thousands of times its bound.
    z_hat = wm @ Z
    assert np.abs(z_hat).max() > 1e3 * amplitude
    # The direct form's rounding reaches R: its smallest eigenvalue is at the machine's mercy.
    assert _rounding_bound(Z, wm, wc) > 0.1 * r_min
    # The exact S of the same points is positive definite, by more than R's own margin.
    S_exact = _exact_innovation_cov(Z, wm, wc, channel.model.R)
    assert np.linalg.eigvalsh(S_exact).min() > 0.5 * r_min
    # A locked channel is nowhere near: the rounding is a billionth of R.
    _, wm_l, wc_l, Z_l = _transform(channel, LOCKED_MEAN, LOCKED_COV)
    assert _rounding_bound(Z_l, wm_l, wc_l) < 1e-9 * r_min


def test_the_prefilter_keeps_a_lost_channels_phase_spread_within_the_circle():
    capped = _phase_spread_within_circle(LOST_COV[None])[0]
    assert capped[2, 2] == pytest.approx(PHASE_VAR_UNIFORM_RAD2, rel=1e-12)
    # D P D: every correlation kept, the other variances untouched, still positive definite
    corr = lambda P: P / np.sqrt(np.outer(np.diag(P), np.diag(P)))  # noqa: E731
    np.testing.assert_allclose(corr(capped), corr(LOST_COV), rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(np.delete(np.diag(capped), 2), np.delete(np.diag(LOST_COV), 2))
    assert np.linalg.eigvalsh(capped).min() > 0
    # the cancellation is gone: rounding a billionth of R at the step the library refused
    channel = _vector_prefilter()
    prior = channel.engine.predict(Gaussian(LOST_MEAN[None], capped[None]), channel.model)
    _, wm, wc, Z = _transform(channel, prior.mean[0], prior.cov[0])
    assert _rounding_bound(Z, wm, wc) < 1e-6 * np.linalg.eigvalsh(channel.model.R).min()
    # a locked channel's covariance is returned as it is
    locked = LOCKED_COV[None]
    assert _phase_spread_within_circle(locked) is locked


def test_the_prefilter_steps_on_from_a_lost_channels_state():
    # The library refused this state's next update before the fix; now the channel
    # carries on (lost: its outputs are what the loss-of-lock metric judges).
    channel = _vector_prefilter()
    rng = np.random.default_rng(22)
    simulator, amplitude = CorrelatorSimulator(T, 1.0), amplitude_from_cn0(np.full((1, 1), 27.0), T)
    zero = np.zeros((1, 1))
    channel.step(
        {
            "correlators": simulator.draw(zero, zero, zero, amplitude, rng),
            "nco_shift_chips": zero,
            "nco_shift_hz": zero,
            "data_bit": np.ones((1, 1)),
        }
    )
    channel.state = Gaussian(LOST_MEAN[None], LOST_COV[None])
    for _ in range(200):
        out = channel.step(
            {
                "correlators": simulator.draw(zero, zero, rng.uniform(-500, 500, (1, 1)), amplitude, rng),
                "nco_shift_chips": zero,
                "nco_shift_hz": zero,
                "data_bit": np.ones((1, 1)),
            }
        )
        assert channel.state.cov[0, 2, 2] < 1e3  # was 3.8e6 rad² and growing
    assert np.all(np.isfinite(out["freq_error_hz"])) and np.all(out["freq_error_var_hz2"] > 0)
