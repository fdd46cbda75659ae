"""Fixed-position bit fields of navigation words: integers scaled by their LSB.

A message format (Galileo I/NAV words, F/NAV pages) is a layout, ``name -> (first bit,
1-based; length; scale factor; signed)``, the field's integer the most significant bit
first, two's complement where signed, times its scale factor (the ICD's LSB) in physical
units. These two functions read and write any such layout.
"""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError

__all__ = ["Layout", "field_integer", "encode_fields", "decode_fields", "read_fields", "read_field"]

#: ``name -> (first bit, 1-based; length; scale; signed)``.
Layout = dict[str, tuple[int, int, float, bool]]


def field_integer(bits: np.ndarray, first: int, n: int) -> int:
    """The unsigned integer of ``n`` bits from bit ``first`` (1-based), most significant first."""
    return int("".join(map(str, np.asarray(bits[first - 1 : first - 1 + n]).tolist())) or "0", 2)


def encode_fields(n_bits: int, layout: Layout, values: dict[str, float], label: str, source: str) -> np.ndarray:
    """``n_bits`` bits (0/1) holding ``values`` of ``layout``, each quantised to the nearest
    integer of its scale (fields not given are 0, as reserved and spare bits). A value out of
    its field is refused in one line naming ``label.name`` and ``source`` (the ICD's table)."""
    bits = np.zeros(n_bits, dtype=np.uint8)
    for name, (first, n, scale, signed) in layout.items():
        if name not in values:
            continue
        q = int(np.round(float(values[name]) / scale))
        lo, hi = (-(1 << (n - 1)), (1 << (n - 1)) - 1) if signed else (0, (1 << n) - 1)
        if not lo <= q <= hi:
            raise ConfigError(
                f"{label}.{name}",
                f"{values[name]!r} does not fit {n} {'signed ' if signed else ''}bits of scale {scale:g} ({source})",
            )
        q &= (1 << n) - 1
        bits[first - 1 : first - 1 + n] = (q >> np.arange(n - 1, -1, -1)) & 1
    return bits


def decode_fields(bits: np.ndarray, layout: Layout) -> dict[str, float]:
    """The values of ``layout``'s fields in ``bits``, in physical units (an integer where the
    scale is 1)."""
    out: dict[str, float] = {}
    for name, (first, n, scale, signed) in layout.items():
        q = field_integer(bits, first, n)
        if signed and q >> (n - 1):
            q -= 1 << n
        out[name] = q * scale if scale != 1 else q
    return out


def read_fields(
    bits: np.ndarray, first0: int, n: int, count: int, scale: float = 1.0, signed: bool = False
) -> np.ndarray:
    """``count`` fields of ``n`` bits one after the other from bit ``first0`` (0-based, where
    `decode_fields`' layouts count from 1), times ``scale``, as floats."""
    layout = {str(k): (first0 + 1 + k * n, n, scale, signed) for k in range(count)}
    return np.array(list(decode_fields(bits, layout).values()), dtype=float)


def read_field(bits: np.ndarray, first0: int, n: int, scale: float = 1.0, signed: bool = False) -> float:
    """One field of ``n`` bits from bit ``first0`` (0-based), times ``scale``."""
    return float(read_fields(bits, first0, n, 1, scale, signed)[0])
