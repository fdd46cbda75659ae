"""GPS user range accuracy: the URA index's metres (IS-GPS-200 20.3.3.3.1.3) and CNAV's
URA_ED index (30.3.3.1.1.4), below every module that reads or writes one."""

from __future__ import annotations

import numpy as np

__all__ = ["URA_M", "ura_ed_m"]

#: URA index -> nominal accuracy, m (upper bounds of IS-GPS-200 20.3.3.3.1.3; index 15: none, -1).
URA_M = np.array(
    [2.4, 3.4, 4.85, 6.85, 9.65, 13.65, 24.0, 48.0, 96.0, 192.0, 384.0, 768.0, 1536.0, 3072.0, 6144.0, -1.0]
)


def ura_ed_m(index: int) -> float:
    """The accuracy (m) of a URA_ED index: the LNAV URA table for 0-15, :math:`2^{1 + N/2}`
    below 0 (IS-GPS-200 30.3.3.1.1.4)."""
    return float(URA_M[index]) if index >= 0 else float(2.0 ** (1 + index / 2))
