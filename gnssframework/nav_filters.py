"""The registered ``nav_filter`` plugins as classes: ``gnssframework.nav_filters.<Name>(**params)``
(see `gnssframework.plugin_classes`)."""

from .plugin_classes import kind_module

__getattr__, __dir__ = kind_module("nav_filter", __name__)
