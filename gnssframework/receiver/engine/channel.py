r"""A tracking channel of the loop engine: a signal description and its replica's NCOs.

The NCO and sign convention of the whole engine (one for every loop and every source)
-------------------------------------------------------------------------------------
- **Code NCO**: code phase :math:`\hat\tau` in chips of the primary code (the chip index
  the replica generates; it grows at the code rate, ``chip_rate_hz`` plus code Doppler)
  and code rate :math:`\dot{\hat\tau}` in chips/s.
- **Carrier NCO**: carrier phase :math:`\hat\theta` (rad) and frequency :math:`\hat f`
  (Hz) of the Doppler part (the intermediate frequency is the sample source's business).
- Over one coherent interval from :math:`t_k` to :math:`t_k + T` both NCOs hold their rate:
  :math:`\hat\tau(t_k + T) = \hat\tau(t_k) + \dot{\hat\tau} T`,
  :math:`\hat\theta(t_k + T) = \hat\theta(t_k) + 2\pi\hat f T`.
- **Errors are truth minus replica**: code error :math:`\delta\tau = \tau - \hat\tau`
  (chips, the mean over the interval), phase error :math:`\delta\theta = \theta - \hat\theta`
  at the interval's start, frequency error :math:`\delta f = \delta\theta` advance over the
  interval / :math:`2\pi T`. A positive code error means the signal's code is ahead of the
  replica: the correlator tap at offset :math:`o` (early :math:`-d/2`, late :math:`+d/2`)
  sees :math:`R(\delta\tau - o)`, so the late tap is the stronger, in the analytic model
  (`gnssframework.signal.correlator_model`) and in the sample correlators
  (`gnssframework.receiver.channels.correlator`) alike.
- **Range**: code phase :math:`\tau = f_{chip} t - \rho/\lambda_{chip}` and Doppler
  :math:`f = -\dot\rho/\lambda` (`code_phase_of_range`), so a code error
  :math:`\delta\tau` is a range error :math:`\rho - \hat\rho = -\lambda_{chip}\,\delta\tau`
  and a frequency error :math:`\delta f` a rate error :math:`\dot\rho - \dot{\hat\rho} =
  -\lambda\,\delta f`.

Steering: a scalar loop commands frequencies (`Channel.steer_frequency`: ``carrier_freq_hz``,
``code_freq_hz``, optional ``carrier_phase_step_rad``); a vector loop commands a range and a
rate (`Channel.steer_range`: ``nco_range_m``, ``nco_range_rate_m_s``). After either,
``shift_chips`` and ``shift_hz`` say how far the command moved the NCOs from where they
would have run on (what a channel filter keeping its states relative to the replica needs:
``nco_shift_chips``, ``nco_shift_hz``).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ...signal.gps_l1ca import GPS_L1CA
from ...signal.spec import SignalSpec
from .truth import code_phase_of_range

__all__ = ["Channel", "ReplicaErrors", "code_phase_of_range", "range_nco"]


class ReplicaErrors(NamedTuple):
    """The replica's true errors over one interval (truth minus replica, batch shape)."""

    code_chips: np.ndarray  #: code phase error, mean over the interval (chips)
    phase_rad: np.ndarray  #: carrier phase error at the interval's start (rad)
    freq_hz: np.ndarray  #: carrier frequency error over the interval (Hz)

    def mid_phase_rad(self, coherent_time_s: float) -> np.ndarray:
        """Phase error at mid-interval, wrapped to (-pi, pi]."""
        return np.angle(np.exp(1j * (self.phase_rad + np.pi * self.freq_hz * coherent_time_s)))


