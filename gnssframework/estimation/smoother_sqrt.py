r"""The square-root (``"sqrt"``) form of the RTS smoother: the smoothed covariance carried as a
factor $S^s_k$ ($P^s_k = S^s_k S^{sT}_k$), never formed by a subtraction.

The forward pass of a square-root engine (``Estimator.smoother_gain == "sqrt"``, the SVD-CKF's)
keeps, per step, the factors of the prediction $x_k \to x^-_{k+1}$
(`Estimator.transition_factors`): $X$ with $X X^T = P_k$ (for the SVD-CKF the
$\sqrt{W_i}$-weighted deviations of its cubature points, $\pm S/\sqrt 2$ with $S = V
\sqrt{|w|}$ its SVD root), $Y$ their images ($\sqrt{W_i}(f(\mathcal X_i) - m^-_{k+1})$), and a
root $S_Q$ of the Q in force, so that

$$
P^-_{k+1} = Y Y^T + S_Q S_Q^T, \qquad C_{k+1} = X Y^T, \qquad P_k = X X^T .
$$

One QR factorisation of the stacked factors (the square-root cubature RTS smoother of
Arasaratnam & Haykin, "Cubature Kalman smoothers", *Automatica* 47(10), 2011) gives the
lower-triangular root of the joint covariance of $(x^-_{k+1}, x_k)$:

$$
\begin{bmatrix} Y & S_Q \\ X & 0 \end{bmatrix} = \begin{bmatrix} L_{11} & 0 \\ L_{21} & L_{22}
\end{bmatrix} \Theta, \quad \Theta\Theta^T = I:\quad L_{11} L_{11}^T = P^-_{k+1},\;
L_{21} L_{11}^T = C_{k+1},\; L_{22} L_{22}^T = P_k - C_{k+1} (P^-_{k+1})^{-1} C_{k+1}^T .
$$

The gain is $G_k = L_{21} L_{11}^{-1}$, one batched solve with the triangular root of
$P^-_{k+1}$ (whose condition number is the square root of $P^-$'s), and the SVD
pseudo-inverse $L_{11}^{+}$ where $L_{11}$ is numerically singular (singular values below
$n\,\epsilon\,\max s$ dropped: the threshold is on the root, so the directions kept are those
whose *variance* exceeds $\epsilon^2$ of the largest). The covariance is written as a sum of
squares, PSD for any gain and the RTS covariance at the RTS gain,

$$
P^s_k = \operatorname{Cov}(x_k - G_k x^-_{k+1}) + G_k P^s_{k+1} G_k^T, \qquad
S^s_k = \operatorname{tria}\big[\, L_{21} - G_k L_{11},\; L_{22},\; G_k S^s_{k+1} \,\big],
$$

$\operatorname{tria}$ the lower-triangular factor of a QR factorisation of the transpose
(the first block is zero where $L_{11}$ is invertible). In exact arithmetic this is the RTS
smoother of `gnssframework.estimation.smoother`; in floating point $P^s_k = S^s_k S^{sT}_k$ is
symmetric PSD by construction.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .. import backend
from .compiled import sqrt_smoother as compiled_sqrt
from .compiled import tria as compiled_tria
from .linalg import mat_vec, symmetrize, transpose

__all__ = ["psd_root", "tria", "sqrt_terms", "sqrt_rts_step", "sqrt_rts_step_cov", "cov_of"]


def psd_root(a: np.ndarray) -> np.ndarray:
    r"""A square root $S = V \sqrt{\max(w, 0)}$ of a symmetric ``a`` $= V \operatorname{diag}(w)
    V^T$, ``(..., n, n)``: $S S^T = a$ for a PSD ``a`` (rounding-negative eigenvalues dropped)."""
    w, V = np.linalg.eigh(symmetrize(np.asarray(a, dtype=float)))
    root: np.ndarray = V * np.sqrt(np.maximum(w, 0.0))[..., None, :]
    return root


def tria(a: np.ndarray) -> np.ndarray:
    r"""Lower-triangular $L$ ``(..., p, p)`` with $L L^T = A A^T$ for ``a`` ``(..., p, q)``, $q \ge p$:
    from the QR factorisation $A^T = Q R$, $L = R^T$ (batched). Under the ``numba`` backend
    one compiled Householder pass per element (`compiled.tria`); NumPy's LAPACK ``qr`` otherwise."""
    if backend.compiled() and a.shape[-1] >= a.shape[-2] and np.all(np.isfinite(a)):
        return compiled_tria.tria(a)
    # mode "raw" returns LAPACK's Householder output transposed, (..., p, q): R^T is the lower
    # triangle of its first p columns (no triu copy of the (..., q, p) result).
    p = a.shape[-2]
    h = np.linalg.qr(transpose(a), mode="raw")[0]
    out: np.ndarray = np.tril(h[..., :p])
    return out


def cov_of(root: np.ndarray) -> np.ndarray:
    """``root @ root^T``, symmetrised (a covariance from its factor)."""
    return symmetrize(root @ transpose(root))


