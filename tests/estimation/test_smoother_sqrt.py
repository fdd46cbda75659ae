"""The square-root RTS smoother (`gnssframework.estimation.smoother_sqrt`, ``form="sqrt"``, the
SVD-CKF's default) against independent truths:

- the covariance form of the same stored forward pass (``form="solve"``, itself checked
  against FilterPy and the dense joint posterior in test_smoother.py) on a well-conditioned
  nonlinear model, and the dense joint posterior of a linear model directly;
- on an ill-conditioned model (a constant-acceleration state with Q ~ 1e-18 and a 1e-4 m
  position measurement), a theorem (with P0 and Q positive definite every smoothed
  covariance is positive definite) and the same filter and smoother run in 60-digit decimal
  arithmetic: the covariance form's has negative eigenvalues there and errors larger than
  the smallest directions' spread; the square-root form's eigenvalues are all >= 0, it is
  exactly symmetric, and it is right to ~1e-5 of every direction's spread.
"""

from __future__ import annotations

import numpy as np
import pytest

import gnssframework as gf
from gnssframework import backend
from gnssframework.errors import ConfigError
from gnssframework.estimation import Gaussian, LinearModel
from conftest import create
from test_smoother import pendulum_data, pendulum_model


def _pendulum_run(rng, engine: str = "svd-ckf", K: int = 30):
    model = pendulum_model(np.diag([1e-4, 4e-3]), np.diag([0.01, 0.02]))
    zs = pendulum_data(rng, K, model)
    init = Gaussian(np.array([0.6, 0.1]), np.diag([0.1, 0.1]))
    return model, zs, init


def test_square_root_form_is_the_svd_ckfs_and_equals_the_covariance_form(rng):
    model, zs, init = _pendulum_run(rng)
    result = gf.filter_sequence(create("estimator", "svd-ckf"), model, zs, init, store="smoother")
    assert result.smoother_inputs.gain_form == "sqrt"
    X, Y, S_Q = result.smoother_inputs.factors
    # the stored factors are those of the stored prediction: X Y^T = C, Y Y^T + Q = P^-
    np.testing.assert_allclose(X @ np.swapaxes(Y, -1, -2), result.smoother_inputs.cross_cov, rtol=0, atol=1e-15)
    np.testing.assert_allclose(
        Y @ np.swapaxes(Y, -1, -2) + S_Q @ np.swapaxes(S_Q, -1, -2),
        result.smoother_inputs.prior_cov,
        rtol=0,
        atol=1e-15,
    )
    sqrt, plain = gf.smooth(result), gf.smooth(result, form="solve")
    assert sqrt.cov_root is not None and plain.cov_root is None
    np.testing.assert_allclose(sqrt.mean, plain.mean, rtol=0, atol=1e-9)
    np.testing.assert_allclose(sqrt.cov, plain.cov, rtol=0, atol=1e-9)
    np.testing.assert_allclose(sqrt.gain, plain.gain, rtol=0, atol=1e-9)
    np.testing.assert_allclose(sqrt.initial.mean, plain.initial.mean, rtol=0, atol=1e-9)
    np.testing.assert_allclose(sqrt.initial.cov, plain.initial.cov, rtol=0, atol=1e-9)
    np.testing.assert_allclose(sqrt.lag_one_cov(), plain.lag_one_cov(), rtol=0, atol=1e-9)
    np.testing.assert_allclose(sqrt.cov, sqrt.cov_root @ np.swapaxes(sqrt.cov_root, -1, -2), rtol=0, atol=1e-17)
    assert np.abs(sqrt.mean - result.mean).max() > 1e-3  # the backward pass did something
    for lag in (1, 4):
        lagged, lagged_plain = gf.fixed_lag_smooth(result, lag), gf.fixed_lag_smooth(result, lag, form="solve")
        np.testing.assert_allclose(lagged.mean, lagged_plain.mean, rtol=0, atol=1e-9)
        np.testing.assert_allclose(lagged.cov, lagged_plain.cov, rtol=0, atol=1e-9)


#: The ill-conditioned model: constant acceleration, 1 s steps, white-jerk Q with q = 1e-18, a
#: 1e-4 m position measurement, from a 100 m / 10 m/s / 1 m/s^2 prior (P's eigenvalues span ~1e10).
ILL_F = np.array([[1.0, 1.0, 0.5], [0.0, 1.0, 1.0], [0.0, 0.0, 1.0]])
ILL_Q = 1e-18 * np.array([[1 / 20, 1 / 8, 1 / 6], [1 / 8, 1 / 3, 1 / 2], [1 / 6, 1 / 2, 1.0]])
ILL_H, ILL_R, ILL_P0 = np.array([[1.0, 0.0, 0.0]]), np.array([[1e-8]]), np.diag([1e4, 1e2, 1.0])


