r"""The navigation side of vector tracking on samples: the model, the step and the command.

A `VectorNavigator` is created at the hand-over (`vector_handover`) and holds the
navigation filter, its state, the vector channels' ephemerides and the anchors that turn
each replica's code NCO into a transmit time. Every coherent interval ``T``:

1. each vector channel's filter turns its correlators into a code error and a frequency
   error with their variances (`measure`: the channel parts of the vector loop of
   reference 000, `gnssframework.receiver.tracking.vector`);
2. the navigation filter takes them as pseudorange and rate errors of each replica at a
   common epoch (`step`; Zou et al. 2018, eqs. 35-36): the replica's pseudorange is
   :math:`R = c\,(t_{rx} - t_{tx})`, its receive time from the sample counter and its
   transmit time from the chips its code NCO has generated since the fix;
3. the filter's position, velocity and clock predict every channel's pseudorange and
   rate at the start of its next interval (`command`),
   :math:`\hat R = \lVert s(t_{tx}) - r \rVert + b - c\,\Delta t_{SV} + I` (satellite
   at transmit time, rotated by the Earth's turn during the flight, its clock from the
   ephemeris, Klobuchar :math:`I` when page 18 is known) and
   :math:`\dot{\hat R} = (v_s - v)\cdot e + d - c\,\Delta\dot t_{SV}`, and the replicas
   are steered to them by the loop engine's range command
   (`gnssframework.receiver.channels.nco.ReplicaNCOs.steer_range`; carrier: a vector FLL,
   no PLL, no carrier phase tracking after the hand-over).

A channel whose signal fades keeps being driven by the solution; its C/N0 estimate scales
the variances it reports (the thermal variances grow as 1/C/N0), so the filter leans on
the strong channels, and below ``min_cn0_dbhz`` its output is left out of the update.
With ``monitor_false_alarm`` (`VectorConfig`) a `ChannelMonitor` tests each channel's
innovation every interval and leaves a faulty channel out of the update (still driven by
the solution) until its innovations agree again; each exclusion and return is an event.
"""

from __future__ import annotations

import dataclasses

from typing import TYPE_CHECKING, Any

import numpy as np
import pymap3d

from ... import names, registry
from ...errors import NumericalError
from ...interfaces import ChannelFilter, RunContext, refuse_fixed_channel_set
from ...navigation.ephemeris import Ephemerides, satellite_state
from ...navigation.geometry import line_of_sight
from ...navigation.lnav import IonoUtc
from ...navigation.pvt import klobuchar_delay_s
from ...signal.correlators import Correlators
from ..engine.channel_monitor import ChannelMonitor
from .observables import SPEED_OF_LIGHT_MPS
from .vector_config import VectorConfig
from .vector_solution import VectorSolution
from .vector_time import FULL_DOF, RELAXATION, TimeOffset, TimeOffsetEstimator

if TYPE_CHECKING:
    from ..channels import SampleTracker

__all__ = ["VectorNavigator", "rotate", "stack"]

_C = SPEED_OF_LIGHT_MPS
_OMEGA_E = 7.2921151467e-5  # WGS 84 Earth rotation rate (rad/s), IS-GPS-200 Table 20-IV
#: Variance (chips², Hz²) that makes the navigation filter ignore a channel's output.
_IGNORE_VAR = 1e8


