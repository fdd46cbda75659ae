"""The plugin registry.

Plugins are discovered through the ``gnssframework`` entry-point group (the built-ins
and the core's own scenario kinds too) and register their classes with pluggy hooks ``register_<kind>(register)``::

    import gnssframework as gf
    gf.registry.kinds()                       # ["augmentation", "channel_filter", ...]
    gf.registry.names("estimator")            # ["ckf", "ekf", "kf", "svd-ckf", "ukf"]
    ukf = gf.registry.create("estimator", "ukf", alpha=0.01, beta=2.0, kappa=0.0)

Loading is robust: a plugin that fails to import or to register is recorded in
``failures`` (distribution, entry point, exception) and the others still load.

A plugin package need not list its classes in hooks: `plugin_hooks` makes the
``register_<kind>`` hooks of every plugin class its modules define, so adding a plugin
is writing its class (the built-in plugins register this way)::

    from gnssframework.registry import plugin_hooks, submodules

    globals().update(plugin_hooks(*submodules(__name__, __path__)))
"""

from __future__ import annotations

import importlib
import importlib.metadata as md
import pkgutil
import threading
import types
from dataclasses import dataclass
from typing import Any
from collections.abc import Callable, Iterable

import pluggy

from . import hookspecs
from .hookspecs import Register, hookimpl
from .errors import ConfigError, PluginError
from .suggest import did_you_mean
from .estimation.adaptation import Augmentation, NoiseAdapter
from .estimation.estimator import Estimator
from .estimation.robust import RobustUpdate
from .interfaces import ChannelFilter, Discriminator, NavFilter
from .plugin_docs import parameter_table
from .signal.cn0_estimator import CN0Estimator
from .signal.registered import Signal
from .signal.spec import SignalSpec

__all__ = [
    "ENTRY_POINT_GROUP",
    "PluginInfo",
    "LoadFailure",
    "kinds",
    "names",
    "get",
    "create",
    "describe",
    "failures",
    "register_module",
    "register_kind",
    "base_class",
    "reload",
    "defined_plugins",
    "plugin_hooks",
    "submodules",
    "signal_spec",
]

ENTRY_POINT_GROUP = "gnssframework"

#: The class every plugin of a kind derives from. A kind whose base lives in this layer or
#: below is written here; a higher layer that owns a kind's base (the experiments' metrics
#: and scenarios, the receiver's sample sources and acquisitions) declares it with
#: `register_kind` where the base is defined, so this module never reaches up to it. A
#: plugin of such a kind imports its base, so the base is declared before the plugin
#: registers.
BASES: dict[str, type] = {
    "estimator": Estimator,
    "noise_adapter": NoiseAdapter,
    "augmentation": Augmentation,
    "discriminator": Discriminator,
    "channel_filter": ChannelFilter,
    "nav_filter": NavFilter,
    "signal": Signal,
    "cn0_estimator": CN0Estimator,
    "robust_update": RobustUpdate,
}


def register_kind(kind: str, base: type) -> type:
    """Declare ``base`` as the class every plugin of ``kind`` derives from; returns ``base``.

    Called by the module that defines ``base``, right after it (``registry.register_kind(
    "scenario", Scenario)``): the layer that owns a kind registers it, the registry imports
    nothing above itself. ``kind`` needs its ``register_<kind>`` hook in `hookspecs`.

    Raises
    ------
    PluginError
        For a kind without a hook, a base that is not a class, or a second, different base
        for a kind (a module imported again under the same name re-declares its own base).
    """
    if kind not in hookspecs.KINDS:
        raise PluginError(
            f"plugin kind {kind!r} has no register_{kind} hook in gnssframework.hookspecs; "
            f"kinds: {', '.join(sorted(hookspecs.KINDS))}"
        )
    if not isinstance(base, type):
        raise PluginError(f"the base of plugin kind {kind!r} must be a class, got {base!r}")
    known = BASES.get(kind)
    if known is not None and known is not base and _qualified(known) != _qualified(base):
        raise PluginError(f"plugin kind {kind!r} already has the base {_qualified(known)}; refused {_qualified(base)}")
    BASES[kind] = base
    return base


