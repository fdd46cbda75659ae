"""WGS-84 Earth model for the strapdown mechanisation: rotation rate, J2 gravity.

Every function works on batched ECEF positions of shape ``(..., 3)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["EarthModel", "WGS84", "STANDARD_GRAVITY_MPS2"]

#: Standard gravity (m/s^2), the unit behind "g" in manoeuvre limits and "mg" biases.
STANDARD_GRAVITY_MPS2 = 9.80665


@dataclass(frozen=True)
class EarthModel:
    """Earth constants used by the mechanisation and the trajectory generator.

    Defaults are WGS-84 (Groves, *Principles of GNSS, Inertial and Multisensor
    Integrated Navigation Systems*, 2nd ed., sec. 2.4: WGS-84 constants and the J2
    gravitation model).
    ``rate_rad_s = 0`` gives a non-rotating Earth, used by the closed-form Schuler test.

    Attributes
    ----------
    rate_rad_s
        Earth rotation rate omega_ie.
    gm_m3_s2
        Earth's gravitational constant mu.
    j2
        Second zonal harmonic.
    semi_major_axis_m
        Equatorial radius R_0.
    """

    rate_rad_s: float = 7.292115e-5
    gm_m3_s2: float = 3.986004418e14
    j2: float = 1.082627e-3
    semi_major_axis_m: float = 6378137.0

    @property
    def rate_vector(self) -> np.ndarray:
        """omega_ie^e = (0, 0, omega_ie) (rad/s)."""
        return np.array([0.0, 0.0, self.rate_rad_s])

    def gravitation_ecef(self, r_ecef_m: np.ndarray) -> np.ndarray:
        """Gravitational acceleration gamma^e (mass attraction only) with the J2 term.

        Groves 2nd ed. sec. 2.4 (J2 gravitation model in ECEF)::

            gamma = -mu/r^3 [ r + 1.5 J2 (R0/r)^2 (x (1-5z^2/r^2), y (1-5z^2/r^2), z (3-5z^2/r^2)) ]
        """
        r = np.asarray(r_ecef_m, dtype=float)
        r2 = r[..., 0] ** 2 + r[..., 1] ** 2 + r[..., 2] ** 2
        z2 = r[..., 2] ** 2 / r2
        k = 1.5 * self.j2 * self.semi_major_axis_m**2 / r2
        scale = -self.gm_m3_s2 / (r2 * np.sqrt(r2))
        out = np.empty(r.shape)
        horizontal = scale * (1.0 + k * (1.0 - 5.0 * z2))
        out[..., 0] = horizontal * r[..., 0]
        out[..., 1] = horizontal * r[..., 1]
        out[..., 2] = scale * (1.0 + k * (3.0 - 5.0 * z2)) * r[..., 2]
        return out

    def gravity_ecef(self, r_ecef_m: np.ndarray) -> np.ndarray:
        """Gravity g^e = gamma^e - Omega_ie Omega_ie r^e (gravitation plus centrifugal).

        Groves 2nd ed. sec. 2.4 (gravity as gravitation plus centrifugal, ECEF form).
        """
        r = np.asarray(r_ecef_m, dtype=float)
        g = self.gravitation_ecef(r)
        g[..., :2] += self.rate_rad_s**2 * r[..., :2]
        return g

    def gravity_gradient(self, r_ecef_m: np.ndarray, form: str = "full") -> np.ndarray:
        """Jacobian d g^e / d r^e, shape ``(..., 3, 3)``.

        ``"full"``: point-mass gradient ``mu/r^3 (3 u u^T - I)`` plus the centrifugal
        Jacobian ``omega_ie^2 diag(1, 1, 0)``; its horizontal ``-g/r`` terms are what
        close the Schuler loop in an ECEF error model. ``"radial"``: Groves 2nd ed.
        sec. 14.2.3's simplification ``2 g / r u u^T`` (vertical only), adequate under
        frequent aiding but without the Schuler loop. J2's share of the gradient
        (about 0.1 %) is neglected in both.
        """
        r = np.asarray(r_ecef_m, dtype=float)
        r2 = np.sum(r * r, axis=-1)[..., None, None]
        u = r / np.sqrt(r2[..., 0])
        uu = u[..., :, None] * u[..., None, :]
        if form == "full":
            eye = np.eye(3)
            grad = self.gm_m3_s2 / (r2 * np.sqrt(r2)) * (3.0 * uu - eye)
            return grad + self.rate_rad_s**2 * np.diag([1.0, 1.0, 0.0])
        if form == "radial":
            g = np.linalg.norm(self.gravity_ecef(r), axis=-1)[..., None, None]
            return 2.0 * g / np.sqrt(r2) * uu
        from gnssframework.errors import ConfigError

        raise ConfigError("gravity_gradient", f"unknown form {form!r}; allowed: 'full', 'radial'")


WGS84 = EarthModel()
