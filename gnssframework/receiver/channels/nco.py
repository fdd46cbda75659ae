r"""The replica NCOs of the sample tracker's channels and how every closer steers them.

The convention is the loop engine's (`gnssframework.receiver.engine.channel`): the code
NCO's phase is the chip index the replica generates, errors are truth minus replica, a
range :math:`\rho` at time :math:`t` is the code phase :math:`f_{chip} t - \rho/\lambda_{chip}`
(`engine.truth.code_phase_of_range`) and a range rate the Doppler :math:`-\dot\rho/\lambda`.
The tracker keeps a channel's code phase as ``code_phase`` chips into the current code
period at the sample ``start_sample`` (its whole periods counted in ``ms_index``: the
compiled interval kernel advances them in place, per slot), ``code_rate`` chips/s and the
carrier NCO's ``doppler`` (Hz above the intermediate frequency).

`ReplicaNCOs` steers them the three ways a closer commands:

- `at(slots).steer_frequency`: a channel filter's NCO commands (``carrier_freq_hz``,
  ``code_freq_hz``, optional ``carrier_phase_step_rad``) with the signature and meaning of
  `engine.channel.Channel.steer_frequency`, so that the engine's own
  `engine.closers.ScalarCloser` steps a channel filter on samples;
- `at(slots).steer_by_errors`: the scalar closure of an error-output filter
  (`closure.ErrorFeedback`) moves the code phase by a gain times its code error and the
  carrier by a gain times its frequency error (truth minus replica: the replica gains
  them), code rate carrier-aided: `engine.channel.Channel.steer_by_errors`'s moves;
- `steer_range`: the vector closer's range and rate command, the moves of the engine's
  `Channel.steer_range` (`engine.channel.range_nco`) on these slots.

`tests/receiver/test_nco_commands.py` holds the three equal to the engine `Channel`'s on
the same NCO states and commands.

Every move is recorded (``shift_chips``, ``shift_hz``) for the error-output filters'
``nco_shift_chips`` and ``nco_shift_hz`` inputs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...signal.spec import SignalSpec
from ..engine.channel import range_nco
from ..engine.closers import range_error_chips
from ..engine.truth import code_phase_of_range

__all__ = ["ReplicaNCOs", "SlotNCOs"]


@dataclass
class ReplicaNCOs:
    """The tracker's per-slot NCO arrays (views, not copies) and their steering."""

    spec: SignalSpec
    code_phase: np.ndarray
    code_rate: np.ndarray
    doppler: np.ndarray
    doppler_cycles: np.ndarray
    shift_chips: np.ndarray
    shift_hz: np.ndarray

    def at(self, slots: np.ndarray) -> SlotNCOs:
        """The NCOs of ``slots`` as an engine channel takes frequency commands."""
        return SlotNCOs(self, slots)

    def steer_range(
        self,
        slots: np.ndarray,
        replica_range_m: np.ndarray,
        range_m: np.ndarray,
        range_rate_m_s: np.ndarray,
        t_s: np.ndarray,
    ) -> None:
        """Move the replicas of ``slots``, which hold the pseudoranges ``replica_range_m`` at
        recording times ``t_s`` (their start samples), to ``range_m`` and ``range_rate_m_s``:
        the moves of `engine.channel.Channel.steer_range` (`engine.channel.range_nco`), the
        code phase by the commanded minus the held range's code phase."""
        code, code_rate, doppler = range_nco(self.spec, range_m, range_rate_m_s, t_s, (np.size(slots),))
        shift = code - code_phase_of_range(self.spec, replica_range_m, t_s)
        self.code_phase[slots] += shift
        self.shift_chips[slots] = shift
        self.shift_hz[slots] = doppler - self.doppler[slots]
        self.doppler[slots] = doppler
        self.code_rate[slots] = code_rate

    def doppler_hz(self, range_rate_m_s: np.ndarray) -> np.ndarray:
        """The carrier Doppler (Hz) of a replica at ``range_rate_m_s``."""
        return -range_rate_m_s / self.spec.wavelength_m

    def range_rate_m_s(self, doppler_hz: np.ndarray) -> np.ndarray:
        """The range rate (m/s) a carrier at ``doppler_hz`` holds."""
        return -self.spec.wavelength_m * doppler_hz

    #: A channel filter's code error as the navigation filters' range error in chips
    #: (`engine.closers.range_error_chips`).
    range_error_chips = staticmethod(range_error_chips)


class SlotNCOs:
    """The NCOs of some slots of a `ReplicaNCOs`, steered by frequency as an
    `engine.channel.Channel` is (what `engine.closers.ScalarCloser.step` calls)."""

    def __init__(self, ncos: ReplicaNCOs, slots: np.ndarray) -> None:
        self.ncos, self.slots = ncos, slots

    def steer_frequency(
        self, carrier_freq_hz: np.ndarray, code_freq_hz: np.ndarray, carrier_phase_step_rad: np.ndarray | float = 0.0
    ) -> None:
        """Next interval from frequency commands: the code NCO runs on (the tracker's
        interval kernel has advanced it), the carrier at ``carrier_freq_hz`` plus the
        phase step; ``shift_chips`` 0 and ``shift_hz`` the frequency change, as the engine's."""
        n, i = self.ncos, self.slots
        f_new = np.asarray(carrier_freq_hz, float)
        n.shift_chips[i] = 0.0
        n.shift_hz[i] = f_new - n.doppler[i]
        n.doppler[i] = f_new
        n.code_rate[i] = code_freq_hz
        n.doppler_cycles[i] += np.asarray(carrier_phase_step_rad, float) / (2 * np.pi)

    def steer_by_errors(self, code_step_chips: np.ndarray, freq_step_hz: np.ndarray) -> None:
        """Next interval moved by an estimate of the errors, as `engine.channel.Channel.steer_by_errors`:
        the code phase jumps by ``code_step_chips``, the carrier frequency by
        ``freq_step_hz`` (no phase jump), the code rate the new carrier's carrier-aided one."""
        n, i = self.ncos, self.slots
        n.shift_chips[i] = code_step_chips
        n.shift_hz[i] = freq_step_hz
        n.doppler[i] += freq_step_hz
        n.code_phase[i] += code_step_chips
        n.code_rate[i] = n.spec.code_freq_hz(n.doppler[i])
