"""What a scenario can represent, checked when the config loads.

Two kinds of limit: the coherent interval T must be a whole number of the signal's code
periods between one period and one data symbol (1 to 20 ms for GPS L1 C/A, the default;
`coherent_time` makes the type for a `SignalSpec`; a scenario's parameter models check their
``coherent_time_s`` against their own ``signal`` through `SignalCoherentTime`), and one batch of runs must fit in a
stated memory budget. A scenario estimates its batch's memory from its epochs, runs and
channels (bytes per epoch, run and channel measured on the harnesses and rounded up;
``tests/experiments/test_limits.py`` holds each estimate above the measured peak), so a config that
would need tens of GiB is refused with the estimate before anything is allocated.
"""

from __future__ import annotations

import os
from typing import Annotated, Any, ClassVar

from pydantic import AfterValidator, BaseModel, Field, GetJsonSchemaHandler, field_validator
from pydantic.json_schema import JsonSchemaValue
from pydantic_core import PydanticKnownError

from ..errors import ConfigError
from ..signal.gps_l1ca import GPS_L1CA
from ..signal.spec import SignalSpec

__all__ = [
    "SignalCoherentTime",
    "coherent_time",
    "coherent_time_bounds",
    "MEMORY_BUDGET_ENV",
    "DEFAULT_MEMORY_BUDGET_GIB",
    "memory_budget_gib",
    "check_batch_memory",
]


def coherent_time_bounds(signal: SignalSpec = GPS_L1CA) -> tuple[float, float]:
    """Shortest and longest coherent interval of ``signal`` (s): one code period, and the
    longest a known symbol or overlay boundary allows (`SignalSpec.longest_coherent_s`:
    one data bit, 20 ms, on L1 C/A; a longer interval would integrate across bit edges)."""
    return signal.code_period_s, signal.longest_coherent_s


#: Environment variable that raises (or lowers) the per-batch memory budget, in GiB.
MEMORY_BUDGET_ENV = "GNSSFRAMEWORK_MEMORY_BUDGET_GIB"
DEFAULT_MEMORY_BUDGET_GIB = 8.0


#: How the error message names a signal's code where its registry name would read oddly.
_CODE_NAMES = {"gps-l1ca": "C/A"}


def _whole_code_periods(signal: SignalSpec):
    period_s = signal.code_period_s
    lo, hi = coherent_time_bounds(signal)
    what = _CODE_NAMES.get(signal.name, signal.name)

    def check(value: float) -> float:
        """Refuse an interval that is not a whole number of the signal's code periods."""
        periods = value / period_s
        if abs(periods - round(periods)) > 1e-9 * max(1.0, periods):
            raise ValueError(
                f"must be a whole multiple of the {period_s * 1e3:g} ms {what} code period, from {lo} "
                f"to {hi} s (got {value!r})"
            )
        return value

    return check


def coherent_time(signal: SignalSpec = GPS_L1CA):
    """The type of a coherent integration interval T (s) of ``signal``: whole code periods,
    from one period to `coherent_time_bounds`' longest."""
    lo, hi = coherent_time_bounds(signal)
    return Annotated[float, Field(ge=lo, le=hi), AfterValidator(_whole_code_periods(signal))]


class SignalCoherentTime(BaseModel):
    """Base of a parameter model whose ``coherent_time_s`` (T, s; None where a case takes its
    scenario's) must be whole code periods of the model's `signal`, from one period to
    `coherent_time_bounds`' longest: the checks and messages of `coherent_time`'s type,
    read off the class's own signal (a subclass for another signal sets ``signal``), and
    the bounds in the JSON schema (the config reference)."""

    #: The signal whose code periods T counts (the scenario's).
    signal: ClassVar[SignalSpec] = GPS_L1CA

    @field_validator("coherent_time_s", check_fields=False)
    @classmethod
    def _whole_code_periods_of_the_signal(cls, value: float | None) -> float | None:
        if value is None:
            return value
        lo, hi = coherent_time_bounds(cls.signal)
        if not value >= lo:
            raise PydanticKnownError("greater_than_equal", {"ge": lo})
        if not value <= hi:
            raise PydanticKnownError("less_than_equal", {"le": hi})
        out: float = _whole_code_periods(cls.signal)(value)
        return out

    @classmethod
    def __get_pydantic_json_schema__(cls, core_schema: Any, handler: GetJsonSchemaHandler) -> JsonSchemaValue:
        schema = handler(core_schema)
        field = handler.resolve_ref_schema(schema).get("properties", {}).get("coherent_time_s")
        if field is not None:
            lo, hi = coherent_time_bounds(cls.signal)
            for number in [field, *field.get("anyOf", [])]:
                if number.get("type") == "number":
                    number.update(minimum=lo, maximum=hi)
        return schema


def memory_budget_gib() -> float:
    """The per-batch memory budget in GiB (``GNSSFRAMEWORK_MEMORY_BUDGET_GIB``, default 8)."""
    text = os.environ.get(MEMORY_BUDGET_ENV, "")
    if not text:
        return DEFAULT_MEMORY_BUDGET_GIB
    try:
        budget = float(text)
    except ValueError:
        budget = float("nan")
    if not budget > 0 or budget == float("inf"):
        raise ConfigError(MEMORY_BUDGET_ENV, f"must be a positive number of GiB (got {text!r})")
    return budget


def check_batch_memory(estimate_bytes: float, field: str, what: str) -> None:
    """Refuse a batch whose estimated memory exceeds the budget.

    Parameters
    ----------
    estimate_bytes
        The batch's estimated peak memory in bytes.
    field
        Config field path the error names (the one that sets the batch's size).
    what
        The batch's size in words (``"1 batch of 5 runs x 30000 epochs x 8 channels"``).

    Raises
    ------
    ConfigError
        Naming ``field``, the estimate and the budget.
    """
    budget = memory_budget_gib()
    need_gib = estimate_bytes / 2**30
    if need_gib > budget:
        raise ConfigError(
            field,
            f"{what} needs about {need_gib:.3g} GiB, above the memory budget of {budget:g} GiB "
            f"per batch; use a longer coherent_time_s, a shorter duration_s or a smaller batch_size "
            f"(or set {MEMORY_BUDGET_ENV})",
        )
