"""Lines a reader skipped: refusing them (strict mode), reporting them, exit statuses.

Readers of recorded files (:func:`~gnssframework.io.nmea.read_nmea`,
:func:`~gnssframework.io.observations.read_code_carrier`) either skip a bad line and list it as
``(line, reason)``, or, with ``strict=True``, refuse the file at the first such line. The
commands that use them (``filter-positions``, ``smooth``) print the list, write it beside
their output as ``<out>.skipped.csv`` and say in their exit status whether anything was
skipped.
"""

from __future__ import annotations

import csv
from pathlib import Path
from collections.abc import Sequence

from ..errors import DataFileError

__all__ = [
    "EXIT_OK",
    "EXIT_ERROR",
    "EXIT_SKIPPED",
    "EXIT_TRUNCATED",
    "EXIT_STATUS_HELP",
    "refuse_or_keep",
    "sidecar_path",
    "write_skipped_report",
    "print_skipped",
    "exit_status",
]

#: Every line used, nothing skipped.
EXIT_OK = 0
#: Nothing written: a library error (bad file in strict mode, unreadable file, bad option).
EXIT_ERROR = 2
#: Output written, but some lines were skipped (listed in the summary and the sidecar).
EXIT_SKIPPED = 3
#: Output written from the part before the cut, but the file is truncated.
EXIT_TRUNCATED = 4

EXIT_STATUS_HELP = (
    f"exit status: {EXIT_OK} every line used; {EXIT_SKIPPED} output written but lines were skipped "
    f"(listed on stdout and in <out>.skipped.csv); {EXIT_TRUNCATED} output written but the input "
    f"file is truncated; {EXIT_ERROR} error, nothing written (with --strict: the first bad line)"
)


def refuse_or_keep(path: str | Path, skipped: Sequence[tuple[int, str]], strict: bool) -> None:
    """With ``strict``, raise a :class:`DataFileError` naming the first skipped line."""
    if strict and skipped:
        line, reason = min(skipped)
        more = f" (and {len(skipped) - 1} more bad lines)" if len(skipped) > 1 else ""
        raise DataFileError(str(path), line, f"{reason}{more}; without --strict it would be skipped")


def sidecar_path(out: str | Path) -> Path:
    """``<out>.skipped.csv``: where a command lists the lines it skipped."""
    out = Path(out)
    return out.with_name(out.name + ".skipped.csv")


def write_skipped_report(out: str | Path, source: str | Path, skipped: Sequence[tuple[int, str]]) -> Path:
    """Write ``<out>.skipped.csv`` (``file,line,reason``; header only when nothing was skipped,
    so a stale list from an earlier run never survives)."""
    from .files import atomic_open

    path = sidecar_path(out)
    with atomic_open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["file", "line", "reason"])
        for line, reason in skipped:
            w.writerow([str(source), line, reason])
    return path


def print_skipped(skipped: Sequence[tuple[int, str]], limit: int = 20) -> None:
    """Print the first ``limit`` skipped lines and how many more there are."""
    for line, reason in skipped[:limit]:
        print(f"  skipped line {line}: {reason}")
    if len(skipped) > limit:
        print(f"  ... and {len(skipped) - limit} more")


def exit_status(skipped: Sequence[tuple[int, str]], truncated: bool = False) -> int:
    """:data:`EXIT_TRUNCATED`, :data:`EXIT_SKIPPED` or :data:`EXIT_OK`."""
    if truncated:
        return EXIT_TRUNCATED
    return EXIT_SKIPPED if skipped else EXIT_OK
