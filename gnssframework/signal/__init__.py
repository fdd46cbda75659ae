"""Signal layer: correlators, codes, correlator models, IF samples."""

from .correlators import Correlators

__all__ = ["Correlators"]