def _qualified(cls: type) -> str:
    return f"{cls.__module__}.{cls.__qualname__}"


def base_class(kind: str) -> type | None:
    """The class every plugin of ``kind`` derives from (``None`` while the module that
    declares it with `register_kind` has not been imported)."""
    return BASES.get(kind)


def _name_attribute(kind: str) -> str:
    return "kind" if kind == "scenario" else "name"


def plugin_name(kind: str, cls: type) -> str:
    """A plugin class's registry name (a scenario's is its ``kind`` attribute)."""
    return str(getattr(cls, _name_attribute(kind), "") or "")


def defined_plugins(*modules: types.ModuleType) -> dict[str, list[type]]:
    """The plugin classes ``modules`` define, by kind, in the order they are defined.

    A plugin class is one the module itself defines (not one it imports) that derives
    from a kind's base class (`BASES`, `register_kind`) and names itself: its own ``name`` (a scenario's
    own ``kind``) in its class body. A shared base without a name of its own (a helper
    such as an abstract code discriminator) is not a plugin.

    Raises
    ------
    PluginError
        For a named class that derives from the bases of two kinds.
    """
    bases = {kind: base_class(kind) for kind in hookspecs.KINDS}
    out: dict[str, list[type]] = {}
    for module in modules:
        for cls in vars(module).values():
            if not isinstance(cls, type) or cls.__module__ != module.__name__:
                continue
            kinds = [
                k
                for k, base in bases.items()
                if base is not None and issubclass(cls, base) and _name_attribute(k) in vars(cls)
            ]
            if len(kinds) > 1:
                raise PluginError(
                    f"{module.__name__}.{cls.__name__} derives from the bases of {', '.join(kinds)}; "
                    "a plugin class has one kind"
                )
            if kinds:
                out.setdefault(kinds[0], []).append(cls)
    return out


def _register_hook(kind: str, classes: Iterable[type]) -> Callable[[Register], None]:
    classes = tuple(classes)

    def hook(register: Register) -> None:
        for cls in classes:
            register(cls)

    hook.__name__ = hook.__qualname__ = f"register_{kind}"
    return hookimpl(hook)


def plugin_hooks(*modules: types.ModuleType) -> dict[str, Callable[[Register], None]]:
    """``register_<kind>`` hook implementations registering every plugin class that
    ``modules`` define (`defined_plugins`), for a plugin package's entry-point module:
    ``globals().update(plugin_hooks(...))``. A kind none of them defines gets no hook."""
    return {f"register_{kind}": _register_hook(kind, classes) for kind, classes in defined_plugins(*modules).items()}


def submodules(package: str, path: Iterable[str]) -> list[types.ModuleType]:
    """Every module of a package (``__name__`` and ``__path__`` of its ``__init__``),
    imported, sorted by name: a new module of the package needs no list to be edited."""
    return [
        importlib.import_module(f"{package}.{info.name}")
        for info in sorted(pkgutil.iter_modules(path), key=lambda i: i.name)
    ]


@dataclass(frozen=True)
class PluginInfo:
    """What ``gnssframework plugins`` lists for one plugin."""

    kind: str
    name: str
    description: str
    distribution: str
    version: str
    cls: type


@dataclass(frozen=True)
class LoadFailure:
    """A plugin that could not be loaded or registered."""

    distribution: str
    entry_point: str
    error: str

    def __str__(self) -> str:
        return f"{self.distribution} (entry point {self.entry_point!r}): {self.error}"


