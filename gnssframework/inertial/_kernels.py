"""Compiled (numba) strapdown loop; :mod:`gnssframework.inertial.mechanisation`'s NumPy
code is the reference and a test holds the two equal to rounding.

One call runs every time step for every batch element in compiled code, without the
per-step NumPy temporaries that dominate the reference path on small batches.
"""

from __future__ import annotations

import math

import numpy as np

from gnssframework.backend import HAVE_NUMBA

if HAVE_NUMBA:
    import numba

__all__ = ["HAVE_NUMBA", "integrate_kernel"]

ROTATION_MODES = {"none": 0, "first-order": 1, "exact": 2}


def _integrate(
    q0, v0, r0, dth, dv, pth, pdv, has_prev, dt, coning, sculling, rot_mode, omega, gm, j2, a_m, qs, vs, rs
):  # pragma: no cover - compiled
    n_t = dth.shape[0]
    n_b = q0.shape[0]
    cz, sz = math.cos(-0.5 * omega * dt), math.sin(-0.5 * omega * dt)
    qzw, qzz = math.cos(-0.5 * omega * dt), math.sin(-0.5 * omega * dt)  # q_z(-omega dt)
    for b in range(n_b):
        qw, qx, qy, qz = q0[b, 0], q0[b, 1], q0[b, 2], q0[b, 3]
        vx, vy, vz = v0[b, 0], v0[b, 1], v0[b, 2]
        rx, ry, rz = r0[b, 0], r0[b, 1], r0[b, 2]
        ptx, pty, ptz = pth[b, 0], pth[b, 1], pth[b, 2]
        pvx, pvy, pvz = pdv[b, 0], pdv[b, 1], pdv[b, 2]
        prev = has_prev
        qs[0, b, 0], qs[0, b, 1], qs[0, b, 2], qs[0, b, 3] = qw, qx, qy, qz
        vs[0, b, 0], vs[0, b, 1], vs[0, b, 2] = vx, vy, vz
        rs[0, b, 0], rs[0, b, 1], rs[0, b, 2] = rx, ry, rz
        for k in range(n_t):
            tx, ty, tz = dth[k, b, 0], dth[k, b, 1], dth[k, b, 2]
            ux, uy, uz = dv[k, b, 0], dv[k, b, 1], dv[k, b, 2]
            ax, ay, az = tx, ty, tz
            wx, wy, wz = ux, uy, uz
            if prev:
                if coning:
                    ax += (pty * tz - ptz * ty) / 12.0
                    ay += (ptz * tx - ptx * tz) / 12.0
                    az += (ptx * ty - pty * tx) / 12.0
                if sculling:
                    wx += ((pty * uz - ptz * uy) + (pvy * tz - pvz * ty)) / 12.0
                    wy += ((ptz * ux - ptx * uz) + (pvz * tx - pvx * tz)) / 12.0
                    wz += ((ptx * uy - pty * ux) + (pvx * ty - pvy * tx)) / 12.0
            if rot_mode > 0:
                cx, cy, cz_ = ay * uz - az * uy, az * ux - ax * uz, ax * uy - ay * ux
                if rot_mode == 1:
                    wx += 0.5 * cx
                    wy += 0.5 * cy
                    wz += 0.5 * cz_
                else:
                    a2 = ax * ax + ay * ay + az * az
                    if a2 < 1e-6:
                        k1 = 0.5 - a2 / 24.0 + a2 * a2 / 720.0
                        k2 = 1.0 / 6.0 - a2 / 120.0 + a2 * a2 / 5040.0
                    else:
                        an = math.sqrt(a2)
                        k1 = (1.0 - math.cos(an)) / a2
                        k2 = (1.0 - math.sin(an) / an) / a2
                    ccx, ccy, ccz = ay * cz_ - az * cy, az * cx - ax * cz_, ax * cy - ay * cx
                    wx += k1 * cx + k2 * ccx
                    wy += k1 * cy + k2 * ccy
                    wz += k1 * cz_ + k2 * ccz
            # resolve in ECEF with the start attitude: rotate by q (v + w t + u x t, t = 2 u x v)
            t1 = 2.0 * (qy * wz - qz * wy)
            t2 = 2.0 * (qz * wx - qx * wz)
            t3 = 2.0 * (qx * wy - qy * wx)
            ex = wx + qw * t1 + (qy * t3 - qz * t2)
            ey = wy + qw * t2 + (qz * t1 - qx * t3)
            ez = wz + qw * t3 + (qx * t2 - qy * t1)
            # then by half the Earth rotation of the interval
            fx, fy, fz = cz * ex - sz * ey, sz * ex + cz * ey, ez
            gx, gy, gz = _gravity(rx, ry, rz, omega, gm, j2, a_m)
            mvx = vx + 0.5 * (fx + (gx + 2.0 * omega * vy) * dt)
            mvy = vy + 0.5 * (fy + (gy - 2.0 * omega * vx) * dt)
            mvz = vz + 0.5 * (fz + gz * dt)
            mrx = rx + 0.25 * dt * (vx + mvx)
            mry = ry + 0.25 * dt * (vy + mvy)
            mrz = rz + 0.25 * dt * (vz + mvz)
            gx, gy, gz = _gravity(mrx, mry, mrz, omega, gm, j2, a_m)
            nvx = vx + fx + (gx + 2.0 * omega * mvy) * dt
            nvy = vy + fy + (gy - 2.0 * omega * mvx) * dt
            nvz = vz + fz + gz * dt
            rx += 0.5 * dt * (vx + nvx)
            ry += 0.5 * dt * (vy + nvy)
            rz += 0.5 * dt * (vz + nvz)
            vx, vy, vz = nvx, nvy, nvz
            # attitude: q_z(-omega dt) (x) q (x) q(alpha)
            a2 = ax * ax + ay * ay + az * az
            if a2 < 1e-8:
                kk = 0.5 - a2 / 48.0
                cc = 1.0 - a2 / 8.0
            else:
                an = math.sqrt(a2)
                kk = math.sin(0.5 * an) / an
                cc = math.cos(0.5 * an)
            bw, bx, by, bz = cc, kk * ax, kk * ay, kk * az
            nw = qw * bw - qx * bx - qy * by - qz * bz
            nx = qw * bx + qx * bw + qy * bz - qz * by
            ny = qw * by - qx * bz + qy * bw + qz * bx
            nz = qw * bz + qx * by - qy * bx + qz * bw
            qw = qzw * nw - qzz * nz
            qx = qzw * nx - qzz * ny
            qy = qzw * ny + qzz * nx
            qz = qzw * nz + qzz * nw
            nrm = math.sqrt(qw * qw + qx * qx + qy * qy + qz * qz)
            qw, qx, qy, qz = qw / nrm, qx / nrm, qy / nrm, qz / nrm
            ptx, pty, ptz, pvx, pvy, pvz = tx, ty, tz, ux, uy, uz
            prev = True
            qs[k + 1, b, 0], qs[k + 1, b, 1], qs[k + 1, b, 2], qs[k + 1, b, 3] = qw, qx, qy, qz
            vs[k + 1, b, 0], vs[k + 1, b, 1], vs[k + 1, b, 2] = vx, vy, vz
            rs[k + 1, b, 0], rs[k + 1, b, 1], rs[k + 1, b, 2] = rx, ry, rz


