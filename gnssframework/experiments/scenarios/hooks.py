"""The core's scenario kinds, registered through the ``register_scenario`` hook like any
third-party scenario: this module is the ``scenarios`` entry point of the
``gnssframework`` group in ``pyproject.toml``, which the registry loads like any other.

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
