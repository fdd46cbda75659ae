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
    from numba.core import ir_utils
    from numba.core.compiler import CompilerBase, DefaultPassBuilder
    from numba.core.compiler_machinery import FunctionPass, register_pass
    from numba.core.typed_passes import NopythonTypeInference

    @register_pass(mutates_CFG=False, analysis_only=False)
    class _PropagateCopies(FunctionPass):
        """Replaces each use of a copy ``a = b`` by ``b`` where that is the same value.

        numba inlines a step (``inline="always"``) by binding each parameter to the
        caller's variable with such a copy, and lowers every copy of an array as a
        reference-count increment, with its decrement at the copy's last use. In a step
        with loops and early returns, numba's LLVM pass that prunes increment/decrement
        pairs cannot match them, so each inlined call paid two atomic operations per
        array argument per element (the sigma-point driver 27 increments and 58
        decrements against the single loop's 21 and 46, predict moments 15/32 against
        6/20; 5-18 % on the smallest kernels, docs/benchmarks.md). With the copies
        propagated (numba's own analysis, which its parallel pipeline runs too) the
        arguments are the caller's variables and the counts are the single loop's. The
        arithmetic is untouched (bitwise the same results)."""

        _name = "gnssframework_propagate_copies"

        def __init__(self):
            FunctionPass.__init__(self)

        def run_pass(self, state):
            blocks = state.func_ir.blocks
            in_copies, _ = ir_utils.copy_propagate(blocks, state.typemap)
            ir_utils.apply_copy_propagate(
                blocks, in_copies, ir_utils.get_name_var_table(blocks), state.typemap, state.calltypes
            )
            return True

    class _DriverCompiler(CompilerBase):
        """numba's nopython pipeline with `_PropagateCopies` after type inference (the
        drivers' pipeline: see `jit_pair`)."""

        def define_pipelines(self):
            pm = DefaultPassBuilder.define_nopython_pipeline(self.state)
            pm.add_pass_after(_PropagateCopies, NopythonTypeInference)
            pm.finalize()
            return [pm]
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
    ``njit``) run slower (docs/benchmarks.md)."""
    if not HAVE_NUMBA:
        return fn
    return numba.njit(inline="always", nogil=True)(fn)


def jit_pair(fn):
    """(serial, parallel) compiled versions of a batch driver that loops with prange,
    compiled with the inlined steps' argument copies propagated (`_PropagateCopies`)."""
    if not HAVE_NUMBA:
        return fn, fn
    serial = numba.njit(cache=True, nogil=True, pipeline_class=_DriverCompiler)(twin(fn, "_serial"))
    parallel = numba.njit(cache=True, nogil=True, parallel=True, pipeline_class=_DriverCompiler)(twin(fn, "_parallel"))
    return serial, parallel