def _gravity(x, y, z, omega, gm, j2, a_m):  # pragma: no cover - compiled
    r2 = x * x + y * y + z * z
    z2 = z * z / r2
    k = 1.5 * j2 * a_m * a_m / r2
    scale = -gm / (r2 * math.sqrt(r2))
    h = scale * (1.0 + k * (1.0 - 5.0 * z2))
    return h * x + omega * omega * x, h * y + omega * omega * y, scale * (1.0 + k * (3.0 - 5.0 * z2)) * z


if HAVE_NUMBA:
    _gravity = numba.njit(cache=True, fastmath=False)(_gravity)
    _integrate = numba.njit(cache=True, fastmath=False)(_integrate)


def integrate_kernel(q0, v0, r0, dth, dv, pth, pdv, has_prev, dt, coning, sculling, rotation_term, earth):
    """Run the compiled loop on flat batches: q0 (B, 4), dth (T, B, 3); returns (qs, vs, rs)."""
    n_t, n_b = dth.shape[0], q0.shape[0]
    qs = np.empty((n_t + 1, n_b, 4))
    vs = np.empty((n_t + 1, n_b, 3))
    rs = np.empty((n_t + 1, n_b, 3))
    _integrate(
        q0,
        v0,
        r0,
        dth,
        dv,
        pth,
        pdv,
        bool(has_prev),
        float(dt),
        bool(coning),
        bool(sculling),
        ROTATION_MODES[rotation_term],
        float(earth.rate_rad_s),
        float(earth.gm_m3_s2),
        float(earth.j2),
        float(earth.semi_major_axis_m),
        qs,
        vs,
        rs,
    )
    return qs, vs, rs
