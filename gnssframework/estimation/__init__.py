"""Batched Gaussian estimation: states, models, engines, adapters, sequences.

This subpackage knows nothing of GNSS.
"""

from .adaptation import (
    AdaptationStep,
    AdapterRun,
    Augmentation,
    AugmentedProblem,
    NoiseAdapter,
    SafeguardParams,
)
from .estimator import Estimator, SigmaPointEstimator
from .sequence import RECOVERIES, FilterResult, filter_sequence
from .types import Gaussian, LinearModel, Model, NonlinearModel, Update, numerical_jacobian

__all__ = [
    "AdaptationStep",
    "AdapterRun",
    "Augmentation",
    "AugmentedProblem",
    "Estimator",
    "FilterResult",
    "Gaussian",
    "LinearModel",
    "Model",
    "NoiseAdapter",
    "NonlinearModel",
    "RECOVERIES",
    "SafeguardParams",
    "SigmaPointEstimator",
    "Update",
    "filter_sequence",
    "numerical_jacobian",
]
