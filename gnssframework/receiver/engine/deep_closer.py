r"""The deep-integration closer of the loop engine: NCOs aided by a navigator (Cai and Guo 2017).

`DeepCloser` closes the loop of `gnssframework.receiver.deep.aided_tracking.run_aided_tracking`
around engine `Channel`\ s steered by range (`Channel.steer_range`), at three rates
(Cai and Guo 2017, section 3.1):

- every coherent interval T: the prefilter (a ``channel_filter`` providing
  `CHANNEL_OUTPUTS` as each interval's *new* information, e.g. ``iq-filter`` with
  ``output = "equivalent"``) reads the interval's correlators; the replica of the next
  interval is commanded from the current NCO schedule;
- every NCO interval (``n_nco`` intervals): the navigator's receiver position, velocity,
  acceleration and clock give each channel's pseudorange, rate and acceleration along the
  line of sight (`line_of_sight_kinematics`), from which the range and rate commands of
  the coming NCO interval are laid out (`nco_schedule`, chords of the predicted polynomial;
  ``accel_aiding=False`` drops the acceleration);
- every integration interval (``n_upd`` intervals): the prefilter outputs of the interval
  are fitted per channel by weighted least squares as the range residual
  :math:`\delta\rho(t) = \delta\rho_u + \delta\dot\rho_u (t - t_u) + \tfrac12\delta\ddot\rho (t - t_u)^2`
  and its rate, against the navigator's prediction (not the replica, which departs from
  it by a known amount), and the marginal of range and rate at :math:`t_u` goes to the
  navigator's ``update`` (Groves 2013, section 16.3.3).

Signs: the engine's (`gnssframework.receiver.engine.channel`). The prefilter reports the
replica's code error (truth minus replica code phase, chips) and frequency error (Hz);
the range residual is :math:`\delta\rho = -\lambda_{chip}\,\delta\tau` (`range_error_chips`)
and the rate residual :math:`\delta\dot\rho = -\lambda\,\delta f`.

The prefilter keeps its states relative to the replica: it is told how far each command
moved the code NCO (``nco_shift_chips``, the channel's ``shift_chips``) and how far the
frequency moved from the *ramp* the replica was following (``nco_shift_hz``
:math:`= -(\dot{\hat\rho}_{new} - (\dot{\hat\rho}_{old} + \ddot{\hat\rho} T))/\lambda`),
not the aided ramp itself: handed the whole frequency change, its frequency-rate state
learnt the absolute line-of-sight acceleration from a zero prior (rate information biased
by tens of standard deviations during a 20 g boost with a perfect navigator).

Optionally a carrier-phase prefilter (``carrier_filter``, e.g. ``kf-carrier-loop``)
closes only the carrier loop on top of the aided replica: its replica is the aided one
plus its own phase and frequency corrections (held here, relative to the channel's carrier
NCO), its correlators the interval's rotated by the corrections' mid-interval phase
(`rotated`); nothing of it goes to the navigator. An integration update moves the aided
replica's frequency by the navigator's correction along the line of sight; the carrier
loop had already absorbed that error, so its correction moves the other way at the next
re-aiding (``transfer_hz``; without it a 0.5 m/s correction is a 2.6 Hz step, about 1 rad
of transient in a 6 Hz loop).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from ... import names
from ...errors import ConfigError, NumericalError
from ...interfaces import ChannelFilter, RunContext
from ...signal.correlators import Correlators
from ...signal.spec import SignalSpec
from ..deep.aiding import line_of_sight_kinematics, nco_schedule
from .channel import Channel
from .closers import CHANNEL_OUTPUTS, range_error_chips

__all__ = ["Navigator", "DeepCloser", "check_deep_prefilters", "interval_fit", "fit_rows", "FitRows", "rotated"]


class Navigator(Protocol):
    """What aids the NCOs and takes the prefilters' output (the INS + integration filter slot)."""

    def kinematics(self, t_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Receiver position, velocity, acceleration ``(runs, 3)`` and clock bias, drift ``(runs,)``."""

    def update(
        self, t_s: float, residual_m: np.ndarray, residual_cov: np.ndarray, los: np.ndarray, cn0_dbhz: np.ndarray
    ) -> None:
        """Integration update: residuals ``(runs, ch, 2)`` [range m, rate m/s], covariance ``(runs, ch, 2, 2)``."""


def check_deep_prefilters(channel: ChannelFilter, carrier_filter: ChannelFilter | None) -> None:
    """Refuse, naming the field, prefilters that cannot feed deep integration or close a carrier loop."""
    missing = [n for n in CHANNEL_OUTPUTS if n not in channel.provides]
    if missing:
        raise ConfigError(
            "channel_filter", f"{channel.name!r} cannot feed deep integration: it does not provide {', '.join(missing)}"
        )
    if carrier_filter is not None and (
        names.CORRELATORS not in carrier_filter.requires or names.CARRIER_FREQ_HZ not in carrier_filter.provides
    ):
        raise ConfigError(
            "carrier_filter",
            f"{carrier_filter.name!r} cannot close a carrier loop: it must take "
            "correlators and provide carrier_freq_hz (e.g. kf-carrier-loop)",
        )


@dataclass(frozen=True)
class FitRows:
    """The navigator's predictions and the fit's rows for the coherent intervals of one NCO interval."""

    predicted_range_m: np.ndarray  # (n, runs, ch) the navigator's predicted range at mid-interval
    predicted_rate_m_s: np.ndarray  # (n, runs, ch) and rate
    h_rho: np.ndarray  # (n, 3) rows of the least-squares fit of [dr(t_u), dr_dot(t_u), dr_ddot]: range
    h_rate: np.ndarray  # (n, 3) and rate
    outer_rho: np.ndarray  # (n, 3, 3) their outer products (normal-matrix terms)
    outer_rate: np.ndarray


def fit_rows(
    k0: int, n: int, T: float, n_upd: int, rho: np.ndarray, rate: np.ndarray, acc: np.ndarray, t_aid: float
) -> FitRows:
    """`FitRows` of the ``n`` coherent intervals from ``k0``, aided at ``t_aid`` with the
    predicted range, rate and acceleration ``rho``, ``rate``, ``acc`` ``(runs, ch)``.

    Predictions at mid-interval :math:`\\rho + \\dot\\rho\\tau + \\tfrac12\\ddot\\rho\\tau^2`,
    :math:`\\dot\\rho + \\ddot\\rho\\tau` (``tau`` since the aiding instant); fit rows
    ``[1, dt, dt^2/2]`` (range) and ``[0, 1, dt]`` (rate), ``dt`` mid-interval minus the
    coming update instant.
    """
    # Mid-interval times since the aiding instant as Python floats, squared one by one.
    tau_list = [(k0 + i) * T + T / 2 - t_aid for i in range(n)]
    tau = np.array(tau_list)[:, None, None]
    tau2 = np.array([t**2 for t in tau_list])[:, None, None]
    ks = np.arange(k0, k0 + n)
    fit_dt = (ks + 0.5) * T - (ks // n_upd + 1) * n_upd * T
    h_rho = np.stack([np.ones(n), fit_dt, 0.5 * fit_dt * fit_dt], -1)
    h_rate = np.stack([np.zeros(n), np.ones(n), fit_dt], -1)
    return FitRows(
        rho + rate * tau + 0.5 * acc * tau2,
        rate + acc * tau,
        h_rho,
        h_rate,
        h_rho[:, :, None] * h_rho[:, None, :],
        h_rate[:, :, None] * h_rate[:, None, :],
    )


def interval_fit(
    outputs: np.ndarray, replica: np.ndarray, rows: list[FitRows], signal: SignalSpec
) -> tuple[np.ndarray, np.ndarray]:
    """Normal matrix ``(runs, ch, 3, 3)`` and right-hand side of one integration interval's fit.

    Weighted least squares of [dr(t_u), dr_dot(t_u), dr_ddot] from the interval's new
    information: range residual quadratic in time, rate residual linear (a constant-rate
    fit would hand over its mid-interval value as t_u's: a lag). Residuals are taken
    against the navigator's own prediction, a smooth function of time.

    ``outputs`` ``(4, n_upd, runs, ch)``: the prefilter's code and frequency errors and their
    variances per coherent interval; ``replica`` ``(2, n_upd, runs, ch)``: the replica's
    range at mid-interval and its rate; ``rows``: the `FitRows` of the NCO intervals they
    fall in. All intervals' terms at once, summed in their order from zero (``add``
    reduced along the first axis adds one interval after the other, as a running sum would).
    """
    code, freq, var_code, var_freq = outputs
    chip_m, wavelength_m = signal.chip_length_m, signal.wavelength_m
    cat = lambda name: np.concatenate([getattr(b, name) for b in rows])  # noqa: E731
    w_rho = 1.0 / (var_code * chip_m**2)
    w_rate = 1.0 / (var_freq * wavelength_m**2)
    z_rho = range_error_chips(code) * chip_m + replica[0] - cat("predicted_range_m")
    z_rate = -freq * wavelength_m + replica[1] - cat("predicted_rate_m_s")
    h_rho, h_rate = cat("h_rho")[:, None, None], cat("h_rate")[:, None, None]
    normal_terms = (
        w_rho[..., None, None] * cat("outer_rho")[:, None, None]
        + w_rate[..., None, None] * cat("outer_rate")[:, None, None]
    )
    rhs_terms = (w_rho * z_rho)[..., None] * h_rho + (w_rate * z_rate)[..., None] * h_rate
    return np.add.reduce(normal_terms, axis=0, initial=0.0), np.add.reduce(rhs_terms, axis=0, initial=0.0)


def rotated(corr: Correlators, phase_rad: np.ndarray) -> Correlators:
    """The correlators of a replica advanced in phase by ``phase_rad`` (every tap rotated by its negative)."""
    rot = np.exp(-1j * phase_rad)
    if not corr.extra and isinstance(corr, Correlators):  # complex taps of one shape: no re-validation
        return Correlators.trusted(corr.early * rot, corr.prompt * rot, corr.late * rot)
    return type(corr)(corr.early * rot, corr.prompt * rot, corr.late * rot, {k: v * rot for k, v in corr.extra.items()})


def _check_finite(name: str, step: int, *arrays: np.ndarray) -> None:
    """Refuse a navigator output holding NaN or inf (it would silently poison every channel)."""
    bad = np.zeros(np.shape(arrays[0])[:1], bool)
    for a in arrays:
        a = np.asarray(a, float)
        bad |= ~np.isfinite(a).reshape(a.shape[0], -1).all(axis=1) if a.ndim else ~np.isfinite(a)
    if bad.any():
        raise NumericalError(
            name,
            [(int(i),) for i in np.flatnonzero(bad)],
            step,
            "navigator kinematics (position, velocity, acceleration or clock) not finite",
        )


class DeepCloser:
    """Prefilters per channel, a navigator per run aiding every channel's NCOs by range.

    Parameters
    ----------
    channel_filter
        The code/frequency prefilter (provides `CHANNEL_OUTPUTS` as new information).
    navigator
        Aids the NCOs and takes the integration updates (`Navigator`).
    carrier_filter
        Optional carrier-phase prefilter (requires ``correlators``, provides
        ``carrier_freq_hz``, may provide ``carrier_phase_step_rad``).
    accel_aiding
        Use the line-of-sight acceleration in the replica (Cai and Guo 2017, section 2.3).
    pull_in_updates
        First integration intervals whose fit is recorded but not handed to the navigator.

    Use: `reset`, then `start` (the first interval's `Channel`), then per interval k, after
    the channel's `Channel.errors` and the source's correlators, `step` (which commands
    interval k+1); `rotation_rad` before `step` gives the carrier loop's correction.
    """

    def __init__(
        self,
        channel_filter: ChannelFilter,
        navigator: Navigator,
        *,
        carrier_filter: ChannelFilter | None = None,
        accel_aiding: bool = True,
        pull_in_updates: int = 0,
    ) -> None:
        check_deep_prefilters(channel_filter, carrier_filter)
        self.filter, self.navigator, self.carrier_filter = channel_filter, navigator, carrier_filter
        self.accel_aiding, self.pull_in_updates = accel_aiding, pull_in_updates

    def reset(
        self,
        batch: tuple[int, int],
        coherent_time_s: float,
        n_nco: int,
        n_upd: int,
        epochs: int,
        *,
        signal: SignalSpec,
        early_late_spacing_chips: float = 1.0,
        cn0_dbhz: np.ndarray | float = 45.0,
    ) -> None:
        """Start the prefilters on ``batch`` ``(runs, channels)``: ``n_nco`` and ``n_upd``
        coherent intervals per NCO and integration interval, ``epochs`` intervals in all."""
        T = self.T = coherent_time_s
        self.batch, self.n_nco, self.n_upd, self.K, self.signal = batch, n_nco, n_upd, epochs, signal
        self.cn0 = np.broadcast_to(np.asarray(cn0_dbhz, float), batch)
        self.zeros = np.zeros(batch)
        # Data bits are wiped off (1 everywhere): as an array of the batch's shape the prefilter's
        # wipe-off takes its unchecked path (the same products as with a scalar 1).
        self.ones = np.ones(batch)
        self.filter.reset(
            batch,
            RunContext(
                coherent_time_s=T,
                early_late_spacing_chips=early_late_spacing_chips,
                epoch_interval_s=T,
                cn0_dbhz=self.cn0,
            ),
        )
        if self.carrier_filter is not None:
            # Its NCO starts on the aided replica: frequency correction 0 (doppler_hz), phase correction 0.
            self.carrier_filter.reset(
                batch,
                RunContext(
                    coherent_time_s=T,
                    early_late_spacing_chips=early_late_spacing_chips,
                    epoch_interval_s=T,
                    cn0_dbhz=self.cn0,
                    doppler_hz=0.0,
                ),
            )
            self.corr_phase_rad = np.zeros(batch)
            self.corr_freq_hz = np.zeros(batch)  # the loop's own NCO frequency
            self.transfer_hz = np.zeros(batch)  # navigator corrections taken back out of the aided replica
        self.rate_before_update: np.ndarray | None = None
        self.shift_hz = self.zeros  # the last command's frequency shift from the ramp (none at the start)
        # The current integration interval's prefilter outputs (copied: a plugin may reuse its
        # output arrays), the replica's mid-interval range and rate, and the NCO intervals' fit rows.
        self.fit_out = np.empty((4, n_upd) + batch)  # code error, frequency error and their variances
        self.fit_replica = np.empty((2, n_upd) + batch)
        self.fit_rows: list[FitRows] = []
        self.updates: list[tuple[float, np.ndarray, np.ndarray]] = []  # (t_u, residual, covariance)

    # --- aiding --------------------------------------------------------------------------

    def reaid(self, k: int, sat_states: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
        """Aid from the navigator at edge ``k`` (satellites' position, velocity, acceleration
        there): lay out the NCO schedule of the coming NCO interval and its fit rows."""
        T = self.T
        t0 = k * T
        p, v, a, b, d = self.navigator.kinematics(t0)
        _check_finite(type(self.navigator).__name__, k, p, v, a, b, d)
        rho, rate, acc, _ = line_of_sight_kinematics(p, v, a, *sat_states, b, d)
        self.sched_range, self.sched_rate = nco_schedule(rho, rate, acc, T, self.n_nco, accel_aiding=self.accel_aiding)
        if self.carrier_filter is not None and self.rate_before_update is not None:
            # The update's correction of the predicted rate (f = -rate / lambda), undone on the carrier side.
            self.transfer_hz -= -(rate - self.rate_before_update) / self.signal.wavelength_m
            self.rate_before_update = None
        self.slope = acc if self.accel_aiding else np.zeros_like(rate)
        self.fit_rows.append(fit_rows(k, min(self.n_nco, self.K - k), T, self.n_upd, rho, rate, acc, t0))

    def start(self, sat_states: tuple[np.ndarray, np.ndarray, np.ndarray]) -> Channel:
        """Aid at edge 0 and return the channels of the first interval (carrier phase 0, no shift)."""
        self.reaid(0, sat_states)
        return Channel.from_range(self.batch, self.sched_range[0], self.sched_rate[0], t_s=0.0, signal=self.signal)

    def _command(self, channel: Channel, k: int, slope: np.ndarray) -> None:
        """Steer ``channel`` for interval ``k`` from the schedule; ``slope``: the ramp the
        replica followed over interval k-1 (for the frequency shift handed to the prefilter)."""
        j = k % self.n_nco
        rate_new = self.sched_rate[j]
        self.shift_hz = -(rate_new - (channel.nco_range_rate_m_s + slope * self.T)) / self.signal.wavelength_m
        channel.steer_range(self.sched_range[j], rate_new, k * self.T)

    # --- one interval --------------------------------------------------------------------

    def rotation_rad(self) -> np.ndarray | None:
        """The carrier loop's correction at mid-interval (its replica minus the aided one), or None."""
        if self.carrier_filter is None:
            return None
        return self.corr_phase_rad + np.pi * (self.corr_freq_hz + self.transfer_hz) * self.T

    def step(
        self, channel: Channel, correlators: Correlators, k: int, sat_next: tuple[np.ndarray, np.ndarray, np.ndarray]
    ) -> dict[str, np.ndarray]:
        """Interval ``k`` (after ``channel``'s `Channel.errors` or `Channel.run_interval`): the
        prefilter, the carrier loop, the fit; at an integration edge the navigator's update;
        then the command of interval k+1 (re-aided at an NCO edge). ``sat_next``: the
        satellites' position, velocity and acceleration at edge k+1. Returns the prefilter's outputs."""
        out = self.filter.checked_step(
            {
                names.CORRELATORS: correlators,
                names.NCO_SHIFT_CHIPS: channel.shift_chips,
                names.NCO_SHIFT_HZ: self.shift_hz,
                names.DATA_BIT: self.ones,
            }
        )
        if self.carrier_filter is not None:
            self._carrier_step(correlators)
        i = k % self.n_upd
        fit_out = self.fit_out
        fit_out[0, i], fit_out[1, i] = out[names.CODE_ERROR_CHIPS], out[names.FREQ_ERROR_HZ]
        fit_out[2, i], fit_out[3, i] = out[names.CODE_ERROR_VAR_CHIPS2], out[names.FREQ_ERROR_VAR_HZ2]
        rate = channel.nco_range_rate_m_s
        self.fit_replica[0, i] = channel.nco_range_m + rate * self.T / 2
        self.fit_replica[1, i] = rate
        if (k + 1) % self.n_upd == 0:
            self._integration_update(k + 1, sat_next)
        if k + 1 < self.K:
            slope = self.slope  # the ramp of interval k, before a re-aiding changes it
            if (k + 1) % self.n_nco == 0:
                self.reaid(k + 1, sat_next)
            self._command(channel, k + 1, slope)
        return out

    def _carrier_step(self, corr: Correlators) -> None:
        """Close the carrier loop on the correlators rotated by its corrections."""
        T = self.T
        c_out = self.carrier_filter.checked_step({names.CORRELATORS: rotated(corr, self.rotation_rad())})
        self.corr_phase_rad = (
            self.corr_phase_rad
            + 2 * np.pi * (self.corr_freq_hz + self.transfer_hz) * T
            + np.asarray(c_out.get("carrier_phase_step_rad", 0.0), float)
        )
        self.corr_freq_hz = np.broadcast_to(np.asarray(c_out[names.CARRIER_FREQ_HZ], float), self.batch)

    def _integration_update(self, k_edge: int, sat_states: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
        """Fit the interval's information and hand it to the navigator at edge ``k_edge`` (after the pull-in)."""
        t1 = k_edge * self.T
        normal, rhs = interval_fit(self.fit_out, self.fit_replica, self.fit_rows, self.signal)
        self.fit_rows = []
        normal_inv = np.linalg.inv(normal)
        cov = normal_inv[..., :2, :2]  # marginal of [range, rate] at t_u
        res = np.einsum("...ij,...j->...i", normal_inv, rhs)[..., :2]
        self.updates.append((t1, res, cov))
        p, v, a, b, d = self.navigator.kinematics(t1)
        _, rate_u, _, los_u = line_of_sight_kinematics(p, v, a, *sat_states, b, d)
        if len(self.updates) > self.pull_in_updates:
            self.navigator.update(t1, res, cov, los_u, self.cn0)
            self.rate_before_update = rate_u
