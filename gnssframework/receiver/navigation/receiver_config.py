"""The receiver's choice of filters: a small TOML file, or the command's options.

``receive --config receiver.toml`` reads::

    [channel_filter]
    name = "iq-filter"
    params = { estimator = "ckf" }

    [nav_filter]
    name = "ekf-pv"
    params = { accel_psd = 0.5 }

(each also written as a bare name, ``nav_filter = "ekf-pv"``; either table may be left out).
Each is a plugin reference of the comparison configs' candidates
(`gnssframework.plugin_ref.ComponentRef`): the name is checked against the registry, the
parameters by the plugin's own model, and an error names the field's path
(``nav_filter.params.accel_psd``). ``--channel-filter``/``--nav-filter`` override the file.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from ... import registry
from ...errors import ConfigError
from ...io.text import read_toml
from ...plugin import validation_message
from ...plugin_ref import ComponentRef, PluginSpec
from ..channels.config import TrackingConfig
from .filtered import check_nav_filter

__all__ = ["ReceiverFilters", "load_receiver_config", "receiver_filters"]

_REF = "the {kind} plugin: its name, or {{ name, params }}"


class ReceiverFilters(BaseModel):
    """The channel filter of the tracking stages and the navigation filter of the fixes
    (None: the least-squares fix of each epoch alone)."""

    model_config = ConfigDict(extra="forbid")

    channel_filter: ComponentRef("channel_filter") | None = Field(None, description=_REF.format(kind="channel_filter"))
    nav_filter: ComponentRef("nav_filter") | None = Field(None, description=_REF.format(kind="nav_filter"))


def _check_params(spec: PluginSpec, where: str) -> None:
    """Create the plugin once so a bad parameter is refused before the run, its field
    continued from ``where`` (``nav_filter.params``: ``nav_filter.params.accel_psd``)."""
    try:
        spec.cls(**spec.params)
    except ConfigError as exc:
        own = f"{spec.kind} {spec.name!r}"
        if exc.field == own or exc.field.startswith((own + ".", own + "[")):
            raise ConfigError(f"{where}{exc.field[len(own) :]}", exc.detail) from None
        raise ConfigError(where, str(exc)) from None


def load_receiver_config(path: str | Path) -> ReceiverFilters:
    """Read and validate a receiver TOML file (see the module text).

    Raises
    ------
    DataFileError
        If the file is missing or not TOML (with the line).
    ConfigError
        For an unknown key, plugin name or parameter, naming its path.
    """
    path = Path(path)
    data = read_toml(path)
    try:
        config = ReceiverFilters.model_validate(data)
    except ValidationError as exc:
        raise validation_message(exc, model=ReceiverFilters) from None
    for kind in ("channel_filter", "nav_filter"):
        spec = getattr(config, kind)
        if spec is not None:
            if kind == "nav_filter":
                check_nav_filter(spec.name, "nav_filter.name")
            _check_params(spec, f"{kind}.params")
    return config


def receiver_filters(
    config: str | Path | None = None,
    channel_filter: str | None = None,
    channel_params: dict[str, Any] | None = None,
    nav_filter: str | None = None,
) -> ReceiverFilters:
    """The filters of a run: the file's, overridden by the options ``channel_filter``
    (with ``channel_params``) and ``nav_filter`` where given; the channel filter defaults
    to `TrackingConfig`'s, the nav filter to None (least squares).

    Raises
    ------
    ConfigError
        For an unknown or unfit name (field ``channel_filter``/``nav_filter``, the
        known names and the closest) or a bad parameter (``channel_params.<name>``).
    """
    chosen = load_receiver_config(config) if config is not None else ReceiverFilters()
    updates: dict[str, Any] = {}
    if channel_filter is not None or channel_params:
        name = channel_filter or (
            chosen.channel_filter.name
            if chosen.channel_filter
            else TrackingConfig.model_fields["channel_filter"].default
        )
        try:
            registry.get("channel_filter", name)
        except ConfigError as exc:
            raise ConfigError("channel_filter", exc.detail) from None
        spec = PluginSpec("channel_filter", name, dict(channel_params or {}))
        _check_params(spec, "channel_params")
        updates["channel_filter"] = spec
    if nav_filter is not None:
        check_nav_filter(nav_filter, "nav_filter")
        same = chosen.nav_filter is not None and chosen.nav_filter.name == nav_filter
        updates["nav_filter"] = chosen.nav_filter if same else PluginSpec("nav_filter", nav_filter, {})
    chosen = chosen.model_copy(update=updates)
    if chosen.channel_filter is None:  # the tracking stages' own default
        default = PluginSpec("channel_filter", TrackingConfig.model_fields["channel_filter"].default, {})
        chosen = chosen.model_copy(update={"channel_filter": default})
    return chosen
