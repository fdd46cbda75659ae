"""Per-channel tracking as a Parquet table (``tracking.parquet``) that pandas opens.

The rows of ``tracking.csv`` (`channels.report.write_tracking_outputs`): one per channel
filter update, sorted by time then PRN, with the columns of
`channels.records.RECORD_FIELDS` plus ``prn``, in their own types (float64, int, bool for
``lock``, the stage's name as a dictionary-encoded string) and without the CSV's rounding.
Written through pyarrow (the ``[columnar]`` extra); the file's metadata names the channel
filter and the run's duration. The channels of several signals (``signal_of``, a
`multi_receive.SignalSet`'s, given: keys ``index x 1000 + PRN``) get a ``signal`` column,
the signal's name, and their own PRN in ``prn``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...errors import ConfigError
from ..channels import STAGES
from ..channels.records import RECORD_FIELDS, TrackingResult

__all__ = ["write_tracking_parquet", "PYARROW_MISSING"]

PYARROW_MISSING = "the Parquet output needs pyarrow: pip install 'gnssframework[columnar]'"


def write_tracking_parquet(path: str | Path, tracking: TrackingResult, signal_of=None) -> Path:
    """Write ``tracking``'s rows (see the module text; ``signal_of`` maps a channel's key to
    its `SignalSpec` for a run of several signals).

    Raises
    ------
    ConfigError
        When pyarrow is not installed (a one-line message naming the extra).
    """
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        raise ConfigError("outputs", PYARROW_MISSING) from None
    rows = [(prn, *r) for prn, ch in tracking.channels.items() for r in ch.rows]
    names = ("prn", *RECORD_FIELDS)
    columns = (
        {n: np.array([r[i] for r in rows]) for i, n in enumerate(names)} if rows else {n: np.zeros(0) for n in names}
    )
    order = np.lexsort((columns["prn"], columns["time_s"])) if rows else np.zeros(0, int)
    arrays = {}
    for n in names:
        v = columns[n][order]
        if n == "stage":
            arrays[n] = pa.array([STAGES[int(s)] for s in v], pa.string()).dictionary_encode()
        elif n == "lock":
            arrays[n] = pa.array(v.astype(bool))
        elif n in ("prn", "coherent_ms"):
            arrays[n] = pa.array(v.astype(np.int64))
        else:
            arrays[n] = pa.array(v.astype(np.float64))
    if signal_of is not None:
        from .multi_receive import KEY_STEP

        keys = columns["prn"][order].astype(np.int64)
        names_of = {int(k): signal_of(int(k)).name for k in np.unique(keys)}
        arrays["signal"] = pa.array([names_of[int(k)] for k in keys], pa.string()).dictionary_encode()
        arrays["prn"] = pa.array(keys % KEY_STEP)
    table = pa.table(arrays).replace_schema_metadata(
        {"channel_filter": str(tracking.channel_filter), "duration_s": repr(float(tracking.duration_s))}
    )
    path = Path(path)
    pq.write_table(table, path)
    return path
