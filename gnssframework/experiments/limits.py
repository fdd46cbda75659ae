"""What a scenario can represent, checked when the config loads.

Two kinds of limit: the coherent interval T must be a whole number of GPS L1 C/A code
periods (1 ms) between 1 and 20 ms (a data bit), and one batch of runs must fit in a
stated memory budget. A scenario estimates its batch's memory from its epochs, runs and
channels (bytes per epoch, run and channel measured on the harnesses and rounded up;
``tests/test_limits.py`` holds each estimate above the measured peak), so a config that
would need tens of GiB is refused with the estimate before anything is allocated.
"""

from __future__ import annotations

import os
from typing import Annotated

from pydantic import AfterValidator, Field

from ..errors import ConfigError
from ..signal.constants import CA_CODE_PERIOD_S

__all__ = ["CoherentTime", "MIN_COHERENT_TIME_S", "MAX_COHERENT_TIME_S", "MEMORY_BUDGET_ENV",
           "DEFAULT_MEMORY_BUDGET_GIB", "memory_budget_gib", "check_batch_memory"]

MIN_COHERENT_TIME_S = CA_CODE_PERIOD_S
#: One navigation data bit: a longer interval would integrate across bit edges.
MAX_COHERENT_TIME_S = 0.02
#: Environment variable that raises (or lowers) the per-batch memory budget, in GiB.
MEMORY_BUDGET_ENV = "GNSSFRAMEWORK_MEMORY_BUDGET_GIB"
DEFAULT_MEMORY_BUDGET_GIB = 8.0


def _whole_code_periods(value: float) -> float:
    """Refuse an interval that is not a whole number of 1 ms C/A code periods."""
    periods = value / CA_CODE_PERIOD_S
    if abs(periods - round(periods)) > 1e-9 * max(1.0, periods):
        raise ValueError(f"must be a whole multiple of the 1 ms C/A code period, from {MIN_COHERENT_TIME_S} to "
                         f"{MAX_COHERENT_TIME_S} s (got {value!r})")
    return value


#: A coherent integration interval T in seconds: whole code periods, 1 to 20 ms.
CoherentTime = Annotated[float, Field(ge=MIN_COHERENT_TIME_S, le=MAX_COHERENT_TIME_S),
                         AfterValidator(_whole_code_periods)]


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
        raise ConfigError(field, f"{what} needs about {need_gib:.3g} GiB, above the memory budget of {budget:g} GiB "
                          f"per batch; use a longer coherent_time_s, a shorter duration_s or a smaller batch_size "
                          f"(or set {MEMORY_BUDGET_ENV})")
