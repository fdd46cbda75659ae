"""The ``signal`` plugin kind: a ranging signal registers like any plugin.

A signal plugin is a class holding one `SignalSpec` (its ``spec``); its registry name is
the spec's. A third party adds a signal by writing the description, its code generator
and this class, and pointing the ``gnssframework`` entry-point group at the module::

    class QzssL1ca(Signal):
        spec = QZSS_L1CA
        name = QZSS_L1CA.name
        description = "QZSS L1 C/A (IS-QZSS-PNT)"

``gnssframework.registry.signal_spec(name)`` hands the description to the receiver's
generic blocks.
"""

from __future__ import annotations

from typing import Any, ClassVar

from ..errors import PluginError
from ..plugin import Plugin, PluginParams
from .spec import SignalSpec

__all__ = ["Signal", "SignalParams"]


class SignalParams(PluginParams):
    """The parameters of a signal (none)."""

    no_parameters: ClassVar[str] = "a signal is its description (carrier, code, chip rate, sub-carrier, symbols)"


class Signal(Plugin):
    """Plugin kind ``signal``: a class holding one signal description.

    Attributes
    ----------
    spec
        The `SignalSpec`; its ``name`` must be the plugin's ``name``.
    """

    kind = "signal"
    spec: ClassVar[SignalSpec]
    Params = SignalParams
    params: SignalParams  # self.params, as validated

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        spec = cls.__dict__.get("spec")
        name = cls.__dict__.get("name")
        if spec is not None and name is not None and spec.name != name:
            raise PluginError(f"{cls.__name__}: name {name!r} differs from its spec's name {spec.name!r}")
