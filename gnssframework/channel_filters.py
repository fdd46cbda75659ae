"""The registered ``channel_filter`` plugins as classes: ``gnssframework.channel_filters.<Name>(**params)``
(see `gnssframework.plugin_classes`)."""

from .plugin_classes import kind_module

__getattr__, __dir__ = kind_module("channel_filter", __name__)
