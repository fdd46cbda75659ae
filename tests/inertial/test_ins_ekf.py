"""The ``ins-ekf`` integration filter against independent oracles.

* Closed loop with differenced range/rate residuals against an open-loop 17-state filter
  that keeps the receiver clock (bias and drift, re-diffused every step: unobservable)
  and uses the undifferenced, per-channel 2x2 covariance, written out here with the
  textbook (non-Joseph) update. Every estimator from the registry must agree.
* Loose update: a position/velocity fix against the Gaussian conditioning formula.
"""

from __future__ import annotations

import numpy as np
import pytest

from gnssframework import testing
from gnssframework.errors import ConfigError, InvalidInputError
from gnssframework.interfaces import RunContext
from gnssframework.registry import create

M = 15


def _problem(rng, runs=3, n_ch=6):
    F = np.eye(M) + rng.normal(size=(M, M)) * 0.05
    L = rng.normal(size=(M, M)) * 0.1
    Q = L @ L.T + 1e-3 * np.eye(M)
    L0 = rng.normal(size=(M, M))
    P0 = L0 @ L0.T + np.eye(M)
    los = rng.normal(size=(runs, n_ch, 3))
    los /= np.linalg.norm(los, axis=-1, keepdims=True)
    A = rng.normal(size=(runs, n_ch, 2, 2)) * 0.7
    cov = A @ np.swapaxes(A, -1, -2) + 0.3 * np.eye(2)  # correlated range/rate noise per channel
    cn0 = rng.uniform(35, 48, size=(runs, n_ch))
    return F, Q, P0, los, cov, cn0


def _open_loop_with_clock(F, Q, P0, los, cov, zs, clock_var=1e10):
    """17 states [15 | bias, drift]; measurements [ranges..., rates...] of all channels."""
    runs, n = los.shape[:2]
    Fa = np.zeros((M + 2, M + 2))
    Fa[:M, :M] = F
    Fa[M:, M:] = [[1.0, 0.1], [0.0, 1.0]]
    Qa = np.zeros_like(Fa)
    Qa[:M, :M] = Q
    Qa[M:, M:] = clock_var * np.eye(2)
    H = np.zeros((runs, 2 * n, M + 2))
    H[:, :n, 6:9] = los
    H[:, n:, 3:6] = los
    H[:, :n, M] = -1.0
    H[:, n:, M + 1] = -1.0
    R = np.zeros((runs, 2 * n, 2 * n))
    i = np.arange(n)
    for a in range(2):
        for b in range(2):
            R[:, a * n + i, b * n + i] = cov[..., a, b]
    x = np.zeros((runs, M + 2))
    P = np.zeros((runs, M + 2, M + 2))
    P[:, :M, :M] = P0
    P[:, M:, M:] = clock_var * np.eye(2)
    for z in zs:
        x, P = x @ Fa.T, Fa @ P @ Fa.T + Qa
        S = H @ P @ np.swapaxes(H, 1, 2) + R
        K = P @ np.swapaxes(H, 1, 2) @ np.linalg.inv(S)
        x = x + np.einsum("rij,rj->ri", K, z - np.einsum("rij,rj->ri", H, x))
        P = P - K @ S @ np.swapaxes(K, 1, 2)
    return x[:, :M], P[:, :M, :M]


