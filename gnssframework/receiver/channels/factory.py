"""A channel filter validated and built once per task, copied for every channel.

The sample receiver needs a fresh filter for every channel that enters a stage (its own
state from `reset`), and more for the probes of `batch.batch_layout`: a tracking run of a
few satellites asked the registry for the same filter 14-21 times, validating the same
parameters every time. A `FilterFactory` asks once: it builds one *prototype* (the
registry validates its parameters, the plugin's ``__init__`` runs) and gives every
channel a copy of it that has never been reset (`FilterFactory.new`: a deep copy that
shares the prototype's frozen parameter models and compiled functions, cheaper than a
validated build). A plugin whose prototype cannot be copied is built anew each time, as
before.

`StageFilters` holds the factories of a `TrackingConfig`'s stages (``pull-in``,
``track``, ``extended``): built once for a task (a command, a scenario's batch) and
handed down to the trackers it runs.
"""

from __future__ import annotations

import copy
import json
from typing import Any

from pydantic import BaseModel

from ... import registry
from ...errors import ConfigError
from ...interfaces import ChannelFilter
from ..engine.closers import NCO_COMMANDS
from .closure import ERROR_OUTPUTS
from .config import TrackingConfig

__all__ = ["FilterFactory", "StageFilters", "sample_filter_params", "supports", "STAGE_NAMES"]

#: The scalar stages whose filters a `StageFilters` holds.
STAGE_NAMES = ("pull-in", "track", "extended")


def supports(cls: type, *names: str) -> bool:
    """Whether channel filter class ``cls`` provides every output of ``names``."""
    return all(n in cls.provides for n in names)


def _shared_leaves(obj: Any) -> dict[int, Any]:
    """A `copy.deepcopy` memo that keeps ``obj``'s immutable parts shared: its pydantic
    models (plugin parameters are frozen) and compiled functions (numba dispatchers,
    recognised by ``py_func``: copying one would rebuild it)."""
    memo: dict[int, Any] = {}
    seen: set[int] = set()
    stack = [obj]
    while stack:
        v = stack.pop()
        if id(v) in seen or isinstance(v, type):
            continue
        seen.add(id(v))
        if isinstance(v, BaseModel) or (callable(v) and hasattr(v, "py_func")):
            memo[id(v)] = v
        elif isinstance(v, dict):
            stack.extend(v.values())
        elif isinstance(v, (list, tuple, set, frozenset)):
            stack.extend(v)
        elif hasattr(v, "__dict__"):
            stack.extend(vars(v).values())
    return memo


def _key(params: dict[str, Any]) -> str:
    return json.dumps(params, sort_keys=True, default=repr)


class FilterFactory:
    """One plugin configuration, validated and built once; `new` gives a fresh copy.

    Parameters
    ----------
    kind, name, params
        The registry reference (``params`` validated by the plugin's ``Params``).
    prototype
        An instance already built for this reference (e.g. a scenario's candidate
        plugin), never reset; built here when ``None``.
    """

    def __init__(self, kind: str, name: str, params: dict[str, Any] | None = None, *, prototype: Any = None) -> None:
        self.kind, self.name = kind, name
        self.params = dict(params or {})
        self.cls = registry.get(kind, name)
        self.prototype = registry.create(kind, name, **self.params) if prototype is None else prototype
        self._memo = _shared_leaves(self.prototype)
        try:  # a plugin holding something deepcopy cannot copy (a lock, a file) is built every time
            copy.deepcopy(self.prototype, dict(self._memo))
            self.copies = True
        except Exception:  # noqa: BLE001 - any failure: fall back to construction
            self.copies = False

    def new(self) -> Any:
        """A fresh instance (never reset) of the configuration."""
        if self.copies:
            return copy.deepcopy(self.prototype, dict(self._memo))
        return registry.create(self.kind, self.name, **self.params)


def sample_filter_params(name: str, params: dict[str, Any], *, pll_only: bool = False) -> dict[str, Any]:
    """The parameters of a channel filter that can track on samples, checked: it requires
    ``correlators`` and outputs NCO commands (`NCO_COMMANDS`) or errors
    (`closure.ERROR_OUTPUTS`); ``pll_only`` switches off its FLL assist where it has one
    (the ``extended`` stage)."""
    cls = registry.get("channel_filter", name)
    if "correlators" not in cls.requires or not (supports(cls, *NCO_COMMANDS) or supports(cls, *ERROR_OUTPUTS)):
        raise ConfigError(
            "channel_filter",
            f"{name!r} cannot track on samples: it must require 'correlators' and "
            f"provide {', '.join(NCO_COMMANDS)} or {', '.join(ERROR_OUTPUTS)}",
        )
    params = dict(params)
    if pll_only and "fll_bandwidth_hz" in cls.Params.model_fields:
        params["fll_bandwidth_hz"] = 0.0  # the PLL stage: no FLL assist
    return params


class StageFilters:
    """The channel filters of a `TrackingConfig`'s scalar stages, each configuration built
    once (two stages with the same filter and parameters share one factory).

    Parameters
    ----------
    config
        The stages' filters: ``pull_in_filter``/``pull_in_params`` for ``pull-in``,
        ``channel_filter``/``channel_params`` for ``track`` and, with the FLL assist off,
        for ``extended``.
    channel_filter
        Optionally the ``channel_filter`` already built (a candidate's plugin, never
        reset): the ``track`` stage's prototype.
    """

    def __init__(self, config: TrackingConfig, channel_filter: ChannelFilter | None = None) -> None:
        self.config = config
        made: dict[tuple, FilterFactory] = {}

        def factory(name: str, params: dict[str, Any], pll_only: bool, prototype=None) -> FilterFactory:
            checked = sample_filter_params(name, params, pll_only=pll_only)
            key = (name, _key(checked))
            if key not in made:  # built only for a configuration not seen yet
                made[key] = FilterFactory(
                    "channel_filter", name, checked, prototype=prototype if checked == dict(params) else None
                )
            return made[key]

        self.track = factory(config.channel_filter, config.channel_params, False, channel_filter)
        self.pull_in = factory(config.pull_in_filter, config.pull_in_params, False)
        self.extended = factory(config.channel_filter, config.channel_params, True)

    def factory(self, stage: str) -> FilterFactory:
        """The factory of ``stage`` (one of `STAGE_NAMES`)."""
        return {"pull-in": self.pull_in, "track": self.track, "extended": self.extended}[stage]

    def new(self, stage: str) -> ChannelFilter:
        """A fresh filter of ``stage``."""
        return self.factory(stage).new()
