"""The library's exceptions.

Every failure a user can meet is one of these, with a message that says what to fix:
config errors name the field and the allowed values, data-file errors name the file and
line, numerical failures name the filter, the batch element and the step.
"""

from __future__ import annotations

from collections.abc import Sequence

__all__ = [
    "GnssFrameworkError",
    "ConfigError",
    "PluginError",
    "DataFileError",
    "NumericalError",
    "NotPositiveDefiniteError",
    "InvalidMeasurementError",
    "InvalidInitialStateError",
    "NonFiniteError",
    "InvalidInputError",
    "InvalidArgumentError",
    "WorkerError",
    "RunFailure",
    "GnssFrameworkWarning",
]


class GnssFrameworkError(Exception):
    """Base class of every exception raised by gnssframework."""


class GnssFrameworkWarning(UserWarning):
    """Base class of the library's warnings: a result that is computed but may mislead (the
    command line prints each as one ``warning:`` line)."""


class ConfigError(GnssFrameworkError):
    """A configuration or plugin parameter is invalid.

    Deliberately not a ``ValueError``: pydantic would turn a ``ValueError`` raised inside
    a validator into its own error and lose the field path this one carries.

    Parameters
    ----------
    field
        Dotted path of the offending field (``"candidates[0].estimator.alpha"``).
    message
        What is wrong and what is allowed.
    """

    def __init__(self, field: str, message: str) -> None:
        self.field = field
        self.detail = message
        super().__init__(f"{field}: {message}" if field else message)

    def __reduce__(self) -> tuple:
        # Rebuild from the constructor's arguments so the error crosses a process
        # boundary (ProcessPoolExecutor) with its message and field intact.
        return (type(self), (self.field, self.detail))


class PluginError(GnssFrameworkError):
    """A plugin could not be loaded or registered."""


class DataFileError(GnssFrameworkError, ValueError):
    """A data file (RINEX, NMEA, CSV) cannot be read; names the file and the line."""

    def __init__(self, path: str, line: int | None, message: str) -> None:
        self.path = str(path)
        self.line = line
        self.detail = message
        where = f"{self.path}:{line}" if line is not None else self.path
        super().__init__(f"{where}: {message}")

    def __reduce__(self) -> tuple:
        return (type(self), (self.path, self.line, self.detail))


class NumericalError(GnssFrameworkError, ArithmeticError):
    """A numerical failure inside a filter.

    Attributes
    ----------
    filter_name
        Registry name of the filter that failed (``"ckf"``).
    batch_indices
        Index tuples of every failing batch element (first one is in the message).
    step
        Time step of ``gnssframework.filter_sequence`` (``None`` for a lone call).
    """

    what = "numerical failure"

    def __init__(
        self,
        filter_name: str,
        batch_indices: Sequence[tuple[int, ...]],
        step: int | None = None,
        detail: str = "",
    ) -> None:
        self.filter_name = filter_name
        self.batch_indices = [tuple(int(i) for i in b) for b in batch_indices]
        self.step = step
        self.detail = detail
        super().__init__(self._message())

    def __reduce__(self) -> tuple:
        return (type(self), (self.filter_name, self.batch_indices, self.step, self.detail))

    def _message(self) -> str:
        first = self.batch_indices[0] if self.batch_indices else ()
        more = len(self.batch_indices) - 1
        where = f"batch element {first}" + (f" (and {more} more)" if more > 0 else "")
        when = f", step {self.step}" if self.step is not None else ""
        tail = f": {self.detail}" if self.detail else ""
        return f"{self.filter_name}: {self.what} at {where}{when}{tail}"

    def at_step(self, step: int) -> NumericalError:
        """Return a copy of this error that names the time step."""
        return type(self)(self.filter_name, self.batch_indices, step, self.detail)


class NotPositiveDefiniteError(NumericalError):
    """A covariance (state or innovation) is not positive definite or not finite."""

    what = "covariance is not positive definite"


class InvalidMeasurementError(NumericalError):
    """A measurement holds NaN or inf and was not declared missing."""

    what = "measurement is NaN or inf"


class InvalidInitialStateError(NumericalError):
    """The initial mean is NaN/inf, or the initial covariance is not finite, symmetric and
    positive definite; ``detail`` says which."""

    what = "invalid initial state"


class NonFiniteError(NumericalError):
    """A prediction or posterior became NaN or inf (an overflow); ``detail`` says which."""

    what = "result is NaN or inf"


class InvalidInputError(GnssFrameworkError, ValueError):
    """An array given to a filter has the wrong shape or length; names the filter and the input.

    Parameters
    ----------
    filter_name
        The filter that refused it (``"ukf"``).
    input_name
        The offending input (``"zs"``, ``"initial mean"``, ``"measurement z"``).
    message
        What is wrong and what is expected.
    """

    def __init__(self, filter_name: str, input_name: str, message: str) -> None:
        self.filter_name = filter_name
        self.input_name = input_name
        self.detail = message
        super().__init__(f"{filter_name}: {input_name}: {message}")

    def __reduce__(self) -> tuple:
        return (type(self), (self.filter_name, self.input_name, self.detail))


class InvalidArgumentError(GnssFrameworkError, TypeError):
    """A library call got the wrong kind of object (a string, None or a dict where an
    estimator, model, adapter or state is expected) or came out of order (a step before
    ``reset``); names the call, the argument and what to pass.

    Parameters
    ----------
    call
        The call that refused it (``"filter_sequence"``, ``"channel_filter 'hatch'"``).
    argument
        The offending argument (``"estimator"``, ``"initial"``) or method.
    message
        What is expected and what it got.
    """

    def __init__(self, call: str, argument: str, message: str) -> None:
        self.call = call
        self.argument = argument
        self.detail = message
        super().__init__(f"{call}: {argument}: {message}")

    def __reduce__(self) -> tuple:
        return (type(self), (self.call, self.argument, self.detail))


class WorkerError(GnssFrameworkError):
    """An exception raised in a worker process that could not travel back to the parent.

    The original exception's type, message and traceback are kept as text, so a failure
    in a worker never shows as a bare ``BrokenProcessPool``.

    Parameters
    ----------
    where
        What the worker was doing (``"case 'c45', candidate 'ckf', batch 0"``).
    message
        ``"TypeName: message"`` of the original exception.
    traceback_text
        Its formatted traceback in the worker.
    """

    def __init__(self, where: str, message: str, traceback_text: str = "") -> None:
        self.where = where
        self.detail = message
        self.traceback_text = traceback_text
        super().__init__(f"{where}: {message}")

    def __reduce__(self) -> tuple:
        return (type(self), (self.where, self.detail, self.traceback_text))


class RunFailure(GnssFrameworkError):
    """A library error raised while simulating one batch of a comparison, with where it
    happened: candidate, case, runs and sweep point, then the original one-line message
    (which names the filter, batch element and step of a numerical failure).

    Parameters
    ----------
    where
        ``"candidate 'ukf', case 'c45', runs 0-1"`` (and ``", sweep point cn0=30"``).
    message
        The original error's message.
    cause
        The original error's type name (``"NotPositiveDefiniteError"``).
    """

    def __init__(self, where: str, message: str, cause: str = "") -> None:
        self.where = where
        self.detail = message
        self.cause = cause
        super().__init__(f"{where}: {message}")

    def __reduce__(self) -> tuple:
        return (type(self), (self.where, self.detail, self.cause))
