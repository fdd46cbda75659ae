"""The core's scenario kinds, registered through the ``register_scenario`` hook like any
third-party scenario (the registry loads this module before the entry points)."""

from __future__ import annotations

from ...hookspecs import Register, hookimpl
from . import SCENARIOS


@hookimpl
def register_scenario(register: Register) -> None:
    for cls in SCENARIOS.values():
        register(cls)
