"""gnssframework: build, combine and compare GNSS tracking and estimation filters.

>>> import gnssframework as gf
>>> "ukf" in gf.registry.names("estimator")
True
"""

from importlib.metadata import PackageNotFoundError, version
from typing import Any

from . import errors, registry
from .errors import (
    ConfigError,
    DataFileError,
    GnssFrameworkError,
    InvalidArgumentError,
    InvalidInitialStateError,
    InvalidInputError,
    InvalidMeasurementError,
    NonFiniteError,
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
    FilterStep,
    FixedLagSmoother,
    Gaussian,
    LinearModel,
    NoiseAdapter,
    NonlinearModel,
    SigmaPointEstimator,
    SmoothedResult,
    Update,
    filter_sequence,
    fixed_lag_smooth,
    smooth,
)
from .hookspecs import hookimpl
from .interfaces import ChannelFilter, Discriminator, NavFilter, RunContext
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
    "FilterStep",
    "FixedLagSmoother",
    "Gaussian",
    "GnssFrameworkError",
    "InvalidArgumentError",
    "InvalidInitialStateError",
    "InvalidInputError",
    "InvalidMeasurementError",
    "LinearModel",
    "NavFilter",
    "NoiseAdapter",
    "NonFiniteError",
    "NonlinearModel",
    "NotPositiveDefiniteError",
    "NumericalError",
    "Plugin",
    "PluginError",
    "PluginParams",
    "RunContext",
    "SigmaPointEstimator",
    "SmoothedResult",
    "Update",
    "WorkerError",
    "compare",
    "errors",
    "filter_sequence",
    "fixed_lag_smooth",
    "hookimpl",
    "registry",
    "smooth",
]


def __getattr__(name: str) -> Any:
    # The comparison API pulls in the experiments layer (pandas, xarray when used): on demand.
    if name in ("compare", "load_results"):
        from .experiments import results

        return getattr(results, name)
    raise AttributeError(f"module 'gnssframework' has no attribute {name!r}")
