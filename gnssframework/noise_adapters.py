"""The registered ``noise_adapter`` plugins as classes: ``gnssframework.noise_adapters.<Name>(**params)``
(see `gnssframework.plugin_classes`)."""

from .plugin_classes import kind_module

__getattr__, __dir__ = kind_module("noise_adapter", __name__)
