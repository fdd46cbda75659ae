"""The compiled path changes closed-loop results no more than rounding does (issue 11).

A step of the compiled kernels equals the NumPy reference to 1e-12 on random models
(tests/estimation/test_kernels.py), but in the closed vector loop (channel filters steering their
NCOs from the navigation filter) any rounding difference grows over a run. These tests
measure that growth on the reference itself, so the compiled path is judged against
what the arithmetic allows rather than against a bit pattern:

- the NumPy path run again with the initial state nudged by one ulp moves the results
  by about as much as switching to the compiled path does;
- the ``ukf`` at its default alpha = 1e-3 (centre weight about -1e6) loses digits to
  cancellation in both paths: against the same update evaluated in 80-bit long double
  the compiled path is as accurate as the NumPy path.
"""

from __future__ import annotations

import numpy as np
from gnssframework.backend import set_backend
import pytest

from gnssframework import testing
from gnssframework.experiments import get_scenario
from gnssframework_plugins import estimators as builtin_estimators

SERIES = (
    "code_error_chips",
    "freq_error_hz",
    "position_error_m",
    "velocity_error_m_s",
    "nav_nees",
    "code_output_error_chips",
    "freq_output_error_hz",
)


def _run(estimator: str, backend: str, nudge: bool = False):
    return testing.vector_loop_series(
        {"name": "iq-filter", "params": {"estimator": estimator}}, backend=backend, nudge_initial_ulp=nudge
    )


def _rel(a: dict, b: dict) -> dict[str, float]:
    return {k: float(np.max(np.abs(a[k] - b[k])) / np.max(np.abs(a[k]))) for k in SERIES}


@pytest.mark.other_machines
@pytest.mark.parametrize("estimator", ["svd-ckf", "ckf"])
def test_compiled_path_moves_closed_loop_results_no_more_than_rounding_moves_the_reference(estimator):
    # Resolution: a compiled posterior mean biased by 1e-8 relative per step fails this
    # (checked by mutation); 1e-10 does not, as the loop's own rounding growth covers it.
    # Finer per-step agreement is tests/estimation/test_kernels.py's (1e-12 on random models).
    reference = _run(estimator, "numpy")
    compiled = _rel(reference, _run(estimator, "numba"))
    nudged = _rel(reference, _run(estimator, "numpy", nudge=True))
    # The loop amplifies rounding: a one-ulp nudge of the reference moves its results far
    # beyond 1e-12 (measured 6e-9 to 3e-7 over 5 s), so no implementation that does not
    # repeat NumPy's summation order bit for bit could stay within 1e-12 of it.
    assert max(nudged.values()) > 1e-9
    # The yardstick is the one-ulp nudge alone: reversing the reference's sums gives, for
    # svd-ckf, exactly the compiled path's results (benchmarks/closed_loop_rounding.py),
    # so it would measure the compiled path against itself.
    for name in SERIES:
        assert compiled[name] <= 10 * nudged[name] + 1e-12, (name, compiled[name], nudged[name])


# -- the ukf's cancellation, against an 80-bit evaluation of the same update -------------

LD = np.longdouble


def _cholesky_ld(P: np.ndarray) -> np.ndarray:
    n = P.shape[0]
    L = np.zeros_like(P)
    for j in range(n):
        L[j, j] = np.sqrt(P[j, j] - np.sum(L[j, :j] ** 2))
        for i in range(j + 1, n):
            L[i, j] = (P[i, j] - np.sum(L[i, :j] * L[j, :j])) / L[j, j]
    return L


def _solve_spd_ld(S: np.ndarray, B: np.ndarray) -> np.ndarray:
    L = _cholesky_ld(S)
    n = S.shape[0]
    Y = np.zeros_like(B)
    for i in range(n):
        Y[i] = (B[i] - L[i, :i] @ Y[:i]) / L[i, i]
    X = np.zeros_like(B)
    for i in reversed(range(n)):
        X[i] = (Y[i] - L[i + 1 :, i] @ X[i + 1 :]) / L[i, i]
    return X


def _channel_iq_ld(x: np.ndarray, d: float, T: float) -> np.ndarray:
    """Zou et al. (2018) eqs. 2-7 in long double, written from the equations (not the
    library's code): A R(dtau - o) sinc(df T) [cos, sin](pi df T + dtheta), o = -d, 0, d."""
    A, dtau, theta, df = x[0], x[1], x[2], x[3]
    r = np.maximum(LD(0), LD(1) - np.abs(dtau - np.array([-d, 0.0, d], dtype=LD)))
    a = LD(np.pi) * df * LD(T)
    sinc = np.sin(a) / a if a != 0 else LD(1)
    return np.concatenate([A * r * sinc * np.cos(a + theta), A * r * sinc * np.sin(a + theta)])


