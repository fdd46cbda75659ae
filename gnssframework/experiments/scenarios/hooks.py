"""The core's scenario kinds, registered through the ``register_scenario`` hook like any
third-party scenario (the registry loads this module before the entry points).

Importing the kinds here, not in the package's ``__init__``, keeps the arrows one way:
each kind imports the base classes of `gnssframework.experiments.scenarios`, and only
this module (loaded by `gnssframework.experiments`) imports the kinds."""

from __future__ import annotations

from ...hookspecs import Register, hookimpl
from . import SCENARIOS, carrier_smoothing, deep_integration, multipath, scintillation, vector_tracking  # noqa: F401


@hookimpl
def register_scenario(register: Register) -> None:
    for cls in SCENARIOS.values():
        register(cls)
