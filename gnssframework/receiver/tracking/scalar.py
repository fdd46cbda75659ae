"""Closed-loop simulation of channel tracking on the analytic correlator model.

The harness owns the truth and the replica NCOs. Every coherent interval it forms the
tracking errors (truth minus replica), draws the correlators those errors produce, hands
them to a ``channel_filter``, and steers the NCOs with the commands it returns. The
correlators therefore reflect the loop's own errors.

Channel-filter command names (outputs of ``ChannelFilter.step``):

- ``carrier_freq_hz``: carrier NCO frequency (Doppler, Hz) for the next interval;
- ``code_freq_hz``: code NCO rate (chips/s) for the next interval;
- ``carrier_phase_step_rad`` (optional): a phase correction applied to the carrier
  NCO at the start of the next interval, used by Kalman loops that estimate phase.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ... import names
from ...errors import ConfigError
from ...interfaces import ChannelFilter, RunContext
from ...signal.constants import CA_CHIP_RATE_HZ, L1_FREQ_HZ
from ...signal.correlator_model import CorrelatorSimulator, amplitude_from_cn0

__all__ = ["SignalTruth", "TrackingRecord", "run_closed_loop", "check_closed_loop", "NCO_COMMANDS"]


@dataclass(frozen=True)
class SignalTruth:
    """True code and carrier phase at the K+1 epoch boundaries, batch-first.

    Attributes
    ----------
    code_phase_chips
        ``(K+1, ...)``.
    carrier_phase_rad
        ``(K+1, ...)``; include here any phase process (scintillation phase, clock).
    amplitude_scale
        ``(K, ...)`` multiplicative amplitude factor per interval (scintillation
        intensity as ``sqrt``), 1 by default.
    cn0_dbhz
        Nominal C/N0, broadcast to the batch.
    coherent_time_s
        Interval length T.
    """

    code_phase_chips: np.ndarray
    carrier_phase_rad: np.ndarray
    cn0_dbhz: np.ndarray | float
    coherent_time_s: float
    amplitude_scale: np.ndarray | float = 1.0

    @property
    def epochs(self) -> int:
        return self.code_phase_chips.shape[0] - 1

    @classmethod
    def from_dynamics(
        cls,
        duration_s: float,
        coherent_time_s: float,
        cn0_dbhz: np.ndarray | float,
        doppler_hz: np.ndarray | float = 0.0,
        doppler_rate_hz_s: np.ndarray | float = 0.0,
        code_phase0_chips: np.ndarray | float = 0.0,
        carrier_phase0_rad: np.ndarray | float = 0.0,
        extra_phase_rad: np.ndarray | None = None,
        amplitude_scale: np.ndarray | float = 1.0,
        doppler_jerk_hz_s2: np.ndarray | float = 0.0,
        extra_cycles: np.ndarray | None = None,
    ) -> "SignalTruth":
        """Polynomial line-of-sight dynamics, code locked to the carrier.

        The carrier advances by ``f t + fdot t^2 / 2 + fddot t^3 / 6`` cycles (Doppler
        ``f``, Doppler rate ``fdot`` = line-of-sight acceleration over the wavelength,
        ``fddot`` = ``doppler_jerk_hz_s2``, line-of-sight jerk over the wavelength) plus
        ``extra_cycles`` ``(K+1, ...)`` (any other line-of-sight motion, in carrier
        cycles); the code follows the same range (code-carrier coherence).
        ``extra_phase_rad`` ``(K+1, ...)`` is added to the carrier phase only (e.g.
        scintillation phase, which does not affect the code).
        """
        K = int(round(duration_s / coherent_time_s))
        t = np.arange(K + 1) * coherent_time_s
        shape = np.broadcast_shapes(np.shape(doppler_hz), np.shape(doppler_rate_hz_s), np.shape(cn0_dbhz),
                                    np.shape(code_phase0_chips), np.shape(carrier_phase0_rad),
                                    np.shape(doppler_jerk_hz_s2))
        tt = t.reshape((-1,) + (1,) * len(shape))
        cycles = (np.asarray(doppler_hz) * tt + 0.5 * np.asarray(doppler_rate_hz_s) * tt**2
                  + np.asarray(doppler_jerk_hz_s2) * tt**3 / 6.0)
        if extra_cycles is not None:
            cycles = cycles + extra_cycles
        carrier = np.asarray(carrier_phase0_rad) + 2 * np.pi * cycles
        if extra_phase_rad is not None:
            carrier = carrier + extra_phase_rad
        code = np.asarray(code_phase0_chips) + CA_CHIP_RATE_HZ * (tt + cycles / L1_FREQ_HZ)
        full = np.broadcast_shapes((K + 1,) + shape, np.shape(cycles))
        return cls(np.broadcast_to(code, full), np.broadcast_to(carrier, np.broadcast_shapes(full, carrier.shape)),
                   cn0_dbhz, coherent_time_s, amplitude_scale)


@dataclass
class TrackingRecord:
    """Per-interval record of a closed-loop run, time on axis 0 (K intervals)."""

    code_error_chips: np.ndarray
    phase_error_rad: np.ndarray
    freq_error_hz: np.ndarray
    carrier_freq_hz: np.ndarray
    outputs: dict[str, np.ndarray] = field(default_factory=dict)


#: Outputs a channel filter needs to steer the NCOs of a closed loop.
NCO_COMMANDS = (names.CARRIER_FREQ_HZ, names.CODE_FREQ_HZ)


def check_closed_loop(channel: ChannelFilter, record: tuple[str, ...] = ()) -> None:
    """Refuse a channel filter that cannot close a tracking loop (or lacks an output to record).

    Raises
    ------
    ConfigError
        With field ``"channel_filter"``.
    """
    needed = NCO_COMMANDS + tuple(record)
    missing = [n for n in needed if n not in channel.provides]
    if names.CORRELATORS not in channel.requires or missing:
        raise ConfigError("channel_filter", f"{channel.name!r} cannot close a tracking loop: it must require "
                          f"'correlators' and provide {', '.join(needed)}")


def run_closed_loop(
    channel: ChannelFilter,
    truth: SignalTruth,
    rng: np.random.Generator,
    *,
    initial_doppler_hz: np.ndarray | float = 0.0,
    initial_code_phase_chips: np.ndarray | float | None = None,
    early_late_spacing_chips: float = 1.0,
    record: tuple[str, ...] = (),
) -> TrackingRecord:
    """Track ``truth`` with ``channel`` in closed loop.

    Parameters
    ----------
    channel
        A ``channel_filter`` that requires ``correlators`` and provides
        ``carrier_freq_hz`` and ``code_freq_hz``.
    truth
        True signal phases.
    rng
        Source of the correlator noise.
    initial_doppler_hz
        The acquisition's Doppler estimate (carrier NCO at start).
    initial_code_phase_chips
        The acquisition's code phase (default: the true one).
    record
        Further channel outputs to keep (e.g. ``("phase_disc_rad",)``).
    """
    check_closed_loop(channel, record)
    T = truth.coherent_time_s
    batch = truth.code_phase_chips.shape[1:]
    f_nco = np.broadcast_to(np.asarray(initial_doppler_hz, float), batch).copy()
    code_freq = CA_CHIP_RATE_HZ * (1 + f_nco / L1_FREQ_HZ)
    code_nco = (truth.code_phase_chips[0] if initial_code_phase_chips is None
                else np.broadcast_to(np.asarray(initial_code_phase_chips, float), batch)).copy()
    carrier_nco = np.zeros(batch)
    channel.reset(batch, RunContext(coherent_time_s=T, early_late_spacing_chips=early_late_spacing_chips,
                                    epoch_interval_s=T, cn0_dbhz=truth.cn0_dbhz, doppler_hz=f_nco))
    amp0 = amplitude_from_cn0(truth.cn0_dbhz, T)
    correlators = CorrelatorSimulator(T, early_late_spacing_chips)  # simulate_correlators' constants, once
    scale = np.asarray(truth.amplitude_scale)
    rec: dict[str, list] = {k: [] for k in ("code", "phase", "freq", "fnco", *record)}
    for k in range(truth.epochs):
        code_end = code_nco + code_freq * T
        carrier_end = carrier_nco + 2 * np.pi * f_nco * T
        code_err = 0.5 * ((truth.code_phase_chips[k] - code_nco) + (truth.code_phase_chips[k + 1] - code_end))
        ph0 = truth.carrier_phase_rad[k] - carrier_nco
        freq_err = ((truth.carrier_phase_rad[k + 1] - carrier_end) - ph0) / (2 * np.pi * T)
        amp = amp0 * (scale[k] if scale.ndim else scale)
        corr = correlators.draw(code_err, ph0, freq_err, np.asarray(amp, float), rng)
        out = channel.checked_step({names.CORRELATORS: corr})
        rec["code"].append(code_err)
        rec["phase"].append(np.angle(np.exp(1j * (ph0 + np.pi * freq_err * T))))  # mid-interval, wrapped
        rec["freq"].append(freq_err)
        rec["fnco"].append(f_nco)
        for name in record:
            rec[name].append(out[name])
        code_nco, carrier_nco = code_end, carrier_end + out.get("carrier_phase_step_rad", 0.0)
        f_nco = np.asarray(out["carrier_freq_hz"], float)
        code_freq = np.asarray(out["code_freq_hz"], float)
    stack = {k: np.stack(v) for k, v in rec.items()}
    return TrackingRecord(stack.pop("code"), stack.pop("phase"), stack.pop("freq"), stack.pop("fnco"), stack)
