"""Hook specifications: one ``register_<kind>(register)`` hook per plugin kind.

A plugin module implements the hooks for the kinds it provides and calls ``register``
with each plugin class::

    from gnssframework import hookimpl

    @hookimpl
    def register_estimator(register):
        register(MyFilter)

and points the ``gnssframework`` entry-point group at that module in its
``pyproject.toml``. The built-in plugins do exactly this.
"""

from __future__ import annotations

from collections.abc import Callable

import pluggy

__all__ = ["hookspec", "hookimpl", "KINDS", "COMPONENT_KINDS"]

hookspec = pluggy.HookspecMarker("gnssframework")
hookimpl = pluggy.HookimplMarker("gnssframework")

Register = Callable[[type], None]

#: The plugin kinds a comparison candidate composes.
COMPONENT_KINDS = ("estimator", "noise_adapter", "augmentation", "discriminator", "channel_filter", "nav_filter")
#: Every plugin kind, in the order the CLI lists them: the components, then the metrics a
#: scenario reports, the scenarios themselves, the receiver's front end (sample formats
#: and acquisition), the signals it receives and the C/N0 estimators of its lock detectors.
KINDS = COMPONENT_KINDS + (
    "metric",
    "scenario",
    "sample_source",
    "acquisition",
    "signal",
    "cn0_estimator",
    "robust_update",
)


@hookspec
def register_estimator(register: Register) -> None:
    """Register Gaussian filter engines (subclasses of ``Estimator``)."""


@hookspec
def register_robust_update(register: Register) -> None:
    """Register robust measurement updates (subclasses of
    ``gnssframework.estimation.robust.RobustUpdate``)."""


@hookspec
def register_noise_adapter(register: Register) -> None:
    """Register Q/R adapters (subclasses of ``NoiseAdapter``)."""


@hookspec
def register_augmentation(register: Register) -> None:
    """Register model rewrites (subclasses of ``Augmentation``)."""


@hookspec
def register_discriminator(register: Register) -> None:
    """Register correlator discriminators (subclasses of ``Discriminator``)."""


@hookspec
def register_channel_filter(register: Register) -> None:
    """Register per-channel filters (subclasses of ``ChannelFilter``)."""


@hookspec
def register_nav_filter(register: Register) -> None:
    """Register navigation filters (subclasses of ``NavFilter``)."""


@hookspec
def register_metric(register: Register) -> None:
    """Register metric components (``gnssframework.experiments.metrics``)."""


@hookspec
def register_scenario(register: Register) -> None:
    """Register scenario kinds (subclasses of ``gnssframework.experiments.scenarios.Scenario``;
    a scenario's registry name is its ``kind``)."""


@hookspec
def register_sample_source(register: Register) -> None:
    """Register recording formats (subclasses of
    ``gnssframework.receiver.frontend.SampleSource``)."""


@hookspec
def register_acquisition(register: Register) -> None:
    """Register signal acquisitions (subclasses of
    ``gnssframework.receiver.acquisition.Acquisition``)."""


@hookspec
def register_signal(register: Register) -> None:
    """Register ranging signals (subclasses of ``gnssframework.signal.registered.Signal``,
    each holding one ``SignalSpec``)."""


@hookspec
def register_cn0_estimator(register: Register) -> None:
    """Register C/N0 estimators (subclasses of
    ``gnssframework.signal.cn0_estimator.CN0Estimator``)."""
