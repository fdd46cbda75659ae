"""Posterior Cramér-Rao bound: the recursion against a Kalman filter, the correlator
Fisher information against numerical derivatives, and the bound against the candidates."""

import numpy as np
from gnssframework.backend import set_backend
import pytest
from filterpy.kalman import KalmanFilter

from gnssframework.experiments import get_scenario
from gnssframework.receiver.tracking.pcrb import correlator_fisher, pcrb_linear
from gnssframework.signal.correlator_model import amplitude_from_cn0, correlator_mean, tap_noise_cov


def test_pcrb_equals_the_kalman_covariance_on_a_linear_gaussian_model():
    # On a linear-Gaussian model the PCRB is attained: J_k^-1 is the KF covariance.
    # Oracle: FilterPy's Kalman filter on a random 4-state, 2-measurement model.
    rng = np.random.default_rng(0)
    n, m, steps = 4, 2, 30
    F = np.eye(n) + 0.1 * rng.standard_normal((n, n))
    G = rng.standard_normal((n, n))
    Q = 0.05 * G @ G.T
    H = rng.standard_normal((m, n))
    R = np.diag([0.3, 2.0])
    P0 = np.diag([4.0, 1.0, 2.0, 0.5])
    Rinv_sqrt = np.diag(1 / np.sqrt(np.diag(R)))
    bound = pcrb_linear(F, Q, lambda k: Rinv_sqrt @ H, P0, steps)
    kf = KalmanFilter(dim_x=n, dim_z=m)
    kf.F, kf.Q, kf.H, kf.R, kf.P = F, Q, H, R, P0.copy()
    for k in range(steps):
        if k:
            kf.predict()
        kf.update(np.zeros(m))
        np.testing.assert_allclose(bound[k], kf.P, rtol=1e-9, atol=1e-12)


def test_pcrb_handles_a_singular_process_noise():
    # A constant state (Q = 0) measured K times with variance r: the bound is
    # 1 / (1/p0 + K/r), the closed form of averaging.
    bound = pcrb_linear(np.eye(1), np.zeros((1, 1)), lambda k: np.array([[1 / np.sqrt(0.5)]]), np.eye(1) * 2.0, 50)
    K = np.arange(1, 51)
    np.testing.assert_allclose(bound[:, 0, 0], 1 / (1 / 2.0 + K / 0.5), rtol=1e-12)


