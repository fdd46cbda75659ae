"""The five real CNAV messages of PRN 1 in tests/data/gnsstk_cnav_gps_l2_prn1.hex (GNSSTk's
test data, LGPL 3.0; see the file's comments for where they come from and GNSSTk's values)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gnssframework.navigation import cnav

FILE = Path(__file__).parent / "data" / "gnsstk_cnav_gps_l2_prn1.hex"


def gnsstk_messages() -> list[tuple[int, float, np.ndarray]]:
    """``(message type, the transmit time GNSSTk gives it, its 300 bits)`` per message."""
    out = []
    for line in FILE.read_text().splitlines():
        if line.startswith("#") or not line.strip():
            continue
        kind, ct, text = line.split()
        bits = np.array([int(c) for c in bin(int(text, 16))[2:].zfill(300)], dtype=np.uint8)
        out.append((int(kind), float(ct), bits))
    return out


def gnsstk_cnav() -> dict[int, cnav.CnavMessage]:
    """The messages by type, read (`cnav.message_from_bits`)."""
    return {kind: cnav.message_from_bits(bits) for kind, _, bits in gnsstk_messages()}
