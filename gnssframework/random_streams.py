"""One random stream per Monte Carlo run, drawn as one batch.

A Monte Carlo run must see the same random numbers whichever runs it was simulated
with: a comparison of 4 runs in batches of 2 and one of 4 runs in one batch, or 3 runs
extended to 4, must agree run by run. One ``numpy.random.Generator`` shared by a batch
cannot give that (its draws are laid out over the batch, so run 2 of a 1-run batch and
run 2 of a 2-run batch get different numbers). :class:`RunStreams` holds one generator
per run and lays each draw out over a named *run axis*: run ``r``'s slice comes from its
own generator only, and every run consumes its generator in the same order whatever the
batch. The comparison runner seeds run ``r`` of a case from
``SeedSequence([seed, *case_key, r])`` (see :func:`run_streams`).

Library functions that simulate (clock, noise, scintillation, IMU, correlator noise,
navigation bits) take either a plain ``Generator`` or a ``RunStreams`` and draw through
the functions of this module (:func:`standard_normal`, :func:`uniform`, :func:`integers`,
:func:`random`, :func:`choice`), naming the axis of their output that holds the runs.

Examples
--------
>>> import numpy as np
>>> four = run_streams(7, (1,), range(4))
>>> two = run_streams(7, (1,), range(2, 4))
>>> a = four.standard_normal((5, 4, 3), run_axis=1)   # epochs x runs x channels
>>> b = two.standard_normal((5, 2, 3), run_axis=1)
>>> bool(np.array_equal(a[:, 2:], b))
True
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Sequence
from typing import Any, TypeAlias

import numpy as np

from .errors import ConfigError

__all__ = [
    "RunStreams",
    "run_streams",
    "as_run_streams",
    "name_key",
    "child",
    "standard_normal",
    "uniform",
    "integers",
    "random",
    "choice",
    "Size",
]

#: A draw's shape, as NumPy's ``size``: an int or a sequence of ints (None: no shape, refused
#: by the per-run draws, which need the run axis).
Size: TypeAlias = int | Sequence[int] | None


def name_key(name: str) -> tuple[int, int]:
    """Two 32-bit words from a name's SHA-256: a stable seed component for a case or a
    purpose, independent of its position in a list (a sweep that runs a subset of the
    cases keeps each case's random numbers)."""
    digest = hashlib.sha256(name.encode()).digest()
    return int.from_bytes(digest[:4], "little"), int.from_bytes(digest[4:8], "little")


class RunStreams:
    """Independent random generators, one per Monte Carlo run of a batch.

    Run ``r`` draws from ``SeedSequence([*base, r], spawn_key=purpose)``: ``base`` is what
    the runs belong to (the runner's seed and case key), ``purpose`` the hashed names of
    :meth:`child` streams.

    Parameters
    ----------
    base
        Entropy words common to the runs, e.g. ``(seed, *name_key(case))``.
    runs
        The run indices of the batch, in order.
    purpose
        Spawn key of a child stream (empty for the runs' own streams).
    """

    def __init__(self, base: Sequence[int], runs: Sequence[int], purpose: tuple[int, ...] = ()) -> None:
        self.base = tuple(int(b) for b in base)
        self.runs = tuple(int(r) for r in runs)
        if not self.runs:
            raise ConfigError("runs", "a batch needs at least one run (got 0 random streams)")
        self.purpose = tuple(purpose)
        self.generators = [
            np.random.default_rng(np.random.SeedSequence([*self.base, r], spawn_key=self.purpose)) for r in self.runs
        ]

    def __len__(self) -> int:
        return len(self.runs)

    def __repr__(self) -> str:
        return f"RunStreams(runs {self.runs[0]}..{self.runs[-1]})"

    def child(self, purpose: str) -> RunStreams:
        """Streams for one purpose (``"truth"``, ``"receiver"``...): each run's child is
        seeded from the run's seed and the purpose's name, so what one purpose draws never
        shifts another's numbers (candidates that consume different amounts of receiver
        noise still share their truth)."""
        return RunStreams(self.base, self.runs, self.purpose + name_key(purpose))

    def shared(self, purpose: str) -> np.random.Generator:
        """One generator common to every run of every batch (seeded from ``base`` and
        ``purpose`` only): for draws that belong to the case, not to a run, such as the
        training runs an oracle is tuned on."""
        return np.random.default_rng(
            np.random.SeedSequence(list(self.base), spawn_key=self.purpose + name_key(purpose) + (1,))
        )

    def _draw(
        self, size: Size, run_axis: int, one: Callable[[np.random.Generator, tuple[int, ...]], Any]
    ) -> np.ndarray:
        shape: tuple[int, ...] = (
            () if size is None else (int(size),) if isinstance(size, (int, np.integer)) else tuple(int(n) for n in size)
        )
        axis = run_axis % len(shape) if shape else 0
        if not shape or shape[axis] != len(self):
            raise ValueError(
                f"a draw of shape {shape} with the runs on axis {run_axis} needs "
                f"{len(self)} runs on that axis (one random stream per run)"
            )
        per_run = shape[:axis] + shape[axis + 1 :]
        return np.stack([np.asarray(one(g, per_run)) for g in self.generators], axis=axis)

    def standard_normal(self, size: Size, run_axis: int = 0) -> np.ndarray:
        """Standard normal draws of ``size``; axis ``run_axis`` indexes the runs."""
        return self._draw(size, run_axis, lambda g, s: g.standard_normal(s))

    def uniform(self, low: float = 0.0, high: float = 1.0, size: Size = None, run_axis: int = 0) -> np.ndarray:
        """Uniform draws on ``[low, high)`` (scalar bounds)."""
        return self._draw(size, run_axis, lambda g, s: g.uniform(low, high, s))

    def integers(self, low: int, high: int | None = None, size: Size = None, run_axis: int = 0) -> np.ndarray:
        """Integers on ``[low, high)`` (scalar bounds), as ``Generator.integers``."""
        return self._draw(size, run_axis, lambda g, s: g.integers(low, high, s))

    def random(self, size: Size = None, run_axis: int = 0) -> np.ndarray:
        """Uniform draws on ``[0, 1)``."""
        return self._draw(size, run_axis, lambda g, s: g.random(s))

    def choice(self, a: Any, size: Size = None, run_axis: int = 0) -> np.ndarray:
        """Draws from ``a`` with replacement, as ``Generator.choice``."""
        return self._draw(size, run_axis, lambda g, s: g.choice(a, s))


def run_streams(seed: int, key: Sequence[int], runs: Sequence[int]) -> RunStreams:
    """The streams of runs ``runs``: run ``r`` from ``SeedSequence([seed, *key, r])``.

    ``key`` identifies what the runs belong to (the comparison runner uses the case's
    :func:`name_key`), so the same run of the same case gets the same numbers in every
    batch, executor and resume.
    """
    return RunStreams((int(seed), *map(int, key)), runs)


def as_run_streams(rng: np.random.Generator | RunStreams | int, runs: int) -> RunStreams:
    """``rng`` as per-run streams: ``RunStreams`` as given (checked against ``runs``), an int
    as a seed, a ``Generator`` by drawing a seed from it (runs ``0 .. runs-1``)."""
    if isinstance(rng, RunStreams):
        if len(rng) != runs:
            raise ValueError(f"{len(rng)} random streams given for a batch of {runs} runs")
        return rng
    if runs < 1:
        raise ConfigError("runs", f"a batch needs at least one run (got {runs})")
    if isinstance(rng, (int, np.integer)) and not isinstance(rng, bool):
        return run_streams(int(rng), (), range(runs))
    if isinstance(rng, np.random.Generator):
        return run_streams(int(rng.integers(0, 2**63)), (), range(runs))
    raise TypeError(f"expected a numpy Generator, RunStreams or an int seed, got {type(rng).__name__}")


# -- draws from either kind, the runs on a named axis ----------------------------------------


def child(rng: Any, purpose: str) -> Any:
    """``rng.child(purpose)`` for :class:`RunStreams`; a plain generator is used as it is
    (there are no per-run streams to split)."""
    return rng.child(purpose) if isinstance(rng, RunStreams) else rng


def standard_normal(rng: Any, size: Size, run_axis: int = 0) -> np.ndarray:
    """``rng.standard_normal(size)``; with :class:`RunStreams`, axis ``run_axis`` holds the runs."""
    if isinstance(rng, RunStreams):
        return rng.standard_normal(size, run_axis=run_axis)
    out: np.ndarray = rng.standard_normal(size)
    return out


def uniform(rng: Any, low: float, high: float, size: Size, run_axis: int = 0) -> np.ndarray:
    """``rng.uniform(low, high, size)``; with :class:`RunStreams`, axis ``run_axis`` holds the runs."""
    if isinstance(rng, RunStreams):
        return rng.uniform(low, high, size, run_axis=run_axis)
    out: np.ndarray = rng.uniform(low, high, size)
    return out


def integers(rng: Any, low: int, high: int | None, size: Size, run_axis: int = 0) -> np.ndarray:
    """``rng.integers(low, high, size)``; with :class:`RunStreams`, axis ``run_axis`` holds the runs."""
    if isinstance(rng, RunStreams):
        return rng.integers(low, high, size, run_axis=run_axis)
    out: np.ndarray = rng.integers(low, high, size)
    return out


def random(rng: Any, size: Size, run_axis: int = 0) -> np.ndarray:
    """``rng.random(size)``; with :class:`RunStreams`, axis ``run_axis`` holds the runs."""
    if isinstance(rng, RunStreams):
        return rng.random(size, run_axis=run_axis)
    out: np.ndarray = rng.random(size)
    return out


def choice(rng: Any, a: Any, size: Size, run_axis: int = 0) -> np.ndarray:
    """``rng.choice(a, size)``; with :class:`RunStreams`, axis ``run_axis`` holds the runs."""
    if isinstance(rng, RunStreams):
        return rng.choice(a, size, run_axis=run_axis)
    out: np.ndarray = rng.choice(a, size)
    return out
