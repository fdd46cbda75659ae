"""A results folder belongs to one comparison, and to one process at a time.

``summary.json``, ``report.md``, the plots and ``raw/`` of a folder describe one
configuration. Writing another configuration into it (other seed, scenario, cases,
candidates or batch size: anything in ``ComparisonConfig.identity``) would mix its time
series with the first one's, so it is refused with one line naming what differs. More or
fewer runs, another executor, other sweeps, metrics or published values are the same
comparison and reuse what the folder holds.

A second process writing into a folder that a first one is writing would interleave
their files; an exclusive lock on ``<folder>/.lock`` (``fcntl.flock``, released by the
kernel when the holder exits, even by a kill) refuses it.
"""

from __future__ import annotations

import json
import os
from contextlib import contextmanager
from pathlib import Path
from typing import Any
from collections.abc import Iterator

from ..errors import ConfigError
from ..io.files import atomic_write_text
from .store import ResultStore

__all__ = ["claim_folder", "IDENTITY_FIELDS"]

#: The config's fields that change its numbers (see ``ComparisonConfig.identity``).
IDENTITY_FIELDS = ("seed", "batch_size", "scenario", "cases", "candidates")


def _lock(out: Path):
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX: no lock, as before
        return None
    fh = open(out / ".lock", "a+")
    try:
        fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        fh.close()
        raise ConfigError(
            "out",
            f"{out} is being written by another gnssframework process; wait for it to finish or choose another folder",
        ) from None
    fh.seek(0)
    fh.truncate()
    fh.write(f"{os.getpid()}\n")
    fh.flush()
    return fh


def _differences(previous: dict[str, Any], current: dict[str, Any]) -> list[str]:
    return [f for f in IDENTITY_FIELDS if previous.get(f) != current.get(f)]


@contextmanager
def claim_folder(out: Path, config) -> Iterator[ResultStore]:
    """Lock ``out``, check that it holds ``config``'s comparison (or nothing), record it,
    and yield its result store.

    Raises
    ------
    ConfigError
        ``out``: the folder holds another configuration's results, or another process
        is writing it.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    lock = _lock(out)
    try:
        store = ResultStore(out / "results.sqlite")
        identity = config.identity()
        current = json.loads(config.model_dump_json())
        held = store.meta("identity")
        if held is None and (out / "raw").is_dir() and any((out / "raw").iterdir()):
            raise ConfigError(
                "out", f"{out} holds time series (raw/) but no record of their comparison; choose an empty folder"
            )
        if held is not None and held != identity:
            try:
                previous = json.loads((out / "config.json").read_text())
            except (OSError, ValueError):
                previous = {}
            what = (
                ", ".join(_differences(previous, current))
                or "its identity: nothing written differs, so the scenario's code changed the numbers since "
                "(its revision)"
            )
            name = previous.get("name", "another comparison")
            raise ConfigError(
                "out",
                f"{out} holds the results of {name!r}, a different configuration (it differs "
                f"in: {what}); choose another folder, or delete this one to start afresh",
            )
        if held is None:
            store.set_meta("identity", identity)
        atomic_write_text(out / "config.json", config.model_dump_json(indent=2))
        yield store
    finally:
        if lock is not None:
            lock.close()