@pytest.mark.other_machines
@pytest.mark.parametrize("update_first", [True, False])
def test_compiled_pcrb_equals_the_numpy_recursion(update_first):
    # Stacked square roots run in one compiled call under the numba backend; the NumPy
    # loop is the reference (1e-12 relative). A random 9-state model with a singular Q
    # and a poorly known state (variance 1e6, like the carrier-phase offsets).

    rng = np.random.default_rng(3)
    n, m, steps = 9, 5, 40
    F = np.eye(n) + 0.05 * rng.standard_normal((n, n))
    G = rng.standard_normal((n, 3))
    Q = 0.1 * G @ G.T
    roots = rng.standard_normal((steps, m, n))
    P0 = np.diag(np.r_[np.full(n - 1, 2.0), 1e6])
    # Tolerates: 1e-12 of each step's largest entry, or 10 times what P0 one ulp up or
    # down moves the NumPy recursion (about 2e-15 with the update first, 2e-13 without:
    # the 1e6 variance), whichever is larger. The compiled loop repeats the reference's
    # products and LU solve in the same order, and equals it bitwise here under every
    # OpenBLAS kernel tried; the measured allowance is for a CPU whose BLAS rounds the
    # reference's products otherwise. Resolution: Q scaled by 1 + 1e-9 in the compiled
    # call fails this (checked by mutation: 7e-10).
    from gnssframework import testing

    try:
        set_backend("numpy")
        reference = pcrb_linear(F, Q, roots.__getitem__, P0, steps, update_first)
        assert np.array_equal(pcrb_linear(F, Q, roots, P0, steps, update_first), reference)  # same loop
        nudged = [list(pcrb_linear(F, Q, roots, p, steps, update_first)) for p in testing.ulp_nudges(P0)]
        set_backend("numba")
        compiled = pcrb_linear(F, Q, roots, P0, steps, update_first)
    finally:
        set_backend(None)
    # each step normalised by its own largest entry (a list of steps)
    testing.assert_within_rounding(list(compiled), list(reference), nudged, what="compiled PCRB recursion")
    # Not the same function by accident: a changed root changes the compiled result.
    roots[steps // 2, 0, 0] += 1.0
    set_backend("numba")
    try:
        assert np.max(np.abs(pcrb_linear(F, Q, roots, P0, steps, update_first) - compiled)) > 1e-6
    finally:
        set_backend(None)
    with pytest.raises(ValueError, match="steps=40"):
        pcrb_linear(F, Q, roots[:-1], P0, steps, update_first)


@pytest.mark.other_machines
def test_vector_tracking_bound_is_the_same_on_both_backends():
    # Tolerates: the rounding the 100-step information recursion amplifies, measured here
    # on the NumPy path with P0 one ulp up and one ulp down (about 1e-10 to 7e-10 relative;
    # the compiled path differs by 0 to 4e-10 here and by 1.2e-9 on a Xeon with AVX-512,
    # as OpenBLAS's kernels and numba's code change with the CPU). Why: a fixed 1e-12
    # passed only on the machine that wrote it. Resolution: a compiled PCRB whose
    # measurement square roots are scaled by 1 + 1e-7, or whose F is off by 1e-9 on the
    # diagonal, fails this (checked by mutation: 3e-8 and 2e-8 against about 7e-9).
    from gnssframework import testing

    scen = get_scenario({"kind": "vector-tracking", "duration_s": 1.0, "channels": 8, "settle_s": 0.0})
    P0 = np.diag([100.0] * 3 + [1.0] * 3 + [100.0, 1.0])
    try:
        set_backend("numpy")
        reference = scen.bound(30.0, P0)
        nudged = [scen.bound(30.0, p) for p in testing.ulp_nudges(P0)]
        set_backend("numba")
        compiled = scen.bound(30.0, P0)
    finally:
        set_backend(None)
    np.testing.assert_array_equal(compiled[0], reference[0])  # the times
    testing.assert_within_rounding(compiled, reference, nudged, factor=10.0, what="compiled PCRB")


@pytest.mark.parametrize("cn0", [30.0, 45.0])
def test_correlator_fisher_matches_numerical_derivatives_of_the_correlator_model(cn0):
    # J = d mu^T C^-1 d mu over [I; Q], derivatives of correlator_mean taken numerically
    # on each side of the correlation peak (the prompt's kink) and averaged.
    T, d = 0.01, 0.5
    offsets = np.array([-d, 0.0, d])
    Cinv = np.linalg.inv(tap_noise_cov(offsets))
    A = float(amplitude_from_cn0(cn0, T))
    h = 1e-6

    def mu(tau, phase):
        y = correlator_mean(A, tau, phase, 0.0, T, offsets)
        return np.concatenate([y.real, y.imag])

    def info(tau0):
        dt = (mu(tau0 + h, 0.3) - mu(tau0 - h, 0.3)) / (2 * h)
        dp = (mu(tau0, 0.3 + h) - mu(tau0, 0.3 - h)) / (2 * h)
        J = np.zeros((2, 2))
        for a, da in enumerate((dt, dp)):
            for b, db in enumerate((dt, dp)):
                J[a, b] = da[:3] @ Cinv @ db[:3] + da[3:] @ Cinv @ db[3:]
        return J

    expected = 0.5 * (info(1e-4) + info(-1e-4))
    np.testing.assert_allclose(correlator_fisher(cn0, T, 2 * d), expected, rtol=1e-3, atol=1e-6 * A**2)
    # The phase bound is the textbook 1 / (2 c T) rad^2 per interval.
    assert correlator_fisher(cn0, T)[1, 1] == pytest.approx(2 * 10 ** (cn0 / 10) * T)


def test_no_candidate_beats_the_pcrb_beyond_monte_carlo_noise():
    scen = get_scenario({"kind": "vector-tracking", "duration_s": 3.0, "settle_s": 0.5, "steady_state_s": 1.5})
    for name, params in (
        ("discriminator", {}),
        ("iq-filter", {"output": "split"}),
        ("iq-filter", {"output": "filtered"}),
    ):
        plugins = scen.build(
            {
                "channel_filter": {"name": name, "params": params},
                "nav_filter": {"name": "ekf-pv", "params": {"clock": "ocxo"}},
            }
        )
        m = scen.run_batch({"cn0_dbhz": 35.0}, plugins, 6, np.random.default_rng(9)).metrics
        for err, bound in (("position_error_rmse", "pcrb_position"), ("velocity_error_rmse", "pcrb_velocity")):
            # The bound is on the mean square error: the mean of the squared per-run RMS
            # errors may not fall below the squared bound by more than two standard errors.
            # (Early in a run the position error is close to it: measured 4.5 +- 0.8 m^2
            # for the discriminators against 4.1 m^2.)
            sq = m[err] ** 2
            assert np.mean(sq) + 2 * np.std(sq, ddof=1) / np.sqrt(sq.size) > np.mean(m[bound] ** 2), (name, err)


# --- The code-only bound ---------------------------------------------------------------


def _sky(n_ch: int = 6, seed: int = 4):
    """Satellites at 20 000 km in random directions of the upper half-sphere, moving at
    3.9 km/s in random directions, and a receiver at the origin."""
    rng = np.random.default_rng(seed)
    up = rng.standard_normal((n_ch, 3))
    up[:, 2] = np.abs(up[:, 2]) + 0.3
    s0 = 2e7 * up / np.linalg.norm(up, axis=1, keepdims=True)
    vel = 3.9e3 * rng.standard_normal((n_ch, 3)) / np.sqrt(3)
    return s0, vel


def test_code_only_bound_of_a_static_receiver_is_the_least_squares_covariance_over_k():
    # Static satellites and receiver, velocity and drift known, no clock noise: the K
    # intervals' code measurements of variance sigma^2 = lambda_chip^2 / J_tau (per
    # channel) average to the snapshot least-squares covariance sigma^2 (G^T G)^-1 / K,
    # G = [-e^T, 1] (the closed form of averaging K independent snapshots).
    from gnssframework.receiver.tracking.pcrb import vector_tracking_pcrb
    from gnssframework.signal.constants import CA_CHIP_LENGTH_M

    s0, _ = _sky()
    cn0, T, K = 40.0, 0.01, 200
    P0 = np.diag([1e8] * 3 + [1e-18] * 3 + [1e8, 1e-18])
    _, pos, _ = vector_tracking_pcrb(
        lambda t: np.broadcast_to(s0, np.shape(t) + s0.shape),
        np.zeros(3),
        np.zeros(3),
        np.zeros((2, 2)),
        P0,
        np.full(len(s0), cn0),
        T,
        K,
        measurements="code",
    )
    e = s0 / np.linalg.norm(s0, axis=1, keepdims=True)
    G = np.hstack([-e, np.ones((len(s0), 1))])
    sigma2 = CA_CHIP_LENGTH_M**2 / correlator_fisher(cn0, T)[0, 0]
    k = np.arange(1, K + 1)
    np.testing.assert_allclose(pos, np.sqrt(np.trace(sigma2 * np.linalg.inv(G.T @ G)[:3, :3]) / k), rtol=1e-4)
    # Exactly, with the 1e8 m^2 prior on position and clock bias (its information 1e-8
    # against about 1e-4 per interval: 6e-5 of the bound at k = 1, hence 1e-4 above).
    P = np.linalg.inv(np.eye(4) / 1e8 + k[:, None, None] * (G.T @ G)[None] / sigma2)
    np.testing.assert_allclose(pos, np.sqrt(np.trace(P[:, :3, :3], axis1=1, axis2=2)), rtol=1e-9)


def test_code_only_bound_is_the_batch_least_squares_information_of_the_whole_state():
    # Moving satellites, unknown velocity and clock drift, no clock noise: the state at
    # step k is Phi^k x_0 (Phi the constant-velocity transition), so the bound at step k
    # is Phi^k (P0^-1 + sum_j (H_j Phi^j)^T (H_j Phi^j))^-1 Phi^kT, the batch
    # least-squares information of all the code measurements up to k, H_j's rows
    # sqrt(J_tau) [-e_ij^T, 0, 1, 0] / lambda_chip with e_ij towards satellite i at t_j.
    from gnssframework.receiver.tracking.pcrb import vector_tracking_pcrb
    from gnssframework.signal.constants import CA_CHIP_LENGTH_M

    s0, sv = _sky()
    r0, v = np.array([1.0, -2.0, 0.5]), np.array([3.0, 1.0, -0.2])
    cn0, T, K = np.array([45.0, 40.0, 35.0, 45.0, 30.0, 42.0]), 0.02, 60
    P0 = np.diag([25.0] * 3 + [0.5] * 3 + [400.0, 4.0])
    sat_pos = lambda t: s0 + np.asarray(t)[..., None, None] * sv  # noqa: E731
    times, pos, vel = vector_tracking_pcrb(sat_pos, r0, v, np.zeros((2, 2)), P0, cn0, T, K, measurements="code")
    Phi = np.eye(8)
    Phi[0:3, 3:6] = T * np.eye(3)
    Phi[6, 7] = T
    info = np.linalg.inv(P0)
    sq = np.sqrt([correlator_fisher(c, T)[0, 0] for c in cn0])
    for j, t in enumerate(times):
        los = sat_pos(t) - (r0 + v * t)
        e = los / np.linalg.norm(los, axis=1, keepdims=True)
        H = np.zeros((len(s0), 8))
        H[:, 0:3], H[:, 6] = -e, 1.0
        A = (sq[:, None] * H / CA_CHIP_LENGTH_M) @ np.linalg.matrix_power(Phi, j)
        info += A.T @ A
        Pj = np.linalg.matrix_power(Phi, j) @ np.linalg.inv(info) @ np.linalg.matrix_power(Phi, j).T
        assert pos[j] == pytest.approx(np.sqrt(np.trace(Pj[0:3, 0:3])), rel=1e-8)
        assert vel[j] == pytest.approx(np.sqrt(np.trace(Pj[3:6, 3:6])), rel=1e-8)


def test_the_carrier_phase_only_adds_information():
    # Dropping the carrier phase cannot lower the bound; with it, the velocity bound is
    # orders of magnitude lower (phase tracks range changes to millimetres: measured 207
    # times lower after 3 s here, a deterministic number; 100 is asserted). The default is
    # the code-and-carrier bound.
    from gnssframework.errors import ConfigError
    from gnssframework.receiver.tracking.pcrb import vector_tracking_pcrb

    s0, sv = _sky()
    args = (
        lambda t: s0 + np.asarray(t)[..., None, None] * sv,
        np.zeros(3),
        np.zeros(3),
        np.diag([1e-4, 1e-6]),
        np.diag([9.0] * 3 + [0.09] * 3 + [9.0, 0.09]),
        np.full(len(s0), 35.0),
        0.01,
        300,
    )
    _, pos_code, vel_code = vector_tracking_pcrb(*args, measurements="code")
    _, pos_both, vel_both = vector_tracking_pcrb(*args, measurements="code-and-carrier")
    assert np.array_equal(vector_tracking_pcrb(*args)[1], pos_both)
    assert np.all(pos_code >= pos_both * (1 - 1e-9)) and np.all(vel_code >= vel_both * (1 - 1e-9))
    assert vel_code[-1] > 100 * vel_both[-1]
    with pytest.raises(ConfigError, match="measurements.*'carrier'.*allowed: code-and-carrier, code"):
        vector_tracking_pcrb(*args, measurements="carrier")


def test_scenario_reports_the_code_only_bound_where_it_reports_the_bound():
    kw = {"kind": "vector-tracking", "duration_s": 1.0, "settle_s": 0.2, "steady_state_s": 0.5}
    scen = get_scenario(kw)
    plugins = scen.build(
        {
            "channel_filter": {"name": "discriminator", "params": {}},
            "nav_filter": {"name": "ekf-pv", "params": {"clock": "ocxo"}},
        }
    )
    m = scen.run_batch({"cn0_dbhz": 40.0}, plugins, 2, np.random.default_rng(1)).metrics
    times, code_pos, code_vel = scen.bound(40.0, scen.truth(40.0, 1, np.random.default_rng(0))[2], "code")
    keep = times >= 0.2
    np.testing.assert_allclose(m["pcrb_position_code"], np.sqrt(np.mean(code_pos[keep] ** 2)), rtol=1e-12)
    np.testing.assert_allclose(m["pcrb_velocity_code"], np.sqrt(np.mean(code_vel[keep] ** 2)), rtol=1e-12)
    assert np.all(m["pcrb_position_code"] > m["pcrb_position"])
    moving = scen.run_batch({"cn0_dbhz": 40.0, "motion": "figure-eight"}, plugins, 1, np.random.default_rng(1))
    assert "pcrb_position_code" not in moving.metrics and "pcrb_position" not in moving.metrics
    off = get_scenario({**kw, "pcrb": False}).run_batch({"cn0_dbhz": 40.0}, plugins, 1, np.random.default_rng(1))
    assert "pcrb_position_code" not in off.metrics and "pcrb_position" not in off.metrics
