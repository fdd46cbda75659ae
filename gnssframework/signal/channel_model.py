"""The correlator-domain channel model of Zou et al. (2018), vector tracking with an ACKF.

State of one channel, ``x = [A, dtau, dtheta, df, dfdot]``: correlator amplitude,
code phase error (chips), carrier phase error (rad), carrier frequency error (Hz) and
its rate (Hz/s). Measurements: the six correlator outputs
``[I_E, I_P, I_L, Q_E, Q_P, Q_L]`` after data wipe-off.
"""

from __future__ import annotations

import math

import numpy as np

from ..backend import jit
from ..errors import ConfigError
from .correlator_model import correlator_mean
from .gps_l1ca import GPS_L1CA
from .spec import SignalSpec

__all__ = ["channel_iq", "channel_iq_row", "channel_transition", "channel_model", "code_to_carrier"]


def code_to_carrier(signal: SignalSpec = GPS_L1CA) -> float:
    """Code chipping rate over carrier frequency, ``f_code / f_carrier`` (1/1540 for GPS L1 C/A)."""
    return signal.chip_rate_hz / signal.carrier_freq_hz


def channel_iq(
    x: np.ndarray, spacing_chips: float, coherent_time_s: float, data_bit: np.ndarray | float = 1.0
) -> np.ndarray:
    r"""The six correlator outputs of Zou et al. (2018), eqs. 2-7, vectorised.

    $$
    I_E = A\, R(\delta\tau + d)\, D\, \mathrm{sinc}(\delta f T) \cos(\pi \delta f T + \delta\theta)
    $$

    with ``R(dtau)`` for prompt and ``R(dtau - d)`` for late, and Q with ``sin``. Here
    ``d`` is the early-prompt spacing ``spacing_chips``. The paper writes the early tap
    as ``R(dtau - d)``, i.e. with the opposite sign of ``dtau``. The library keeps the
    convention of `gnssframework.signal.correlator_model` and of the loop engine
    (`gnssframework.receiver.engine.channel`: ``dtau`` = true minus replica code phase,
    a tap at offset o sees ``R(dtau - o)``) everywhere.

    Parameters
    ----------
    x
        States ``(..., 5)``; any leading dimensions.
    spacing_chips
        Early-to-prompt spacing d (half the early-late spacing).
    coherent_time_s
        Coherent integration time T.
    data_bit
        +1 or -1 (1 after wipe-off).

    Returns
    -------
    np.ndarray
        ``(..., 6)``: ``[I_E, I_P, I_L, Q_E, Q_P, Q_L]``.
    """
    y = correlator_mean(
        x[..., 0],
        x[..., 1],
        x[..., 2],
        x[..., 3],
        coherent_time_s,
        np.array([-spacing_chips, 0.0, spacing_chips]),
        data_bit,
    )
    return np.concatenate([y.real, y.imag], axis=-1)


def channel_transition(
    coherent_time_s: float, code_to_carrier: float | None = None, signal: SignalSpec = GPS_L1CA
) -> np.ndarray:
    r"""Transition matrix of the channel state over one coherent interval (Zou et al. 2018, eq. 9).

    ``code_to_carrier`` is ``f_code / f_carrier``, by default ``signal``'s (`code_to_carrier`).

    $$
    \delta\tau' = \delta\tau + \tfrac{f_{code}}{f_{carrier}} T \delta f, \quad
    \delta\theta' = \delta\theta + 2\pi T \delta f + \pi T^2 \dot{\delta f}, \quad
    \delta f' = \delta f + T \dot{\delta f}
    $$
    """
    if code_to_carrier is None:
        code_to_carrier = signal.chip_rate_hz / signal.carrier_freq_hz
    T = coherent_time_s
    F = np.eye(5)
    # Our code error is true minus replica code phase (the engine's convention): a
    # positive frequency error (range shrinking faster than the replica's) advances the
    # true code faster than the replica's, so it *grows*, as in the paper.
    F[1, 3] = code_to_carrier * T
    F[2, 3] = 2 * np.pi * T
    F[2, 4] = np.pi * T**2
    F[3, 4] = T
    return F


