r"""The one truth type of the loop engine: what the simulated signal of every channel is.

A closed loop needs, per channel and at every interval boundary :math:`t_k = kT`, the
true code phase (chips) and carrier phase (rad) its replica is compared with, and the
signal's amplitude (C/N0 and per-interval gains). `LoopTruth` holds them in one of two
forms:

- **phases**: ``code_phase_chips`` and ``carrier_phase_rad`` given at the ``K+1``
  boundaries (a Monte Carlo scenario's line-of-sight dynamics, a synthetic recording);
- **geometry**: satellite and receiver states and the receiver clock, from which the
  true pseudorange :math:`\rho` of every channel follows (vector and aided loops); its
  phases are :math:`\tau = f_{chip} t - \rho/\lambda_{chip}` and
  :math:`\theta = \theta_0 - 2\pi\rho_{carrier}/\lambda` (`code_phase_of_range`).

Sign convention of the engine (`gnssframework.receiver.engine.channel`): errors are truth
minus replica, in code phase (chips) and carrier phase (rad); the Doppler is
:math:`f = -\dot\rho/\lambda`.

`SignalTruth`, `VectorTruth` and `DeepTruth` (the former three harnesses' truth types) are
constructors of a `LoopTruth` with their old positional order.
"""

from __future__ import annotations

from dataclasses import dataclass
from collections.abc import Callable

import numpy as np

from ...navigation.geometry import ranges_from_receivers
from ...signal.gps_l1ca import GPS_L1CA
from ...signal.spec import SignalSpec

__all__ = ["LoopTruth", "SignalTruth", "VectorTruth", "DeepTruth", "code_phase_of_range"]


def code_phase_of_range(signal: SignalSpec, range_m: np.ndarray, t_s: np.ndarray | float) -> np.ndarray:
    r"""Code phase (chips) of a signal received over ``range_m`` at time ``t_s``:
    :math:`\tau = f_{chip} t - \rho / \lambda_{chip}` (the code phase grows with time and
    falls as the range grows)."""
    return signal.chip_rate_hz * np.asarray(t_s, float) - np.asarray(range_m, float) / signal.chip_length_m


@dataclass(frozen=True, kw_only=True)
class LoopTruth:
    """Truth of a closed-loop run, batch-first (time on axis 0 where there is one).

    Attributes
    ----------
    coherent_time_s
        Interval length T.
    cn0_dbhz
        Nominal C/N0 (what the channel filters are told), broadcast to the batch.
    signal
        The signal description (`GPS_L1CA` by default).
    code_phase_chips, carrier_phase_rad
        Phases form: ``(K+1, ...)`` true code phase and carrier phase at the boundaries
        (include in the carrier any phase process: scintillation phase, clock).
    amplitude_scale
        Phases form: ``(K, ...)`` multiplicative amplitude per interval (scintillation
        intensity as ``sqrt``), 1 by default.
    sat_state
        Geometry form: ``sat_state(t) -> (pos, vel[, acc])``, each ``(*t.shape, channels,
        3)`` or ``(*t.shape, runs, channels, 3)`` (ECEF).
    receiver_state
        Geometry form: ``receiver_state(t) -> (pos, vel[, acc])``, each ``(*t.shape, runs, 3)``.
    clock_m
        Geometry form: ``(K+1, runs, 2)`` receiver clock bias (m) and drift (m/s).
    receiver_positions
        Optional ``receiver_positions(t) -> (*t.shape, runs, 3)`` for a block of times
        (``None``: ``receiver_state`` per time).
    range_error_m
        Optional ``range_error_m(t) -> (code_m, carrier_m)``, each ``(*t.shape, runs, ch)``:
        range errors the receiver's model lacks (`gnssframework.simulation.propagation`).
    signal_gain, noise_gain
        Optional ``(K, runs, channels)`` amplitude factors of each interval's correlator
        signal and noise (a C/N0 fade); the channel filters still get ``cn0_dbhz``.
    """

    coherent_time_s: float
    cn0_dbhz: np.ndarray | float
    signal: SignalSpec = GPS_L1CA
    code_phase_chips: np.ndarray | None = None
    carrier_phase_rad: np.ndarray | None = None
    amplitude_scale: np.ndarray | float = 1.0
    sat_state: Callable[[np.ndarray], tuple[np.ndarray, ...]] | None = None
    receiver_state: Callable[[np.ndarray], tuple[np.ndarray, ...]] | None = None
    clock_m: np.ndarray | None = None
    receiver_positions: Callable[[np.ndarray], np.ndarray] | None = None
    range_error_m: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]] | None = None
    signal_gain: np.ndarray | None = None
    noise_gain: np.ndarray | None = None

    @property
    def epochs(self) -> int:
        """Number of intervals K."""
        if self.code_phase_chips is not None:
            return self.code_phase_chips.shape[0] - 1
        return self.clock_m.shape[0] - 1

    # --- phases form ---------------------------------------------------------------------

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
        signal: SignalSpec = GPS_L1CA,
    ) -> LoopTruth:
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
        shape = np.broadcast_shapes(
            np.shape(doppler_hz),
            np.shape(doppler_rate_hz_s),
            np.shape(cn0_dbhz),
            np.shape(code_phase0_chips),
            np.shape(carrier_phase0_rad),
            np.shape(doppler_jerk_hz_s2),
        )
        tt = t.reshape((-1,) + (1,) * len(shape))
        cycles = (
            np.asarray(doppler_hz) * tt
            + 0.5 * np.asarray(doppler_rate_hz_s) * tt**2
            + np.asarray(doppler_jerk_hz_s2) * tt**3 / 6.0
        )
        if extra_cycles is not None:
            cycles = cycles + extra_cycles
        carrier = np.asarray(carrier_phase0_rad) + 2 * np.pi * cycles
        if extra_phase_rad is not None:
            carrier = carrier + extra_phase_rad
        code = np.asarray(code_phase0_chips) + signal.chip_rate_hz * (tt + cycles / signal.carrier_freq_hz)
        full = np.broadcast_shapes((K + 1,) + shape, np.shape(cycles))
        return cls(
            code_phase_chips=np.broadcast_to(code, full),
            carrier_phase_rad=np.broadcast_to(carrier, np.broadcast_shapes(full, carrier.shape)),
            cn0_dbhz=cn0_dbhz,
            coherent_time_s=coherent_time_s,
            amplitude_scale=amplitude_scale,
            signal=signal,
        )

    # --- geometry form -------------------------------------------------------------------

    def pseudorange(self, t: np.ndarray | float, k: np.ndarray | int, sat_pos: np.ndarray | None = None) -> np.ndarray:
        """True code pseudorange (m) at time t (epoch index k for the clock): ``(runs, ch)``.
        ``sat_pos`` saves recomputing the satellite positions when the caller has them."""
        s = self.sat_state(t)[0] if sat_pos is None else sat_pos
        r = self.receiver_state(t)[0]
        rho = ranges_from_receivers(s, r) + self.clock_m[k, :, 0][:, None]
        if self.range_error_m is not None:
            rho = rho + self.range_error_m(np.asarray(t, float))[0]
        return rho

    def pseudoranges(self, k0: int, k1: int, sat_pos: np.ndarray) -> np.ndarray:
        """`pseudorange` at the boundaries ``k0 .. k1 - 1`` at once, ``(k1 - k0, runs, ch)``.

        ``sat_pos`` ``(k1 - k0, ch, 3)``: the satellites there. The same arithmetic per
        element as `pseudorange`, on a block of epochs.
        """
        t = np.arange(k0, k1) * self.coherent_time_s
        if self.receiver_positions is not None:
            r = np.asarray(self.receiver_positions(t), float)
        else:
            r = np.stack([np.asarray(self.receiver_state(ti)[0], float) for ti in t])
        rho = ranges_from_receivers(sat_pos, r) + self.clock_m[k0:k1, :, 0][..., None]
        if self.range_error_m is not None:
            rho = rho + self.range_error_m(t)[0]
        return rho

    def carrier_minus_code_m(self, k0: int, k1: int) -> np.ndarray | None:
        """Carrier range minus code range at the boundaries ``k0 .. k1 - 1`` ``(k1 - k0, runs, ch)``
        (twice the ionospheric advance), or None without range errors."""
        if self.range_error_m is None:
            return None
        code, carrier = self.range_error_m(np.arange(k0, k1) * self.coherent_time_s)
        return carrier - code

    def nav_truth(self, t: float, k: int) -> np.ndarray:
        """True navigation state ``[x, y, z, vx, vy, vz, b, d]`` at t (clock interpolated), ``(runs, 8)``."""
        r, v = self.receiver_state(np.asarray(t))[:2]
        frac = (t / self.coherent_time_s) - k
        clock = (1 - frac) * self.clock_m[k] + frac * self.clock_m[min(k + 1, self.epochs)]
        return np.concatenate([r, v, clock], axis=-1)


