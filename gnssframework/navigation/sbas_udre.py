r"""SBAS L1's δUDRE messages (RTCA DO-229 A.4.4.13 and A.4.4.16): type 27's service regions
and type 28's clock-ephemeris covariance, read from a message's 250 bits (bits numbered from
0, the preamble's first; the layouts in `sbas_content`'s table). `sbas_content.decode_content`
hands a message of either type here; `sbas_pvt.delta_udre` turns them into δUDRE.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .bit_fields import read_field as _field
from .bit_fields import read_fields as _fields

__all__ = ["DELTA_UDRE", "ServiceMessage", "CovarianceMatrices", "service_content", "covariance_content"]


@dataclass(frozen=True)
class CovarianceMatrices:
    """Type 28: per satellite named (``slots``, 1-based mask numbers) its scale exponent and
    the relative clock-ephemeris covariance ``C = RᵀR`` (4 × 4, x y z clock; R = 2^(exponent
    - 5) E) of the corrections of mask ``iodp``."""

    iodp: int
    slots: tuple[int, ...]
    scale_exponents: tuple[int, ...]
    covariances: np.ndarray = field(repr=False)


#: δUDRE of each indicator 0-15 (DO-229 Table A-16).
DELTA_UDRE = np.array([1.0, 1.1, 1.25, 1.5, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0, 20.0, 30.0, 40.0, 50.0, 100.0])


@dataclass(frozen=True)
class ServiceMessage:
    """Type 27: one of the ``count`` service messages of set ``iods`` (this one ``number``,
    0-based), its ``priority``, its δUDRE indicators inside and outside its regions, and the
    regions: ``(lat1, lon1, lat2, lon2, quadrangle)`` in degrees (a quadrangle has corners
    (1, 1), (2, 1), (2, 2), (1, 2) of the two latitudes and longitudes; a triangle (1, 1),
    (2, 1), (2, 2))."""

    iods: int
    count: int
    number: int
    priority: int
    inside: int
    outside: int
    regions: tuple[tuple[int, int, int, int, bool], ...]

    def contains(self, lat_deg: float, lon_deg: float) -> list[bool]:
        """Whether each region holds the point (its border included)."""
        out = []
        for lat1, lon1, lat2, lon2, quadrangle in self.regions:
            in_box = min(lat1, lat2) <= lat_deg <= max(lat1, lat2) and min(lon1, lon2) <= lon_deg <= max(lon1, lon2)
            if not in_box or quadrangle:
                out.append(in_box)
                continue
            if lat1 == lat2 or lon1 == lon2:  # a triangle of no area
                out.append(False)
                continue
            # The triangle (1,1), (2,1), (2,2): the box's half on corner (2,1)'s side of the
            # diagonal from (1,1) to (2,2).
            a = (lat_deg - lat1) / (lat2 - lat1)
            b = (lon_deg - lon1) / (lon2 - lon1)
            out.append(b <= a)
        return out


def service_content(bits: np.ndarray) -> ServiceMessage:
    n = int(_field(bits, 23, 3))
    regions = []
    for k in range(min(n, 5)):
        p = 36 + 35 * k
        regions.append(
            (
                int(_field(bits, p, 8, signed=True)),
                int(_field(bits, p + 8, 9, signed=True)),
                int(_field(bits, p + 17, 8, signed=True)),
                int(_field(bits, p + 25, 9, signed=True)),
                bool(_field(bits, p + 34, 1)),
            )
        )
    return ServiceMessage(
        int(_field(bits, 14, 3)),
        int(_field(bits, 17, 3)) + 1,
        int(_field(bits, 20, 3)),
        int(_field(bits, 26, 2)),
        int(_field(bits, 28, 4)),
        int(_field(bits, 32, 4)),
        tuple(regions),
    )


def covariance_content(bits: np.ndarray) -> CovarianceMatrices:
    slots, exponents, matrices = [], [], []
    for k in range(2):
        p = 16 + 105 * k
        slot = int(_field(bits, p, 6))
        if slot == 0:
            continue
        exponent = int(_field(bits, p + 6, 3))
        e = np.zeros((4, 4))
        e[np.diag_indices(4)] = _fields(bits, p + 9, 9, 4)
        e[np.triu_indices(4, 1)] = _fields(bits, p + 45, 10, 6, signed=True)  # E12 E13 E14 E23 E24 E34
        r = 2.0 ** (exponent - 5) * e
        slots.append(slot)
        exponents.append(exponent)
        matrices.append(r.T @ r)
    return CovarianceMatrices(
        int(_field(bits, 14, 2)), tuple(slots), tuple(exponents), np.array(matrices).reshape(-1, 4, 4)
    )
