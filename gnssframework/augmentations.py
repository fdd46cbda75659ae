"""The registered ``augmentation`` plugins as classes: ``gnssframework.augmentations.<Name>(**params)``
(see `gnssframework.plugin_classes`)."""

from .plugin_classes import kind_module

__getattr__, __dir__ = kind_module("augmentation", __name__)
