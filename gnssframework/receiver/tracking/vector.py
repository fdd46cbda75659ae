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

from ... import random_streams as draw
from ...errors import ConfigError
from ...estimation.consistency import nees
from ...interfaces import ChannelFilter, NavFilter, RunContext
from ...navigation.geometry import line_of_sight, range_rate, ranges_from_receivers
from ...signal.constants import CA_CHIP_LENGTH_M, L1_WAVELENGTH_M
from ...signal.correlator_model import CorrelatorSimulator, amplitude_from_cn0
from ...signal.navdata import BIT_PERIOD_S, random_nav_bits

__all__ = ["VectorTruth", "VectorRecord", "run_vector_loop", "check_composition", "predicted_range",
           "CHANNEL_OUTPUTS", "NAV_OUTPUTS", "HARNESS_INPUTS"]

#: What a channel filter must provide to feed a vector loop's nav filter.
CHANNEL_OUTPUTS = ("code_error_chips", "code_error_var_chips2", "freq_error_hz", "freq_error_var_hz2")
#: What a nav filter must provide to close a vector loop.
NAV_OUTPUTS = ("position_m", "velocity_m_s", "clock_m", "cov", "nco_range_m", "nco_range_rate_m_s")


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
    """

    sat_state: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]
    receiver_state: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]
    clock_m: np.ndarray
    cn0_dbhz: np.ndarray
    coherent_time_s: float
    range_error_m: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]] | None = None

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
HARNESS_INPUTS = ("sat_pos_m", "sat_vel_m_s", "next_sat_pos_m", "next_sat_vel_m_s", "replica_range_m",
                  "replica_rate_m_s")


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
    T = truth.coherent_time_s
    K = truth.epochs
    t_edges = np.arange(K + 1) * T
    runs = truth.clock_m.shape[1]
    # Satellite states at every epoch edge and mid-interval, in two vectorised calls
    # instead of two orbit evaluations per epoch.
    sat_edges = truth.sat_state(t_edges)
    sat_mids = truth.sat_state(t_edges[:-1] + T / 2)
    n_ch = sat_edges[0].shape[-2]
    batch = (runs, n_ch)
    cn0 = np.broadcast_to(np.asarray(truth.cn0_dbhz, float), batch)

    theta0 = draw.uniform(rng, -np.pi, np.pi, batch, 0)  # unknown initial carrier phase per channel
    bits = random_nav_bits(int(np.ceil(K * T / BIT_PERIOD_S)) + 1, rng, batch) if data_bits != "none" else None
    bits_f = bits.astype(float) if bits is not None else None

    context = RunContext(coherent_time_s=T, early_late_spacing_chips=early_late_spacing_chips, epoch_interval_s=T,
                         cn0_dbhz=cn0, initial_state=initial_state, initial_cov=initial_cov)
    channel.reset(batch, context)
    nav.reset((runs,), context)
    # Per-run constants of the correlator draws (tap offsets, noise root, amplitude).
    simulator = CorrelatorSimulator(T, early_late_spacing_chips)
    amplitude = amplitude_from_cn0(cn0, T)

    # First NCO command from the initial estimate, propagated back to t_0.
    s_mid, sv_mid = truth.sat_state(np.asarray(T / 2))
    rho0, rate0, _ = predicted_range(initial_state, s_mid, sv_mid)
    nco_range = rho0 - rate0 * T / 2
    nco_rate = rate0
    carrier_rep = np.zeros(batch)
    shift_chips = np.zeros(batch)
    shift_hz = np.zeros(batch)

    code_rec, freq_rec, code_out_rec, freq_out_rec = (np.empty((K,) + batch) for _ in range(4))
    err_rec = np.empty((K, runs, 8))
    nees_rec, nees_pos_rec, nees_vel_rec = (np.empty((K, runs)) for _ in range(3))
    block = max(1, min(K, _BLOCK))
    cov_buf = np.empty((block, runs, 8, 8))
    for k0 in range(0, K, block):
        k1 = min(K, k0 + block)
        # The truth of a block of epochs in a few vectorised calls: true pseudoranges and
        # carrier phases at the edges, the true navigation state at the mid-intervals.
        rho_edges, x_true = _truth_block(truth, sat_edges[0], t_edges, k0, k1)
        carrier_edges = rho_edges
        if truth.range_error_m is not None:  # errors the receiver's model lacks (code and carrier differ)
            code_m, carrier_m = truth.range_error_m(t_edges[k0:k1 + 1])
            rho_edges, carrier_edges = rho_edges + code_m, rho_edges + carrier_m
        phase_true = theta0 - 2 * np.pi * carrier_edges / L1_WAVELENGTH_M
        for k in range(k0, k1):
            j = k - k0
            true_rho, next_rho = rho_edges[j], rho_edges[j + 1]
            tm = t_edges[k] + T / 2
            rep_end = nco_range + nco_rate * T
            code_err = 0.5 * ((true_rho - nco_range) + (next_rho - rep_end)) / CA_CHIP_LENGTH_M
            f_rep = -nco_rate / L1_WAVELENGTH_M
            ph0 = phase_true[j] - carrier_rep
            carrier_rep_end = carrier_rep + 2 * np.pi * f_rep * T
            ph1 = phase_true[j + 1] - carrier_rep_end
            freq_err = (ph1 - ph0) / (2 * np.pi * T)
            i_bit = int(tm // BIT_PERIOD_S)
            corr = simulator.draw(code_err, ph0, freq_err, amplitude, rng,
                                  bits_f[i_bit] if bits_f is not None else 1.0)
            inputs = {"correlators": corr, "nco_shift_chips": shift_chips, "nco_shift_hz": shift_hz}
            if data_bits == "known":
                inputs["data_bit"] = bits[i_bit]
            ch_out = channel.checked_step(inputs)

            nav_in = dict(ch_out)
            nav_in.update(sat_pos_m=sat_mids[0][k], sat_vel_m_s=sat_mids[1][k], next_sat_pos_m=sat_edges[0][k + 1],
                          next_sat_vel_m_s=sat_edges[1][k + 1], replica_range_m=nco_range + nco_rate * T / 2,
                          replica_rate_m_s=nco_rate if nco_rate.shape == batch else np.broadcast_to(nco_rate, batch))
            nav_out = nav.checked_step(nav_in)

            est = np.concatenate([nav_out["position_m"], nav_out["velocity_m_s"], nav_out["clock_m"]], axis=-1)
            np.subtract(est, x_true[j], out=err_rec[k])
            cov_buf[j] = nav_out["cov"]  # a copy: a nav filter may reuse its array
            code_rec[k] = code_err
            freq_rec[k] = freq_err
            code_out_rec[k] = ch_out["code_error_chips"] - code_err
            freq_out_rec[k] = ch_out["freq_error_hz"] - freq_err

            new_range, new_rate = nav_out["nco_range_m"], nav_out["nco_range_rate_m_s"]
            shift_chips = (new_range - rep_end) / CA_CHIP_LENGTH_M
            shift_hz = -(new_rate - nco_rate) / L1_WAVELENGTH_M
            nco_range, nco_rate = new_range, new_rate
            carrier_rep = carrier_rep_end
        # NEES of the block's epochs in three batched solves instead of three per epoch.
        err, cov = err_rec[k0:k1], cov_buf[:k1 - k0]
        nees_rec[k0:k1] = nees(err, cov)
        nees_pos_rec[k0:k1] = nees(err[..., 0:3], cov[..., 0:3, 0:3])
        nees_vel_rec[k0:k1] = nees(err[..., 3:6], cov[..., 3:6, 3:6])
    return VectorRecord(code_rec, freq_rec, err_rec[..., 0:3], err_rec[..., 3:6], nees_rec,
                        t_edges[:-1] + T / 2, nees_position=nees_pos_rec, nees_velocity=nees_vel_rec,
                        code_output_error_chips=code_out_rec, freq_output_error_hz=freq_out_rec)


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