@pytest.mark.other_machines
@pytest.mark.parametrize("estimator", ["kf", "ekf", "ukf", "ckf"])
def test_closed_loop_differenced_filter_equals_open_loop_17_state_filter(estimator):
    rng = np.random.default_rng(12)
    F, Q, P0, los, cov, cn0 = _problem(rng)
    runs, n = los.shape[:2]
    # residual = true minus predicted: [e.dr - db, e.dv - dd] with a large common clock
    zs = [
        np.concatenate(
            [
                rng.normal(size=(runs, n)) * 3 + rng.normal(size=(runs, 1)) * 1e2,
                rng.normal(size=(runs, n)) + rng.normal(size=(runs, 1)) * 1e1,
            ],
            axis=-1,
        )
        for _ in range(5)
    ]
    x_ref, P_ref = _open_loop_with_clock(F, Q, P0, los, cov, zs)
    # Tolerates: the oracle's own rounding. Its clock states (variance 1e10, re-diffused
    # every step) make S ill-conditioned (about 1e10), so its non-Joseph update loses about
    # 10 digits: P0 one ulp away moves it by about 4e-6 relative, and so does another
    # OpenBLAS kernel (Prescott against SkylakeX: 5e-6). Measured here on the oracle and
    # allowed 10 times; the differenced filter itself is well conditioned. Resolution: the
    # filter with the range/rate cross-covariance dropped, or Q scaled by 1 + 1e-3, fails
    # this (checked by mutation).
    nudged = [_open_loop_with_clock(F, Q, p, los, cov, zs) for p in testing.ulp_nudges(P0)]

    ekf = create("nav_filter", "ins-ekf", estimator=estimator)
    ekf.reset((runs,), RunContext(initial_cov=P0))
    applied = np.zeros((runs, M))  # total correction applied to the "INS", propagated like the error
    for z in zs:
        applied = applied @ F.T
        # The corrected INS no longer has the applied part of the error: its residuals lose H @ applied.
        pred = np.concatenate(
            [np.einsum("rcj,rj->rc", los, applied[:, 6:9]), np.einsum("rcj,rj->rc", los, applied[:, 3:6])], axis=-1
        )
        zc = z - pred
        out = ekf.step(
            {
                "transition": F,
                "process_noise": Q,
                "residual_m": np.stack([zc[:, :n], zc[:, n:]], -1),
                "residual_cov": cov,
                "los": los,
                "cn0_dbhz": cn0,
            }
        )
        applied = applied + out["error_state"]
    testing.assert_within_rounding(applied, x_ref, [x for x, _ in nudged], what="corrections")
    testing.assert_within_rounding(ekf.cov, P_ref, [P for _, P in nudged], what="covariance")
    np.testing.assert_array_equal(ekf.state.mean, 0.0)  # closed loop: nothing carried over


def test_loose_update_is_gaussian_conditioning_on_the_fix():
    rng = np.random.default_rng(5)
    runs = 4
    L0 = rng.normal(size=(M, M))
    P0 = L0 @ L0.T + np.eye(M)
    B = rng.normal(size=(runs, 6, 6))
    R = B @ np.swapaxes(B, 1, 2) + np.eye(6)
    z = rng.normal(size=(runs, 6))
    ekf = create("nav_filter", "ins-ekf")
    ekf.reset((runs,), RunContext(initial_cov=P0))
    out = ekf.step({"position_velocity_error": z, "position_velocity_cov": R})
    idx = np.r_[6:9, 3:6]  # position then velocity in the 15-state layout
    S = P0[np.ix_(idx, idx)] + R
    K = P0[:, idx] @ np.linalg.inv(S)
    np.testing.assert_allclose(out["error_state"], np.einsum("rij,rj->ri", K, z), rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(out["cov"], P0 - K @ S @ np.swapaxes(K, 1, 2), rtol=1e-8, atol=1e-8)


def test_ins_ekf_refuses_bad_inputs_by_name():
    ekf = create("nav_filter", "ins-ekf")
    with pytest.raises(ConfigError, match="initial_cov"):
        ekf.reset((2,), RunContext())
    with pytest.raises(InvalidInputError, match="15, 15"):
        ekf.reset((2,), RunContext(initial_cov=np.eye(9)))
    ekf.reset((2,), RunContext(initial_cov=np.eye(M)))
    with pytest.raises(InvalidInputError, match="residual_m"):
        ekf.step({"transition": np.eye(M)})
    with pytest.raises(ConfigError, match="estimator"):
        create("nav_filter", "ins-ekf", estimator="no-such")