def sqrt_terms(point_root: np.ndarray, image_root: np.ndarray, noise_root: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r"""The gain $G_k$ and the root $D_k$ of $\operatorname{Cov}(x_k - G_k x^-_{k+1})$ of each stored
    transition (module docstring), batched over every leading axis. Under the ``numba`` backend
    one compiled pass per element (`compiled.sqrt_smoother.sqrt_terms`: the stacked factor built
    in the kernel, the gain by back-substitution on the triangular $L_{11}$); the elements whose
    $L_{11}$ is numerically singular, and every element elsewhere, by NumPy (`_numpy_terms`).

    Parameters
    ----------
    point_root, image_root
        $X$ and $Y$ ``(..., n, N)``.
    noise_root
        $S_Q$ ``(..., n, n)``.

    Returns
    -------
    (np.ndarray, np.ndarray)
        $G$ ``(..., n, n)`` and lower-triangular $D$ ``(..., n, n)``, $D D^T = (L_{21} - G L_{11})
        (\cdot)^T + L_{22} L_{22}^T$.
    """
    if backend.compiled() and all(np.all(np.isfinite(a)) for a in (point_root, image_root, noise_root)):
        # one compiled pass per element (`compiled.sqrt_smoother`); the elements whose L11 is
        # numerically singular (flagged) take the NumPy path below, with its pseudo-inverse
        gain, D, regular = compiled_sqrt.sqrt_terms(point_root, image_root, noise_root)
        if not regular.all():
            bad = ~regular
            batch = regular.shape
            gain[bad], D[bad] = _numpy_terms(
                *(np.broadcast_to(a, batch + a.shape[-2:])[bad] for a in (point_root, image_root, noise_root))
            )
        return gain, D
    return _numpy_terms(point_root, image_root, noise_root)


def _numpy_terms(
    point_root: np.ndarray, image_root: np.ndarray, noise_root: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """`sqrt_terms` by NumPy stacking, `tria` and `_root_gain` (the reference path)."""
    n, N = point_root.shape[-2:]
    batch = np.broadcast_shapes(point_root.shape[:-2], image_root.shape[:-2], noise_root.shape[:-2])
    top = np.concatenate(
        [np.broadcast_to(image_root, batch + (n, N)), np.broadcast_to(noise_root, batch + (n, n))], axis=-1
    )
    bottom = np.concatenate([np.broadcast_to(point_root, batch + (n, N)), np.zeros(batch + (n, n))], axis=-1)
    L = tria(np.concatenate([top, bottom], axis=-2))  # (..., 2n, 2n) lower
    L11, L21, L22 = L[..., :n, :n], L[..., n:, :n], L[..., n:, n:]
    gain = _root_gain(L11, L21)
    D = tria(np.concatenate([L21 - gain @ L11, L22], axis=-1))
    return gain, D


def _root_gain(L11: np.ndarray, L21: np.ndarray) -> np.ndarray:
    r"""$G = L_{21} L_{11}^{+}$: one batched solve of $L_{11}^T G^T = L_{21}^T$ where the triangular
    $L_{11}$ is regular (its smallest diagonal above $n \epsilon$ times its largest), the
    SVD pseudo-inverse (singular values below $n \epsilon \max s$ dropped) for the rest."""
    n = L11.shape[-1]
    eps = n * np.finfo(float).eps
    d = np.abs(np.diagonal(L11, axis1=-2, axis2=-1))
    regular = d.min(axis=-1) > eps * d.max(axis=-1)
    eye = np.eye(n)
    safe = np.where(regular[..., None, None], L11, eye)
    gain: np.ndarray = transpose(np.linalg.solve(transpose(safe), transpose(L21)))
    if not regular.all():
        bad = ~regular
        U, s, Vt = np.linalg.svd(L11[bad])
        inv_s = np.where(s > eps * s[..., :1], 1.0 / np.where(s > eps * s[..., :1], s, 1.0), 0.0)
        gain = gain.copy()
        gain[bad] = ((L21[bad] @ transpose(Vt)) * inv_s[..., None, :]) @ transpose(U)
    return gain


def sqrt_rts_step(
    filtered_mean: np.ndarray,
    prior_mean: np.ndarray,
    next_mean: np.ndarray,
    next_root: np.ndarray,
    gain: np.ndarray,
    cond_root: np.ndarray,
    residual_x: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    r"""One backward step from $k+1$ to $k$ in square-root form, batched.

    $m^s_k = m_k + G_k (m^s_{k+1} - m^-_{k+1})$, $S^s_k = \operatorname{tria}[D_k,\ G_k S^s_{k+1}]$
    (`sqrt_terms` gives $G_k$, $D_k$).

    Returns
    -------
    (np.ndarray, np.ndarray)
        $m^s_k$ ``(..., n)`` and lower-triangular $S^s_k$ ``(..., n, n)``.
    """
    diff = (residual_x or np.subtract)(next_mean, prior_mean)
    mean = filtered_mean + mat_vec(gain, diff)
    spread = gain @ next_root
    root = tria(np.concatenate([np.broadcast_to(cond_root, spread.shape), spread], axis=-1))
    return mean, root


def sqrt_rts_step_cov(
    filtered_mean: np.ndarray,
    prior_mean: np.ndarray,
    next_mean: np.ndarray,
    next_root: np.ndarray,
    gain: np.ndarray,
    cond_root: np.ndarray,
    residual_x: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""`sqrt_rts_step` and the covariance $P^s_k = S^s_k S^{sT}_k$ (`cov_of`): under the ``numba``
    backend the factor and its product in one compiled pass per element
    (`compiled.sqrt_smoother.sqrt_step_root`), the NumPy path otherwise.

    Returns
    -------
    (np.ndarray, np.ndarray, np.ndarray)
        $m^s_k$ ``(..., n)``, lower-triangular $S^s_k$ and symmetric $P^s_k$ ``(..., n, n)``.
    """
    if backend.compiled() and all(np.all(np.isfinite(a)) for a in (gain, cond_root, next_root)):
        diff = (residual_x or np.subtract)(next_mean, prior_mean)
        root, cov = compiled_sqrt.sqrt_step_root(gain, cond_root, next_root)
        return filtered_mean + mat_vec(gain, diff), root, cov
    mean, root = sqrt_rts_step(filtered_mean, prior_mean, next_mean, next_root, gain, cond_root, residual_x)
    return mean, root, cov_of(root)