class _Registry:
    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._loaded = False
        self._loading: tuple[int, str] | None = None  # (thread, entry point) while loading
        self._plugins: dict[str, dict[str, PluginInfo]] = {k: {} for k in hookspecs.KINDS}
        self._failures: list[LoadFailure] = []
        self._pm = pluggy.PluginManager(ENTRY_POINT_GROUP)
        self._pm.add_hookspecs(hookspecs)

    # -- loading --------------------------------------------------------------------
    def ensure_loaded(self) -> None:
        if self._loaded:
            return
        if self._loading is not None and self._loading[0] == threading.get_ident():
            # A plugin module asking the registry while it is imported by entry point would
            # wait on the lock its own loading holds: refuse, and the loader records it.
            raise PluginError(
                f"entry point {self._loading[1]!r} looked the registry up while being loaded; "
                "look plugins up when they are used, not at import"
            )
        with self._lock:
            if self._loaded:
                return
            # The core's own hooks (its scenario kinds) come through this group too: one path.
            for ep in md.entry_points(group=ENTRY_POINT_GROUP):
                dist = ep.dist.name if ep.dist is not None else "unknown"
                version = ep.dist.version if ep.dist is not None else ""
                self._loading = (threading.get_ident(), ep.name)
                try:
                    module = ep.load()
                    self._add_module(module, ep.name, dist, version)
                except Exception as exc:  # noqa: BLE001 - any plugin error must not stop the rest
                    self._failures.append(LoadFailure(dist, ep.name, f"{type(exc).__name__}: {exc}"))
                finally:
                    self._loading = None
            self._loaded = True

    def _add_module(self, module: Any, ep_name: str, dist: str, version: str) -> None:
        plugin_name = f"{dist}:{ep_name}"
        if self._pm.is_registered(module) or self._pm.has_plugin(plugin_name):
            return
        self._pm.register(module, name=plugin_name)
        for kind in hookspecs.KINDS:
            caller = getattr(self._pm.hook, f"register_{kind}")
            for impl in caller.get_hookimpls():
                if impl.plugin_name != plugin_name:
                    continue
                try:
                    impl.function(register=lambda cls, _k=kind: self._add(_k, cls, dist, version))
                except Exception as exc:  # noqa: BLE001
                    self._failures.append(
                        LoadFailure(dist, ep_name, f"register_{kind} failed: {type(exc).__name__}: {exc}")
                    )

    def _add(self, kind: str, cls: type, dist: str, version: str) -> None:
        base = base_class(kind)
        if base is None:  # a class of the kind would have imported its base, declaring it
            raise PluginError(
                f"{cls!r} registered as {kind}, a kind whose base class is not declared "
                f"(registry.register_kind({kind!r}, Base) where Base is defined); "
                "it cannot be one of its plugins"
            )
        if not isinstance(cls, type) or not issubclass(cls, base):
            raise PluginError(
                f"{cls!r} registered as {kind} is not a subclass of {getattr(base, '__name__', 'a class')}"
            )
        name = plugin_name(kind, cls)
        if not name:
            raise PluginError(f"{cls.__name__} registered as {kind} has no `{_name_attribute(kind)}`")
        missing = sorted(getattr(cls, "__abstractmethods__", ()))
        if missing:
            raise PluginError(
                f"{kind} {name!r} ({cls.__name__}) leaves abstract methods unimplemented: {', '.join(missing)}"
            )
        known = self._plugins[kind].get(name)
        if known is not None and known.cls is not cls:
            raise PluginError(f"{kind} {name!r} is already registered by {known.distribution}")
        _document_parameters(cls)
        text = getattr(cls, "description", "") or (cls.__doc__ or "")
        self._plugins[kind][name] = PluginInfo(
            kind, name, text.strip().splitlines()[0] if text.strip() else "", dist, version, cls
        )

    # -- queries --------------------------------------------------------------------
    def check_kind(self, kind: str) -> None:
        if kind not in self._plugins:
            raise ConfigError("kind", f"unknown plugin kind {kind!r}; allowed: {', '.join(sorted(self._plugins))}")

    def get(self, kind: str, name: str) -> type[Any]:
        self.ensure_loaded()
        self.check_kind(kind)
        try:
            return self._plugins[kind][name].cls
        except KeyError:
            known = sorted(self._plugins[kind])
            hint = did_you_mean(name, known, cutoff=0.4)
            raise ConfigError(kind, f"unknown {kind} {name!r}; known: {', '.join(known) or '(none)'}{hint}") from None


