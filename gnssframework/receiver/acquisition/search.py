"""The ``acquisition`` plugin kind and what an acquisition reports per satellite."""

from __future__ import annotations

import abc
import inspect
from dataclasses import dataclass

import numpy as np

from ... import registry
from ...errors import ConfigError
from ...plugin import Plugin
from ...signal.gps_l1ca import GPS_L1CA
from ...signal.spec import SignalSpec

__all__ = ["Acquisition", "AcquisitionResult", "searched_prns", "check_contract"]


@dataclass(frozen=True)
class AcquisitionResult:
    """One PRN's search.

    Attributes
    ----------
    prn
        Satellite searched.
    detected
        Whether the test statistic crossed the threshold.
    doppler_hz
        Carrier Doppler (relative to the IF) of the peak, after the fine search.
    code_phase_samples
        First sample at which a code period starts (the replica's chip 0), in
        ``[0, samples per code period)``: where tracking starts.
    code_phase_chips
        Code phase at the first sample of the searched data, in ``[0, code length)``: chips
        the signal had already sent at sample 0 (a generator's ``code_phase_chips``).
    cn0_dbhz
        C/N0 estimated from the peak power and the noise floor (biased low by the
        residual code-phase and Doppler offsets of the grid).
    test_statistic
        Peak of the normalised statistic (non-coherent sum of ``|z|^2/sigma^2``).
    threshold
        The statistic's threshold for the stated false-alarm probability.
    """

    prn: int
    detected: bool
    doppler_hz: float
    code_phase_samples: int
    code_phase_chips: float
    cn0_dbhz: float
    test_statistic: float
    threshold: float


class Acquisition(Plugin, abc.ABC):
    """Plugin kind ``acquisition``: find the satellites of one signal in a stretch of samples.

    The signal is a `SignalSpec` (GPS L1 C/A by default); the PRNs searched are its
    ``prns`` unless given.
    """

    kind = "acquisition"

    @abc.abstractmethod
    def samples_needed(self, sample_rate_hz: float, signal: SignalSpec = GPS_L1CA) -> int:
        """Samples the search of ``signal`` reads from the start of the recording."""

    @abc.abstractmethod
    def acquire(
        self,
        samples: np.ndarray,
        sample_rate_hz: float,
        if_hz: float,
        prns: tuple[int, ...] | None = None,
        signal: SignalSpec = GPS_L1CA,
    ) -> list[AcquisitionResult]:
        """Search ``prns`` of ``signal`` (all of ``signal.prns`` for ``None``) in ``samples``
        (complex, or real at ``if_hz``); one result per PRN."""


#: The contract's methods and the arguments the receiver passes them, by position (the
#: signal last: added by issue 36).
CONTRACT = {
    "samples_needed": ("sample_rate_hz", "signal"),
    "acquire": ("samples", "sample_rate_hz", "if_hz", "prns", "signal"),
}


def check_contract(acquisition: Acquisition) -> Acquisition:
    """``acquisition``, refused with a one-line `ConfigError` when one of its methods
    cannot take the arguments the receiver passes (`CONTRACT`): a plugin written before
    the signal was added (``acquire(samples, sample_rate_hz, if_hz, prns)``) fails here,
    named, rather than with a ``TypeError`` deep in a search."""
    for method, args in CONTRACT.items():
        try:
            inspect.signature(getattr(acquisition, method)).bind(*args)
        except TypeError:
            name = getattr(acquisition, "name", "") or type(acquisition).__name__
            raise ConfigError(
                "acquisition",
                f"plugin {name!r} is written to the old contract: its {method}() "
                f"does not take ({', '.join(args)}); the contract now passes the signal last "
                f"(`signal: SignalSpec = GPS_L1CA`): add it to {type(acquisition).__name__}.{method}",
            ) from None
        except ValueError:  # no signature to read (a builtin): left to the call
            continue
    return acquisition


def searched_prns(prns: tuple[int, ...] | None, signal: SignalSpec) -> tuple[int, ...]:
    """``prns`` checked against ``signal`` (a `ConfigError` naming a PRN it does not
    define), or all of its PRNs for ``None``."""
    return signal.prns if prns is None else tuple(signal.check_prn(p) for p in prns)


registry.register_kind("acquisition", Acquisition)  # this layer owns the kind's base
