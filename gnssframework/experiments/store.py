"""The embedded SQLite store of per-run metrics, and which batches of runs it holds.

A comparison of ``runs`` runs in batches of ``batch_size`` is planned at fixed run
boundaries: batch ``b`` holds runs ``b * batch_size`` to ``min((b + 1) * batch_size,
runs) - 1`` (:func:`plan_batches`). The store records each finished batch by its first
run and its number of runs, and a metric's values for ``runs`` runs are read from the
batches of that plan only. So 3 runs then 4 (batches of 2) recompute the batch of runs
2-3 instead of reusing the 1-run batch of run 2, and 4 then 3 reads run 2 from a 1-run
batch: the numbers are those of a fresh comparison with that many runs, bit for bit,
even where a batch's arithmetic depends on its size. Random numbers never do (one stream
per run: :mod:`gnssframework.random_streams`).

Rows are written in one transaction per finished batch (the batch's metrics and its
``batches`` row commit together or not at all; SQLite's rollback journal undoes a
transaction cut by a crash), so an interrupted comparison loses at most the batches in
flight and a later run never trusts a half-written batch.

The key of every row includes the config's identity hash (`ComparisonConfig.identity`):
a changed seed or scenario starts afresh, while more runs of the same config reuse what
is there. Column names are those of ``summary.json`` (``case``, ``candidate``,
``metric``, ``run``, ``value``).
"""

from __future__ import annotations

import sqlite3
from contextlib import closing, contextmanager
from pathlib import Path
from collections.abc import Iterator

import numpy as np

from ..errors import DataFileError

__all__ = ["ResultStore", "plan_batches", "STORE_FORMAT"]

#: Version of the table layout; a store of another version is refused, not misread.
STORE_FORMAT = 2

_SCHEMA = """
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT);
CREATE TABLE IF NOT EXISTS configs (config TEXT PRIMARY KEY, batch_size INTEGER);
CREATE TABLE IF NOT EXISTS batches (
    config TEXT, "case" TEXT, candidate TEXT, first_run INTEGER, runs INTEGER,
    PRIMARY KEY (config, "case", candidate, first_run, runs));
CREATE TABLE IF NOT EXISTS trials (
    config TEXT, candidate TEXT, trial INTEGER, "values" TEXT, objective REAL,
    PRIMARY KEY (config, candidate, trial));
CREATE TABLE IF NOT EXISTS metrics (
    config TEXT, "case" TEXT, candidate TEXT, first_run INTEGER, batch_runs INTEGER, run INTEGER,
    metric TEXT, value REAL,
    PRIMARY KEY (config, "case", candidate, first_run, batch_runs, run, metric));
"""


def plan_batches(runs: int, batch_size: int) -> list[tuple[int, int]]:
    """``(first_run, runs)`` of every batch of a comparison (fixed boundaries).

    >>> plan_batches(5, 2)
    [(0, 2), (2, 2), (4, 1)]
    """
    return [(first, min(batch_size, runs - first)) for first in range(0, runs, batch_size)]


