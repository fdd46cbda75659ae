"""The core's scenario kinds, registered through the ``register_scenario`` hook like any
third-party scenario (the registry loads this module before the entry points, and adds
it by the same path as an entry point's module).

Every module of this package is imported here, not in the package's ``__init__``: a
scenario kind is one module with ``@register_scenario``, found without a list to edit,
and the arrows stay one way (each kind imports the base classes of
`gnssframework.experiments.scenarios`; only this module, loaded by the registry and by
`gnssframework.experiments`, imports the kinds)."""

from __future__ import annotations

from ...hookspecs import Register, hookimpl
from ...registry import submodules
from . import __name__ as _package, __path__ as _package_path, declared_scenarios

submodules(_package, _package_path)  # imports every kind (this module among them: already in sys.modules)


@hookimpl
def register_scenario(register: Register) -> None:
    for cls in declared_scenarios():
        register(cls)
