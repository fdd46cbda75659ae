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
from .compiled_model import CompiledFunctions, linear_f, linear_h, linear_h_jacobian, register_warm_up
from .em import LearnedNoise, learn_noise
from .estimator import Estimator, SigmaPointEstimator
from .sequence import FilterResult, SmootherInputs, filter_sequence
from .smoother import FixedLagSmoother, LagEstimate, SmoothedResult, fixed_lag_smooth, smooth
from .step import RECOVERIES, FilterStep, StepResult
from .types import Gaussian, LinearModel, Model, NonlinearModel, Update, numerical_jacobian

__all__ = [
    "AdaptationStep",
    "AdapterRun",
    "Augmentation",
    "AugmentedProblem",
    "Estimator",
    "FilterResult",
    "FilterStep",
    "FixedLagSmoother",
    "LagEstimate",
    "LearnedNoise",
    "CompiledFunctions",
    "Gaussian",
    "LinearModel",
    "Model",
    "NoiseAdapter",
    "NonlinearModel",
    "RECOVERIES",
    "SafeguardParams",
    "SigmaPointEstimator",
    "SmoothedResult",
    "SmootherInputs",
    "StepResult",
    "Update",
    "filter_sequence",
    "fixed_lag_smooth",
    "learn_noise",
    "linear_f",
    "linear_h",
    "linear_h_jacobian",
    "numerical_jacobian",
    "register_warm_up",
    "smooth",
]
