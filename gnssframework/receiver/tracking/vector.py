"""Vector tracking: channel filters -> navigation filter -> NCO commands, every epoch.

A composition of the loop engine (`gnssframework.receiver.engine`): `Channel` NCOs steered
by range, a correlator source (the `AnalyticSource` by default, or IF samples of the same
truth: ``source``) and a `VectorCloser`. The loop is batched over Monte Carlo
runs (axis 0) and channels (axis 1). Each
coherent interval k, from $t_k$ to $t_{k+1} = t_k + T$:

1. the replica of channel i runs from the NCO command
   ($\\hat\\rho_i(t_k)$, $\\dot{\\hat\\rho}_i$), so its code error and carrier phase and
   frequency errors against the true signal are known to the simulation (`Channel.errors`);
2. the correlators those errors produce are drawn (`simulate_correlators`);
3. the channel filter turns them into code-phase and carrier-frequency errors with
   their variances (``code_error_chips``, ``code_error_var_chips2``,
   ``freq_error_hz``, ``freq_error_var_hz2``);
4. the navigation filter takes them as pseudorange and pseudorange-rate errors of
   the replica at mid-interval (Zou et al. 2018, eqs. 35-36),
   $\\delta\\rho = -\\lambda_{chip}\\, \\delta\\tau$ and $\\delta\\dot\\rho = -\\lambda_{L1}\\, \\delta f$,
   and returns the NCO command of the next interval (``nco_range_m``,
   ``nco_range_rate_m_s``);
5. the channel filter is told how far its replica moved (``nco_shift_chips``,
   ``nco_shift_hz``), so it can keep its error states relative to the replica.

Signs: the engine's (`gnssframework.receiver.engine.channel`): code error = true minus
replica code phase (chips), so a range error $-\\lambda_{chip}\\,\\delta\\tau$ (the nav
filter's ``code_error_chips`` input is the range error in chips, `VectorCloser` negates);
frequency error = true minus replica Doppler (Hz), with the Doppler
$f = -\\dot\\rho / \\lambda_{L1}$. (Before the engine this loop drew its correlators at the
range error in chips, the opposite sign of the sample receiver's; the draws are now the
mirror image, E and L exchanged, of the same law.)
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ... import names
from ... import random_streams as draw
from ...errors import ConfigError
from ...estimation.consistency import nees
from ...interfaces import ChannelFilter, NavFilter, RunContext
from ...navigation.geometry import enu_rotation, line_of_sight, range_rate, ranges_from_receivers
from ...estimation.types import Update
from ...navigation.filter_integrity import normalised_innovation_squared
from ...navigation.integrity import covariance_protection_levels
from ...signal.correlator_model import CorrelatorSimulator, amplitude_from_cn0
from ...signal.navdata import random_nav_bits
from ..engine.channel import Channel
from ..engine.channel_monitor import ChannelMonitor
from ..engine.closers import CHANNEL_OUTPUTS, HARNESS_INPUTS, NAV_OUTPUTS, VectorCloser, check_composition
from ..engine.sources import AnalyticSource, CorrelatorSource
from ..engine.truth import LoopTruth, VectorTruth, code_phase_of_range

__all__ = [
    "VectorTruth",
    "VectorRecord",
    "run_vector_loop",
    "check_composition",
    "predicted_range",
    "enu_rotation",
    "smooth_record",
    "CHANNEL_OUTPUTS",
    "NAV_OUTPUTS",
    "HARNESS_INPUTS",
]


@dataclass
class VectorRecord:
    """Time series of a vector-tracking run, time on axis 0 (K intervals)."""

    code_error_chips: np.ndarray  # (K, runs, ch) true code error of the replica (truth minus replica code phase)
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
    #: (K, runs, 3) position error in east, north, up at the true position (m), and with
    #: ``integrity_risk`` the protection levels of the nav filter's covariance (K, runs)
    #: (`navigation.integrity.covariance_protection_levels`).
    position_error_enu_m: np.ndarray | None = None
    hpl_m: np.ndarray | None = None
    vpl_m: np.ndarray | None = None
    #: With ``store_estimates``: the nav filter's posterior states (K, runs, 8) and their
    #: covariances (K, runs, 8, 8), what `smooth_record` smooths.
    estimate: np.ndarray | None = None
    estimate_cov: np.ndarray | None = None
    #: (K, runs) the nav filter's normalised innovation squared :math:`\nu^T S^{-1} \nu` of
    #: the channels in its update (those the monitor left out dropped) and its degrees of
    #: freedom, the rows used (`navigation.filter_integrity`); None for a nav filter that
    #: does not keep its ``last_step``.
    nis: np.ndarray | None = None
    nis_dof: np.ndarray | None = None


def run_vector_loop(
    channel: ChannelFilter,
    nav: NavFilter,
    truth: LoopTruth,
    initial_state: np.ndarray,
    initial_cov: np.ndarray,
    rng: np.random.Generator,
    *,
    early_late_spacing_chips: float = 1.0,
    data_bits: str = "known",
    monitor: ChannelMonitor | None = None,
    integrity_risk: float | None = None,
    store_estimates: bool = False,
    innovations: bool = False,
    source: CorrelatorSource | None = None,
    initial_carrier_phase_rad: np.ndarray | None = None,
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
    monitor
        A `ChannelMonitor` screening each channel's innovation (`VectorCloser`); its
        exclusions per interval are recorded in ``extra["excluded"]`` ``(K, runs, ch)``.
    integrity_risk
        With it, each epoch's horizontal and vertical protection levels of the nav filter's
        position covariance at this fault-free integrity risk (`VectorRecord.hpl_m`).
    store_estimates
        Keep every epoch's posterior state and covariance (`VectorRecord.estimate`, 576
        bytes per epoch and run) for `smooth_record`.
    innovations
        Record the nav filter's normalised innovation squared each epoch
        (`VectorRecord.nis`; one batched solve of the innovation covariance per epoch) if
        it keeps its ``last_step``.
    source
        Where the correlators come from (`gnssframework.receiver.engine.sources`): None,
        the analytic model at the replica's true errors (`AnalyticSource`, drawn from
        ``rng`` with the truth's C/N0 and gains); or any other source, e.g. IF samples of
        this truth (`SampleSource` of `engine.truth_samples.truth_samples`), which carry
        their own noise, C/N0 and carrier phases (then give those phases below and
        ``data_bits = "none"``, the samples having no data).
    initial_carrier_phase_rad
        ``(runs, channels)`` true carrier phases at t = 0 (rad); None: drawn uniform from
        ``rng`` (the analytic model's unknown initial phase).
    """
    closer = VectorCloser(channel, nav, monitor)
    if data_bits not in ("none", "known", "unknown"):
        raise ConfigError("scenario.data_bits", f"got {data_bits!r}; allowed: none, known, unknown")
    T, K = truth.coherent_time_s, truth.epochs
    signal = truth.signal
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
            raise ConfigError(
                f"truth.{name}", f"must have the shape (epochs, runs, channels) = {(K,) + batch}, got {np.shape(gain)}"
            )

    if initial_carrier_phase_rad is None:  # unknown initial carrier phase per channel
        theta0 = draw.uniform(rng, -np.pi, np.pi, batch, 0)
    elif np.shape(initial_carrier_phase_rad) != batch:
        raise ConfigError(
            "initial_carrier_phase_rad",
            f"must have the shape (runs, channels) = {batch}, got {np.shape(initial_carrier_phase_rad)}",
        )
    else:
        theta0 = np.asarray(initial_carrier_phase_rad, float)
    if source is not None and data_bits != "none":
        raise ConfigError(
            "data_bits",
            f"got {data_bits!r} with a correlator source of its own: its samples carry no "
            "data the loop draws; use 'none'",
        )
    bit_period_s = signal.symbol_period_s
    bits = random_nav_bits(int(np.ceil(K * T / bit_period_s)) + 1, rng, batch) if data_bits != "none" else None
    bits_f = bits.astype(float) if bits is not None else None
    context = RunContext(
        coherent_time_s=T,
        early_late_spacing_chips=early_late_spacing_chips,
        epoch_interval_s=T,
        cn0_dbhz=cn0,
        initial_state=initial_state,
        initial_cov=initial_cov,
    )
    # The first NCO command: the initial estimate's range and rate at mid-interval, propagated back to t_0.
    s_mid, sv_mid = truth.sat_state(np.asarray(T / 2))[:2]
    rho0, rate0, _ = predicted_range(initial_state, s_mid, sv_mid)
    replica = Channel.from_range(batch, rho0 - rate0 * T / 2, rate0, t_s=0.0, signal=signal)
    closer.reset(replica, context)
    if source is None:
        source = AnalyticSource(
            CorrelatorSimulator(T, early_late_spacing_chips),
            amplitude_from_cn0(cn0, T),
            rng,
            signal_gain=truth.signal_gain,
            noise_gain=truth.noise_gain,
        )
    record = _Recorder(K, runs, batch, integrity_risk, store_estimates)
    excluded = np.zeros((K,) + batch, bool) if monitor is not None else None

    block = max(1, min(K, _BLOCK))
    for k0 in range(0, K, block):
        k1 = min(K, k0 + block)
        code_edges, phase_true, x_true = _block_truth(truth, sat_edges[0], t_edges, theta0, k0, k1)
        for k in range(k0, k1):
            j = k - k0
            err = replica.errors(code_edges[j], code_edges[j + 1], phase_true[j], phase_true[j + 1], T)
            i_bit = int((t_edges[k] + T / 2) // bit_period_s)
            corr = source.correlate(replica, k, err, bits_f[i_bit] if bits_f is not None else 1.0)
            ch_out = closer.channel_step(replica, corr, bits[i_bit] if data_bits == "known" else None)
            geometry = {
                names.SAT_POS_M: sat_mids[0][k],
                names.SAT_VEL_M_S: sat_mids[1][k],
                names.NEXT_SAT_POS_M: sat_edges[0][k + 1],
                names.NEXT_SAT_VEL_M_S: sat_edges[1][k + 1],
            }
            nav_out = closer.nav_step(replica, ch_out, geometry, T, t_edges[k + 1])
            record.epoch(k, j, nav_out, x_true[j], ch_out, err.code_chips, err.freq_hz)
            last = getattr(nav, "last_step", None) if innovations else None
            if last is not None:
                record.innovation(k, last.update, None if monitor is None else monitor.excluded)
            if monitor is not None:
                excluded[k] = monitor.excluded
        record.block_nees(k0, k1)
    result = record.result(t_edges[:-1] + T / 2)
    if excluded is not None:
        result.extra["excluded"] = excluded
    return result


class _Recorder:
    """The run's series: the replica's true errors, the channel outputs' errors, the nav
    state's error and, per block of epochs, its NEES, its position error in east, north,
    up and (with ``integrity_risk``) the protection levels of its covariance."""

    def __init__(
        self,
        K: int,
        runs: int,
        batch: tuple[int, int],
        integrity_risk: float | None = None,
        store_estimates: bool = False,
    ) -> None:
        self.code, self.freq, self.code_out, self.freq_out = (np.empty((K,) + batch) for _ in range(4))
        self.err = np.empty((K, runs, 8))
        self.nees, self.nees_pos, self.nees_vel = (np.empty((K, runs)) for _ in range(3))
        block = max(1, min(K, _BLOCK))
        self.cov = np.empty((block, runs, 8, 8))
        self.true_pos = np.empty((block, runs, 3))
        self.err_enu = np.empty((K, runs, 3))
        self.integrity_risk = integrity_risk
        self.hpl: np.ndarray | None = None
        self.vpl: np.ndarray | None = None
        if integrity_risk is not None:
            self.hpl, self.vpl = np.empty((K, runs)), np.empty((K, runs))
        self.est = np.empty((K, runs, 8)) if store_estimates else None
        self.est_cov = np.empty((K, runs, 8, 8)) if store_estimates else None
        self.nis: np.ndarray | None = None
        self.nis_dof: np.ndarray | None = None

    def epoch(
        self,
        k: int,
        j: int,
        nav_out: dict[str, np.ndarray],
        x_true: np.ndarray,
        ch_out: dict[str, np.ndarray],
        code_err: np.ndarray,
        freq_err: np.ndarray,
    ) -> None:
        est = np.concatenate([nav_out[names.POSITION_M], nav_out[names.VELOCITY_M_S], nav_out[names.CLOCK_M]], axis=-1)
        np.subtract(est, x_true, out=self.err[k])
        self.cov[j] = nav_out[names.COV]  # a copy: a nav filter may reuse its array
        if self.est is not None and self.est_cov is not None:
            self.est[k], self.est_cov[k] = est, self.cov[j]
        self.true_pos[j] = x_true[..., 0:3]
        self.code[k] = code_err
        self.freq[k] = freq_err
        self.code_out[k] = ch_out[names.CODE_ERROR_CHIPS] - code_err
        self.freq_out[k] = ch_out[names.FREQ_ERROR_HZ] - freq_err

    def innovation(self, k: int, update: Update, excluded: np.ndarray | None) -> None:
        """The nav filter's NIS at epoch ``k`` without the rows of the ``excluded`` channels
        ``(runs, ch)`` (measurements stacked per channel block: ranges, then rates)."""
        K, runs = self.nees.shape
        if self.nis is None or self.nis_dof is None:
            self.nis, self.nis_dof = np.full((K, runs), np.nan), np.zeros((K, runs), int)
        m, ch = update.innovation.shape[-1], self.code.shape[-1]
        used = None if excluded is None or m % ch else np.tile(~excluded, m // ch)
        self.nis[k], self.nis_dof[k] = normalised_innovation_squared(update.innovation, update.innovation_cov, used)

    def block_nees(self, k0: int, k1: int) -> None:
        """NEES of the block's epochs in three batched solves instead of three per epoch."""
        err, cov = self.err[k0:k1], self.cov[: k1 - k0]
        self.nees[k0:k1] = nees(err, cov)
        self.nees_pos[k0:k1] = nees(err[..., 0:3], cov[..., 0:3, 0:3])
        self.nees_vel[k0:k1] = nees(err[..., 3:6], cov[..., 3:6, 3:6])
        R = enu_rotation(self.true_pos[: k1 - k0])  # (block, runs, 3, 3), at the true positions
        self.err_enu[k0:k1] = np.einsum("...ij,...j->...i", R, err[..., 0:3])
        if self.hpl is not None and self.vpl is not None and self.integrity_risk is not None:
            cov_enu = R @ cov[..., 0:3, 0:3] @ np.swapaxes(R, -1, -2)
            self.hpl[k0:k1], self.vpl[k0:k1] = covariance_protection_levels(cov_enu, self.integrity_risk)

    def result(self, time_s: np.ndarray) -> VectorRecord:
        return VectorRecord(
            self.code,
            self.freq,
            self.err[..., 0:3],
            self.err[..., 3:6],
            self.nees,
            time_s,
            nees_position=self.nees_pos,
            nees_velocity=self.nees_vel,
            code_output_error_chips=self.code_out,
            freq_output_error_hz=self.freq_out,
            position_error_enu_m=self.err_enu,
            hpl_m=self.hpl,
            vpl_m=self.vpl,
            estimate=self.est,
            estimate_cov=self.est_cov,
            nis=self.nis,
            nis_dof=self.nis_dof,
        )


def smooth_record(
    record: VectorRecord, transition: tuple[np.ndarray, np.ndarray], initial_state: np.ndarray, initial_cov: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""Fixed-interval RTS smoothing of a run's nav estimates (`run_vector_loop` with
    ``store_estimates``): the smoothed position and velocity errors ``(K, runs, 3)`` each
    and the smoothed covariances ``(K, runs, 8, 8)``.

    The loop's nav filter predicts its posterior :math:`m_{k-1}, P_{k-1}` over one interval
    by its ``transition`` ``(F, Q)``, :math:`m^-_k = F m_{k-1}`,
    :math:`P^-_k = F P_{k-1} F^T + Q`, cross covariance :math:`C_k = P_{k-1} F^T`; the
    first epoch's estimate is updated from ``initial_state``, ``initial_cov`` without a
    prediction (``F = I``, ``Q = 0``). `gnssframework.estimation.smoother.smooth` runs the
    backward pass on those (Särkkä 2013, ch. 8-9). Exact for a filter whose prediction is
    that linear one on the 8 published states (``ekf-pv`` with any engine); the NCO
    feedback does not enter the state's dynamics, so it changes nothing here.

    Raises
    ------
    ConfigError
        Without stored estimates, or a transition that is not 8 x 8.
    """
    from ...estimation.sequence import FilterResult, SmootherInputs
    from ...estimation.smoother import smooth
    from ...estimation.types import Gaussian

    if record.estimate is None or record.estimate_cov is None:
        raise ConfigError("store_estimates", "smoothing needs run_vector_loop(..., store_estimates=True)")
    F, Q = (np.asarray(a, float) for a in transition)
    if F.shape != (8, 8) or Q.shape != (8, 8):
        raise ConfigError("nav_filter", f"smoothing needs the transition of the 8 published states; got F {F.shape}")
    m, P = record.estimate, record.estimate_cov
    K, runs = m.shape[:2]
    x0 = np.broadcast_to(np.asarray(initial_state, float), (runs, 8))
    P0 = np.broadcast_to(np.asarray(initial_cov, float), (runs, 8, 8))
    prior_mean = np.concatenate([x0[None], m[:-1] @ F.T])
    prior_cov = np.concatenate([P0[None], F @ P[:-1] @ F.T + Q])
    cross_cov = np.concatenate([P0[None], P[:-1] @ F.T])
    none = np.zeros((K, runs, 0))
    result = FilterResult(
        m,
        P,
        none,
        none[..., None],
        np.broadcast_to(Q, (K, 8, 8)),
        none[..., None],
        np.zeros((K, runs), bool),
        np.arange(K),
        time_s=record.time_s,
        smoother_inputs=SmootherInputs(prior_mean, prior_cov, cross_cov, Gaussian(x0, P0), "solve"),
    )
    s = smooth(result)
    change = s.mean - m  # smoothed minus filtered: the error changes by as much
    return record.position_error_m + change[..., 0:3], record.velocity_error_m_s + change[..., 3:6], s.cov


def _block_truth(
    truth: LoopTruth, sat_pos_edges: np.ndarray, t_edges: np.ndarray, theta0: np.ndarray, k0: int, k1: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The truth of epochs ``k0..k1`` in a few vectorised calls: the true code phases (chips,
    `code_phase_of_range` of the code pseudoranges) and carrier phases (rad) at the edges,
    and the true nav states at the mid-intervals. Errors the receiver's model lacks
    (`LoopTruth.range_error_m`) make code and carrier differ."""
    rho_edges, x_true = _truth_block(truth, sat_pos_edges, t_edges, k0, k1)
    carrier_edges = rho_edges
    if truth.range_error_m is not None:
        code_m, carrier_m = truth.range_error_m(t_edges[k0 : k1 + 1])
        rho_edges, carrier_edges = rho_edges + code_m, rho_edges + carrier_m
    signal = truth.signal
    code = code_phase_of_range(signal, rho_edges, t_edges[k0 : k1 + 1, None, None])
    return code, theta0 - 2 * np.pi * carrier_edges / signal.wavelength_m, x_true


#: Epochs whose truth (and NEES) the loop computes in one vectorised pass.
_BLOCK = 256


def _truth_block(
    truth: LoopTruth, sat_pos_edges: np.ndarray, t_edges: np.ndarray, k0: int, k1: int
) -> tuple[np.ndarray, np.ndarray]:
    """True pseudoranges at the edges ``k0..k1`` ``(k1-k0+1, runs, ch)`` and the true
    navigation states at the mid-intervals ``k0..k1-1`` ``(k1-k0, runs, 8)``: the values of
    `LoopTruth.pseudorange` and `LoopTruth.nav_truth` at each epoch, in one call each."""
    T = truth.coherent_time_s
    edges = np.arange(k0, k1 + 1)
    r = truth.receiver_state(t_edges[k0 : k1 + 1])[0]
    s = sat_pos_edges[k0 : k1 + 1]
    rho = ranges_from_receivers(s, r) + truth.clock_m[edges, :, 0][..., None]
    tm = t_edges[k0:k1] + T / 2
    ks = edges[:-1]
    r, v = truth.receiver_state(tm)[:2]
    frac = ((tm / T) - ks)[:, None, None]
    clock = (1 - frac) * truth.clock_m[ks] + frac * truth.clock_m[np.minimum(ks + 1, truth.epochs)]
    return rho, np.concatenate([r, v, clock], axis=-1)


def predicted_range(
    x: np.ndarray, sat_pos: np.ndarray, sat_vel: np.ndarray
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