class VectorNavigator:
    """The navigation filter over the vector channels (see the module text).

    Parameters
    ----------
    tracker
        The `SampleTracker` whose NCO arrays it reads and steers.
    vector
        `VectorConfig`.
    solution
        Where its states go.
    slots, eph
        The vector channels' slots (ascending) and their ephemerides, in that order.
    iono
        Klobuchar coefficients, or None.
    rx_offset_s
        Receiver time minus recording time (s).
    tx_anchor, chip_anchor
        Per tracker slot: a replica's transmit time (s of week, SV time) when its code NCO
        had generated ``chip_anchor`` chips (``ms_index * code length + code_phase``).
    """

    def __init__(
        self,
        tracker: SampleTracker,
        vector: VectorConfig,
        solution: VectorSolution,
        slots: np.ndarray,
        eph: Ephemerides,
        iono: IonoUtc | None,
        rx_offset_s: float,
        tx_anchor: np.ndarray,
        chip_anchor: np.ndarray,
    ) -> None:
        self.tracker = tracker
        self.vector = vector
        self.solution = solution
        self.slots = slots
        self.eph = eph
        self.iono = iono
        self.rx_offset = rx_offset_s
        self.tx_anchor = tx_anchor
        self.chip_anchor = chip_anchor
        self.filter = registry.create("nav_filter", vector.nav_filter, **vector.nav_params)
        refuse_fixed_channel_set(self.filter, "vector.nav_params")
        self.started = False
        self.pending: dict[int, tuple] = {}
        self.iono_m = np.zeros(slots.size)
        self.monitor = None
        self._cov = None
        self._last_cov: np.ndarray | None = None
        self._unchecked = False
        #: An assisted start's in-loop time check (`vector_time`; set by the hand-over).
        self.time: TimeOffsetEstimator | None = None
        if vector.monitor_false_alarm is not None:
            self.monitor = ChannelMonitor(vector.monitor_false_alarm, vector.monitor_consecutive)
            self.monitor.reset((1, len(tracker.signal.prns)))

    def start_at(self, x0: np.ndarray, cov0: np.ndarray, t_fix: float) -> None:
        """The first state ``x0`` (covariance ``cov0``) at recording time ``t_fix``; the
        filter starts at the first common epoch (`step`)."""
        self.x_fix, self.cov0, self.t_fix = x0, cov0, t_fix
        self.x = x0
        self.iono_m = self.delays(self.slots, x0[:3], t_fix)

    # --- the navigation model ------------------------------------------------------------

    def replica_tx(self, slots: np.ndarray) -> np.ndarray:
        """Transmit time (GPS s of week, SV time) of the replica at each slot's start sample."""
        t = self.tracker
        sp = t.signal
        chips = t.ms_index[slots] * sp.code_length_chips + t.code_phase[slots]
        return self.tx_anchor[slots] + (chips - self.chip_anchor[slots]) / sp.chip_rate_hz

    def satellites(self, slots: np.ndarray, tx_s: np.ndarray, r: np.ndarray):
        """Satellite position and velocity (rotated into the receive-time frame), clock (m)
        and clock drift (m/s) at the transmit times ``tx_s`` of the channels ``slots``."""
        eph = self.eph.subset(np.searchsorted(self.slots, slots))
        # One evaluation at the satellite-time stamp: its GPS time is ``clock`` (< 1 ms)
        # earlier, where the position is ``vel * clock`` back (the neglected acceleration
        # term, |a| dt^2 / 2 < 1e-6 m, and the clock's change over it are far below the
        # loop's noise).
        st = satellite_state(eph, tx_s)
        clock = st.clock_l1_s
        position = st.position_m - st.velocity_mps * clock[:, None]
        tau = np.linalg.norm(position - r, axis=-1) / _C
        return rotate(position, tau), rotate(st.velocity_mps, tau), _C * clock, _C * st.clock_drift_s_s

    def delays(self, slots: np.ndarray, r: np.ndarray, t_s: float) -> np.ndarray:
        """Klobuchar delay (m) of each channel from position ``r`` (0 without page 18)."""
        if self.iono is None:
            return np.zeros(slots.size)
        pos, *_ = self.satellites(slots, self.replica_tx(slots), r)
        lat, lon, h = pymap3d.ecef2geodetic(*r)
        az, el, _ = pymap3d.ecef2aer(pos[:, 0], pos[:, 1], pos[:, 2], lat, lon, h)
        return _C * klobuchar_delay_s(
            self.iono.alpha, self.iono.beta, lat, lon, np.asarray(az), np.asarray(el), t_s + self.rx_offset
        )

    def velocity(
        self, slots: np.ndarray, r: np.ndarray, doppler_hz: np.ndarray | None = None
    ) -> tuple[np.ndarray, float, np.ndarray]:
        """Least-squares velocity and clock drift from the channels' Dopplers (their NCOs',
        or ``doppler_hz``) at position ``r``:
        :math:`-\\lambda f = (v_s - v)\\cdot e + d - c\\,\\Delta\\dot t_{SV}`; and the
        geometry matrix ``G = [-e, 1]``."""
        t = self.tracker
        pos, vel, _, drift = self.satellites(slots, self.replica_tx(slots), r)
        _, e = line_of_sight(pos, r)
        doppler_hz = t.doppler[slots] if doppler_hz is None else doppler_hz
        y = -t.signal.wavelength_m * doppler_hz - np.sum(vel * e, axis=1) + drift
        H = np.hstack([-e, np.ones((slots.size, 1))])
        sol = np.linalg.lstsq(H, y, rcond=None)[0]
        return sol[:3], float(sol[3]), H

    def predict(
        self, slots: np.ndarray, x: np.ndarray, t_s: np.ndarray, tx_s: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Pseudorange (m) and its rate (m/s) of channels ``slots`` predicted by state ``x``
        (at recording time ``t_s`` per channel, transmit times ``tx_s``)."""
        r = x[:3] + x[3:6] * (t_s - self.t_nav)[:, None]
        b = x[6] + x[7] * (t_s - self.t_nav)
        pos, vel, clock, drift = self.satellites(slots, tx_s, r)
        dist, e = line_of_sight(pos, r)
        rate = np.sum((vel - x[3:6]) * e, axis=-1) + x[7] - drift
        j = np.searchsorted(self.slots, slots)
        return dist + b - clock + self.iono_m[j], rate

    # --- the loop ------------------------------------------------------------------------

    def measure(self, filt: ChannelFilter, slots: np.ndarray, w: np.ndarray) -> None:
        """Step vector channel ``slots[0]``'s filter on its wiped sums ``w`` and keep its
        errors for the next `step`, with the replica's receive and transmit time at
        mid-interval and its Doppler."""
        t = self.tracker
        nco = t.nco
        out = filt.checked_step(
            {
                "correlators": Correlators.trusted(w[:, 0], w[:, 1], w[:, 2]),
                "nco_shift_chips": t.shift_chips[slots],
                "nco_shift_hz": t.shift_hz[slots],
            }
        )
        i = int(slots[0])
        t.shift_chips[i] = t.shift_hz[i] = 0.0
        end = int(t.start_sample[i])
        mid = 0.5 * (t.acc_t0[i] * t.fs + end)
        # The replica's transmit time at mid-interval: the chips its NCO generated since the
        # hand-over, less the half interval's chips at the rate it ran.
        tx_mid = self.replica_tx(np.array([i]))[0] - (end - mid) / t.fs * t.code_rate[i] / t.signal.chip_rate_hz
        self.pending[i] = (
            mid / t.fs,
            float(nco.range_error_chips(np.ravel(out["code_error_chips"])[0])),
            float(np.ravel(out["code_error_var_chips2"])[0]),
            float(np.ravel(out["freq_error_hz"])[0]),
            float(np.ravel(out["freq_error_var_hz2"])[0]),
            tx_mid,
            float(t.doppler[i]),
        )

    def ready(self) -> bool:
        """Whether every vector channel has a measurement for the next `step`."""
        return bool(self.slots.size) and all(int(s) in self.pending for s in self.slots)

    def step(self) -> None:
        """One navigation filter step on the vector channels' measurements, then `command`."""
        t = self.tracker
        sp = t.signal
        slots = self.slots
        meas = [self.pending.pop(int(s)) for s in slots]
        t_mid, code, var_code, freq, var_freq, tx_mid, dop = (np.array(m) for m in zip(*meas))
        T = t.config.coherent_ms * sp.code_period_s
        if not self.started:
            t_nav = float(np.mean(t_mid))
            x = self.x_fix.copy()
            x[:3] += x[3:6] * (t_nav - self.t_fix)
            x[6] += x[7] * (t_nav - self.t_fix)
            self.filter.reset(
                (1,),
                RunContext(
                    coherent_time_s=T, epoch_interval_s=T, initial_state=x[None], initial_cov=self.cov0, signal=sp
                ),
            )
            self.started = True
            self.t_nav = t_nav
            self.x = x
        else:
            self.t_nav += T
        # Each replica's pseudorange and rate at the common epoch, in the filter's model
        # (satellite clock and ionosphere removed: h(x) = |s - r| + b).
        rate_rep = t.nco.range_rate_m_s(dop)
        range_rep = _C * (t_mid + self.rx_offset - tx_mid) + rate_rep * (self.t_nav - t_mid)
        tx_nav = tx_mid + (self.t_nav - t_mid) * (1 + dop / sp.carrier_freq_hz)
        pos, vel, clock, drift = self.satellites(slots, tx_nav, self.x[:3])
        prns = [sp.prns[int(s)] for s in slots]
        cn0 = np.array([t.channels[p].cn0_dbhz for p in prns])
        ref = np.array([t.channels[p].cn0_ref for p in prns])
        lat, lon, _ = pymap3d.ecef2geodetic(*self.x[:3], deg=False)  # below the mask: driven, not used
        up = np.array([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)])
        in_view = line_of_sight(pos, self.x[:3])[1] @ up >= np.sin(np.radians(self.vector.elevation_mask_deg))
        use = (cn0 >= self.vector.min_cn0_dbhz) & in_view
        # The thermal variances grow as 1/(C/N0): scale the ones set at the hand-over C/N0.
        scale = 10 ** ((ref - np.maximum(cn0, self.vector.min_cn0_dbhz)) / 10)
        if self.monitor is not None:
            out_now = self._screen(slots, code, var_code * scale, pos, T)
            use &= ~out_now
            in_view &= ~out_now
        # The time check (`vector_time`) reads every channel in view, weak ones weighted down
        # by their C/N0 (a wrong start time is what weakens them).
        var_time = var_code * 10 ** ((ref - cn0) / 10)
        var_code = np.where(use, var_code * scale, _IGNORE_VAR)
        var_freq = np.where(use, var_freq * scale, _IGNORE_VAR)
        inputs: dict[str, Any] = {
            names.CODE_ERROR_CHIPS: code[None],
            names.CODE_ERROR_VAR_CHIPS2: var_code[None],
            names.FREQ_ERROR_HZ: freq[None],
            names.FREQ_ERROR_VAR_HZ2: var_freq[None],
            names.SAT_POS_M: pos,
            names.SAT_VEL_M_S: vel,
            names.NEXT_SAT_POS_M: pos,
            names.NEXT_SAT_VEL_M_S: vel,
            names.REPLICA_RANGE_M: (range_rep + clock - self.iono_m)[None],
            names.REPLICA_RATE_M_S: (rate_rep + drift)[None],
        }
        out = self.filter.checked_step(inputs)
        x = np.concatenate([out[names.POSITION_M][0], out[names.VELOCITY_M_S][0], out[names.CLOCK_M][0]])
        if not np.all(np.isfinite(x)):
            raise NumericalError(
                self.vector.nav_filter,
                [(0,)],
                len(self.solution.sample_time_s),
                f"non-finite state at the vector epoch {self.t_nav:.3f} s of the recording",
            )
        self.x = x
        self._last_cov = np.asarray(out[names.COV])[0]
        if self.monitor is not None:
            self._cov = np.array(self._last_cov[:8, :8])
        if self.time is not None:
            # The measured pseudoranges in the filter's model (h(x) = |s - r| + b), less the
            # state's: what a wrong start time leaves (`vector_time`).
            z = range_rep + clock - self.iono_m + sp.chip_length_m * code
            los = line_of_sight(pos, x[:3])[1]
            resid = z - np.linalg.norm(pos - x[:3], axis=1) - x[6]
            rate = np.sum(los * vel, axis=1) - drift
            found = self.time.add(self.t_nav, resid, sp.chip_length_m**2 * var_time, los, rate, in_view)
            if found is not None and self._time_checked(found):  # the start time moves
                moved = self._shift_time(found, z, tx_nav, in_view, var_time, T)
                if moved is not None:
                    self.command(slots, moved)
                    return  # the filter restarts at this epoch: no state row for it
        s = self.solution
        s.sample_time_s.append(self.t_nav)
        s.state.append(x)
        s.cov.append(np.array(out[names.COV])[0])
        mask = np.zeros(len(sp.prns), bool)
        mask[slots] = use
        s.used.append(mask)
        s.used_sat_pos_m.append(pos[use])
        if self.monitor is not None:  # this epoch's channels the monitor left out
            out_mask = np.zeros(len(sp.prns), bool)
            out_mask[slots] = self.monitor.excluded[0, slots]
            s.monitor_excluded.append(out_mask)
        self.command(slots, x)

    def _time_checked(self, found: TimeOffset) -> bool:
        """What a window's estimate of the start time's error does (`vector_time`): True when
        it moves the start time (significant at ``time_false_alarm``, at least a code
        period); the check ends when the estimate is within two of its sigmas of zero on a
        window of full information (or below a code period); otherwise the next window pools
        on, and the first such window says so once (the time is not confirmed so far)."""
        sp = self.tracker.signal
        moves = found.significant(self.vector.time_false_alarm)
        if moves and round(found.offset_s / sp.code_period_s) != 0:
            return True
        if moves or (found.dof >= FULL_DOF and abs(found.offset_s) < 2.0 * found.sigma_s):
            self.time = None
            self.solution.events.append(
                (
                    self.t_nav,
                    f"start time checked in the loop: {found.offset_s:+.4f} ± {found.sigma_s:.4f} s over "
                    f"{found.epochs} epochs: left as it is",
                )
            )
        elif not self._unchecked:  # neither moved nor confirmed: said once (a later check may follow)
            self._unchecked = True
            so_far = (
                "fewer than five channels in view: the offset is not observable (a start time off by "
                "more than the pull-in's check sees can lose channels before it is estimated)"
                if not np.isfinite(found.sigma_s)
                else f"{found.offset_s:+.4f} ± {found.sigma_s:.4f} s over {found.epochs} epochs: neither "
                f"significant at {self.vector.time_false_alarm:g} nor within two sigmas of zero; later "
                "windows pool on"
            )
            self.solution.events.append((self.t_nav, f"the start time is not confirmed in the loop so far ({so_far})"))
        return False

    def _shift_time(
        self, found: TimeOffset, z: np.ndarray, tx_nav: np.ndarray, in_view: np.ndarray, var_chips2, T: float
    ) -> np.ndarray | None:
        """Move every transmit-time label and the receiver time by `vector_time.RELAXATION`
        times ``found``'s estimate in whole code periods (the pseudoranges ``z`` unchanged),
        re-solve position and clock on this epoch's pseudoranges (the channels ``in_view``,
        weighted by their code variances) with the satellites where they now are, restart
        the filter there (velocity and drift kept) and drop the states before (they were
        solved at the wrong time); an event. None, and nothing moved, with fewer than four
        channels to solve on."""
        sp = self.tracker.signal
        slots = self.slots
        w = np.where(in_view, 1.0 / (sp.chip_length_m**2 * np.asarray(var_chips2, float)), 0.0)
        if np.count_nonzero(w > 0) < 4:
            return None
        shift_s = round(RELAXATION * found.offset_s / sp.code_period_s) * sp.code_period_s
        _, _, old_clock, _ = self.satellites(slots, tx_nav, self.x[:3])
        old_iono = self.iono_m.copy()
        self.tx_anchor[self.tx_anchor != 0.0] += shift_s  # every channel anchored (vector or joining)
        self.rx_offset += shift_s
        x = self.x.copy()
        tx_new = tx_nav + shift_s
        for _ in range(4):  # Gauss-Newton on position and clock
            pos, _, clock, _ = self.satellites(slots, tx_new, x[:3])
            self.iono_m = self.delays(slots, x[:3], self.t_nav)
            zz = z - old_clock + clock + old_iono - self.iono_m  # the clock and ionosphere at the new labels
            rng, los = line_of_sight(pos, x[:3])
            H = np.hstack([-los, np.ones((slots.size, 1))])
            Hw = H * w[:, None]
            info = Hw.T @ H
            dx = np.linalg.solve(info, Hw.T @ (zz - rng - x[6]))
            x[:3] += dx[:3]
            x[6] += dx[3]
        cov = np.zeros((8, 8))
        pc = np.r_[0:3, 6]
        cov[np.ix_(pc, pc)] = np.linalg.inv(info)
        vd = np.r_[3:6, 7]
        prior = np.asarray(self._last_cov, float)[:8, :8] if self._last_cov is not None else np.asarray(self.cov0)
        cov[np.ix_(vd, vd)] = prior[np.ix_(vd, vd)]
        self.filter.reset(
            (1,),
            RunContext(coherent_time_s=T, epoch_interval_s=T, initial_state=x[None], initial_cov=cov, signal=sp),
        )
        self.x = x
        s = self.solution
        dropped = len(s.sample_time_s)
        for rows in (s.sample_time_s, s.state, s.cov, s.used, s.used_sat_pos_m, s.monitor_excluded):
            rows.clear()
        s.rx_offset_s = self.rx_offset
        if self.time is not None:
            self.time.restart(self.t_nav)
        s.events.append(
            (
                self.t_nav,
                f"start time corrected by {shift_s:+.3f} s (estimated {found.offset_s:+.4f} ± "
                f"{found.sigma_s:.4f} s over {found.epochs} epochs of the vector channels' code errors); "
                f"the {dropped} states before, solved at the wrong time, dropped",
            )
        )
        return x

    def _screen(
        self, slots: np.ndarray, code_chips: np.ndarray, var_chips2: np.ndarray, sat_pos: np.ndarray, T: float
    ) -> np.ndarray:
        """The channel monitor's verdict on ``slots`` this interval (True: left out): their
        range innovations (the code errors, in metres) against ``R + h P⁻ hᵀ``, ``P⁻`` the
        filter's last covariance carried over ``T`` by its ``transition`` (the hand-over
        covariance at the first step); an event for each channel excluded or readmitted."""
        sp = self.tracker.signal
        if self._cov is None:
            P = np.asarray(self.cov0, float)[:8, :8]
        else:
            F, Q = (np.asarray(a, float)[:8, :8] for a in self.filter.transition(T))
            P = F @ self._cov @ F.T + Q
        n = len(sp.prns)
        innovation, variance, los = np.zeros((1, n)), np.ones((1, n)), np.zeros((1, n, 3))
        innovation[0, slots] = sp.chip_length_m * code_chips
        variance[0, slots] = sp.chip_length_m**2 * var_chips2
        los[0, slots] = line_of_sight(sat_pos, self.x[:3])[1]
        before = self.monitor.excluded[0, slots].copy()
        out = self.monitor.screen(innovation, variance, los, P)[0, slots]
        for s, was, now in zip(slots, before, out):
            if was != now:
                self.solution.events.append(
                    (
                        self.t_nav,
                        f"PRN {sp.prns[int(s)]}: "
                        + (
                            f"left out of the navigation update by the channel monitor ({self.monitor.consecutive} "
                            "intervals in a row failed its innovation test)"
                            if now
                            else "back in the navigation update (its innovations pass the channel monitor again)"
                        ),
                    )
                )
        return out

    def command(self, slots: np.ndarray, x: np.ndarray) -> None:
        """Steer every channel of ``slots`` to the state's prediction at its next interval."""
        t = self.tracker
        start_s = t.start_sample[slots] / t.fs
        tx = self.replica_tx(slots)
        rho, rate = self.predict(slots, x, start_s, tx)
        t.nco.steer_range(slots, _C * (start_s + self.rx_offset - tx), rho, rate, start_s)


def rotate(v: np.ndarray, tau_s: np.ndarray) -> np.ndarray:
    """ECEF vectors of transmit time expressed in the ECEF frame ``tau_s`` later (Earth rotation)."""
    th = _OMEGA_E * tau_s
    c, s = np.cos(th), np.sin(th)
    return np.stack([c * v[:, 0] + s * v[:, 1], -s * v[:, 0] + c * v[:, 1], v[:, 2]], axis=-1)


def stack(records: list[Ephemerides]) -> Ephemerides:
    """One `Ephemerides` of several records, in order (`Ephemerides.concatenate`), without
    their broadcast accuracy (the vector loop's measurement model does not take it)."""
    return dataclasses.replace(Ephemerides.concatenate(records), accuracy_m=None)
