"""Batched Hamilton quaternions, scalar first ``[w, x, y, z]``, shape ``(..., 4)``.

The hot path of the mechanisation needs these on batches of runs; scipy's
``Rotation`` (used as the oracle in the tests) covers everything else. A quaternion
``q_b^e`` rotates body vectors into ECEF: ``v^e = q (x) v^b (x) q*`` (Groves 2nd ed.
appendix E, quaternion attitude).
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "cross",
    "quat_multiply",
    "quat_conjugate",
    "quat_rotate",
    "quat_from_rotvec",
    "quat_to_rotvec",
    "quat_to_dcm",
    "quat_normalize",
]


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product over the last axis (numpy.cross without its per-call overhead,
    which dominates the mechanisation's small per-step arrays)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a1 * b2 - a2 * b1
    out[..., 1] = a2 * b0 - a0 * b2
    out[..., 2] = a0 * b1 - a1 * b0
    return out


def quat_multiply(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton product ``p (x) q``, broadcasting over leading axes."""
    pw, px, py, pz = p[..., 0], p[..., 1], p[..., 2], p[..., 3]
    qw, qx, qy, qz = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    out = np.empty(np.broadcast_shapes(p.shape, q.shape))
    out[..., 0] = pw * qw - px * qx - py * qy - pz * qz
    out[..., 1] = pw * qx + px * qw + py * qz - pz * qy
    out[..., 2] = pw * qy - px * qz + py * qw + pz * qx
    out[..., 3] = pw * qz + px * qy - py * qx + pz * qw
    return out


def quat_conjugate(q: np.ndarray) -> np.ndarray:
    """Conjugate (inverse of a unit quaternion)."""
    return np.asarray(q, dtype=float) * np.array([1.0, -1.0, -1.0, -1.0])


def quat_rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors: ``q (x) v (x) q*`` without forming the matrix."""
    q = np.asarray(q, dtype=float)
    v = np.asarray(v, dtype=float)
    w = q[..., :1]
    u = q[..., 1:]
    t = 2.0 * cross(u, v)
    return v + w * t + cross(u, t)


def quat_from_rotvec(phi: np.ndarray) -> np.ndarray:
    """Quaternion of a rotation vector, series near zero angle."""
    phi = np.asarray(phi, dtype=float)
    a2 = np.sum(phi * phi, axis=-1, keepdims=True)
    a = np.sqrt(a2)
    small = a2 < 1e-8
    safe = np.where(small, 1.0, a)
    # sin(a/2)/a, with its Taylor series 1/2 - a^2/48 for small angles
    k = np.where(small, 0.5 - a2 / 48.0, np.sin(0.5 * safe) / safe)
    c = np.where(small, 1.0 - a2 / 8.0, np.cos(0.5 * safe))
    return np.concatenate([c, k * phi], axis=-1)


def quat_to_rotvec(q: np.ndarray) -> np.ndarray:
    """Rotation vector of a unit quaternion (angle in [0, pi])."""
    q = np.asarray(q, dtype=float)
    q = np.where(q[..., :1] < 0, -q, q)
    s = np.linalg.norm(q[..., 1:], axis=-1, keepdims=True)
    angle = 2.0 * np.arctan2(s, q[..., :1])
    small = s < 1e-12
    k = np.where(small, 2.0, angle / np.where(small, 1.0, s))
    return k * q[..., 1:]


def quat_normalize(q: np.ndarray) -> np.ndarray:
    """Unit-norm quaternion."""
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def quat_to_dcm(q: np.ndarray) -> np.ndarray:
    """Direction cosine matrix ``C`` with ``C v = q (x) v (x) q*``."""
    w, x, y, z = np.moveaxis(np.asarray(q, dtype=float), -1, 0)
    return np.stack(
        [
            np.stack([w * w + x * x - y * y - z * z, 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), w * w - x * x + y * y - z * z, 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), w * w - x * x - y * y + z * z], -1),
        ],
        axis=-2,
    )
