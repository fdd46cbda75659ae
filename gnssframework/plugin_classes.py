"""Plugins as typed classes by kind: ``gnssframework.estimators.UKF(alpha=0.5)``.

Each kind module (`gnssframework.estimators`, `gnssframework.noise_adapters`...) looks its
attributes up in the registry when they are first read, so the core imports no plugin
package: whatever is registered (built-in or third-party) is there. An attribute is the
plugin's registry name in class style (`class_name`: ``"svd-ckf"`` -> ``SVDCKF``,
``"sage-husa"`` -> ``SageHusa``) or its Python class name (``UnscentedKalmanFilter``); it
is the registered class itself, whose signature lists its parameters, so
``UKF(alpha=0.5)`` is ``registry.create("estimator", "ukf", alpha=0.5)``.
"""

from __future__ import annotations

from typing import Any
from collections.abc import Callable

__all__ = ["class_name", "kind_module"]


def class_name(name: str) -> str:
    """A registry name in class style: parts of up to three characters upper-cased
    (acronyms), longer ones capitalised.

    Examples
    --------
    >>> class_name("ukf"), class_name("svd-ckf"), class_name("sage-husa"), class_name("colored-ar1")
    ('UKF', 'SVDCKF', 'SageHusa', 'ColoredAR1')
    """
    return "".join(p.upper() if len(p) <= 3 else p.capitalize() for p in name.replace("_", "-").split("-"))


def _classes(kind: str) -> dict[str, type]:
    from . import registry

    out: dict[str, type] = {}
    for name in registry.names(kind):
        cls = registry.get(kind, name)
        out.setdefault(class_name(name), cls)
        out.setdefault(cls.__name__, cls)
    return out


def kind_module(kind: str, module: str) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """``__getattr__`` and ``__dir__`` for the module ``module`` of plugin kind ``kind``."""

    def __getattr__(attribute: str) -> type:
        if attribute.startswith("__"):
            raise AttributeError(attribute)
        classes = _classes(kind)
        try:
            return classes[attribute]
        except KeyError:
            from .suggest import did_you_mean

            raise AttributeError(
                f"module {module!r} has no {kind} {attribute!r}; registered: "
                f"{', '.join(sorted(classes)) or '(none)'}{did_you_mean(attribute, classes)}"
            ) from None

    def __dir__() -> list[str]:
        return sorted(_classes(kind))

    return __getattr__, __dir__
