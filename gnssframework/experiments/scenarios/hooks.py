"""The core's scenario kinds, registered through the ``register_scenario`` hook like any
third-party scenario (the registry loads this module before the entry points).

Every module of this package is imported here, not in the package's ``__init__``: a
scenario kind is one module with ``@register_scenario``, found without a list to edit,
and the arrows stay one way (each kind imports the base classes of
`gnssframework.experiments.scenarios`; only this module, loaded by
`gnssframework.experiments`, imports the kinds)."""

from __future__ import annotations

import importlib
import pkgutil

from ...hookspecs import Register, hookimpl
from . import SCENARIOS, __name__ as _package, __path__ as _package_path

for _module in pkgutil.iter_modules(_package_path):
    if f"{_package}.{_module.name}" != __name__:
        importlib.import_module(f"{_package}.{_module.name}")


@hookimpl
def register_scenario(register: Register) -> None:
    for cls in SCENARIOS.values():
        register(cls)