class ResultStore:
    """Per-run metrics of comparisons, in ``path`` (an SQLite file)."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        try:
            with self._connect() as con:
                tables = {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
                if "batches" in tables and "meta" not in tables:
                    raise DataFileError(
                        str(self.path),
                        None,
                        "a result store of an earlier gnssframework (format 1, "
                        "batches numbered by position); write this comparison to a new --out folder",
                    )
                con.executescript(_SCHEMA)
                row = con.execute("SELECT value FROM meta WHERE key = 'format'").fetchone()
                if row is None:
                    con.execute("INSERT INTO meta VALUES ('format', ?)", (str(STORE_FORMAT),))
                elif row[0] != str(STORE_FORMAT):
                    raise DataFileError(
                        str(self.path),
                        None,
                        f"result store format {row[0]}, this gnssframework "
                        f"reads format {STORE_FORMAT}; write to a new --out folder",
                    )
        except sqlite3.DatabaseError as exc:
            raise DataFileError(str(self.path), None, f"not a readable result store ({exc})") from None

    @contextmanager
    def _connect(self) -> Iterator[sqlite3.Connection]:
        # One transaction per use: committed on a clean exit, rolled back on an
        # exception; the connection is closed either way.
        with closing(sqlite3.connect(self.path, timeout=30)) as con, con:
            yield con

    def meta(self, key: str) -> str | None:
        """A value of the store's ``meta`` table (``format``, ``identity`` of the folder's comparison)."""
        with self._connect() as con:
            row = con.execute("SELECT value FROM meta WHERE key = ?", (key,)).fetchone()
        return None if row is None else row[0]

    def set_meta(self, key: str, value: str) -> None:
        with self._connect() as con:
            con.execute("INSERT OR REPLACE INTO meta VALUES (?, ?)", (key, value))

    def register(self, config: str, batch_size: int) -> None:
        """Record the batch size of the config with identity ``config`` (its batch plan)."""
        with self._connect() as con:
            con.execute("INSERT OR IGNORE INTO configs VALUES (?, ?)", (config, int(batch_size)))

    def _batch_size(self, con: sqlite3.Connection, config: str) -> int | None:
        row = con.execute("SELECT batch_size FROM configs WHERE config = ?", (config,)).fetchone()
        return None if row is None else int(row[0])

    def finished_batches(self, config: str) -> set[tuple[str, str, int, int]]:
        """``(case, candidate, first_run, runs)`` of every finished batch of ``config`` whose
        metric rows are all there.

        A batch's ``batches`` row says it committed; its metric rows are checked too: every
        metric the other batches of its case and candidate store must have one row per run
        of the batch. A batch with rows missing (a store edited or damaged by hand) is not
        finished: the comparison recomputes it instead of averaging over the runs that are
        left. The metrics expected are those of the same case and candidate, not of the
        whole comparison: a case may define metrics another does not (the posterior
        Cramer-Rao bound on a static receiver only), and its batches are not damaged for it.
        """
        with self._connect() as con:
            rows = con.execute(
                'SELECT b."case", b.candidate, b.first_run, b.runs, m.metric, COUNT(DISTINCT m.run) FROM batches b '
                'LEFT JOIN metrics m ON m.config = b.config AND m."case" = b."case" AND m.candidate = b.candidate '
                "AND m.first_run = b.first_run AND m.batch_runs = b.runs AND m.run >= b.first_run "
                "AND m.run < b.first_run + b.runs WHERE b.config = ? "
                'GROUP BY b."case", b.candidate, b.first_run, b.runs, m.metric',
                (config,),
            ).fetchall()
        held: dict[tuple[str, str, int, int], dict[str, int]] = {}
        for c, k, f, n, metric, count in rows:
            counts = held.setdefault((c, k, int(f), int(n)), {})
            if metric is not None:
                counts[metric] = int(count)
        expected: dict[tuple[str, str], set[str]] = {}
        for (c, k, _, _), counts in held.items():
            expected.setdefault((c, k), set()).update(counts)
        return {
            batch
            for batch, counts in held.items()
            if counts and set(counts) == expected[batch[:2]] and all(v == batch[3] for v in counts.values())
        }

    def damaged_batches(
        self, config: str, finished: set[tuple[str, str, int, int]] | None = None
    ) -> set[tuple[str, str, int, int]]:
        """``(case, candidate, first_run, runs)`` of every batch of ``config`` that committed
        (its ``batches`` row is there) but whose metric rows are not all there: what
        `finished_batches` leaves out for the comparison to recompute (``finished``: its
        answer when the caller has it already, not queried again)."""
        with self._connect() as con:
            committed = {
                (c, k, int(f), int(n))
                for c, k, f, n in con.execute(
                    'SELECT "case", candidate, first_run, runs FROM batches WHERE config = ?', (config,)
                ).fetchall()
            }
        return committed - (self.finished_batches(config) if finished is None else finished)

    def add_batch(self, config: str, case: str, candidate: str, first_run: int, metrics: dict[str, np.ndarray]) -> None:
        """Store one finished batch (runs ``first_run ..``, one value per run) atomically."""
        runs = len(next(iter(metrics.values())))
        rows = [
            (config, case, candidate, first_run, runs, first_run + i, name, float(values[i]))
            for name, values in metrics.items()
            for i in range(runs)
        ]
        with self._connect() as con:
            con.executemany("INSERT OR REPLACE INTO metrics VALUES (?, ?, ?, ?, ?, ?, ?, ?)", rows)
            con.execute(
                "INSERT OR REPLACE INTO batches VALUES (?, ?, ?, ?, ?)", (config, case, candidate, first_run, runs)
            )

    def add_trial(self, config: str, candidate: str, trial: int, values_json: str, objective: float) -> None:
        """Record a finished tuning trial (its parameter values as JSON and its objective)."""
        with self._connect() as con:
            con.execute(
                "INSERT OR REPLACE INTO trials VALUES (?, ?, ?, ?, ?)",
                (config, candidate, int(trial), values_json, float(objective)),
            )

    def trials(self, config: str, candidate: str) -> list[tuple[list, float]]:
        """The finished tuning trials of ``candidate`` in ``config``, in order: (values, objective)."""
        import json

        with self._connect() as con:
            rows = con.execute(
                'SELECT "values", objective FROM trials WHERE config = ? AND candidate = ? ORDER BY trial',
                (config, candidate),
            ).fetchall()
        return [(json.loads(v), float("inf") if o is None else float(o)) for v, o in rows]

    def run_values(self, config: str, case: str, candidate: str, metric: str, runs: int) -> dict[int, float]:
        """The metric of runs ``0 .. runs-1`` by run index (pairs runs across candidates),
        read from the batches of a ``runs``-run comparison only (see the module docstring)."""
        with self._connect() as con:
            batch_size = self._batch_size(con, config)
            if batch_size is None:
                return {}
            plan = set(plan_batches(runs, batch_size))
            rows = con.execute(
                'SELECT first_run, batch_runs, run, value FROM metrics WHERE config = ? AND "case" = ? '
                "AND candidate = ? AND metric = ? AND run < ?",
                (config, case, candidate, metric, runs),
            ).fetchall()
        return {int(r): (float("nan") if v is None else float(v)) for f, n, r, v in rows if (f, n) in plan}

    def values(self, config: str, case: str, candidate: str, metric: str, runs: int) -> np.ndarray:
        """The metric of runs ``0 .. runs-1``, in run order (those the store holds)."""
        by_run = self.run_values(config, case, candidate, metric, runs)
        return np.array([by_run[r] for r in sorted(by_run)], dtype=float)
