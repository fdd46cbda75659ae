"""The one switch between the compiled (numba) and the NumPy reference paths.

Every part of the framework that has a compiled twin (the estimation kernels, the
loop checks, the correlator, the strapdown loop, a model's compiled ``f``/``h``) asks
this module, and only this module, which path to take:

* ``GNSSFRAMEWORK_BACKEND=numpy`` (environment) or :func:`set_backend` selects the NumPy
  path everywhere; an object's own ``backend`` setting overrides it for that object
  (:func:`resolve_backend`). The default is ``"numba"`` when numba imports, else
  ``"numpy"``. The environment is read when this module is imported and again by
  ``set_backend(None)`` (as numba reads its own ``NUMBA_*`` variables), not on every
  step: each read cost about two microseconds, five times per epoch of a vector loop.
* :class:`BackendChoice` is how an engine takes the choice: once, when it is built
  (the engines in `gnssframework.estimation` derive from it), so a later
  :func:`set_backend` or a changed environment moves the objects built after it, never
  one midway through its run.
* :func:`jit` compiles a model function for the kernels (``nopython``, cached on disk,
  GIL released); without numba it returns the function unchanged.
* :func:`set_threads` / :func:`get_threads`: how many threads the kernels that split their
  work by channel (the tracking correlators) may use; by default the cores available.

It imports nothing of the framework but its errors, so every layer may use it.
"""

from __future__ import annotations

import os
from typing import TypeVar
from collections.abc import Callable

from .errors import ConfigError

__all__ = [
    "HAVE_NUMBA",
    "available",
    "get_backend",
    "set_backend",
    "resolve_backend",
    "compiled",
    "BackendChoice",
    "jit",
    "available_cores",
    "set_threads",
    "get_threads",
]

try:  # numba is a dependency, but the NumPy path must keep working without it.
    import numba

    HAVE_NUMBA = True
    if "NUMBA_THREADING_LAYER" not in os.environ:
        # GNU OpenMP (numba's default where present) aborts a process that forks after a
        # parallel kernel ran, which is what `gnssframework compare`'s process pool does.
        # The workqueue layer is fork-safe; parallel kernels run only from the main
        # thread (it is not thread-safe).
        numba.config.THREADING_LAYER = "workqueue"
except ImportError:  # pragma: no cover - exercised only where numba is missing
    numba = None
    HAVE_NUMBA = False

_BACKENDS = ("numba", "numpy")
_ENV = "GNSSFRAMEWORK_BACKEND"
_backend: str | None = None
#: ``$GNSSFRAMEWORK_BACKEND`` as last read (at import, or by ``set_backend(None)``).
_env_value: str | None = os.environ.get(_ENV)

F = TypeVar("F", bound=Callable)


def _check_backend(value: str, field: str) -> str:
    if value not in _BACKENDS:
        raise ConfigError(field, f"must be one of {list(_BACKENDS)}, got {value!r}")
    return value


def available() -> bool:
    """True where the compiled kernels can run (numba imports)."""
    return HAVE_NUMBA


def set_backend(value: str | None) -> None:
    """Select ``"numba"`` or ``"numpy"`` for the whole process (``None``: back to the
    default, reading ``$GNSSFRAMEWORK_BACKEND`` again)."""
    global _backend, _env_value
    if value is None:
        _env_value = os.environ.get(_ENV)
        _backend = None
    else:
        _backend = _check_backend(value, "backend")


def get_backend() -> str:
    """The process-wide backend: :func:`set_backend`, else ``$GNSSFRAMEWORK_BACKEND`` (as
    read at import or by ``set_backend(None)``), else numba (numpy where numba is missing)."""
    if _backend is not None:
        chosen = _backend
    else:
        env = _env_value
        chosen = _check_backend(env, _ENV) if env else "numba"
    return chosen if (chosen == "numpy" or HAVE_NUMBA) else "numpy"


def resolve_backend(override: str | None, field: str = "estimator.backend") -> str:
    """An object's own choice if set (``field`` names it in the error), else the
    process-wide one; numpy where numba is missing."""
    if override is None:
        return get_backend()
    _check_backend(override, field)
    return override if (override == "numpy" or HAVE_NUMBA) else "numpy"


def compiled(override: str | None = None) -> bool:
    """True where the compiled path applies (:func:`resolve_backend` is ``"numba"``)."""
    return resolve_backend(override) == "numba"


class BackendChoice:
    """An object that chooses its path once, when it is built.

    ``uses_compiled`` is fixed at construction from the process-wide backend
    (:func:`get_backend`); assigning ``backend`` (``"numba"``, ``"numpy"``, or ``None`` for
    the process-wide one at that moment) chooses again for this object alone. Neither
    :func:`set_backend` nor ``GNSSFRAMEWORK_BACKEND`` moves an object already built. The
    choice is made in ``__new__``, so a subclass's own ``__init__`` cannot skip it.
    """

    def __new__(cls, *args, **kwargs):
        self = super().__new__(cls)
        self._backend_override = None
        self._uses_compiled = compiled(None)
        return self

    @property
    def backend(self) -> str | None:
        """This object's own choice (``None``: the process-wide one when it was built)."""
        return self._backend_override

    @backend.setter
    def backend(self, value: str | None) -> None:
        self._uses_compiled = compiled(value)  # checks the value before keeping it
        self._backend_override = value

    @property
    def uses_compiled(self) -> bool:
        """True where this object runs the compiled path (fixed when it chose)."""
        return self._uses_compiled


def jit(fn: F) -> F:
    """Compile ``fn`` for the kernels: numba ``njit`` (cached on disk, no fastmath, GIL
    released), or ``fn`` itself where numba is missing. A model's compiled ``f``/``h``
    (`gnssframework.estimation.CompiledFunctions`) must be decorated with it."""
    if not HAVE_NUMBA:
        return fn
    return numba.njit(cache=True, fastmath=False, nogil=True)(fn)


_threads: int | None = None


def available_cores() -> int:
    """The CPUs this process may run on (its affinity mask where the OS has one)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - no affinity on this OS
        return max(1, os.cpu_count() or 1)


def set_threads(value: int | None) -> None:
    """Threads the compiled kernels that split their work by channel may use, for the whole
    process (the calling thread and ``value - 1`` helpers; ``None``: back to the default,
    `available_cores`). Results do not depend on it: each channel's arithmetic is the same
    whichever thread runs it."""
    global _threads
    if value is not None and (isinstance(value, bool) or int(value) != value or value < 1):
        raise ConfigError("threads", f"must be a whole number of at least 1, got {value!r}")
    _threads = None if value is None else int(value)


def get_threads() -> int:
    """The thread count of :func:`set_threads`, else the cores available to the process."""
    return _threads if _threads is not None else available_cores()
