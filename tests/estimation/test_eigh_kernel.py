"""The compiled symmetric eigensolver behind ``svd-ckf`` (estimation.compiled.dense.eigh_into).

Oracles: NumPy/LAPACK ``eigvalsh``/``eigh``, the reconstruction ``A = V diag(w) V^T``
and ``V^T V = I``. The svd-ckf root only needs the eigenvectors up to sign and column
order; the last tests show that the cubature point set (hence every moment) does not
depend on either, and that the kernel's point set equals the one from LAPACK's ``eigh``.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings, strategies as st

from gnssframework.estimation import compiled as kernels
from gnssframework.estimation.compiled import dense


def _eigh(a):
    n = a.shape[0]
    w = np.empty(n)
    v = np.empty((n, n))
    dense.eigh(np.ascontiguousarray(a), w, v)
    return w, v


def _tridiagonal(a):
    n = a.shape[0]
    w = np.empty(n)
    v = np.empty((n, n))
    ok = dense.tridiagonal_eigh_into(np.ascontiguousarray(a), w, v, np.empty((n + 2, n)))
    return ok, w, v


def _check_decomposition(a, w, v, rel=1e-13):
    n = a.shape[0]
    scale = max(np.max(np.abs(a)), 1e-300)
    assert np.max(np.abs(np.sort(w) - np.linalg.eigvalsh(a))) <= rel * scale
    assert np.max(np.abs((v * w) @ v.T - a)) <= rel * scale
    assert np.max(np.abs(v.T @ v - np.eye(n))) <= rel


def _with_spectrum(rng, w):
    q, _ = np.linalg.qr(rng.standard_normal((len(w), len(w))))
    a = (q * w) @ q.T
    return 0.5 * (a + a.T)


@settings(max_examples=60, deadline=None)
@given(n=st.integers(1, 9), seed=st.integers(0, 2**32 - 1), kind=st.sampled_from(["indefinite", "pd", "scaled"]))
def test_eigensolver_reconstructs_the_matrix_with_orthonormal_vectors_and_lapack_eigenvalues(n, seed, kind):
    rng = np.random.default_rng(seed)
    a = rng.standard_normal((n, n))
    a = a + a.T
    if kind == "pd":
        a = a @ a.T + 1e-3 * np.eye(n)
    elif kind == "scaled":  # far from 1 both ways: the power-of-two scaling keeps squares finite
        a = a * 10.0 ** rng.choice([-150, -40, 40, 150])
    ok, w, v = _tridiagonal(a)
    assert ok  # the QR iteration itself converged (no Jacobi fallback)
    _check_decomposition(a, w, v)
    w2, v2 = _eigh(a)
    _check_decomposition(a, w2, v2)


@settings(max_examples=40, deadline=None)
@given(n=st.integers(2, 8), seed=st.integers(0, 2**32 - 1), spread=st.sampled_from([0.0, 1e-14, 1e-10, 1e-6]))
def test_near_degenerate_eigenvalues_still_give_a_backward_stable_decomposition(n, seed, spread):
    # A cluster of (nearly) equal eigenvalues: their eigenvectors are not determined (any
    # basis of the cluster's subspace is right), but A = V diag(w) V^T, V^T V = I and the
    # eigenvalues must hold to rounding.
    rng = np.random.default_rng(seed)
    k = rng.integers(2, n + 1)
    w = np.concatenate([1.0 + spread * np.arange(k), 3.0 + rng.random(n - k)])
    a = _with_spectrum(rng, rng.permutation(w))
    ok, wt, vt = _tridiagonal(a)
    assert ok
    _check_decomposition(a, wt, vt)


@settings(max_examples=30, deadline=None)
@given(n=st.integers(1, 8), seed=st.integers(0, 2**32 - 1))
def test_a_diagonal_matrix_keeps_the_coordinate_axes_even_with_repeated_entries(n, seed):
    # An initial covariance is often diagonal with repeated variances; no rotation may be
    # applied to it, or the cubature points would turn inside the repeated subspace.
    rng = np.random.default_rng(seed)
    d = rng.choice([0.5, 2.0, 25.0], size=n) * rng.choice([1.0, -1.0], size=n)
    w, v = _eigh(np.diag(d))
    assert np.array_equal(w, d)
    assert np.array_equal(v, np.eye(n))


def test_singular_and_zero_matrices():
    rng = np.random.default_rng(3)
    b = rng.standard_normal((5, 2))
    a = b @ b.T  # rank 2: three exact zero eigenvalues
    ok, w, v = _tridiagonal(a)
    assert ok
    _check_decomposition(a, w, v)
    assert np.sum(np.abs(w) <= 1e-14 * np.max(np.abs(a))) == 3
    w, v = _eigh(np.zeros((4, 4)))
    assert np.array_equal(w, np.zeros(4)) and np.array_equal(v, np.eye(4))


def test_non_finite_input_reports_no_convergence_instead_of_looping():
    a = np.eye(4)
    a[1, 2] = a[2, 1] = np.nan
    ok, _, _ = _tridiagonal(a)
    assert not ok


def _cubature_points(mean, root):
    n = len(mean)
    d = np.sqrt(n) * root.T  # row i: sqrt(n) * column i of the root
    return np.concatenate([mean + d, mean - d])


def _ckf_moments(points, fn):
    y = fn(points)
    mu = y.mean(axis=0)
    dy = y - mu
    return mu, dy.T @ dy / len(points)


@settings(max_examples=30, deadline=None)
@given(n=st.integers(1, 7), seed=st.integers(0, 2**32 - 1))
def test_cubature_point_set_ignores_eigenvector_sign_and_order(n, seed):
    # The claim the kernel rests on: flipping the sign of eigenvectors and permuting them
    # permutes the 2n cubature points, so a nonlinear transform's moments are unchanged
    # up to the order of the sums.
    rng = np.random.default_rng(seed)
    p = _with_spectrum(rng, 0.5 + 0.4 * np.arange(n) + 0.1 * rng.random(n))
    mean = rng.standard_normal(n)
    w, v = np.linalg.eigh(p)
    perm = rng.permutation(n)
    signs = rng.choice([1.0, -1.0], size=n)
    root = v * np.sqrt(w)
    other = (v * signs)[:, perm] * np.sqrt(w[perm])

    def fn(x):
        return np.sin(x) + 0.1 * x[:, :1] ** 2

    for a, b in zip(_ckf_moments(_cubature_points(mean, root), fn), _ckf_moments(_cubature_points(mean, other), fn)):
        assert np.max(np.abs(a - b)) <= 1e-14 * max(1.0, np.max(np.abs(a)))


@settings(max_examples=30, deadline=None)
@given(n=st.integers(1, 7), seed=st.integers(0, 2**32 - 1))
def test_kernel_cubature_points_are_lapacks_point_set(n, seed):
    # Separated eigenvalues: the kernel's points (kernels.sigma_points, svd root) and the
    # points from LAPACK's eigh are the same set; each kernel point has a reference point
    # within rounding, one to one.
    rng = np.random.default_rng(seed)
    p = _with_spectrum(rng, 0.5 + 0.4 * np.arange(n) + 0.1 * rng.random(n))
    mean = rng.standard_normal(n)
    X, status = kernels.sigma_points(mean[None], p[None], 1, float(np.sqrt(n)), False)
    assert status.tolist() == [0]
    w, v = np.linalg.eigh(p)
    ref = _cubature_points(mean, v * np.sqrt(w))
    dist = np.max(np.abs(X[:, 0, None, :] - ref[None, :, :]), axis=-1)  # (kernel point, reference point)
    nearest = np.argmin(dist, axis=1)
    assert sorted(nearest.tolist()) == list(range(2 * n))
    assert np.max(dist[np.arange(2 * n), nearest]) <= 1e-13 * max(1.0, np.max(np.abs(ref)))