@jit
def _triangle(tau):
    a = abs(tau)
    return 1.0 - a if a < 1.0 else 0.0


@jit
def channel_iq_row(params, X, k, Z, kz):
    """`channel_iq` of the state ``X[k]`` into ``Z[kz]``, compiled: the model's ``h`` as
    the fused kernels call it (`gnssframework.estimation.CompiledFunctions`). ``params``
    ``[[spacing_chips, coherent_time_s, data_bit]]``; the ideal (unfiltered) triangle
    autocorrelation, as `channel_iq` (a test holds the two to 1e-12)."""
    d = params[0, 0]
    T = params[0, 1]
    u = X[k, 3] * T
    if u == 0.0:
        u = 1e-20  # numpy.sinc's guard, so the two paths agree at df = 0 too
    sinc = math.sin(math.pi * u) / (math.pi * u)
    common = X[k, 0] * params[0, 2] * sinc
    phase = math.pi * X[k, 3] * T + X[k, 2]
    c = common * math.cos(phase)
    s_ = common * math.sin(phase)
    r_e = _triangle(X[k, 1] + d)
    r_p = _triangle(X[k, 1])
    r_l = _triangle(X[k, 1] - d)
    Z[kz, 0] = c * r_e
    Z[kz, 1] = c * r_p
    Z[kz, 2] = c * r_l
    Z[kz, 3] = s_ * r_e
    Z[kz, 4] = s_ * r_p
    Z[kz, 5] = s_ * r_l


def channel_model(
    coherent_time_s: float,
    spacing_chips: float,
    Q: np.ndarray,
    R: np.ndarray,
    code_to_carrier: float | None = None,
    signal: SignalSpec = GPS_L1CA,
):
    """The channel filter's model (eq. 9 transition, eqs. 2-7 correlators) with compiled twins.

    ``f`` and ``h`` are the NumPy functions above; the model also carries their compiled
    versions (``CompiledFunctions``) so a sigma-point filter runs each predict and update
    in one compiled pass: ``F x`` and `channel_iq_row`. Data bit 1 (after wipe-off),
    ideal triangle autocorrelation.

    ``code_to_carrier`` is ``signal``'s by default (GPS L1 C/A's by default); the model's
    triangle is BPSK's one-chip one, so a signal with a sub-carrier (BOC, CBOC: a train of
    triangles, `SignalSpec.autocorrelation`) or with time-multiplexed chips (GPS L2C: a
    half-chip triangle) is refused.

    Raises
    ------
    ConfigError
        For a signal whose chip pulse is not BPSK's full-chip rectangle (`SignalSpec.is_bpsk`).
    """
    if not signal.is_bpsk:
        raise ConfigError(
            "signal",
            f"the Zou et al. channel model assumes BPSK's one-chip triangle autocorrelation; "
            f"{signal.name}'s chip pulse is {_pulse(signal)}",
        )
    from ..estimation.compiled_model import CompiledFunctions, linear_f
    from ..estimation.types import NonlinearModel

    F = channel_transition(coherent_time_s, code_to_carrier, signal=signal)
    d, T = float(spacing_chips), float(coherent_time_s)
    # Its drivers are compiled for the filter's 5 states and 6 correlator outputs.
    compiled = CompiledFunctions(linear_f, F, channel_iq_row, np.array([[d, T, 1.0]]), sizes=(5, 6))
    return NonlinearModel(lambda x: x @ F.T, lambda x: channel_iq(x, d, T), Q, R, compiled=compiled)


def _pulse(signal: SignalSpec) -> str:
    """What a signal's chip pulse is, where it is not BPSK's full-chip rectangle."""
    if signal.subcarrier.kind != "bpsk":
        return f"a {signal.subcarrier.kind} sub-carrier's"
    return f"in one of {signal.subchips_per_chip} time slots of a chip (time-multiplexed components)"
