r"""The replica NCOs of the sample tracker's channels, and the one way they are steered.

Convention (one for every closer): a channel's code NCO holds the code phase it has
generated, ``code_phase`` chips into the current code period at the sample
``start_sample``, advancing at ``code_rate`` chips/s; its carrier NCO runs at ``doppler``
Hz above the intermediate frequency. In range terms, a replica whose code NCO has
generated the chips sent at transmit time :math:`t_{tx}` by receive time :math:`t_{rx}`
holds the pseudorange :math:`R = c\,(t_{rx} - t_{tx})`, and a carrier at Doppler
:math:`f` holds the range rate :math:`\dot R = -\lambda f`. So

- more range is fewer chips: steering a replica from range :math:`R` to :math:`\hat R`
  moves its code phase by :math:`(R - \hat R)/\lambda_{chip}` chips, and its carrier to
  :math:`f = -\dot{\hat R}/\lambda` (`ReplicaNCOs.steer_to_range`, the vector closer's
  command);
- an error-output channel filter on these NCOs reports the code phase the replica must
  gain, :math:`\phi_{true} - \phi_{replica}` chips (`ReplicaNCOs.shift` moves it by a
  gain times that, the scalar `closure.ErrorFeedback`); the same error in delay terms,
  :math:`(R_{true} - R)/\lambda_{chip}` (the navigation filters' ``code_error_chips``,
  as `gnssframework.receiver.tracking.vector` defines it), is its opposite
  (`ReplicaNCOs.delay_error_chips`).

Every move is recorded (``shift_chips``, ``shift_hz``) for the error-output filters'
``nco_shift_chips`` and ``nco_shift_hz`` inputs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...signal.spec import SignalSpec

__all__ = ["ReplicaNCOs"]


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

    def command(self, slots: np.ndarray, carrier_freq_hz: np.ndarray, code_freq_hz: np.ndarray,
                carrier_phase_step_rad: np.ndarray | None = None) -> None:
        """A channel filter's NCO commands: the carrier and code rates of the next interval
        (and a carrier phase step, rad)."""
        self.doppler[slots] = carrier_freq_hz
        self.code_rate[slots] = code_freq_hz
        if carrier_phase_step_rad is not None:
            self.doppler_cycles[slots] += np.asarray(carrier_phase_step_rad, float) / (2 * np.pi)

    def shift(self, slots: np.ndarray, code_chips: np.ndarray, freq_hz: np.ndarray) -> None:
        """Advance the code phase by ``code_chips`` and the carrier by ``freq_hz``; the code
        rate follows the carrier (carrier aiding)."""
        self.shift_chips[slots] = code_chips
        self.shift_hz[slots] = freq_hz
        self.doppler[slots] += freq_hz
        self.code_phase[slots] += code_chips
        self.code_rate[slots] = self.spec.code_freq_hz(self.doppler[slots])

    def steer_to_range(self, slots: np.ndarray, replica_range_m: np.ndarray, range_m: np.ndarray,
                       range_rate_m_s: np.ndarray) -> None:
        """Move replicas holding ``replica_range_m`` to ``range_m`` and ``range_rate_m_s``
        (see the module text); the code rate follows the carrier."""
        code_chips = (replica_range_m - range_m) / self.spec.chip_length_m
        doppler_hz = self.doppler_hz(range_rate_m_s)
        self.code_phase[slots] += code_chips
        self.shift_chips[slots] = code_chips
        self.shift_hz[slots] = doppler_hz - self.doppler[slots]
        self.doppler[slots] = doppler_hz
        self.code_rate[slots] = self.spec.code_freq_hz(doppler_hz)

    def doppler_hz(self, range_rate_m_s: np.ndarray) -> np.ndarray:
        """The carrier Doppler (Hz) of a replica at ``range_rate_m_s``."""
        return -range_rate_m_s / self.spec.wavelength_m

    def range_rate_m_s(self, doppler_hz: np.ndarray) -> np.ndarray:
        """The range rate (m/s) a carrier at ``doppler_hz`` holds."""
        return -self.spec.wavelength_m * doppler_hz

    @staticmethod
    def delay_error_chips(phase_error_chips: np.ndarray | float) -> np.ndarray | float:
        """A code error as phase to gain (these NCOs') in delay terms (true minus replica delay)."""
        return -phase_error_chips
