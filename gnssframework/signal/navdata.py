"""Navigation data bits (50 bit/s on GPS L1 C/A; any signal's symbol period) and data wipe-off."""

from __future__ import annotations

import numpy as np

from .. import random_streams as draw
from ..errors import ConfigError
from .correlators import Correlators
from .gps_l1ca import GPS_L1CA
from .spec import SignalSpec

__all__ = ["random_nav_bits", "bit_at", "data_bit_period_s", "wipe_off"]


def random_nav_bits(n_bits: int, rng: np.random.Generator, batch_shape: tuple[int, ...] = ()) -> np.ndarray:
    """Equiprobable ±1 bits, shape ``(n_bits, *batch_shape)``, ``int8``."""
    return (1 - 2 * draw.integers(rng, 0, 2, (n_bits,) + tuple(batch_shape), run_axis=1)).astype(np.int8)


def bit_at(
    time_s: np.ndarray,
    bits: np.ndarray,
    first_edge_s: float | np.ndarray = 0.0,
    bit_period_s: float | None = None,
    signal: SignalSpec = GPS_L1CA,
) -> np.ndarray:
    """The bit in force at ``time_s``. Bit k spans ``[first_edge + k T_b, first_edge + (k+1) T_b)``
    with ``T_b = bit_period_s``, by default ``signal``'s data bit period (`data_bit_period_s`;
    1/50 s for GPS L1 C/A).

    Times before the first edge take bit 0, and times after the last bit take the last bit.
    """
    if bit_period_s is None:
        bit_period_s = data_bit_period_s(signal)
    k = np.floor((np.asarray(time_s, dtype=float) - first_edge_s) / bit_period_s).astype(int)
    k = np.clip(k, 0, bits.shape[0] - 1)
    if bits.ndim == 1:
        return bits[k]
    # One bit stream per batch element: pick each element's own bit.
    k = np.broadcast_to(k, bits.shape[1:])
    return np.take_along_axis(bits, k[None], axis=0)[0]


def data_bit_period_s(signal: SignalSpec = GPS_L1CA) -> float:
    """The data bit (symbol) period of ``signal`` (s; 20 ms for GPS L1 C/A)."""
    if signal.symbol_period_s is None:
        raise ConfigError("signal", f"{signal.name} carries no data symbols")
    return signal.symbol_period_s


def wipe_off(correlators: Correlators, bit: np.ndarray) -> Correlators:
    """Remove known data bits: multiply every tap by the (±1) bit."""
    b = np.asarray(bit, dtype=float)
    if not correlators.extra and b.shape == correlators.shape:
        # Same shapes, complex taps times real bits: the result needs no checks.
        return Correlators.trusted(correlators.early * b, correlators.prompt * b, correlators.late * b)
    extra = {k: v * b for k, v in correlators.extra.items()}
    return Correlators(correlators.early * b, correlators.prompt * b, correlators.late * b, extra=extra)
