"""The embedded SQLite store of per-run metrics (and which batches are finished).

Rows are written in one transaction per finished batch (the batch's metrics and its
``batches`` row commit together or not at all; SQLite's rollback journal undoes a
transaction cut by a crash), so an interrupted comparison loses at most the batches in
flight and a later run never trusts a half-written batch: only batches listed in
``batches`` are skipped on resume, and their metrics were committed with them.

The key of every row includes the config's identity hash (`ComparisonConfig.identity`):
a changed seed or scenario starts afresh, while more runs of the same config reuse what
is there.
"""

from __future__ import annotations

import sqlite3
from contextlib import closing, contextmanager
from pathlib import Path
from typing import Iterator

import numpy as np

__all__ = ["ResultStore"]

_SCHEMA = """
CREATE TABLE IF NOT EXISTS batches (
    config TEXT, case_name TEXT, candidate TEXT, batch INTEGER, runs INTEGER,
    PRIMARY KEY (config, case_name, candidate, batch));
CREATE TABLE IF NOT EXISTS metrics (
    config TEXT, case_name TEXT, candidate TEXT, run INTEGER, metric TEXT, value REAL,
    PRIMARY KEY (config, case_name, candidate, run, metric));
"""


class ResultStore:
    """Per-run metrics of comparisons, in ``path`` (an SQLite file)."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        with self._connect() as con:
            con.executescript(_SCHEMA)

    @contextmanager
    def _connect(self) -> Iterator[sqlite3.Connection]:
        # One transaction per use: committed on a clean exit, rolled back on an
        # exception; the connection is closed either way.
        with closing(sqlite3.connect(self.path, timeout=30)) as con, con:
            yield con

    def finished_batches(self, config: str) -> set[tuple[str, str, int]]:
        with self._connect() as con:
            rows = con.execute("SELECT case_name, candidate, batch FROM batches WHERE config = ?", (config,))
            return {(c, k, int(b)) for c, k, b in rows}

    def add_batch(self, config: str, case: str, candidate: str, batch: int, first_run: int,
                  metrics: dict[str, np.ndarray]) -> None:
        """Store one finished batch atomically."""
        runs = len(next(iter(metrics.values())))
        rows = [(config, case, candidate, first_run + i, name, float(values[i]))
                for name, values in metrics.items() for i in range(runs)]
        with self._connect() as con:
            con.executemany("INSERT OR REPLACE INTO metrics VALUES (?, ?, ?, ?, ?, ?)", rows)
            con.execute("INSERT OR REPLACE INTO batches VALUES (?, ?, ?, ?, ?)", (config, case, candidate, batch, runs))

    def values(self, config: str, case: str, candidate: str, metric: str, runs: int) -> np.ndarray:
        """The metric of runs ``0 .. runs-1``, in run order."""
        with self._connect() as con:
            rows = con.execute(
                "SELECT value FROM metrics WHERE config = ? AND case_name = ? AND candidate = ? AND metric = ? "
                "AND run < ? ORDER BY run", (config, case, candidate, metric, runs)).fetchall()
        return np.array([r[0] for r in rows], dtype=float)

    def run_values(self, config: str, case: str, candidate: str, metric: str, runs: int) -> dict[int, float]:
        """The metric of runs ``0 .. runs-1`` by run index (pairs runs across candidates)."""
        with self._connect() as con:
            rows = con.execute(
                "SELECT run, value FROM metrics WHERE config = ? AND case_name = ? AND candidate = ? AND metric = ? "
                "AND run < ?", (config, case, candidate, metric, runs)).fetchall()
        return {int(r): (float("nan") if v is None else float(v)) for r, v in rows}
