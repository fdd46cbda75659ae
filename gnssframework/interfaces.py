"""Abstract interfaces of the GNSS plugin kinds.

The estimation kinds (``Estimator``, ``NoiseAdapter``, ``Augmentation``) live in
``gnssframework.estimation``, which knows nothing of GNSS. These three compose them
into a receiver:

- a ``Discriminator`` turns correlators into a code, frequency or phase error;
- a ``ChannelFilter`` processes one channel's correlators or observables per
  epoch (batched over channels and runs);
- a ``NavFilter`` fuses every channel and returns the navigation state and the
  NCO commands of the next epoch.

Channel and navigation filters declare the named quantities they ``provides`` and
``requires``, so a configuration that feeds a nav filter from a channel filter whose
outputs it cannot use is refused before anything runs.
"""

from __future__ import annotations

import abc
from typing import Any, ClassVar, Mapping

import numpy as np
from pydantic import Field

from .errors import PluginError
from .plugin import Plugin, PluginParams
from .signal.correlators import Correlators

__all__ = ["Discriminator", "DiscriminatorParams", "SequentialFilter", "ChannelFilter", "NavFilter"]


class DiscriminatorParams(PluginParams):
    """Parameters every discriminator takes."""

    coherent_time_s: float = Field(0.001, gt=0, le=0.1, description="coherent integration time T")


class Discriminator(Plugin, abc.ABC):
    """Plugin kind ``discriminator``: correlators -> an error in physical units.

    Discriminators have unit slope in their linear region: for a small true error e,
    the output is e plus noise. ``unit`` is ``"chips"``, ``"Hz"`` or ``"rad"``.
    """

    kind = "discriminator"
    unit: ClassVar[str] = ""
    Params = DiscriminatorParams
    #: True for frequency discriminators, which need the previous prompt.
    needs_previous: ClassVar[bool] = False

    @abc.abstractmethod
    def __call__(self, current: Correlators, previous: Correlators | None = None) -> np.ndarray:
        """The error estimate, shape ``current.shape``."""

    @abc.abstractmethod
    def noise_variance(self, cn0_dbhz: float | np.ndarray) -> np.ndarray:
        """Thermal-noise variance of one output (``unit``^2) at the given C/N0."""


class SequentialFilter(Plugin, abc.ABC):
    """A plugin that processes a sequence epoch by epoch, batch-first.

    ``reset`` starts it for a batch; ``step`` takes one epoch's inputs (named arrays) and
    returns named outputs. ``requires`` and ``provides`` name them, so a composition that
    cannot work is refused before a run.
    """

    #: Names of the inputs ``step`` needs.
    requires: ClassVar[tuple[str, ...]] = ()
    #: Names of the outputs ``step`` returns.
    provides: ClassVar[tuple[str, ...]] = ()

    @abc.abstractmethod
    def reset(self, batch_shape: tuple[int, ...], **context: Any) -> None:
        """Start a new sequence for ``batch_shape`` (channels, runs, ...)."""

    @abc.abstractmethod
    def step(self, inputs: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Process one epoch."""

    def checked_step(self, inputs: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        """``step``, then check it returned every name the plugin ``provides`` (harnesses
        call this, so a plugin that breaks its declaration fails at its first epoch, by name)."""
        out = self.step(inputs)
        missing = [n for n in self.provides if n not in out]
        if missing:
            raise PluginError(f"{self.kind} {self.name!r}: step() did not return {', '.join(missing)} "
                              f"that it declares in `provides`")
        return out


class ChannelFilter(SequentialFilter):
    """Plugin kind ``channel_filter``: per-channel processing of correlators (``"correlators"``)
    or observables (``"pseudorange_m"``, ``"carrier_m"``) into named outputs
    (``"code_error_chips"``, ``"smoothed_m"``, NCO commands...)."""

    kind = "channel_filter"


class NavFilter(SequentialFilter):
    """Plugin kind ``nav_filter``: fuses channel outputs into a navigation state.

    ``step`` takes the channel filters' outputs (stacked over channels on the last
    batch axis) and returns the navigation state and, in a vector loop, the
    per-channel NCO commands of the next epoch.
    """

    kind = "nav_filter"
