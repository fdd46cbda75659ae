"""gnssframework: build, combine and compare GNSS tracking and estimation filters.

>>> import gnssframework as gf
>>> "ukf" in gf.registry.names("estimator")
True
"""

from importlib.metadata import PackageNotFoundError, version

from . import errors, registry
from .errors import (
    ConfigError,
    DataFileError,
    GnssFrameworkError,
    InvalidMeasurementError,
    NotPositiveDefiniteError,
    NumericalError,
    PluginError,
    WorkerError,
)
from .estimation import (
    AdaptationStep,
    AdapterRun,
    Augmentation,
    AugmentedProblem,
    Estimator,
    FilterResult,
    Gaussian,
    LinearModel,
    NoiseAdapter,
    NonlinearModel,
    SigmaPointEstimator,
    Update,
    filter_sequence,
)
from .hookspecs import hookimpl
from .interfaces import ChannelFilter, Discriminator, NavFilter
from .plugin import Plugin, PluginParams
from .signal import Correlators

try:
    __version__ = version("gnssframework")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0"

__all__ = [
    "AdaptationStep",
    "AdapterRun",
    "Augmentation",
    "AugmentedProblem",
    "ChannelFilter",
    "ConfigError",
    "Correlators",
    "DataFileError",
    "Discriminator",
    "Estimator",
    "FilterResult",
    "Gaussian",
    "GnssFrameworkError",
    "InvalidMeasurementError",
    "LinearModel",
    "NavFilter",
    "NoiseAdapter",
    "NonlinearModel",
    "NotPositiveDefiniteError",
    "NumericalError",
    "Plugin",
    "PluginError",
    "PluginParams",
    "SigmaPointEstimator",
    "Update",
    "WorkerError",
    "errors",
    "filter_sequence",
    "hookimpl",
    "registry",
]