class _Constructor:
    """A former truth type's name: calling it builds a `LoopTruth`, its positional arguments
    in the type's old order ``fields`` (keywords as `LoopTruth`'s); ``isinstance(x,
    SignalTruth)`` holds for every `LoopTruth`."""

    def __init__(self, name: str, fields: tuple[str, ...]) -> None:
        self.__name__ = self.__qualname__ = name
        self.fields = fields
        self.__doc__ = f"A `LoopTruth` from ``{name}({', '.join(fields)})``, positional in that order."

    def __call__(self, *args, **kwargs) -> LoopTruth:
        if len(args) > len(self.fields):
            raise TypeError(
                f"{self.__name__}() takes at most {len(self.fields)} positional arguments ({len(args)} given)"
            )
        return LoopTruth(**dict(zip(self.fields, args)), **kwargs)

    def __instancecheck__(self, obj: object) -> bool:
        return isinstance(obj, LoopTruth)

    from_dynamics = staticmethod(LoopTruth.from_dynamics)

    def __repr__(self) -> str:
        return f"<LoopTruth constructor {self.__name__}>"


_GEOMETRY = ("sat_state", "receiver_state", "clock_m", "cn0_dbhz", "coherent_time_s")
#: Phases-form truth, ``SignalTruth(code_phase_chips, carrier_phase_rad, cn0_dbhz, coherent_time_s,
#: amplitude_scale=1.0)`` (the scalar harness's order); ``SignalTruth.from_dynamics`` is
#: `LoopTruth.from_dynamics`.
SignalTruth = _Constructor(
    "SignalTruth", ("code_phase_chips", "carrier_phase_rad", "cn0_dbhz", "coherent_time_s", "amplitude_scale", "signal")
)
#: Geometry-form truth, ``VectorTruth(sat_state, receiver_state, clock_m, cn0_dbhz, coherent_time_s,
#: range_error_m=None, signal_gain=None, noise_gain=None)`` (the vector harness's order).
VectorTruth = _Constructor("VectorTruth", _GEOMETRY + ("range_error_m", "signal_gain", "noise_gain", "signal"))
#: Geometry-form truth, ``DeepTruth(sat_state, receiver_state, clock_m, cn0_dbhz, coherent_time_s,
#: receiver_positions=None, range_error_m=None)`` (the aided harness's order; its states return
#: ``(pos, vel, acc)``).
DeepTruth = _Constructor("DeepTruth", _GEOMETRY + ("receiver_positions", "range_error_m", "signal"))
