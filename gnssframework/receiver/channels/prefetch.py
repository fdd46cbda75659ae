"""Read-ahead of a recording's blocks: the next block read, and its power measured, on a
second thread while the channels correlate the current one.

The tracker reads the recording in contiguous blocks (`SampleTracker`): after a block of
``count`` samples from ``first``, the next read nearly always starts at ``first + count``
and asks for the configured block length. `BlockReader` reads that block ahead, on one
worker thread (``numpy.fromfile`` and the compiled `correlator.sum_of_squares` run
without the GIL), and hands it over only when the tracker then asks for exactly that
range; any other request is read there and then. What the tracker gets, samples and
power, is therefore the same array and the same number either way: only when they are
read changes. A block read ahead and not used is dropped.
"""

from __future__ import annotations

from concurrent.futures import Future, ThreadPoolExecutor

import numpy as np

from ..frontend.recording import Recording
from .correlator import sum_of_squares

__all__ = ["BlockReader"]


def _read(recording: Recording, first: int, count: int) -> tuple[np.ndarray, float]:
    new = recording.read_components(first, count)
    return new, (sum_of_squares(new) if new.size else 0.0)


class BlockReader:
    """Blocks of ``recording`` as `Recording.read_components` returns them, with their sum
    of squared components (`correlator.sum_of_squares`; 0 for an empty block).

    Parameters
    ----------
    recording
        The samples.
    ahead_samples
        Length of the block read ahead after each read (the tracker's ``block_ms`` in
        samples); 0 reads nothing ahead (every block is read when asked for).
    """

    def __init__(self, recording: Recording, ahead_samples: int) -> None:
        self.rec = recording
        self.ahead = int(ahead_samples)
        self._pool: ThreadPoolExecutor | None = None
        self._pending: tuple[int, int, Future] | None = None
        self.hits = 0  # blocks handed over from the read-ahead (for tests)

    def read(self, first: int, count: int) -> tuple[np.ndarray, float]:
        """Samples ``[first, first + count)`` (fewer at the end) and their sum of squares;
        then the next ``ahead_samples`` are read ahead."""
        pending, self._pending = self._pending, None
        if pending is not None and pending[:2] == (first, count):
            block = pending[2].result()
            self.hits += 1
        else:
            if pending is not None:
                pending[2].cancel()
            block = _read(self.rec, first, count)
        per = 2 if self.rec.is_complex else 1
        following = first + block[0].size // per
        if self.ahead > 0 and block[0].size and following < self.rec.n_samples:
            if self._pool is None:
                self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="gnssframework-read-ahead")
            self._pending = (following, self.ahead, self._pool.submit(_read, self.rec, following, self.ahead))
        return block

    def close(self) -> None:
        """Drop what was read ahead and stop the worker thread."""
        self._pending = None
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None
