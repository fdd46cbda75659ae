"""gnssframework's built-in plugins.

This package is registered through the ``gnssframework`` entry-point group in
``pyproject.toml``, exactly like a third-party plugin: the core never imports it.
"""

from __future__ import annotations

from gnssframework import hookimpl

from .acquisition import ParallelCodePhaseSearch
from .adapters import InnovationAdapter, MaximumLikelihoodQAdapter, SageHusaAdapter
from .augmentations import ColoredAR1
from .channel_filters import DiscriminatorChannel, IqFilter, KalmanCarrierLoop, ScalarTrackingLoop
from .sample_sources import ComplexFloat32, ComplexInt8, ComplexInt16, ComplexPacked2, RealInt8, RealPacked2
from .smoothers import HatchFilter, KalmanSmoother
from .nav_filters import EkfPositionVelocity, PositionConstantAcceleration
from .nav_filter_pva import EkfPositionVelocityAcceleration
from .ins_filters import InsEkf
from .discriminators import (
    Atan2FLL,
    Atan2PLL,
    CostasAtan,
    CrossProductFLL,
    DotProduct,
    EarlyMinusLateEnvelope,
    EarlyMinusLatePower,
)
from .estimators import (
    CubatureKalmanFilter,
    ExtendedKalmanFilter,
    KalmanFilter,
    SvdCubatureKalmanFilter,
    UnscentedKalmanFilter,
)


@hookimpl
def register_estimator(register):
    for cls in (KalmanFilter, ExtendedKalmanFilter, UnscentedKalmanFilter, CubatureKalmanFilter,
                SvdCubatureKalmanFilter):
        register(cls)


@hookimpl
def register_noise_adapter(register):
    for cls in (InnovationAdapter, SageHusaAdapter, MaximumLikelihoodQAdapter):
        register(cls)


@hookimpl
def register_augmentation(register):
    register(ColoredAR1)


@hookimpl
def register_discriminator(register):
    for cls in (EarlyMinusLateEnvelope, EarlyMinusLatePower, DotProduct, CrossProductFLL, Atan2FLL, CostasAtan,
                Atan2PLL):
        register(cls)


@hookimpl
def register_channel_filter(register):
    for cls in (ScalarTrackingLoop, KalmanCarrierLoop, DiscriminatorChannel, IqFilter, HatchFilter, KalmanSmoother):
        register(cls)


@hookimpl
def register_nav_filter(register):
    register(EkfPositionVelocity)
    register(EkfPositionVelocityAcceleration)
    register(PositionConstantAcceleration)
    register(InsEkf)


@hookimpl
def register_sample_source(register):
    for cls in (RealInt8, ComplexInt8, ComplexInt16, ComplexFloat32, RealPacked2, ComplexPacked2):
        register(cls)


@hookimpl
def register_acquisition(register):
    register(ParallelCodePhaseSearch)