class Channel:
    """The replica NCOs of a batch of channels of one signal (see the module for the convention).

    Attributes
    ----------
    signal
        The signal description (carrier frequency, chip rate, wavelength, chip length).
    code_phase_chips, code_rate_chips_s, carrier_phase_rad, carrier_freq_hz
        NCO state at the start of the current interval (batch shape).
    shift_chips, shift_hz
        How far the last command moved the code phase (chips) and the carrier frequency
        (Hz) from where the NCOs would have run on (0 at the start).
    nco_range_m, nco_range_rate_m_s
        The last range command (range at the interval's start and its rate), when the
        channel is steered by range (`from_range`, `steer_range`); ``None`` otherwise.
    """

    def __init__(
        self,
        signal: SignalSpec,
        code_phase_chips: np.ndarray,
        code_rate_chips_s: np.ndarray,
        carrier_phase_rad: np.ndarray,
        carrier_freq_hz: np.ndarray,
    ) -> None:
        self.signal = signal
        # The description's rates and lengths, read once (the steering runs every interval).
        self._chip_rate_hz, self._chip_m, self._wavelength_m = (
            signal.chip_rate_hz,
            signal.chip_length_m,
            signal.wavelength_m,
        )
        self.code_phase_chips = code_phase_chips
        self.code_rate_chips_s = code_rate_chips_s
        self.carrier_phase_rad = carrier_phase_rad
        self.carrier_freq_hz = carrier_freq_hz
        shape = np.shape(code_phase_chips)
        self._zeros = np.zeros(shape)
        self._zeros.flags.writeable = False  # shared by every frequency command's shift_chips
        self.shift_chips = self._zeros
        self.shift_hz = np.zeros(shape)
        self.nco_range_m: np.ndarray | None = None
        self.nco_range_rate_m_s: np.ndarray | None = None
        self._code_end = self._carrier_end = None

    @property
    def batch(self) -> tuple[int, ...]:
        return np.shape(self.code_phase_chips)

    # --- start ---------------------------------------------------------------------------

    @classmethod
    def start(
        cls,
        batch: tuple[int, ...],
        code_phase_chips: np.ndarray | float,
        doppler_hz: np.ndarray | float,
        *,
        signal: SignalSpec = GPS_L1CA,
        carrier_phase_rad: np.ndarray | float = 0.0,
    ) -> Channel:
        """Channels started from an acquisition: code phase, Doppler (carrier NCO) and the
        carrier-aided code rate :math:`f_{chip}(1 + f_D / f_L)` (`SignalSpec.code_freq_hz`)."""
        f = np.broadcast_to(np.asarray(doppler_hz, float), batch).copy()
        code = np.broadcast_to(np.asarray(code_phase_chips, float), batch).copy()
        carrier = np.broadcast_to(np.asarray(carrier_phase_rad, float), batch).copy()
        return cls(signal, code, signal.code_freq_hz(f), carrier, f)

    @classmethod
    def from_range(
        cls,
        batch: tuple[int, ...],
        range_m: np.ndarray,
        rate_m_s: np.ndarray,
        *,
        t_s: float = 0.0,
        signal: SignalSpec = GPS_L1CA,
    ) -> Channel:
        """Channels started from a range command (range at ``t_s`` and its rate), carrier phase 0."""
        code, code_rate, freq = _range_nco(
            signal.chip_rate_hz, signal.chip_length_m, signal.wavelength_m, range_m, rate_m_s, t_s, batch
        )
        ch = cls(signal, code, code_rate, np.zeros(batch), freq)
        ch.nco_range_m, ch.nco_range_rate_m_s = range_m, rate_m_s
        return ch

    # --- one interval --------------------------------------------------------------------

    def run_interval(self, coherent_time_s: float) -> tuple[np.ndarray, np.ndarray]:
        """Code phase and carrier phase at the end of the current interval (the NCOs hold
        their rates over it); kept for the next `steer_*`."""
        T = coherent_time_s
        self._code_end = self.code_phase_chips + self.code_rate_chips_s * T
        self._carrier_end = self.carrier_phase_rad + 2 * np.pi * self.carrier_freq_hz * T
        return self._code_end, self._carrier_end

    def errors(
        self,
        code_start: np.ndarray,
        code_end: np.ndarray,
        carrier_start: np.ndarray,
        carrier_end: np.ndarray,
        coherent_time_s: float,
    ) -> ReplicaErrors:
        """The replica's errors over the current interval against the true code phase
        (chips) and carrier phase (rad) at its start and end (runs `run_interval`)."""
        rep_code_end, rep_carrier_end = self.run_interval(coherent_time_s)
        code = 0.5 * ((code_start - self.code_phase_chips) + (code_end - rep_code_end))
        ph0 = carrier_start - self.carrier_phase_rad
        return ReplicaErrors(code, ph0, ((carrier_end - rep_carrier_end) - ph0) / (2 * np.pi * coherent_time_s))

    # --- steering (after `run_interval` / `errors` of the interval that ends) ------------

    def steer_frequency(
        self, carrier_freq_hz: np.ndarray, code_freq_hz: np.ndarray, carrier_phase_step_rad: np.ndarray | float = 0.0
    ) -> None:
        """Next interval from frequency commands (a scalar loop's ``carrier_freq_hz``,
        ``code_freq_hz`` and optional ``carrier_phase_step_rad``): the code NCO runs on
        from where it ended; the carrier too, plus the phase step."""
        f_new = np.asarray(carrier_freq_hz, float)
        self.shift_chips = self._zeros
        self.shift_hz = f_new - self.carrier_freq_hz
        self.code_phase_chips = self._code_end
        self.carrier_phase_rad = self._carrier_end + carrier_phase_step_rad
        self.carrier_freq_hz = f_new
        self.code_rate_chips_s = np.asarray(code_freq_hz, float)

    def steer_by_errors(self, code_step_chips: np.ndarray, freq_step_hz: np.ndarray) -> None:
        """Next interval moved by an estimate of the errors (`EstimateCloser`): the code
        phase jumps by ``code_step_chips``, the carrier frequency by ``freq_step_hz`` (the
        carrier phase runs on, no jump), and the code rate is the new carrier frequency's
        carrier-aided one, :math:`f_{chip}(1 + \\hat f / f_L)` (`SignalSpec.code_freq_hz`)."""
        step = np.asarray(code_step_chips, float)
        f_new = self.carrier_freq_hz + np.asarray(freq_step_hz, float)
        self.shift_chips = np.broadcast_to(step, np.shape(self._code_end))
        self.shift_hz = f_new - self.carrier_freq_hz
        self.code_phase_chips = self._code_end + step
        self.carrier_phase_rad = self._carrier_end
        self.carrier_freq_hz = f_new
        self.code_rate_chips_s = self.signal.code_freq_hz(f_new)

    def steer_range(self, nco_range_m: np.ndarray, nco_range_rate_m_s: np.ndarray, t_s: float | np.ndarray) -> None:
        """Next interval, starting at ``t_s``, from a range command (a vector loop's
        ``nco_range_m`` at ``t_s`` and ``nco_range_rate_m_s``): the code NCO jumps to the
        commanded range's code phase, the carrier phase runs on (no jump) at the commanded
        rate's Doppler :math:`-\\dot\\rho/\\lambda`. ``t_s`` may differ per channel (an array)."""
        code, code_rate, f_new = _range_nco(
            self._chip_rate_hz,
            self._chip_m,
            self._wavelength_m,
            nco_range_m,
            nco_range_rate_m_s,
            t_s,
            np.shape(self.code_phase_chips),
        )
        self.shift_chips = code - self._code_end
        self.shift_hz = f_new - self.carrier_freq_hz
        self.code_phase_chips, self.code_rate_chips_s = code, code_rate
        self.carrier_phase_rad = self._carrier_end
        self.carrier_freq_hz = f_new
        self.nco_range_m, self.nco_range_rate_m_s = nco_range_m, nco_range_rate_m_s


