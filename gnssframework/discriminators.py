"""The registered ``discriminator`` plugins as classes: ``gnssframework.discriminators.<Name>(**params)``
(see `gnssframework.plugin_classes`)."""

from .plugin_classes import kind_module

__getattr__, __dir__ = kind_module("discriminator", __name__)
