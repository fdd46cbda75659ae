"""Progress of a long command, for a person at a terminal and for a log alike.

On a terminal a `tqdm` bar; anywhere else (a log file, CI, a notebook cell, a pipe) one
line each time another tenth of the work is done, with the elapsed time, so that a run
of twenty minutes is never silent::

    with Progress(72, "vector_tracking", "batch") as p:
        for _ in jobs:
            ...
            p.update()
    # off a terminal: "vector_tracking: 8/72 batch (11 %), 0:00:41 elapsed" ...

Work on a recording says how much of the signal it has processed and how fast
(``signal_s``: the seconds of signal the whole work stands for): each line (and the bar's
postfix) adds ``9.6/32.0 s of signal, 0.41x real time``, the real-time factor being the
seconds of signal processed per second of wall-clock time (above 1: faster than real
time). `phase` prints one line when a command starts a phase (acquisition, positions),
on a terminal or not.
"""

from __future__ import annotations

import sys
import time
from typing import TextIO

__all__ = ["Progress", "phase", "clock"]


def clock(seconds: float) -> str:
    """``h:mm:ss`` of a duration."""
    hours, rest = divmod(int(seconds), 3600)
    return f"{hours}:{rest // 60:02d}:{rest % 60:02d}"


def phase(desc: str, text: str, start: float, stream: TextIO | None = None) -> None:
    """One line ``desc: text, h:mm:ss elapsed`` (since ``start``, a `time.monotonic` value)."""
    print(
        f"{desc}: {text}, {clock(time.monotonic() - start)} elapsed",
        file=sys.stderr if stream is None else stream,
        flush=True,
    )


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
    signal_s
        Seconds of signal the ``total`` stands for (a recording's): the signal time
        processed and the real-time factor are shown (see the module text).
    """

    def __init__(
        self,
        total: int,
        desc: str,
        unit: str,
        stream: TextIO | None = None,
        terminal: bool | None = None,
        signal_s: float | None = None,
    ) -> None:
        self.total = max(int(total), 0)
        self.desc, self.unit = desc, unit
        self.stream = sys.stderr if stream is None else stream
        if terminal is None:
            isatty = getattr(self.stream, "isatty", None)
            terminal = bool(isatty()) if callable(isatty) else False
        self.done = 0
        self.signal_s = signal_s
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
            if self.signal_s is not None and done > self.done:
                self._bar.set_postfix_str(self._signal(done), refresh=False)
            self._bar.update(done - self.done)
        self.done = done
        if self._bar is None and self.total:
            while self._next_tenth <= 10 and 10 * done >= self._next_tenth * self.total:
                self._next_tenth += 1
                self._line()

    def _signal(self, done: int) -> str:
        """``9.6/32.0 s of signal, 0.41x real time`` at ``done`` units (with ``signal_s`` set)."""
        signal_s = self.signal_s or 0.0
        processed_s = signal_s * done / self.total if self.total else 0.0
        wall_s = time.monotonic() - self._start
        speed = f"{processed_s / wall_s:.2f}x real time" if wall_s > 0 else "-"
        digits = 1 if signal_s >= 1.0 else 3  # a short recording's milliseconds
        return f"{processed_s:.{digits}f}/{signal_s:.{digits}f} s of signal, {speed}"

    def _line(self) -> None:
        signal = f"{self._signal(self.done)}, " if self.signal_s is not None else ""
        print(
            f"{self.desc}: {self.done}/{self.total} {self.unit} ({100 * self.done // self.total} %), {signal}"
            f"{clock(time.monotonic() - self._start)} elapsed",
            file=self.stream,
            flush=True,
        )

    def close(self) -> None:
        """The work is over (a bar is closed; lines need nothing more)."""
        if self._bar is not None:
            self._bar.close()

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
