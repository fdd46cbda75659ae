"""Stepping many channels' filters as one batch.

Channel filter plugins are batch-first: one reset with ``batch_shape (k,)`` steps ``k``
independent channels on ``(k,)``-shaped correlators, in one set of array operations.
Channels enter a stage (and so reset their filter) at different times, so the tracker
resets each channel's filter alone, with ``batch_shape (1,)``, and later merges it into
the batch of the channels in the same stage and coherent interval (`FilterBatch.join`),
or takes it out again (`FilterBatch.leave`) when the channel changes stage or is lost.

Merging needs to know which of a filter's arrays hold per-channel state. `batch_layout`
finds out once per filter configuration by probing: two filters reset with batch shapes
``(1,)`` and ``(2,)`` and stepped twice; an array that is ``(1, ...)`` in one and
``(2, ...)`` in the other is per-channel state, every other value is shared and must be
equal for two filters to merge. A filter whose state cannot be laid out so (or whose two
copies differ in structure, e.g. one has not stepped yet) is not merged: it steps alone.
"""

from __future__ import annotations

import functools
import numbers
import types
from typing import Any
from collections.abc import Callable

import numpy as np
from pydantic import BaseModel

__all__ = ["batch_layout", "FilterBatch", "flatten_state"]

_LEAF = (
    np.ndarray,
    numbers.Number,
    str,
    bytes,
    type(None),
    bool,
    np.generic,
    type,
    types.FunctionType,
    types.MethodType,
    types.BuiltinFunctionType,
    functools.partial,
)


def flatten_state(obj: Any) -> dict[tuple, Any] | None:
    """``{path: leaf}`` of an object's state (attributes, dict items, list/tuple items,
    recursively); ``None`` when an object is reached twice (a cycle, or an object shared
    between two attributes, which merging would part)."""
    out: dict[tuple, Any] = {}
    seen: set[int] = set()

    def walk(v: Any, path: tuple) -> bool:
        # A model's jitted f/h (numba dispatchers, recognised by their ``py_func``) are
        # leaves like plain functions: their internals are the compiler's, shared by all.
        if isinstance(v, _LEAF) or (callable(v) and hasattr(v, "py_func")):
            out[path] = v
            return True
        if id(v) in seen:
            return False
        seen.add(id(v))
        if isinstance(v, dict):
            out[path + ("<dict>",)] = tuple(v.keys())
            return all(walk(x, path + (("i", k),)) for k, x in v.items())
        if isinstance(v, (list, tuple)):
            out[path + ("<seq>",)] = (type(v), len(v))
            return all(walk(x, path + (("i", k),)) for k, x in enumerate(v))
        fields = getattr(v, "__dict__", None)
        if fields is None or isinstance(v, BaseModel):  # opaque, or pydantic settings: compared whole
            out[path] = v
            return True
        out[path + ("<type>",)] = type(v)
        return all(walk(x, path + (("a", k),)) for k, x in fields.items())

    return out if walk(obj, ()) else None


def _shape(v: Any) -> tuple[int, ...] | None:
    return v.shape if isinstance(v, np.ndarray) else None


def batch_layout(make: Callable[[tuple[int, ...]], Any], step: Callable[[Any, int], None]) -> frozenset | None:
    """The paths of a filter configuration's per-channel arrays, or ``None`` when its state
    does not split by channel. ``make(batch_shape)`` makes a reset filter, ``step(f, k)``
    steps it on ``k`` channels."""
    a, b = make((1,)), make((2,))
    for _ in range(2):
        step(a, 1)
        step(b, 2)
    fa, fb = flatten_state(a), flatten_state(b)
    if fa is None or fb is None or fa.keys() != fb.keys():
        return None
    paths = set()
    for p, va in fa.items():
        if p and p[-1][0] == "i" and isinstance(_get(a, p[:-1]), tuple) and _shape(va) is not None:
            return None  # an array inside a tuple cannot be replaced
        sa, sb = _shape(va), _shape(fb[p])
        if sa is not None and sb is not None and sa[:1] == (1,) and sb == (2,) + sa[1:]:
            paths.add(p)
        elif sa != sb or (sa is None and type(va) is not type(fb[p])):
            return None
    # A per-channel array whose memory another path also reaches (the same array, or a view
    # of it) would be parted by merging: such a filter steps alone.
    arrays = [(p, v) for p, v in fa.items() if isinstance(v, np.ndarray)]
    for p in paths:
        if any(q != p and np.shares_memory(fa[p], v) for q, v in arrays):
            return None
    return frozenset(paths)


def _get(obj: Any, path: tuple) -> Any:
    for kind, key in path:
        obj = obj[key] if kind == "i" else getattr(obj, key)
    return obj


def _set(obj: Any, path: tuple, value: Any) -> None:
    parent = _get(obj, path[:-1])
    kind, key = path[-1]
    if kind == "i":
        if isinstance(parent, tuple):
            raise TypeError("state inside a tuple cannot be merged")
        parent[key] = value
    else:
        object.__setattr__(parent, key, value)  # frozen dataclasses (Correlators) too


def _equal(a: Any, b: Any) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return (
            isinstance(a, np.ndarray)
            and isinstance(b, np.ndarray)
            and a.shape == b.shape
            and bool(np.array_equal(a, b))
        )
    if a is b:
        return True
    try:
        return bool(a == b)
    except Exception:  # noqa: BLE001 - incomparable values do not merge
        return False


class FilterBatch:
    """One filter stepping the channels at ``slots`` (its batch axis, in that order)."""

    def __init__(self, filt: Any, slot: int, paths: frozenset) -> None:
        self.filter = filt
        self.slots = [slot]
        self.paths = paths

    @staticmethod
    def fits(filt: Any, paths: frozenset) -> bool:
        """Whether ``filt`` (one channel) holds every per-channel array of ``paths``, ``(1, ...)``."""
        state = flatten_state(filt)
        return state is not None and all(
            p in state and _shape(state[p]) is not None and _shape(state[p])[:1] == (1,) for p in paths
        )

    def join(self, filt: Any, slot: int) -> bool:
        """Merge ``filt`` (one channel, ``batch_shape (1,)``) as the last member; ``False``
        (nothing changed) when its state differs from the batch's beyond the per-channel arrays."""
        mine, theirs = flatten_state(self.filter), flatten_state(filt)
        if mine is None or theirs is None or mine.keys() != theirs.keys() or not self.paths <= mine.keys():
            return False
        for p, v in mine.items():
            if p not in self.paths and p[-1] not in ("<type>", "<dict>", "<seq>") and not _equal(v, theirs[p]):
                return False
            if p[-1] in ("<type>", "<dict>", "<seq>") and v != theirs[p]:
                return False
            if p in self.paths and (
                _shape(theirs[p]) is None or _shape(theirs[p])[:1] != (1,) or _shape(v)[1:] != _shape(theirs[p])[1:]
            ):
                return False
        try:
            for p in self.paths:
                _set(self.filter, p, np.concatenate([mine[p], theirs[p]]))
        except TypeError:
            return False
        self.slots.append(slot)
        return True

    def leave(self, slot: int) -> None:
        """Take channel ``slot`` out of the batch."""
        keep = np.array([s != slot for s in self.slots])
        state = flatten_state(self.filter)
        for p in self.paths:
            _set(self.filter, p, state[p][keep])
        self.slots.remove(slot)
