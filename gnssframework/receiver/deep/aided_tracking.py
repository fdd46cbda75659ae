"""Multi-rate aided tracking harness of deep integration (Cai and Guo 2017), batched over runs and channels.

Rates (Cai and Guo 2017, section 3.1): correlators and the code/frequency prefilter every
coherent interval T (1 ms); the NCOs re-aided every ``nco_interval_s`` from the
navigator (the corrected INS at 200 Hz in deep integration); the integration filter
updated every ``update_interval_s`` (10 Hz).

Each coherent interval k:

1. at an aiding instant, the navigator's receiver position, velocity and acceleration
   and clock give each channel's pseudorange, rate and acceleration along the line of
   sight (`aiding.line_of_sight_kinematics`), from which the replica of the next
   NCO interval is laid out (`aiding.nco_schedule`; ``accel_aiding=False`` is the
   ``deep-no-accel`` candidate);
2. the correlators of the replica's true code, phase and frequency errors are drawn
   (the engine's `AnalyticSource`, as the vector loop does);
3. the channel prefilter (a ``channel_filter`` plugin providing the vector loop's
   outputs, e.g. ``iq-filter`` with ``output = "equivalent"``) returns this interval's
   *new* code-phase and frequency information (so nothing is counted twice);
4. the harness accumulates those per channel as a weighted least-squares fit of the
   range residual $\\delta\\rho(t) = \\delta\\rho_u + \\delta\\dot\\rho_u\\,(t - t_u)
   + \\tfrac12\\delta\\ddot\\rho\\,(t - t_u)^2$ and its rate over the integration interval
   (the marginal of range and rate at $t_u$ is handed over), with
   $\\delta\\rho = -\\lambda_{chip}\\,\\delta\\tau$, $\\delta\\dot\\rho = -\\lambda_{L1}\\,\\delta f$
   (the engine's convention, `gnssframework.receiver.engine.channel`: errors are truth minus
   replica code phase and Doppler);
   both taken against the navigator's prediction along the line of sight (the replica
   departs from it without acceleration aiding, by the known $\\tfrac12\\ddot\\rho\\tau^2$);
5. at an integration instant $t_u$ the fit (mean and 2x2 covariance per channel, the
   interval's new information only) goes to the navigator's ``update`` and the
   accumulator is reset (Groves 2013, section 16.3.3).

Optionally (``carrier_filter``) a carrier-phase prefilter per channel, on a phase
discriminator, closes only the carrier loop (Cai and Guo's (2017) carrier-phase filter): its carrier
replica is the aided one plus the filter's own phase and frequency corrections, and
nothing of it goes to the navigator. Its correlators are the same draw rotated by the
corrections' mid-interval phase (a replica offset by a phase $\\varphi_c$ and a frequency
$f_c$ multiplies the prompt's mean by $e^{-j(\\varphi_c + \\pi f_c T)}$; circular noise
keeps its law; the sinc loss of $f_c$, $1 - (\\pi f_c T)^2/6$, is below $10^{-4}$ for
$f_c$ under 10 Hz and is left out). An integration update moves the aided replica's
frequency by the navigator's correction projected on the line of sight; the carrier loop
had already absorbed that error, so the harness moves its correction the other way at the
next re-aiding (the carrier replica stays continuous; without it the loop took each
correction as a frequency step: a 0.5 m/s correction is a 2.6 Hz step, about 1 rad of
transient in a 6 Hz loop, and slipped cycles after the first update). Its tracking error,
the true carrier phase minus that replica's at mid-interval, is recorded as
``extra["phase_error_rad"]``.

Residual sign: true minus the navigator's prediction, so a
navigator position error $\\delta r$ shows as $\\delta\\rho_i = e_i\\cdot\\delta r - \\delta b$.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from ... import random_streams as draw
from ...errors import ConfigError, NumericalError
from ...interfaces import ChannelFilter, RunContext
from ...signal.correlator_model import CorrelatorSimulator, amplitude_from_cn0
from ...signal.gps_l1ca import GPS_L1CA
from ...signal.spec import SignalSpec
from ...signal.correlators import Correlators
from ..engine.channel import ReplicaErrors
from ..engine.closers import CHANNEL_OUTPUTS, range_error_chips
from ..engine.sources import AnalyticSource
from ..engine.truth import DeepTruth, LoopTruth
from .aiding import line_of_sight_kinematics, nco_schedule

__all__ = ["DeepTruth", "Navigator", "DeepRecord", "run_aided_tracking", "loss_of_lock"]


class Navigator(Protocol):
    """What aids the NCOs and takes the prefilters' output (the INS + integration filter slot)."""

    def kinematics(self, t_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Receiver position, velocity, acceleration ``(runs, 3)`` and clock bias, drift ``(runs,)``."""

    def update(self, t_s: float, residual_m: np.ndarray, residual_cov: np.ndarray, los: np.ndarray,
               cn0_dbhz: np.ndarray) -> None:
        """Integration update: residuals ``(runs, ch, 2)`` [range m, rate m/s], covariance ``(runs, ch, 2, 2)``."""


@dataclass
class DeepRecord:
    """Series of an aided-tracking run. Tracking errors every T, prefilter outputs every update."""

    code_error_chips: np.ndarray  # (K, runs, ch) true code error of the replica (truth minus replica code phase)
    freq_error_hz: np.ndarray  # (K, runs, ch) true frequency error
    time_s: np.ndarray  # (K,) mid-interval times
    update_time_s: np.ndarray  # (U,)
    residual_m: np.ndarray  # (U, runs, ch, 2) prefilter output at each update
    residual_cov: np.ndarray  # (U, runs, ch, 2, 2)
    extra: dict[str, np.ndarray] = field(default_factory=dict)


def _steps(interval_s: float, T: float, name: str) -> int:
    n = int(round(interval_s / T))
    if n < 1 or abs(n * T - interval_s) > 1e-9 * max(1.0, interval_s):
        raise ConfigError(name, f"must be a positive multiple of the coherent time {T} s, got {interval_s}")
    return n


def run_aided_tracking(
    channel: ChannelFilter,
    navigator: Navigator,
    truth: LoopTruth,
    rng: np.random.Generator,
    *,
    nco_interval_s: float = 0.005,
    update_interval_s: float = 0.1,
    accel_aiding: bool = True,
    early_late_spacing_chips: float = 1.0,
    pull_in_updates: int = 0,
    carrier_filter: ChannelFilter | None = None,
) -> DeepRecord:
    """Run the aided tracking loop over all epochs of ``truth`` (data bits wiped off).

    Parameters
    ----------
    channel
        Code/frequency prefilter providing `gnssframework.receiver.tracking.vector.CHANNEL_OUTPUTS`
        as each interval's new information (``iq-filter`` with ``output = "equivalent"``).
    navigator
        Aids the NCOs and takes the integration updates (`Navigator`).
    nco_interval_s, update_interval_s
        Multiples of T; ``update_interval_s`` a multiple of ``nco_interval_s``.
    accel_aiding
        Use the line-of-sight acceleration in the replica (Cai and Guo 2017, section 2.3).
    pull_in_updates
        Number of first integration intervals whose prefilter output is recorded but not
        handed to the navigator: the prefilters pull in from their acquisition prior then,
        and that first output is overconfident (the closed loop's position NEES went from
        3.6 to 7.8 for 3 states with it; ``tests/test_deep_ins.py``).
    carrier_filter
        Optional carrier-phase prefilter (a ``channel_filter`` on ``correlators`` that
        provides ``carrier_freq_hz`` and may provide ``carrier_phase_step_rad``, e.g.
        ``kf-carrier-loop``): it closes only the carrier loop on top of the aided
        replica; its outputs are frequency and phase corrections to that replica.
    """
    _check_prefilters(channel, carrier_filter)
    T = truth.coherent_time_s
    n_nco = _steps(nco_interval_s, T, "nco_interval_s")
    n_upd = _steps(update_interval_s, T, "update_interval_s")
    if n_upd % n_nco:
        raise ConfigError("update_interval_s", f"must be a multiple of nco_interval_s ({nco_interval_s} s)")
    loop = _AidedLoop(channel, navigator, truth, rng, n_nco, n_upd, accel_aiding, early_late_spacing_chips,
                      pull_in_updates, carrier_filter)
    for k in range(truth.epochs):
        j = k % n_nco  # coherent interval within its NCO interval
        if j == 0:
            loop.reaid(k)
        corr, out = loop.prefilter_step(j)
        if carrier_filter is not None:
            loop.carrier_step(corr, j)
        loop.accumulate(k % n_upd, out)
        if (k + 1) % n_upd == 0:
            loop.integration_update(k + 1)
        loop.carry(j)
    return loop.record()


def _check_prefilters(channel: ChannelFilter, carrier_filter: ChannelFilter | None) -> None:
    """Refuse, naming the field, prefilters that cannot feed deep integration or close a carrier loop."""
    missing = [n for n in CHANNEL_OUTPUTS if n not in channel.provides]
    if missing:
        raise ConfigError("channel_filter", f"{channel.name!r} cannot feed deep integration: it does not provide "
                          f"{', '.join(missing)}")
    if carrier_filter is not None and ("correlators" not in carrier_filter.requires
                                       or "carrier_freq_hz" not in carrier_filter.provides):
        raise ConfigError("carrier_filter", f"{carrier_filter.name!r} cannot close a carrier loop: it must take "
                          "correlators and provide carrier_freq_hz (e.g. kf-carrier-loop)")


class _AidedLoop:
    """The state `run_aided_tracking` carries between coherent intervals, and its steps.

    One method per step of the module's list: `reaid` (1, and the block of true errors
    of the coming NCO interval), `prefilter_step` (2-3), `carrier_step` (the optional
    carrier loop), `accumulate` (4), `integration_update` (5), and `carry` (what the next
    interval needs of this one's replica).
    """

    def __init__(self, channel: ChannelFilter, navigator: Navigator, truth: LoopTruth, rng: np.random.Generator,
                 n_nco: int, n_upd: int, accel_aiding: bool, early_late_spacing_chips: float, pull_in_updates: int,
                 carrier_filter: ChannelFilter | None) -> None:
        self.channel, self.navigator, self.truth, self.rng = channel, navigator, truth, rng
        self.carrier_filter = carrier_filter
        self.n_nco, self.n_upd, self.accel_aiding, self.pull_in_updates = n_nco, n_upd, accel_aiding, pull_in_updates
        T = self.T = truth.coherent_time_s
        self.K = truth.epochs
        runs = truth.clock_m.shape[1]
        self.sat_at = _EdgeStates(truth, self.K)
        n_ch = self.sat_at(0)[0].shape[-2]  # satellites (ch, 3), or (runs, ch, 3) with a geometry per run
        batch = self.batch = (runs, n_ch)
        self.cn0 = np.broadcast_to(np.asarray(truth.cn0_dbhz, float), batch)
        # Per-run constants of the correlator draws (tap noise root, amplitude) once, not per
        # interval: the same draws and arithmetic as simulate_correlators.
        self.source = AnalyticSource(CorrelatorSimulator(T, early_late_spacing_chips), amplitude_from_cn0(self.cn0, T),
                                     rng)
        self.signal = truth.signal
        self.zeros = np.zeros(batch)
        # Data bits are wiped off (1 everywhere): as an array of the batch's shape the prefilter's
        # wipe-off takes its unchecked path (the same products as with a scalar 1).
        self.ones = np.ones(batch)
        self.theta0 = draw.uniform(rng, -np.pi, np.pi, batch, 0)
        channel.reset(batch, RunContext(coherent_time_s=T, early_late_spacing_chips=early_late_spacing_chips,
                                        epoch_interval_s=T, cn0_dbhz=self.cn0))
        if carrier_filter is not None:
            # Its NCO starts on the aided replica: frequency correction 0 (doppler_hz), phase correction 0.
            carrier_filter.reset(batch, RunContext(coherent_time_s=T, early_late_spacing_chips=early_late_spacing_chips,
                                                   epoch_interval_s=T, cn0_dbhz=self.cn0, doppler_hz=0.0))
            self.corr_phase_rad = np.zeros(batch)
            self.corr_freq_hz = np.zeros(batch)  # the loop's own NCO frequency
            self.transfer_hz = np.zeros(batch)  # navigator corrections taken back out of the aided replica
        self.rate_before_update: np.ndarray | None = None
        self.rec: dict[str, list] = {k: [] for k in ("code", "freq", "tu", "res", "cov", "phase")}
        # The replica as the previous NCO interval left it (None before the first: no shift).
        self.carrier_rep = np.zeros(batch)
        self.rep_end: np.ndarray | None = None
        self.rate_prev: np.ndarray | None = None
        self.slope_prev: np.ndarray | None = None
        # The prefilter outputs of the current integration interval (copied: a plugin may reuse its
        # output arrays) and the NCO blocks they belong to; the fit is formed at the update instant.
        self.fit_out = np.empty((4, n_upd) + batch)  # code error, frequency error and their variances
        self.fit_blocks: list[_AidedBlock] = []

    def reaid(self, k: int) -> None:
        """Aid the NCOs from the navigator at edge ``k`` and lay out the replica of the coming
        NCO interval, with its true tracking errors and the navigator's predictions."""
        T = self.T
        t0 = k * T
        p, v, a, b, d = self.navigator.kinematics(t0)
        _check_finite(type(self.navigator).__name__, k, p, v, a, b, d)
        s, sv, sa = self.sat_at(k)
        rho, rate, acc, los = line_of_sight_kinematics(p, v, a, s, sv, sa, b, d)
        self.sched_range, self.sched_rate = nco_schedule(rho, rate, acc, T, self.n_nco, accel_aiding=self.accel_aiding)
        if self.carrier_filter is not None and self.rate_before_update is not None:
            # The update's correction of the predicted rate (f = -rate / lambda), undone on the carrier side.
            self.transfer_hz -= -(rate - self.rate_before_update) / self.signal.wavelength_m
            self.rate_before_update = None
        self.slope_new = acc if self.accel_aiding else np.zeros_like(rate)
        # The replica is laid out until the next re-aiding and the truth is known, so the true
        # tracking errors and the navigator's predictions of this NCO interval's coherent
        # intervals are computed at once (the same arithmetic per element as interval by interval).
        blk = self.blk = _aided_block(self.sat_at, k, min(self.n_nco, self.K - k), T, self.n_upd, self.sched_range,
                                      self.sched_rate, rho, rate, acc, t0, self.theta0, self.carrier_rep, self.rep_end,
                                      self.rate_prev, self.slope_prev if self.rate_prev is not None else None,
                                      self.slope_new, self.zeros)
        self.fit_blocks.append(blk)
        self.rec["code"].append(blk.code_err)
        self.rec["freq"].append(blk.freq_err)

    def prefilter_step(self, j: int):
        """Draw the correlators of coherent interval ``j`` of the NCO interval and step the
        code/frequency prefilter on them: ``(correlators, its outputs)``."""
        blk = self.blk
        corr = self.source.correlate(None, j, ReplicaErrors(blk.code_err[j], blk.ph0[j], blk.freq_err[j]))
        out = self.channel.checked_step({"correlators": corr, "nco_shift_chips": blk.shift_chips[j],
                                         "nco_shift_hz": blk.shift_hz[j], "data_bit": self.ones})
        return corr, out

    def carrier_step(self, corr, j: int) -> None:
        """Close the carrier loop on the correlators rotated by its corrections; record its phase error."""
        T, blk = self.T, self.blk
        f_c = self.corr_freq_hz + self.transfer_hz
        rot_rad = self.corr_phase_rad + np.pi * f_c * T  # corrections at mid-interval
        self.rec["phase"].append(blk.ph0[j] + np.pi * blk.freq_err[j] * T - rot_rad)  # wrapped once at the end
        c_out = self.carrier_filter.checked_step({"correlators": _rotated(corr, rot_rad)})
        self.corr_phase_rad = (self.corr_phase_rad + 2 * np.pi * f_c * T
                               + np.asarray(c_out.get("carrier_phase_step_rad", 0.0), float))
        self.corr_freq_hz = np.broadcast_to(np.asarray(c_out["carrier_freq_hz"], float), self.batch)

    def accumulate(self, i: int, out) -> None:
        """Keep the prefilter's new information of interval ``i`` of the integration interval."""
        fit_out = self.fit_out
        fit_out[0, i], fit_out[1, i] = out["code_error_chips"], out["freq_error_hz"]
        fit_out[2, i], fit_out[3, i] = out["code_error_var_chips2"], out["freq_error_var_hz2"]

    def integration_update(self, k_edge: int) -> None:
        """Fit the interval's information and hand it to the navigator at edge ``k_edge`` (after the pull-in)."""
        t1 = k_edge * self.T
        normal, rhs = _interval_fit(self.fit_out, self.fit_blocks, self.signal)
        self.fit_blocks = []
        cov = np.linalg.inv(normal)[..., :2, :2]  # marginal of [range, rate] at t_u
        res = np.einsum("...ij,...j->...i", np.linalg.inv(normal), rhs)[..., :2]
        rec = self.rec
        rec["tu"].append(t1)
        rec["res"].append(res)
        rec["cov"].append(cov)
        s_u, sv_u, sa_u = self.sat_at(k_edge)
        p, v, a, b, d = self.navigator.kinematics(t1)
        _, rate_u, _, los_u = line_of_sight_kinematics(p, v, a, s_u, sv_u, sa_u, b, d)
        if len(rec["tu"]) > self.pull_in_updates:
            self.navigator.update(t1, res, cov, los_u, self.cn0)
            self.rate_before_update = rate_u

    def carry(self, j: int) -> None:
        """What the next interval needs of this one's replica: its end, rate, slope and carrier phase."""
        blk = self.blk
        self.rep_end = blk.rep_end[j]
        self.rate_prev = self.sched_rate[j]
        self.slope_prev = self.slope_new
        self.carrier_rep = blk.carrier_rep_end[j]

    def record(self) -> DeepRecord:
        """The run's series (the carrier loop's phase error wrapped once, here)."""
        rec, T = self.rec, self.T
        extra = ({"phase_error_rad": np.angle(np.exp(1j * np.stack(rec["phase"])))}
                 if self.carrier_filter is not None else {})
        return DeepRecord(np.concatenate(rec["code"]), np.concatenate(rec["freq"]), (np.arange(self.K) + 0.5) * T,
                          np.asarray(rec["tu"]), np.stack(rec["res"]), np.stack(rec["cov"]), extra)


@dataclass(frozen=True)
class _AidedBlock:
    """The coherent intervals of one NCO interval, ``(n, runs, ch)`` each (see `_aided_block`)."""

    code_err: np.ndarray  # true code error of the replica (chips)
    ph0: np.ndarray  # true carrier phase minus the aided replica's at the interval's start (rad)
    freq_err: np.ndarray  # true frequency error of the aided replica (Hz)
    rep_end: np.ndarray  # replica range at the interval's end (m)
    carrier_rep_end: np.ndarray  # aided replica's carrier phase at the interval's end (rad)
    shift_chips: np.ndarray  # NCO shifts handed to the prefilter
    shift_hz: np.ndarray
    replica_mid_m: np.ndarray  # replica range at mid-interval
    predicted_range_m: np.ndarray  # the navigator's predicted range at mid-interval
    predicted_rate_m_s: np.ndarray  # and rate
    h_rho: np.ndarray  # (n, 3) rows of the least-squares fit of [dr(t_u), dr_dot(t_u), dr_ddot]: range
    h_rate: np.ndarray  # and rate
    outer_rho: np.ndarray  # (n, 3, 3) their outer products (normal-matrix terms)
    outer_rate: np.ndarray
    nco_rate: np.ndarray  # (n, runs, ch) the replica's rate over each interval


def _interval_fit(outputs: np.ndarray, blocks: list[_AidedBlock], signal: SignalSpec = GPS_L1CA
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Normal matrix ``(runs, ch, 3, 3)`` and right-hand side of one integration interval's fit.

    Weighted least squares of [dr(t_u), dr_dot(t_u), dr_ddot] from the interval's new
    information: range residual quadratic in time, rate residual linear. The rate
    residual grows through the interval when the navigator's acceleration is off; a
    constant-rate fit would hand over its mid-interval value as t_u's (a lag). Residuals
    are taken against the navigator's own prediction (a smooth function of time), not
    against the replica: without acceleration aiding, or between re-aidings, the replica
    departs from the prediction by a known amount.

    ``outputs`` ``(4, n_upd, runs, ch)``: the prefilter's code and frequency errors and their
    variances per coherent interval; ``blocks``: the NCO intervals they fall in. All
    intervals' terms at once, summed over the intervals in their order from zero (``add``
    reduced along the first axis adds one interval after the other, as a running sum would).
    """
    code, freq, var_code, var_freq = outputs
    chip_m, wavelength_m = signal.chip_length_m, signal.wavelength_m
    cat = lambda name: np.concatenate([getattr(b, name) for b in blocks])  # noqa: E731
    w_rho = 1.0 / (var_code * chip_m**2)
    w_rate = 1.0 / (var_freq * wavelength_m**2)
    # code error: truth minus replica code phase, a range error of -chip length x it (engine convention)
    z_rho = range_error_chips(code) * chip_m + cat("replica_mid_m") - cat("predicted_range_m")
    z_rate = -freq * wavelength_m + cat("nco_rate") - cat("predicted_rate_m_s")
    h_rho, h_rate = cat("h_rho")[:, None, None], cat("h_rate")[:, None, None]
    normal_terms = (w_rho[..., None, None] * cat("outer_rho")[:, None, None]
                    + w_rate[..., None, None] * cat("outer_rate")[:, None, None])
    rhs_terms = (w_rho * z_rho)[..., None] * h_rho + (w_rate * z_rate)[..., None] * h_rate
    return np.add.reduce(normal_terms, axis=0, initial=0.0), np.add.reduce(rhs_terms, axis=0, initial=0.0)


def _aided_block(sat_at, k0: int, n: int, T: float, n_upd: int, sched_range, sched_rate, rho, rate, acc, t_aid: float,
                 theta0, carrier_rep, rep_end_prev, rate_prev, slope_prev, slope, zeros) -> _AidedBlock:
    """Truth and replica of the ``n`` coherent intervals from ``k0`` (one NCO interval), at once.

    Each line is the per-interval formula of `run_aided_tracking` evaluated on a stack of
    intervals, in the same order of operations (so the same bits): the replica's chords
    ``sched_range``, ``sched_rate`` are fixed until the next re-aiding and the truth is known.
    ``rep_end_prev``, ``rate_prev``, ``slope_prev``: the previous NCO interval's last replica
    end, rate and slope (``None`` at the start: no shift).
    """
    chip_m, wavelength_m = sat_at.truth.signal.chip_length_m, sat_at.truth.signal.wavelength_m
    true_rho = np.stack([sat_at.pseudorange(k0 + i) for i in range(n + 1)])
    carrier_rho = true_rho
    if sat_at.truth.range_error_m is not None:  # the carrier range differs from the code's (ionosphere)
        carrier_rho = true_rho + np.stack([sat_at.carrier_minus_code(k0 + i) for i in range(n + 1)])
    nco_range, nco_rate = sched_range[:n], sched_rate[:n]
    rep_end = nco_range + nco_rate * T
    # Truth minus replica code phase (engine convention): the range error over the chip length, negated.
    code_err = -0.5 * ((true_rho[:-1] - nco_range) + (true_rho[1:] - rep_end)) / chip_m
    f_rep = -nco_rate / wavelength_m
    # carrier_rep + the increments one after the other (accumulate adds in sequence, as the loop did).
    carrier = np.add.accumulate(np.concatenate([carrier_rep[None], 2 * np.pi * f_rep * T]), axis=0)
    ph0 = theta0 - 2 * np.pi * carrier_rho[:-1] / wavelength_m - carrier[:-1]
    ph1 = theta0 - 2 * np.pi * carrier_rho[1:] / wavelength_m - carrier[1:]
    freq_err = (ph1 - ph0) / (2 * np.pi * T)
    shift_chips = np.empty_like(nco_range)
    shift_chips[0] = zeros if rep_end_prev is None else -(nco_range[0] - rep_end_prev) / chip_m
    shift_chips[1:] = -(nco_range[1:] - rep_end[:-1]) / chip_m
    # The prefilter's states are errors relative to the aided replica, driven by the
    # navigator's errors: its frequency state moves only by the replica's departure from
    # the ramp it was following (a re-aiding), not by the aided ramp itself. Handing it
    # the whole replica change made its frequency-rate state learn the absolute line-of-
    # sight acceleration from a zero prior: rate information biased by tens of standard
    # deviations during a 20 g boost even with a perfect navigator.
    shift_hz = np.empty_like(nco_rate)
    shift_hz[0] = zeros if rate_prev is None else -(nco_rate[0] - (rate_prev + slope_prev * T)) / wavelength_m
    shift_hz[1:] = -(nco_rate[1:] - (nco_rate[:-1] + slope * T)) / wavelength_m
    # Mid-interval times since the aiding instant as Python floats, squared as the loop squared them.
    tau_list = [(k0 + i) * T + T / 2 - t_aid for i in range(n)]
    tau = np.array(tau_list)[:, None, None]
    tau2 = np.array([t**2 for t in tau_list])[:, None, None]
    # Fit rows: dt is mid-interval minus the coming update instant.
    ks = np.arange(k0, k0 + n)
    fit_dt = (ks + 0.5) * T - (ks // n_upd + 1) * n_upd * T
    h_rho = np.stack([np.ones(n), fit_dt, 0.5 * fit_dt * fit_dt], -1)
    h_rate = np.stack([np.zeros(n), np.ones(n), fit_dt], -1)
    return _AidedBlock(code_err, ph0, freq_err, rep_end, carrier[1:], shift_chips, shift_hz,
                       nco_range + nco_rate * T / 2, rho + rate * tau + 0.5 * acc * tau2, rate + acc * tau,
                       h_rho, h_rate, h_rho[:, :, None] * h_rho[:, None, :], h_rate[:, :, None] * h_rate[:, None, :],
                       nco_rate)


def _rotated(corr, phase_rad: np.ndarray):
    """The correlators of a replica advanced in phase by ``phase_rad`` (every tap rotated by its negative)."""
    rot = np.exp(-1j * phase_rad)
    if not corr.extra and isinstance(corr, Correlators):  # complex taps of one shape: no re-validation
        return Correlators.trusted(corr.early * rot, corr.prompt * rot, corr.late * rot)
    return type(corr)(corr.early * rot, corr.prompt * rot, corr.late * rot,
                      {k: v * rot for k, v in corr.extra.items()})


class _EdgeStates:
    """Satellite states and true pseudoranges at the epoch edges kT, one vectorised orbit
    evaluation (and one receiver-position evaluation) per block of epochs instead of one or
    two per epoch (memory stays bounded on long runs)."""

    def __init__(self, truth: LoopTruth, K: int, block: int = 1000) -> None:
        self.truth, self.T, self.K, self.block = truth, truth.coherent_time_s, K, block
        self.start = -block  # nothing evaluated yet
        self.states: tuple[np.ndarray, ...] = ()
        self.rho: np.ndarray | None = None
        self.divergence: np.ndarray | None = None

    def _load(self, k: int) -> int:
        if not self.start <= k < self.start + self.block:
            self.start = k
            stop = min(k + self.block, self.K + 1)
            self.states = tuple(np.asarray(a) for a in self.truth.sat_state(np.arange(k, stop) * self.T))
            self.rho = None
            self.divergence = None
        return k - self.start

    def __call__(self, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        i = self._load(k)
        return self.states[0][i], self.states[1][i], self.states[2][i]

    def pseudorange(self, k: int) -> np.ndarray:
        """True pseudorange ``(runs, ch)`` at edge k (`LoopTruth.pseudorange`, computed per block)."""
        i = self._load(k)
        if self.rho is None:
            self.rho = self.truth.pseudoranges(self.start, self.start + len(self.states[0]), self.states[0])
        return self.rho[i]

    def carrier_minus_code(self, k: int) -> np.ndarray:
        """Carrier minus code range error ``(runs, ch)`` at edge k (`LoopTruth.carrier_minus_code_m`)."""
        i = self._load(k)
        if self.divergence is None:
            self.divergence = self.truth.carrier_minus_code_m(self.start, self.start + len(self.states[0]))
        return self.divergence[i]


def _check_finite(name: str, step: int, *arrays: np.ndarray) -> None:
    """Refuse a navigator output holding NaN or inf (it would silently poison every channel)."""
    bad = np.zeros(np.shape(arrays[0])[:1], bool)
    for a in arrays:
        a = np.asarray(a, float)
        bad |= ~np.isfinite(a).reshape(a.shape[0], -1).all(axis=1) if a.ndim else ~np.isfinite(a)
    if bad.any():
        raise NumericalError(name, [(int(i),) for i in np.flatnonzero(bad)], step,
                             "navigator kinematics (position, velocity, acceleration or clock) not finite")


def loss_of_lock(code_error_chips: np.ndarray, freq_error_hz: np.ndarray, coherent_time_s: float) -> np.ndarray:
    """Loss-of-lock flags: |code error| > 0.5 chip or |frequency error| > 1/(2T).

    At 1/(2T) the coherent sum has lost 36 % of its amplitude (sinc) and half a chip
    takes the prompt halfway down the correlation triangle; both are choices, stated in
    the docs.
    """
    return (np.abs(code_error_chips) > 0.5) | (np.abs(freq_error_hz) > 0.5 / coherent_time_s)