def _ill_conditioned_run(rng, K: int = 300, B: int = 4):
    zs = rng.standard_normal((K, B, 1)) * np.sqrt(ILL_R[0, 0])
    result = gf.filter_sequence(
        create("estimator", "svd-ckf"),
        LinearModel(ILL_F, ILL_H, ILL_Q, ILL_R),
        zs,
        Gaussian(np.zeros(3), ILL_P0),
        store="smoother",
    )
    return zs, result


def _decimal_rts(zs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The Kalman filter and RTS smoother of the ill-conditioned model in 60-digit decimal
    arithmetic (textbook covariance form: at this precision its rounding is ~1e-45 of the
    largest variance, far below the smallest, ~1e-17 of ~1e-9), as float64 means ``(K, n)``
    and covariances ``(K, n, n)``."""
    from decimal import Decimal, localcontext

    def dec(a):
        return [[Decimal(repr(float(x))) for x in row] for row in np.atleast_2d(a)]

    def mul(A, B):
        return [
            [sum((A[i][k] * B[k][j] for k in range(len(B))), Decimal(0)) for j in range(len(B[0]))]
            for i in range(len(A))
        ]

    def tr(A):
        return [list(r) for r in zip(*A)]

    def add(A, B, sign=1):
        return [[a + sign * b for a, b in zip(ra, rb)] for ra, rb in zip(A, B)]

    def inv(A):  # Gauss-Jordan with partial pivoting
        n = len(A)
        M = [list(r) + [Decimal(int(i == j)) for j in range(n)] for i, r in enumerate(A)]
        for c in range(n):
            p = max(range(c, n), key=lambda r: abs(M[r][c]))
            M[c], M[p] = M[p], M[c]
            M[c] = [x / M[c][c] for x in M[c]]
            for r in range(n):
                if r != c:
                    M[r] = [x - M[r][c] * y for x, y in zip(M[r], M[c])]
        return [r[n:] for r in M]

    with localcontext() as ctx:
        ctx.prec = 60
        F, H, Q, R = dec(ILL_F), dec(ILL_H), dec(ILL_Q), dec(ILL_R)
        m, P = dec(np.zeros((3, 1))), dec(ILL_P0)
        filtered, predicted = [], []
        for z in zs:
            mp, Pp = mul(F, m), add(mul(mul(F, P), tr(F)), Q)
            S = add(mul(mul(H, Pp), tr(H)), R)
            K = mul(mul(Pp, tr(H)), inv(S))
            m = add(mp, mul(K, add(dec(z), mul(H, mp), -1)))
            P = add(Pp, mul(mul(K, S), tr(K)), -1)
            filtered.append((m, P))
            predicted.append((mp, Pp))
        smoothed = [filtered[-1]]
        for k in range(len(zs) - 2, -1, -1):
            (m, P), (mp, Pp), (ms, Ps) = filtered[k], predicted[k + 1], smoothed[0]
            G = mul(mul(P, tr(F)), inv(Pp))
            smoothed.insert(0, (add(m, mul(G, add(ms, mp, -1))), add(P, mul(mul(G, add(Ps, Pp, -1)), tr(G)))))
    return (
        np.array([[float(x[0]) for x in m] for m, _ in smoothed]),
        np.array([[[float(x) for x in row] for row in P] for _, P in smoothed]),
    )


def _whitened_error(cov: np.ndarray, reference: np.ndarray) -> float:
    """Largest error of ``cov`` in the reference's eigenbasis, each entry relative to its
    directions' standard deviations: ``|V^T (P - P_ref) V|_ij / sqrt(w_i w_j)``."""
    w, V = np.linalg.eigh(reference)
    err = np.swapaxes(V, -1, -2) @ (cov - reference) @ V
    return float((np.abs(err) / np.sqrt(w[..., :, None] * w[..., None, :])).max())


def test_square_root_form_stays_psd_where_the_covariance_form_does_not(rng):
    _, result = _ill_conditioned_run(rng)
    assert np.linalg.eigvalsh(result.cov).min() > 0  # the filter itself stayed PD
    plain = gf.smooth(result, form="solve").cov
    sqrt = gf.smooth(result)
    # The covariance form loses positive (semi-)definiteness: eigenvalues far below zero
    # (measured: -1.4e-14, against a largest of ~4e-10 and a smallest true one of ~1e-17).
    assert np.linalg.eigvalsh(plain).min() < -1e-15
    # The square-root form: symmetric, every eigenvalue >= 0, every matrix PD (Cholesky).
    np.testing.assert_array_equal(sqrt.cov, np.swapaxes(sqrt.cov, -1, -2))
    assert np.linalg.eigvalsh(sqrt.cov).min() >= 0.0
    np.linalg.cholesky(sqrt.cov)
    np.testing.assert_allclose(sqrt.mean, gf.smooth(result, form="solve").mean, rtol=0, atol=1e-9)
    # the smoothed covariance never exceeds the filtered one (Loewner order), to rounding
    gap = np.linalg.eigvalsh(result.cov - sqrt.cov)
    assert gap.min() >= -1e-12 * np.abs(result.cov).max()


@pytest.mark.parametrize("path", ["numpy", "numba"])
def test_square_root_form_is_accurate_where_the_covariance_forms_degrade(path, rng):
    """Against the 60-digit reference, per eigen-direction of the true covariance: the
    square-root form is right to 1.2e-5 of each direction's own spread (the forward pass's
    rounding: the median over steps is 6e-7 for every form); the covariance form ("solve") is
    off by 15-39 times the smallest direction's spread and the clipped one ("eigh") by 3-67
    (seeds 0-5, measured). The backward pass on either path (NumPy's QR, the compiled one)."""
    zs, result = _ill_conditioned_run(rng, B=1)
    mean, cov = _decimal_rts(zs[:, 0])
    assert np.linalg.eigvalsh(cov).min() > 0  # the truth is PD, as the theorem says
    backend.set_backend(path)
    try:
        errors = {
            form: _whitened_error(gf.smooth(result, form=form).cov[:, 0], cov) for form in ("solve", "eigh", "sqrt")
        }
        sqrt = gf.smooth(result)
    finally:
        backend.set_backend(None)
    assert errors["sqrt"] < 1e-3, errors
    assert errors["solve"] > 1.0 and errors["eigh"] > 1.0, errors
    assert np.linalg.eigvalsh(sqrt.cov).min() >= 0.0
    np.testing.assert_allclose(sqrt.mean[:, 0], mean, rtol=0, atol=1e-8)


def test_compiled_tria_equals_numpys_qr(rng):
    """`compiled.tria` against LAPACK's QR (`smoother_sqrt.tria` on the numpy backend): the same
    factor up to its columns' signs, lower triangular, full rank or not."""
    from gnssframework.estimation.compiled.tria import tria as compiled_tria
    from gnssframework.estimation.smoother_sqrt import tria

    A = rng.standard_normal((200, 5, 12))
    A[:50] = rng.standard_normal((50, 5, 2)) @ rng.standard_normal((50, 2, 12))  # rank 2
    A[50:60, 3] = 0.0  # a zero row
    L = compiled_tria(A)
    backend.set_backend("numpy")
    try:
        ref = tria(A)
    finally:
        backend.set_backend(None)
    gram = A @ np.swapaxes(A, -1, -2)
    scale = np.abs(gram).max(axis=(-2, -1), keepdims=True)
    assert np.all(np.triu(L, 1) == 0.0)
    np.testing.assert_allclose((L @ np.swapaxes(L, -1, -2)) / scale, gram / scale, rtol=0, atol=1e-14)
    # full rank: the factor is unique up to the signs of its columns
    np.testing.assert_allclose(np.abs(L[60:]), np.abs(ref[60:]), rtol=0, atol=1e-13 * np.sqrt(scale.max()))
    with pytest.raises(ValueError, match="columns"):
        compiled_tria(np.ones((2, 3, 2)))


def test_square_root_fixed_lag_smoother_stays_psd(rng):
    _, result = _ill_conditioned_run(rng)
    for lag in (5, 40):
        assert np.linalg.eigvalsh(gf.fixed_lag_smooth(result, lag).cov).min() >= 0.0
    full = gf.fixed_lag_smooth(result, result.mean.shape[0])
    np.testing.assert_allclose(full.cov, gf.smooth(result).cov, rtol=0, atol=1e-25)
    np.testing.assert_array_equal(gf.fixed_lag_smooth(result, 0).cov, result.cov)


def test_square_root_form_needs_the_factors_and_nonnegative_weights(rng):
    model = LinearModel(np.eye(1), np.eye(1), [[0.1]], [[1.0]])
    result = gf.filter_sequence(
        create("estimator", "kf"), model, np.zeros((3, 1)), Gaussian(np.zeros(1), np.eye(1)), store="smoother"
    )
    assert result.smoother_inputs.factors is None
    with pytest.raises(ConfigError, match="'sqrt' needs the factors"):
        gf.smooth(result, form="sqrt")
    with pytest.raises(ConfigError, match="'sqrt' needs the factors"):
        gf.fixed_lag_smooth(result, 2, form="sqrt")
    ukf = create("estimator", "ukf")  # alpha 1e-3: W0c = 4 - 1e6 < 0
    ukf.smoother_gain = "sqrt"
    with pytest.raises(ConfigError, match="nonnegative covariance weights"):
        gf.filter_sequence(ukf, model, np.zeros((3, 1)), Gaussian(np.zeros(1), np.eye(1)), store="smoother")


def test_square_root_smoother_on_the_compiled_points_equals_numpy(rng):
    """Under the numba backend the factors come from the compiled kernels' points (their own
    eigen root); the smoothed states equal the NumPy path's to rounding."""
    model, zs, init = _pendulum_run(rng)
    out = {}
    for path in ("numpy", "numba"):
        estimator = create("estimator", "svd-ckf")
        estimator.backend = path
        out[path] = gf.smooth(gf.filter_sequence(estimator, model, zs, init, store="smoother"))
    np.testing.assert_allclose(out["numba"].mean, out["numpy"].mean, rtol=0, atol=1e-12)
    np.testing.assert_allclose(out["numba"].cov, out["numpy"].cov, rtol=0, atol=1e-12)


def test_compiled_sqrt_terms_and_step_equal_the_numpy_path(rng):
    """`compiled.sqrt_smoother` (stacked factor, QR, triangular gain solve and the conditional
    root in one pass; the backward step's root and covariance in another) against the NumPy
    path (`smoother_sqrt._numpy_terms`: concatenation, LAPACK's QR, LU solve, SVD where
    singular), to rounding: ~1e-15 relative measured on these well-conditioned factors. Three
    elements have a rank-1 ``Y`` and no noise (``P^-`` singular): flagged by the kernel and
    given the NumPy path's pseudo-inverse gain."""
    from gnssframework.estimation import smoother_sqrt
    from gnssframework.estimation.compiled import sqrt_smoother

    n, N, B = 5, 10, 300
    X, Y = rng.standard_normal((2, B, n, N))
    S = 0.1 * rng.standard_normal((B, n, n))
    Y[:3], S[:3] = 0.0, 0.0
    Y[:3, 0, 0] = 1.0
    R = np.tril(rng.standard_normal((B, n, n)))

    def prod(a):
        return a @ np.swapaxes(a, -1, -2)

    _, _, regular = sqrt_smoother.sqrt_terms(X, Y, S)
    np.testing.assert_array_equal(regular, np.arange(B) >= 3)
    backend.set_backend("numba")
    try:
        G, D = smoother_sqrt.sqrt_terms(X, Y, S)
        mean, root, cov = smoother_sqrt.sqrt_rts_step_cov(np.zeros((B, n)), np.zeros((B, n)), np.ones((B, n)), R, G, D)
    finally:
        backend.set_backend(None)
    backend.set_backend("numpy")
    try:
        G0, D0 = smoother_sqrt.sqrt_terms(X, Y, S)
        mean0, root0 = smoother_sqrt.sqrt_rts_step(np.zeros((B, n)), np.zeros((B, n)), np.ones((B, n)), R, G0, D0)
    finally:
        backend.set_backend(None)
    assert np.abs(G0[:3]).max() > 0.1  # the pseudo-inverse gain is not zero
    for a, ref in ((G, G0), (prod(D), prod(D0)), (prod(root), prod(root0)), (cov, prod(root0)), (mean, mean0)):
        np.testing.assert_allclose(a, ref, rtol=0, atol=1e-12 * np.abs(ref).max())
    assert np.all(np.triu(D, 1) == 0.0) and np.all(np.triu(root, 1) == 0.0)
    np.testing.assert_array_equal(cov, np.swapaxes(cov, -1, -2))