_TABLE_MARK = "Parameter table (generated from ``Params``)"


def _document_parameters(cls: type) -> None:
    """Append the parameter table to the class docstring, so ``help(cls)`` shows it."""
    params = getattr(cls, "Params", None)
    doc = cls.__dict__.get("__doc__") or ""
    if _TABLE_MARK in doc or not (isinstance(params, type) and hasattr(params, "model_fields")):
        return
    try:
        cls.__doc__ = f"{doc.rstrip()}\n\n{_TABLE_MARK}\n\n{parameter_table(params)}\n"
    except (AttributeError, TypeError):  # a class whose __doc__ cannot be set keeps its own
        pass


_REGISTRY = _Registry()


def kinds() -> list[str]:
    """The plugin kinds, sorted."""
    return sorted(hookspecs.KINDS)


def names(kind: str) -> list[str]:
    """Registered plugin names of ``kind``, sorted."""
    _REGISTRY.ensure_loaded()
    _REGISTRY.check_kind(kind)
    return sorted(_REGISTRY._plugins[kind])


def get(kind: str, name: str) -> type[Any]:
    """The plugin class registered as ``kind`` / ``name`` (a subclass of the kind's base,
    `base_class`; typed ``type[Any]`` since the registry holds every kind's classes: a
    caller states the one it expects, ``cls: type[Scenario] = get("scenario", name)``).

    Raises
    ------
    ConfigError
        For an unknown kind or name, listing the known ones and the closest match.
    """
    return _REGISTRY.get(kind, name)


def create(kind: str, name: str, *positional: Any, **params: Any) -> Any:
    """Instantiate a plugin, validating ``params`` with its pydantic model.

    Raises
    ------
    ConfigError
        Unknown kind or name (with the known names and the closest one), a bad
        parameter (naming it and what it allows), or a parameter given by position.
    """
    if positional:
        fields = ", ".join(get(kind, name).Params.model_fields) or "(none)"
        raise ConfigError(
            f"{kind} {name!r}",
            f"parameters are keywords (create({kind!r}, {name!r}, field=value)), "
            f"got {len(positional)} by position: {', '.join(repr(p) for p in positional)[:60]}; "
            f"its parameters: {fields}",
        )
    return get(kind, name)(**params)


def describe() -> list[PluginInfo]:
    """Every registered plugin, sorted by kind then name."""
    _REGISTRY.ensure_loaded()
    return [info for kind in kinds() for _, info in sorted(_REGISTRY._plugins[kind].items())]


def failures() -> list[LoadFailure]:
    """Plugins that failed to import or register."""
    _REGISTRY.ensure_loaded()
    return list(_REGISTRY._failures)


def register_module(module: types.ModuleType | Any, name: str | None = None, distribution: str = "local") -> None:
    """Register a plugin module (or object with hook implementations) at run time.

    Useful in notebooks and tests; packages should use the entry-point group instead.
    """
    _REGISTRY.ensure_loaded()
    with _REGISTRY._lock:
        _REGISTRY._add_module(module, name or str(getattr(module, "__name__", repr(module))), distribution, "")


def reload() -> None:
    """Forget everything and rediscover the entry points (after installing a plugin)."""
    global _REGISTRY
    _REGISTRY = _Registry()


def signal_spec(name: str) -> SignalSpec:
    """The description of the registered signal ``name`` (``"gps-l1ca"``).

    Raises
    ------
    ConfigError
        For an unknown signal, listing the known ones and the closest match.
    """
    spec: SignalSpec = get("signal", name).spec
    return spec
