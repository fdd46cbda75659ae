"""Progress of a long command, for a person at a terminal and for a log alike.

On a terminal a `tqdm` bar; anywhere else (a log file, CI, a notebook cell, a pipe) one
line each time another tenth of the work is done, with the elapsed time, so that a run
of twenty minutes is never silent::

    with Progress(72, "vector_tracking", "batch") as p:
        for _ in jobs:
            ...
            p.update()
    # off a terminal: "vector_tracking: 8/72 batch (11 %), 0:00:41 elapsed" ...
"""

from __future__ import annotations

import sys
import time
from typing import TextIO

__all__ = ["Progress"]


class Progress:
    """Work done out of ``total`` units.

    Parameters
    ----------
    total
        Units of work (batches, percent of a recording).
    desc
        What is being done (printed at the start of each line or bar).
    unit
        The unit's name.
    stream
        Where to write (standard error by default).
    terminal
        Draw a bar (True) or print lines (False); by default, whether ``stream`` is a
        terminal.
    """

    def __init__(self, total: int, desc: str, unit: str, stream: TextIO | None = None,
                 terminal: bool | None = None) -> None:
        self.total = max(int(total), 0)
        self.desc, self.unit = desc, unit
        self.stream = sys.stderr if stream is None else stream
        if terminal is None:
            isatty = getattr(self.stream, "isatty", None)
            terminal = bool(isatty()) if callable(isatty) else False
        self.done = 0
        self._start = time.monotonic()
        self._next_tenth = 1
        self._bar = None
        if terminal:
            from tqdm import tqdm

            self._bar = tqdm(total=self.total, desc=desc, unit=unit, file=self.stream)

    def update(self, n: int = 1) -> None:
        """``n`` more units done."""
        self.set(self.done + n)

    def set(self, done: int) -> None:
        """``done`` units done in all (never moves back)."""
        done = min(max(int(done), self.done), self.total)
        if self._bar is not None:
            self._bar.update(done - self.done)
        self.done = done
        if self._bar is None and self.total:
            while self._next_tenth <= 10 and 10 * done >= self._next_tenth * self.total:
                self._next_tenth += 1
                self._line()

    def _line(self) -> None:
        elapsed = int(time.monotonic() - self._start)
        hours, rest = divmod(elapsed, 3600)
        print(f"{self.desc}: {self.done}/{self.total} {self.unit} ({100 * self.done // self.total} %), "
              f"{hours}:{rest // 60:02d}:{rest % 60:02d} elapsed", file=self.stream, flush=True)

    def close(self) -> None:
        """The work is over (a bar is closed; lines need nothing more)."""
        if self._bar is not None:
            self._bar.close()

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
