r"""BeiDou's broadcast ionosphere model: Klobuchar's eight coefficients in the BDS ICD's form.

D1 and D2 send eight coefficients as GPS's page 18 does (D1 subframe 1; `d1nav`), but the
B1I ICD applies them its own way (BDS-SIS-ICD-B1I 3.0, 5.2.4.7), not by IS-GPS-200's
Figure 20-4 (`pvt.klobuchar_delay_s`):

* the pierce point lies on a thin shell at :math:`h = 375` km over a sphere of
  :math:`R = 6378` km, found exactly on the sphere (Earth's central angle
  :math:`\psi = \pi/2 - E - \arcsin(\frac{R}{R+h}\cos E)`, then
  :math:`\phi_M = \arcsin(\sin\phi_u\cos\psi + \cos\phi_u\sin\psi\cos A)` and
  :math:`\lambda_M = \lambda_u + \arcsin(\sin\psi\sin A / \cos\phi_M)`), not by GPS's
  linear approximation;
* the polynomials take the pierce point's *geographic* latitude, as
  :math:`|\phi_M/\pi|^n` (GPS: the geomagnetic latitude in semicircles, signed), with the
  amplitude :math:`A_2 \ge 0` and the period :math:`A_4` held to
  :math:`72\,000 \le A_4 \le 172\,800` s (GPS has no upper bound);
* the day's delay is a cosine, not its fourth-order series:
  :math:`I'_z = 5\cdot 10^{-9} + A_2 \cos(2\pi (t - 50\,400) / A_4)` for
  :math:`|t - 50\,400| < A_4/4`, else :math:`5\cdot 10^{-9}` s, :math:`t` the local time
  at the pierce point, :math:`(t_E + 43\,200\,\lambda_M/\pi) \bmod 86\,400`, :math:`t_E`
  BDT;
* the slant factor is the shell's exact one, :math:`1/\sqrt{1 - (\frac{R}{R+h}\cos E)^2}`;
* the delay is B1I's (1561.098 MHz): another signal's is
  :math:`(f_{B1I}/f)^2` times it.

The receiver applies these coefficients to a fix of BeiDou satellites when no GPS page 18
was decoded (`receiver.navigation.fixes.solve_epochs`); RTKLIB and GNSSTk apply GPS's
algorithm to BeiDou's coefficients instead (for the same coefficients the two differ by
up to tens of percent at low elevation).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ..errors import ConfigError
from ..signal.beidou_b1i import BEIDOU_B1I
from ..signal.spec import SignalSpec

__all__ = [
    "FIELD_NAMES",
    "BdsKlobuchar",
    "bds_klobuchar_delay_s",
    "bds_pierce_point",
    "BDS_SHELL_HEIGHT_M",
    "BDS_EARTH_RADIUS_M",
]

#: The ionospheric shell's height and the Earth's radius of the ICD's model (m).
BDS_SHELL_HEIGHT_M = 375e3
BDS_EARTH_RADIUS_M = 6378e3
#: The eight coefficients' field names in D1 subframe 1 and D2 page 2 (`d1nav`, `d2nav`).
FIELD_NAMES = tuple(f"{c}{n}_s{u}" for c in ("alpha", "beta") for n, u in enumerate(("", "_sc", "_sc2", "_sc3")))
#: GPS time less BDT (s): BDT = GPST - 14 s.
_BDT_OFFSET_S = 14.0


def bds_pierce_point(
    lat_deg: float, lon_deg: float, azimuth_deg: np.ndarray, elevation_deg: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Latitude and longitude (rad) of the ray's pierce point through the ICD's shell, and
    the slant factor there (module text: the sphere of `BDS_EARTH_RADIUS_M`, the shell
    `BDS_SHELL_HEIGHT_M` above it; `sbas_iono.shell_pierce_point`'s geometry)."""
    from .sbas_iono import shell_pierce_point

    lat, lon, slant = shell_pierce_point(
        lat_deg, lon_deg, azimuth_deg, elevation_deg, BDS_EARTH_RADIUS_M, BDS_SHELL_HEIGHT_M
    )
    return np.radians(lat), np.radians(lon), slant


def bds_klobuchar_delay_s(
    alpha: np.ndarray,
    beta: np.ndarray,
    lat_deg: float,
    lon_deg: float,
    azimuth_deg: np.ndarray,
    elevation_deg: np.ndarray,
    bdt_sow_s: float,
) -> np.ndarray:
    """B1I ionospheric delay (s) of the BDS ICD's Klobuchar model (module text; ICD 3.0,
    5.2.4.7), ``alpha``/``beta`` as broadcast (s, s/π^n), angles in degrees (the user's
    latitude taken on the ICD's sphere), ``bdt_sow_s`` BDT (its seconds of day are
    :math:`t_E`)."""
    phi_m, lam_m, slant = bds_pierce_point(lat_deg, lon_deg, azimuth_deg, elevation_deg)
    t = (bdt_sow_s + 43_200.0 * lam_m / np.pi) % 86_400.0
    powers = np.abs(phi_m / np.pi)[..., None] ** np.arange(4)
    a2 = np.maximum(powers @ np.asarray(alpha, float), 0.0)
    a4 = np.clip(powers @ np.asarray(beta, float), 72_000.0, 172_800.0)
    day = np.abs(t - 50_400.0) < a4 / 4
    vertical = 5e-9 + np.where(day, a2 * np.cos(2 * np.pi * (t - 50_400.0) / a4), 0.0)
    return vertical * slant


@dataclass(frozen=True)
class BdsKlobuchar:
    """BeiDou's broadcast coefficients (D1 subframe 1; D2 page 1), applied by the BDS ICD's
    model (`bds_klobuchar_delay_s`). ``alpha`` in s, s/π, s/π², s/π³; ``beta`` in s and the
    same powers. As `lnav.IonoUtc` for GPS's page 18: ``delay_s`` at ``reference``'s carrier."""

    alpha: tuple[float, float, float, float]
    beta: tuple[float, float, float, float]
    #: The signal whose delay the model gives.
    reference: ClassVar[SignalSpec] = BEIDOU_B1I
    #: Its name in a RINEX 3 navigation header (``IONOSPHERIC CORR``).
    rinex_name: ClassVar[str] = "BDS"

    def __post_init__(self) -> None:
        if len(self.alpha) != 4 or len(self.beta) != 4:
            raise ConfigError("BdsKlobuchar", "four alpha and four beta coefficients")

    def delay_s(
        self, lat_deg: float, lon_deg: float, azimuth_deg: np.ndarray, elevation_deg: np.ndarray, gps_tow_s: float
    ) -> np.ndarray:
        """B1I delay (s) at GPS time ``gps_tow_s`` (taken to BDT, 14 s less)."""
        return bds_klobuchar_delay_s(
            np.asarray(self.alpha),
            np.asarray(self.beta),
            lat_deg,
            lon_deg,
            azimuth_deg,
            elevation_deg,
            gps_tow_s - _BDT_OFFSET_S,
        )

    def fields(self) -> dict[str, float]:
        """D1 subframe 1's field values (`FIELD_NAMES`): the inverse of `from_fields`."""
        return dict(zip(FIELD_NAMES, map(float, (*self.alpha, *self.beta))))

    @classmethod
    def from_fields(cls, fields: dict[str, float]) -> BdsKlobuchar:
        """From D1 subframe 1's (or D2 page 2's) decoded fields (`FIELD_NAMES`)."""
        v = tuple(float(fields[k]) for k in FIELD_NAMES)
        return cls(v[:4], v[4:])  # type: ignore[arg-type]
