"""Result files that a crash cannot leave half-written, and JSON that strict parsers accept.

Every output a later run or another tool reads (summary.json, report.md, CSV, plots,
the per-batch ``.npz`` series, config.json) is written to a temporary file in the same
directory, flushed to disk and moved over the target with :func:`os.replace`, which is
atomic on POSIX and Windows: a reader sees the old file or the new one, never a part.
A process killed mid-write leaves at most a hidden ``.<name>.*.tmp`` file, which no
reader looks at.

JSON is written with ``allow_nan=False``: ``NaN`` and ``Infinity`` are not JSON (RFC 8259)
and jq, JavaScript and most databases reject them. A float that is not finite becomes
``null``; callers that can say why a value is undefined put the reason beside it.
"""

from __future__ import annotations

import csv
import errno
import json
import math
import os
import tempfile
from contextlib import contextmanager, suppress
from pathlib import Path
from typing import IO, Any
from collections.abc import Iterable, Iterator

import numpy as np

__all__ = [
    "atomic_open",
    "atomic_write_text",
    "write_rows_csv",
    "strict_json",
    "dumps_strict",
    "write_json",
    "loads_strict",
]


@contextmanager
def atomic_open(path: str | Path, mode: str = "w", **kwargs: Any) -> Iterator[IO]:
    """Open a temporary file beside ``path``; on a clean exit it replaces ``path``.

    On an exception (or a kill) ``path`` is untouched. ``mode`` is ``"w"`` or ``"wb"``;
    ``kwargs`` go to :func:`open` (``newline=""`` for CSV).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> with atomic_open(d / "a.txt") as fh:
    ...     _ = fh.write("done")
    >>> (d / "a.txt").read_text()
    'done'
    """
    if mode not in ("w", "wb"):
        raise ValueError(f"atomic_open writes whole files: mode 'w' or 'wb', not {mode!r}")
    path = Path(path)
    if not path.parent.is_dir():  # mkstemp would name its temporary file, not the folder the user gave
        raise FileNotFoundError(
            errno.ENOENT,
            f"the output folder {path.parent} does not exist (create it or choose another path)",
            str(path),
        )
    try:
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    except OSError as exc:
        raise OSError(exc.errno, exc.strerror, str(path)) from None
    try:
        with os.fdopen(fd, mode, **kwargs) as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, 0o644)  # mkstemp makes 0600; results are meant to be shared
        os.replace(tmp, path)
    except OSError as exc:  # a full disk names no file: name the output being written
        with suppress(FileNotFoundError):
            os.unlink(tmp)
        if exc.filename is None or str(exc.filename) == tmp:
            raise OSError(exc.errno, exc.strerror or str(exc), str(path)) from None
        raise
    except BaseException:
        with suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


def atomic_write_text(path: str | Path, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    with atomic_open(path, "w", encoding="utf-8") as fh:
        fh.write(text)


def write_rows_csv(path: str | Path, columns: tuple[str, ...], rows: Iterable[dict[str, Any]]) -> Path:
    """Write ``rows`` (one dict each, keyed by ``columns``) as CSV under a header of
    ``columns``, atomically (`atomic_open`); the path."""
    path = Path(path)
    with atomic_open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(columns)
        for row in rows:
            w.writerow([row[c] for c in columns])
    return path


def strict_json(obj: Any) -> Any:
    """A copy of ``obj`` with every non-finite float (``nan``, ``inf``) replaced by ``None``
    and NumPy scalars and arrays turned into Python numbers and lists."""
    if isinstance(obj, dict):
        return {k: strict_json(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [strict_json(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return strict_json(obj.tolist())
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def dumps_strict(obj: Any, **kwargs: Any) -> str:
    """:func:`json.dumps` of :func:`strict_json` ``(obj)``; never emits ``NaN``/``Infinity``."""
    return json.dumps(strict_json(obj), allow_nan=False, **kwargs)


def write_json(path: str | Path, obj: Any, indent: int = 2) -> None:
    """Write ``obj`` as strict JSON to ``path`` atomically."""
    atomic_write_text(path, dumps_strict(obj, indent=indent) + "\n")


def _refuse_constant(name: str) -> None:
    raise ValueError(f"non-standard JSON constant {name}")


def loads_strict(text: str) -> Any:
    """Parse JSON as strict parsers do: ``NaN``, ``Infinity`` and ``-Infinity`` are errors."""
    return json.loads(text, parse_constant=_refuse_constant)