def _ukf_update_ld(m, P, z, R, d, T, alpha=1e-3, beta=2.0, kappa=0.0):
    """Van der Merwe's scaled UKF update in long double: gain and posterior covariance."""
    n = m.shape[0]
    lam = LD(alpha) ** 2 * (n + LD(kappa)) - n
    c = n + lam
    wm = np.full(2 * n + 1, LD(1) / (2 * c))
    wc = wm.copy()
    wm[0] = lam / c
    wc[0] = lam / c + 1 - LD(alpha) ** 2 + LD(beta)
    L = _cholesky_ld(P) * np.sqrt(c)
    X = np.concatenate([m[None], m + L.T, m - L.T])
    Z = np.array([_channel_iq_ld(x, d, T) for x in X])
    z_hat = wm @ Z
    dZ, dX = Z - z_hat, X - m
    S = (dZ.T * wc) @ dZ + R
    K = _solve_spd_ld(S, ((dX.T * wc) @ dZ).T).T
    return K, P - K @ S @ K.T


@pytest.mark.other_machines
def test_compiled_ukf_update_is_as_accurate_as_the_numpy_update_on_the_loops_states():
    # The channel filter's ukf updates of a vector run (30 dB-Hz), the first 20 (P still
    # large, the worst cancellation: relative errors of about 1e-6 in the gain in both
    # paths, measured) and every tenth after.
    caught = []
    update = builtin_estimators.UnscentedKalmanFilter.update

    def spy(self, prior, z, model, **kwargs):
        caught.append((prior, np.array(z), model))
        return update(self, prior, z, model, **kwargs)

    builtin_estimators.UnscentedKalmanFilter.update = spy
    set_backend("numpy")
    try:
        scen = get_scenario({"kind": "vector-tracking", "duration_s": 1.5, "channels": 8, "settle_s": 0.5})
        plugins = scen.build(
            {
                "channel_filter": {"name": "iq-filter", "params": {"estimator": "ukf"}},
                "nav_filter": {"name": "ekf-pv", "params": {"clock": "ocxo"}},
            }
        )
        scen.run_batch({"cn0_dbhz": 30.0}, plugins, 1, np.random.default_rng(5))
    finally:
        builtin_estimators.UnscentedKalmanFilter.update = update
        set_backend(None)
    channel = plugins["channel_filter"]
    engine, T = channel.engine, channel.T
    d = 0.5  # early-prompt spacing of the scenario's 1-chip early-late spacing
    errors = {"numpy": [], "numba": []}
    moved = []  # per step: how far a one-ulp change of the prior moves the reference's gain and posterior
    steps = caught[:20] + caught[20::10]
    for k, (prior, z, model) in enumerate(steps):
        got = {}
        for backend in errors:
            engine.backend = backend  # the engine chose its path when built: choose again
            got[backend] = engine.update(prior, z, model)
        engine.backend = "numpy"
        ref_parts = (got["numpy"].gain, got["numpy"].state.cov)
        for mean, cov in zip(testing.ulp_nudges(prior.mean), testing.ulp_nudges(prior.cov)):
            nudged = engine.update(type(prior)(mean, cov), z, model)
            moved.append(
                (
                    k < 20,
                    testing.relative_change(ref_parts[0], nudged.gain),
                    testing.relative_change(ref_parts[1], nudged.state.cov),
                )
            )
        means = prior.mean.reshape(-1, 5)
        covs = np.broadcast_to(prior.cov, means.shape + (5,)).reshape(-1, 5, 5)
        zs = z.reshape(-1, 6)
        Rs = np.broadcast_to(model.R, (means.shape[0], 6, 6))
        for b in range(means.shape[0]):
            K, P = _ukf_update_ld(means[b].astype(LD), covs[b].astype(LD), zs[b].astype(LD), Rs[b].astype(LD), LD(d), T)
            for backend, upd in got.items():
                gain = upd.gain.reshape(-1, 5, 6)[b]
                cov = upd.state.cov.reshape(-1, 5, 5)[b]
                errors[backend].append(
                    (
                        k < 20,
                        float(np.max(np.abs(gain - K)) / np.max(np.abs(K))),
                        float(np.max(np.abs(cov - P)) / np.max(np.abs(P))),
                    )
                )
    ref, comp = np.array(errors["numpy"]), np.array(errors["numba"])
    # The long-double oracle is the same update: both paths are close to it at all...
    assert ref[:, 1:].max() < 1e-4 and comp[:, 1:].max() < 1e-4
    # ...the cancellation is real (far above double rounding) in both...
    assert ref[:, 1].max() > 1e-9 and comp[:, 1].max() > 1e-9
    # ...and the compiled path loses no more to it than the reference does, on the first
    # steps (gain errors about 1e-6) and after them (about 3e-10): at most twice the
    # reference's own error, or that error plus ten times what a one-ulp change of the prior
    # moves the reference (the rounding sensitivity of the update itself, the factor of
    # `gnssframework.testing.assert_within_rounding`), whichever is larger: two double-
    # precision paths through the same cancellation differ by about that much, on any CPU.
    # A compiled gain and posterior scaled by 1 + 1e-9 fail this (checked by mutation: on the
    # late steps' posterior, whose one-ulp sensitivity is about 2e-11; the gain's is 2e-10).
    moved = np.array(moved)
    for early in (True, False):
        rows, nudged = ref[:, 0] == early, moved[:, 0] == early
        for column in (1, 2):
            worst = ref[rows, column].max()
            allowed = max(2 * worst, worst + 10 * moved[nudged, column].max())
            assert comp[rows, column].max() <= allowed, (early, column, comp[rows, column].max(), allowed)
