"""Vector tracking: channel filters -> navigation filter -> NCO commands, every epoch.

The loop is batched over Monte Carlo runs (axis 0) and channels (axis 1). Each
coherent interval k, from $t_k$ to $t_{k+1} = t_k + T$:

1. the replica of channel i runs from the NCO command
   ($\\hat\\rho_i(t_k)$, $\\dot{\\hat\\rho}_i$), so its code error and carrier phase and
   frequency errors against the true signal are known to the simulation;
2. the correlators those errors produce are drawn (`simulate_correlators`);
3. the channel filter turns them into code-phase and carrier-frequency errors with
   their variances (``code_error_chips``, ``code_error_var_chips2``,
   ``freq_error_hz``, ``freq_error_var_hz2``);
4. the navigation filter takes them as pseudorange and pseudorange-rate errors of
   the replica at mid-interval (Zou et al. 2018, eqs. 35-36),
   $\\delta\\rho = \\lambda_{chip}\\, \\delta\\tau$ and $\\delta\\dot\\rho = -\\lambda_{L1}\\, \\delta f$,
   and returns the NCO command of the next interval (``nco_range_m``,
   ``nco_range_rate_m_s``);
5. the channel filter is told how far its replica moved (``nco_shift_chips``,
   ``nco_shift_hz``), so it can keep its error states relative to the replica.

Signs: code error = true minus replica delay (chips); frequency error = true minus
replica Doppler (Hz), with the Doppler $f = -\\dot\\rho / \\lambda_{L1}$.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ... import names
from ... import random_streams as draw
from ...errors import ConfigError
from ...estimation.consistency import nees
from ...interfaces import ChannelFilter, NavFilter, RunContext
from ...navigation.geometry import line_of_sight, range_rate, ranges_from_receivers
from ...signal.constants import CA_CHIP_LENGTH_M, L1_WAVELENGTH_M
from ...signal.correlator_model import CorrelatorSimulator, amplitude_from_cn0
from ...signal.correlators import Correlators
from ...signal.navdata import BIT_PERIOD_S, random_nav_bits

__all__ = ["VectorTruth", "VectorRecord", "run_vector_loop", "check_composition", "predicted_range",
           "CHANNEL_OUTPUTS", "NAV_OUTPUTS", "HARNESS_INPUTS"]

#: What a channel filter must provide to feed a vector loop's nav filter.
CHANNEL_OUTPUTS = (names.CODE_ERROR_CHIPS, names.CODE_ERROR_VAR_CHIPS2, names.FREQ_ERROR_HZ, names.FREQ_ERROR_VAR_HZ2)
#: What a nav filter must provide to close a vector loop.
NAV_OUTPUTS = (names.POSITION_M, names.VELOCITY_M_S, names.CLOCK_M, names.COV, names.NCO_RANGE_M,
               names.NCO_RANGE_RATE_M_S)


@dataclass(frozen=True)
class VectorTruth:
    """Truth of a vector-tracking run.

    Attributes
    ----------
    sat_state
        ``sat_state(t) -> (pos, vel)``, each ``(*t.shape, channels, 3)`` (ECEF), or
        ``(*t.shape, runs, channels, 3)`` when every run has its own geometry.
    receiver_state
        ``receiver_state(t) -> (pos, vel)``, each ``(*t.shape, runs, 3)``.
    clock_m
        ``(K+1, runs, 2)``: receiver clock bias (m) and drift (m/s) at the epochs.
    cn0_dbhz
        ``(runs, channels)`` or broadcastable.
    coherent_time_s
        T.
    range_error_m
        Optional ``range_error_m(t) -> (code_m, carrier_m)``, each ``(*t.shape, runs,
        channels)``: errors of the true code and carrier ranges that the receiver's model
        does not have (ionosphere, troposphere, broadcast orbit and clock residuals,
        `gnssframework.simulation.propagation`). None: none.
    signal_gain, noise_gain
        Optional ``(K, runs, channels)`` amplitude factors of each interval's correlator
        signal and noise (a C/N0 fade, `gnssframework.simulation.fade.CN0Fade.gains`):
        the correlators' C/N0 is ``cn0_dbhz`` + 20 log10(signal_gain / noise_gain), while
        the channel filters are still given ``cn0_dbhz``, the nominal value. None: 1.
    """

    sat_state: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]
    receiver_state: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]
    clock_m: np.ndarray
    cn0_dbhz: np.ndarray
    coherent_time_s: float
    range_error_m: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]] | None = None
    signal_gain: np.ndarray | None = None
    noise_gain: np.ndarray | None = None

    @property
    def epochs(self) -> int:
        return self.clock_m.shape[0] - 1

    def pseudorange(self, t: np.ndarray, k: np.ndarray | int, sat_pos: np.ndarray | None = None) -> np.ndarray:
        """True pseudorange (m) at time t (epoch index k for the clock): ``(runs, ch)``.
        ``sat_pos`` saves recomputing the satellite positions when the caller has them."""
        s = self.sat_state(t)[0] if sat_pos is None else sat_pos
        r, _ = self.receiver_state(t)
        rho = ranges_from_receivers(s, r) + self.clock_m[k, :, 0][:, None]
        if self.range_error_m is not None:
            rho = rho + self.range_error_m(np.asarray(t, float))[0]
        return rho

    def nav_truth(self, t: float, k: int) -> np.ndarray:
        """True navigation state ``[x, y, z, vx, vy, vz, b, d]`` at t (clock interpolated), ``(runs, 8)``."""
        r, v = self.receiver_state(np.asarray(t))
        frac = (t / self.coherent_time_s) - k
        clock = (1 - frac) * self.clock_m[k] + frac * self.clock_m[min(k + 1, self.epochs)]
        return np.concatenate([r, v, clock], axis=-1)


@dataclass
class VectorRecord:
    """Time series of a vector-tracking run, time on axis 0 (K intervals)."""

    code_error_chips: np.ndarray  # (K, runs, ch) true code error of the replica
    freq_error_hz: np.ndarray  # (K, runs, ch) true frequency error of the replica
    position_error_m: np.ndarray  # (K, runs, 3)
    velocity_error_m_s: np.ndarray  # (K, runs, 3)
    nees: np.ndarray  # (K, runs) normalised estimation error squared of the 8 nav states
    time_s: np.ndarray  # (K,) mid-interval times
    extra: dict[str, np.ndarray] = field(default_factory=dict)
    #: (K, runs) NEES of the position (3 states) and the velocity (3 states), each on
    #: its marginal covariance.
    nees_position: np.ndarray | None = None
    nees_velocity: np.ndarray | None = None
    #: (K, runs, ch) error of what the channel filter handed the nav filter: its output
    #: code (chips) and frequency (Hz) errors minus the true replica errors.
    code_output_error_chips: np.ndarray | None = None
    freq_output_error_hz: np.ndarray | None = None


#: Inputs the vector loop itself gives the nav filter (besides the channel outputs).
HARNESS_INPUTS = (names.SAT_POS_M, names.SAT_VEL_M_S, names.NEXT_SAT_POS_M, names.NEXT_SAT_VEL_M_S,
                  names.REPLICA_RANGE_M, names.REPLICA_RATE_M_S)


def check_composition(channel: ChannelFilter, nav: NavFilter) -> None:
    """Refuse a channel/nav filter pair that cannot close a vector loop.

    Raises
    ------
    ConfigError
        With field ``"channel_filter"`` or ``"nav_filter"`` (the part at fault).
    """
    missing = [n for n in CHANNEL_OUTPUTS if n not in channel.provides]
    if missing:
        raise ConfigError("channel_filter", f"{channel.name!r} cannot feed a vector loop: it does not provide "
                          f"{', '.join(missing)}")
    unmet = [n for n in nav.requires if n not in channel.provides and n not in HARNESS_INPUTS]
    if unmet:
        raise ConfigError("nav_filter", f"{nav.name!r} needs {', '.join(unmet)}, which {channel.name!r} does "
                          f"not provide (it provides {', '.join(channel.provides)})")
    missing = [n for n in NAV_OUTPUTS if n not in nav.provides]
    if missing:
        raise ConfigError("nav_filter", f"{nav.name!r} cannot close a vector loop: it does not provide "
                          f"{', '.join(missing)}")


def run_vector_loop(
    channel: ChannelFilter,
    nav: NavFilter,
    truth: VectorTruth,
    initial_state: np.ndarray,
    initial_cov: np.ndarray,
    rng: np.random.Generator,
    *,
    early_late_spacing_chips: float = 1.0,
    data_bits: str = "known",
) -> VectorRecord:
    """Run the vector tracking loop over all epochs of ``truth``.

    Parameters
    ----------
    channel, nav
        A channel filter providing `CHANNEL_OUTPUTS` and a nav filter providing
        `NAV_OUTPUTS`.
    truth
        The scenario.
    initial_state, initial_cov
        The nav filter's initial estimate ``(runs, 8)`` and covariance ``(8, 8)`` at the
        middle of the first interval (from acquisition and a first fix).
    rng
        Source of every random draw (initial carrier phases, data bits, noise).
    data_bits
        ``"none"``, or 50 bit/s navigation data that is ``"known"`` (the channel filter
        gets ``data_bit`` and wipes it off) or ``"unknown"`` (it must decide).
    """
    check_composition(channel, nav)
    if data_bits not in ("none", "known", "unknown"):
        raise ConfigError("scenario.data_bits", f"got {data_bits!r}; allowed: none, known, unknown")
    T, K = truth.coherent_time_s, truth.epochs
    t_edges = np.arange(K + 1) * T
    # Satellite states at every epoch edge and mid-interval, in two vectorised calls
    # instead of two orbit evaluations per epoch.
    sat_edges = truth.sat_state(t_edges)
    sat_mids = truth.sat_state(t_edges[:-1] + T / 2)
    runs, n_ch = truth.clock_m.shape[1], sat_edges[0].shape[-2]
    batch = (runs, n_ch)
    cn0 = np.broadcast_to(np.asarray(truth.cn0_dbhz, float), batch)
    for name in ("signal_gain", "noise_gain"):
        gain = getattr(truth, name)
        if gain is not None and np.shape(gain) != (K,) + batch:
            raise ConfigError(f"truth.{name}", f"must have the shape (epochs, runs, channels) = {(K,) + batch}, "
                              f"got {np.shape(gain)}")

    theta0 = draw.uniform(rng, -np.pi, np.pi, batch, 0)  # unknown initial carrier phase per channel
    bits = random_nav_bits(int(np.ceil(K * T / BIT_PERIOD_S)) + 1, rng, batch) if data_bits != "none" else None
    context = RunContext(coherent_time_s=T, early_late_spacing_chips=early_late_spacing_chips, epoch_interval_s=T,
                         cn0_dbhz=cn0, initial_state=initial_state, initial_cov=initial_cov)
    channel.reset(batch, context)
    nav.reset((runs,), context)
    correlators = _CorrelatorSource(CorrelatorSimulator(T, early_late_spacing_chips), amplitude_from_cn0(cn0, T),
                                    bits, data_bits == "known", rng, truth.signal_gain, truth.noise_gain)
    replica = _Replica.from_estimate(truth, initial_state, batch)
    record = _Recorder(K, runs, batch)

    block = max(1, min(K, _BLOCK))
    for k0 in range(0, K, block):
        k1 = min(K, k0 + block)
        rho_edges, phase_true, x_true = _block_truth(truth, sat_edges[0], t_edges, theta0, k0, k1)
        for k in range(k0, k1):
            j = k - k0
            code_err, ph0, freq_err = replica.errors(rho_edges[j], rho_edges[j + 1], phase_true[j], phase_true[j + 1],
                                                     T)
            ch_out = channel.checked_step(correlators.inputs(code_err, ph0, freq_err, t_edges[k] + T / 2, replica, k))
            nav_out = nav.checked_step(replica.nav_inputs(ch_out, sat_mids, sat_edges, k, T, batch))
            record.epoch(k, j, nav_out, x_true[j], ch_out, code_err, freq_err)
            replica.steer(nav_out[names.NCO_RANGE_M], nav_out[names.NCO_RANGE_RATE_M_S])
        record.block_nees(k0, k1)
    return record.result(t_edges[:-1] + T / 2)


class _CorrelatorSource:
    """The correlators of each interval, drawn from the replica's true errors, with the
    data bit of the interval (Zou et al. 2018, eqs. 2-7 through `CorrelatorSimulator`),
    and the signal and noise gains of a C/N0 fade if the truth has one."""

    def __init__(self, simulator: CorrelatorSimulator, amplitude: np.ndarray, bits: np.ndarray | None,
                 bits_known: bool, rng: np.random.Generator, signal_gain: np.ndarray | None = None,
                 noise_gain: np.ndarray | None = None) -> None:
        self.simulator, self.amplitude, self.rng = simulator, amplitude, rng
        self.bits, self.bits_f = bits, (bits.astype(float) if bits is not None else None)
        self.bits_known = bits_known
        self.signal_gain, self.noise_gain = signal_gain, noise_gain

    def inputs(self, code_err: np.ndarray, ph0: np.ndarray, freq_err: np.ndarray, t_mid_s: float,
               replica: _Replica, k: int = 0) -> dict[str, np.ndarray]:
        """The channel filter's step inputs at interval ``k``, whose middle is ``t_mid_s``."""
        i_bit = int(t_mid_s // BIT_PERIOD_S)
        bit = self.bits_f[i_bit] if self.bits_f is not None else 1.0
        if self.signal_gain is None and self.noise_gain is None:
            corr = self.simulator.draw(code_err, ph0, freq_err, self.amplitude, self.rng, bit)
        else:  # a fade: draw at the amplitude relative to the noise, then scale both by the noise gain
            g_s = 1.0 if self.signal_gain is None else self.signal_gain[k]
            g_n = 1.0 if self.noise_gain is None else self.noise_gain[k]
            c = self.simulator.draw(code_err, ph0, freq_err, self.amplitude * g_s / g_n, self.rng, bit)
            corr = Correlators.trusted(c.early * g_n, c.prompt * g_n, c.late * g_n)
        inputs = {names.CORRELATORS: corr, names.NCO_SHIFT_CHIPS: replica.shift_chips,
                  names.NCO_SHIFT_HZ: replica.shift_hz}
        if self.bits_known:
            inputs[names.DATA_BIT] = self.bits[i_bit]
        return inputs


class _Replica:
    """The code and carrier NCOs of every channel: the range and rate they hold over the
    current interval, the replica's carrier phase at its start, and how far the last
    command moved them (``nco_shift_chips``, ``nco_shift_hz``)."""

    def __init__(self, range_m: np.ndarray, rate_m_s: np.ndarray, batch: tuple[int, int]) -> None:
        self.range_m, self.rate_m_s = range_m, rate_m_s
        self.carrier_rad = np.zeros(batch)
        self.shift_chips = np.zeros(batch)
        self.shift_hz = np.zeros(batch)
        self._range_end_m = self._carrier_end_rad = None

    @classmethod
    def from_estimate(cls, truth: VectorTruth, initial_state: np.ndarray, batch: tuple[int, int]) -> _Replica:
        """The first NCO command: the initial estimate's range and rate at mid-interval,
        propagated back to t_0."""
        T = truth.coherent_time_s
        s_mid, sv_mid = truth.sat_state(np.asarray(T / 2))
        rho0, rate0, _ = predicted_range(initial_state, s_mid, sv_mid)
        return cls(rho0 - rate0 * T / 2, rate0, batch)

    def errors(self, true_rho: np.ndarray, next_rho: np.ndarray, phase_start: np.ndarray, phase_end: np.ndarray,
               T: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """True code error (chips, mean over the interval), carrier phase error at its start
        (rad) and frequency error (Hz) of the replica against the true signal."""
        self._range_end_m = self.range_m + self.rate_m_s * T
        code_err = 0.5 * ((true_rho - self.range_m) + (next_rho - self._range_end_m)) / CA_CHIP_LENGTH_M
        f_rep = -self.rate_m_s / L1_WAVELENGTH_M
        ph0 = phase_start - self.carrier_rad
        self._carrier_end_rad = self.carrier_rad + 2 * np.pi * f_rep * T
        ph1 = phase_end - self._carrier_end_rad
        return code_err, ph0, (ph1 - ph0) / (2 * np.pi * T)

    def nav_inputs(self, ch_out: dict[str, np.ndarray], sat_mids, sat_edges, k: int, T: float,
                   batch: tuple[int, int]) -> dict[str, np.ndarray]:
        """The nav filter's step inputs: the channel outputs, the satellites at mid-interval
        and at the next edge, and the replica's range and rate at mid-interval."""
        nav_in = dict(ch_out)
        rate = self.rate_m_s
        nav_in.update({names.SAT_POS_M: sat_mids[0][k], names.SAT_VEL_M_S: sat_mids[1][k],
                       names.NEXT_SAT_POS_M: sat_edges[0][k + 1], names.NEXT_SAT_VEL_M_S: sat_edges[1][k + 1],
                       names.REPLICA_RANGE_M: self.range_m + rate * T / 2,
                       names.REPLICA_RATE_M_S: rate if rate.shape == batch else np.broadcast_to(rate, batch)})
        return nav_in

    def steer(self, new_range_m: np.ndarray, new_rate_m_s: np.ndarray) -> None:
        """Take the nav filter's command for the next interval (after `errors` of this one)."""
        self.shift_chips = (new_range_m - self._range_end_m) / CA_CHIP_LENGTH_M
        self.shift_hz = -(new_rate_m_s - self.rate_m_s) / L1_WAVELENGTH_M
        self.range_m, self.rate_m_s = new_range_m, new_rate_m_s
        self.carrier_rad = self._carrier_end_rad


class _Recorder:
    """The run's series: the replica's true errors, the channel outputs' errors, the nav
    state's error and, per block of epochs, its NEES."""

    def __init__(self, K: int, runs: int, batch: tuple[int, int]) -> None:
        self.code, self.freq, self.code_out, self.freq_out = (np.empty((K,) + batch) for _ in range(4))
        self.err = np.empty((K, runs, 8))
        self.nees, self.nees_pos, self.nees_vel = (np.empty((K, runs)) for _ in range(3))
        self.cov = np.empty((max(1, min(K, _BLOCK)), runs, 8, 8))

    def epoch(self, k: int, j: int, nav_out: dict[str, np.ndarray], x_true: np.ndarray, ch_out: dict[str, np.ndarray],
              code_err: np.ndarray, freq_err: np.ndarray) -> None:
        est = np.concatenate([nav_out[names.POSITION_M], nav_out[names.VELOCITY_M_S], nav_out[names.CLOCK_M]], axis=-1)
        np.subtract(est, x_true, out=self.err[k])
        self.cov[j] = nav_out[names.COV]  # a copy: a nav filter may reuse its array
        self.code[k] = code_err
        self.freq[k] = freq_err
        self.code_out[k] = ch_out[names.CODE_ERROR_CHIPS] - code_err
        self.freq_out[k] = ch_out[names.FREQ_ERROR_HZ] - freq_err

    def block_nees(self, k0: int, k1: int) -> None:
        """NEES of the block's epochs in three batched solves instead of three per epoch."""
        err, cov = self.err[k0:k1], self.cov[:k1 - k0]
        self.nees[k0:k1] = nees(err, cov)
        self.nees_pos[k0:k1] = nees(err[..., 0:3], cov[..., 0:3, 0:3])
        self.nees_vel[k0:k1] = nees(err[..., 3:6], cov[..., 3:6, 3:6])

    def result(self, time_s: np.ndarray) -> VectorRecord:
        return VectorRecord(self.code, self.freq, self.err[..., 0:3], self.err[..., 3:6], self.nees, time_s,
                            nees_position=self.nees_pos, nees_velocity=self.nees_vel,
                            code_output_error_chips=self.code_out, freq_output_error_hz=self.freq_out)


def _block_truth(truth: VectorTruth, sat_pos_edges: np.ndarray, t_edges: np.ndarray, theta0: np.ndarray, k0: int,
                 k1: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The truth of epochs ``k0..k1`` in a few vectorised calls: the true code pseudoranges
    and carrier phases (rad) at the edges, and the true nav states at the mid-intervals.
    Errors the receiver's model lacks (`VectorTruth.range_error_m`) make code and carrier differ."""
    rho_edges, x_true = _truth_block(truth, sat_pos_edges, t_edges, k0, k1)
    carrier_edges = rho_edges
    if truth.range_error_m is not None:
        code_m, carrier_m = truth.range_error_m(t_edges[k0:k1 + 1])
        rho_edges, carrier_edges = rho_edges + code_m, rho_edges + carrier_m
    return rho_edges, theta0 - 2 * np.pi * carrier_edges / L1_WAVELENGTH_M, x_true


#: Epochs whose truth (and NEES) the loop computes in one vectorised pass.
_BLOCK = 256


def _truth_block(truth: VectorTruth, sat_pos_edges: np.ndarray, t_edges: np.ndarray, k0: int, k1: int
                 ) -> tuple[np.ndarray, np.ndarray]:
    """True pseudoranges at the edges ``k0..k1`` ``(k1-k0+1, runs, ch)`` and the true
    navigation states at the mid-intervals ``k0..k1-1`` ``(k1-k0, runs, 8)``: the values of
    `VectorTruth.pseudorange` and `VectorTruth.nav_truth` at each epoch, in one call each."""
    T = truth.coherent_time_s
    edges = np.arange(k0, k1 + 1)
    r, _ = truth.receiver_state(t_edges[k0:k1 + 1])
    s = sat_pos_edges[k0:k1 + 1]
    rho = ranges_from_receivers(s, r) + truth.clock_m[edges, :, 0][..., None]
    tm = t_edges[k0:k1] + T / 2
    ks = edges[:-1]
    r, v = truth.receiver_state(tm)
    frac = ((tm / T) - ks)[:, None, None]
    clock = (1 - frac) * truth.clock_m[ks] + frac * truth.clock_m[np.minimum(ks + 1, truth.epochs)]
    return rho, np.concatenate([r, v, clock], axis=-1)


def predicted_range(x: np.ndarray, sat_pos: np.ndarray, sat_vel: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pseudorange, rate and unit line of sight for nav states ``x`` ``(..., 8)``.

    States ``[x, y, z, vx, vy, vz, b, d]`` with any leading dimensions (runs, sigma
    points); satellites ``(ch, 3)`` or ``(..., ch, 3)``. Returns ``rho (..., ch)``,
    ``rate (..., ch)`` and ``e (..., ch, 3)``, the unit vector from receiver to satellite:

    $$
    \\rho = \\lVert s - r \\rVert + b, \\qquad \\dot\\rho = (v_s - v) \\cdot e + d
    $$
    """
    dist, e = line_of_sight(sat_pos, x[..., None, :3])
    rate = range_rate(sat_vel, x[..., None, 3:6], e) + x[..., None, 7]
    return dist + x[..., None, 6], rate, e
