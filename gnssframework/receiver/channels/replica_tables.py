r"""A `SignalSpec`'s spreading waveform as the correlator kernels take it: ±1 tables of
chips (BPSK) or sub-chips (BOC), and phases in the tables' units.

The kernels (`gnssframework.receiver.channels.correlator`) know no signal: a table is any
±1 sequence indexed by :math:`\lfloor p \rfloor \bmod n`; these functions make the
tables of one signal and convert its chips to the tables' units.
"""

from __future__ import annotations

import numpy as np

from ...errors import ConfigError
from ...signal.spec import SignalSpec

__all__ = ["replica_codes", "replica_code_pair", "to_table_units"]


def replica_codes(signal: SignalSpec, prns) -> np.ndarray:
    """``(len(prns), code_length_chips * subchips_per_chip)`` ``float32`` tables of
    ``signal``'s spreading waveform (`SignalSpec.spreading_table`) for the kernels.

    Raises
    ------
    ConfigError
        For a waveform that is not ±1 (CBOC's weighted sum: the kernels keep one sign bit
        per tap), or a PRN the signal does not define.
    """
    tables = np.stack([signal.spreading_table(p) for p in prns]).astype(np.float32)
    if not np.all(np.abs(tables) == 1.0):
        raise ConfigError(
            "signal",
            f"{signal.name}'s spreading waveform is not ±1 ({signal.subcarrier.kind}): "
            "the compiled correlators take ±1 tables (track its BOC(1,1) replica: the -boc11 "
            "signals)",
        )
    return tables


def replica_code_pair(signal: SignalSpec, prns) -> tuple[np.ndarray, np.ndarray | None]:
    """``signal``'s spreading tables as the kernels take them: `replica_codes` where they
    are ±1 (second table None); for a time-multiplexed signal whose tracked component's
    table is 0 in the other components' slots (GPS L2C's CM: ``{-1, 0, +1}``), two ±1
    tables ``a``, ``b`` with ``(a + b) / 2`` the waveform (``a = b`` on the component's
    chips, ``+1`` and ``-1`` in the other slots): correlation is linear in the replica, so
    the mean of the two correlations is the correlation with the waveform.

    Raises
    ------
    ConfigError
        For any other waveform (CBOC's weighted sum), as `replica_codes`.
    """
    tables = np.stack([signal.spreading_table(p) for p in prns]).astype(np.float32)
    if np.all(np.abs(tables) == 1.0) or not np.all(np.isin(tables, (-1.0, 0.0, 1.0))):
        return replica_codes(signal, prns), None
    zero = tables == 0.0
    return np.where(zero, np.float32(1.0), tables), np.where(zero, np.float32(-1.0), tables)


def to_table_units(chips, signal: SignalSpec):
    """Code phases, steps or tap offsets in chips, in the units of `replica_codes`' tables
    (sub-chips: times ``signal.subchips_per_chip``; unchanged for BPSK)."""
    s = signal.subchips_per_chip
    return chips if s == 1 else np.asarray(chips, float) * s