def range_nco(
    signal: SignalSpec, range_m, rate_m_s, t_s: float | np.ndarray, batch: tuple[int, ...]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""The code phase (chips), code rate (chips/s) and Doppler (Hz) a range command sets:
    :math:`f_{chip} t - \rho/\lambda_{chip}`, :math:`f_{chip} - \dot\rho/\lambda_{chip}` and
    :math:`-\dot\rho/\lambda`, batch shape (what `Channel.steer_range` moves its NCOs to;
    the sample tracker's `channels.nco.ReplicaNCOs` steers its slots with it)."""
    return _range_nco(signal.chip_rate_hz, signal.chip_length_m, signal.wavelength_m, range_m, rate_m_s, t_s, batch)


def _range_nco(
    chip_rate_hz: float,
    chip_m: float,
    wavelength_m: float,
    range_m,
    rate_m_s,
    t_s: float | np.ndarray,
    batch: tuple[int, ...],
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""The NCOs a range command sets (`Channel.from_range`, `Channel.steer_range`): code phase
    :math:`f_{chip} t - \rho/\lambda_{chip}` (`code_phase_of_range`), code rate
    :math:`f_{chip} - \dot\rho/\lambda_{chip}` and Doppler :math:`-\dot\rho/\lambda`, batch shape.
    The description's rates and lengths come in read (the steering runs every interval)."""
    t_s = t_s if isinstance(t_s, float) else np.asarray(t_s, float)
    rate = np.asarray(rate_m_s, float)
    code = _batch(chip_rate_hz * t_s - np.asarray(range_m, float) / chip_m, batch)
    return code, _batch(chip_rate_hz - rate / chip_m, batch), _batch(-rate / wavelength_m, batch)


def _batch(a: np.ndarray, batch: tuple[int, ...]) -> np.ndarray:
    """``a`` with the batch's shape (a read-only view when it must be broadcast)."""
    return a if np.shape(a) == batch else np.broadcast_to(a, batch)
