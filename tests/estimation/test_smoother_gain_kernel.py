"""The compiled ``"eigh"`` smoother gain (`gnssframework.estimation.compiled.smoother_gain`)
against the NumPy form it replaces (LAPACK ``eigh``), including numerically singular
``P^-`` where the pseudo-inverse drops eigenvalues."""

from __future__ import annotations

import numpy as np

from gnssframework import backend
from gnssframework.estimation.compiled.smoother_gain import eigh_gain
from gnssframework.estimation.smoother import smoother_gain
from conftest import random_pd


def _numpy_gain(C, P):
    backend.set_backend("numpy")
    try:
        return smoother_gain(C, P, "eigh")
    finally:
        backend.set_backend(None)


def test_compiled_eigh_gain_equals_the_numpy_form(rng):
    n = 5
    P = random_pd(rng, n, batch=(300,))
    # numerically singular ones: rank 3 (two eigenvalues at rounding level are dropped)
    A = rng.standard_normal((40, n, 3))
    P[:40] = A @ np.swapaxes(A, -1, -2)
    C = rng.standard_normal((300, n, n))
    ref = _numpy_gain(C, P)
    got = eigh_gain(C, P)
    scale = np.abs(ref).max(axis=(-2, -1), keepdims=True)
    np.testing.assert_allclose(got[40:], ref[40:], rtol=0, atol=1e-10 * scale[40:].max())
    # on the singular ones both are the pseudo-inverse's gain: C restricted to the range of P
    pinv = np.linalg.pinv(P[:40], rcond=1e-10, hermitian=True)
    np.testing.assert_allclose(got[:40], C[:40] @ pinv, rtol=0, atol=1e-8 * np.abs(C[:40] @ pinv).max())


def test_smoother_gain_uses_the_compiled_kernel_under_numba(rng):
    P = random_pd(rng, 4, batch=(3, 2))
    C = rng.standard_normal((3, 2, 4, 4))
    backend.set_backend("numba")
    try:
        got = smoother_gain(C, P, "eigh")
    finally:
        backend.set_backend(None)
    np.testing.assert_allclose(got, _numpy_gain(C, P), rtol=1e-10, atol=1e-12)
    assert got.shape == (3, 2, 4, 4)
