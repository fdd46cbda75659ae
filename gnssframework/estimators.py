"""The registered ``estimator`` plugins as classes: ``gnssframework.estimators.<Name>(**params)``
(see `gnssframework.plugin_classes`)."""

from .plugin_classes import kind_module

__getattr__, __dir__ = kind_module("estimator", __name__)
