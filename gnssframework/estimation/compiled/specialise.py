"""Helpers that compile the kernels: serial/parallel twins and size-specialised twins.

A twin is a copy of a plain Python function with its own qualified name (so its numba
disk cache entry is its own) and, for a specialised twin, its own globals: numba freezes
a global's value when it compiles, so a twin whose ``_FIXED_N``/``_FIXED_M``/``_FIXED_K``
is a size, or whose helper names point at helpers specialised to that size, compiles
with the sizes as constants (LLVM then unrolls and keeps in registers what the generic
code indexes at run time) and the same arithmetic in the same order (bitwise the same).
"""

from __future__ import annotations

import types as _types

from ...backend import HAVE_NUMBA

if HAVE_NUMBA:
    import numba
    from numba import prange
else:  # pragma: no cover - exercised only where numba is missing
    numba = None
    prange = range

__all__ = ["HAVE_NUMBA", "prange", "twin", "with_globals", "jit", "step_jit", "jit_pair"]


def twin(fn, suffix: str):
    """A copy of ``fn`` with its own qualified name, so its disk cache entry is its own."""
    twin = _types.FunctionType(fn.__code__, fn.__globals__, fn.__name__ + suffix, fn.__defaults__, fn.__closure__)
    twin.__qualname__ = fn.__qualname__ + suffix
    return twin


def with_globals(fn, suffix: str, **overrides):
    """A twin of the plain function ``fn`` whose globals are its module's with
    ``overrides`` (a size constant, or a helper's name bound to its specialised twin;
    see the module docstring). The suffix gives the twin its own disk cache entry."""
    env = dict(fn.__globals__)
    env.update(overrides)
    twin = _types.FunctionType(fn.__code__, env, fn.__name__ + suffix, fn.__defaults__, fn.__closure__)
    twin.__qualname__ = fn.__qualname__ + suffix
    twin.__module__ = fn.__module__
    return twin


def jit(fn):
    if not HAVE_NUMBA:
        return fn
    return numba.njit(cache=True, fastmath=False, nogil=True)(fn)


def step_jit(fn):
    """``fn`` compiled as a step of a driver: numba inlines its IR into each driver that
    calls it (``inline="always"``), so LLVM optimises the step with the driver's own size
    constants and operands. Steps compiled separately and linked as calls (plain
    ``njit``, cached or not) measured 13-25 % slower on the 5x6 fused update; inlined,
    2-4 % (docs/benchmarks.md)."""
    if not HAVE_NUMBA:
        return fn
    return numba.njit(inline="always", nogil=True)(fn)


def jit_pair(fn):
    """(serial, parallel) compiled versions of a batch driver that loops with prange."""
    if not HAVE_NUMBA:
        return fn, fn
    serial = numba.njit(cache=True, nogil=True)(twin(fn, "_serial"))
    parallel = numba.njit(cache=True, nogil=True, parallel=True)(twin(fn, "_parallel"))
    return serial, parallel

