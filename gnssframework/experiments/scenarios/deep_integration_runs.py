"""The ``deep-integration`` scenario's runners of the INS candidates (``deep``, ``deep-no-accel``, ``loose``, ``tight``).

`run_deep` closes the INS-aided tracking loop of `gnssframework.receiver.deep`;
`run_loose` runs the scalar loops, forms position/velocity fixes and feeds them to the
INS's error-state filter (Groves 2013, section 14.1.2); `run_tight` runs the same loops
and feeds each channel's pseudorange and rate to it, single-differenced (section 14.1.3).
"""

from __future__ import annotations

from dataclasses import dataclass
from collections.abc import Callable
from typing import Any, Protocol

import numpy as np

from ... import random_streams as draw
from ...estimation.consistency import nees
from ...errors import ConfigError
from ...interfaces import RunContext
from ...navigation.geometry import line_of_sight, range_rate
from ...receiver.deep.aided_tracking import DeepTruth, run_aided_tracking
from ...receiver.deep.ins_navigator import REJECTED_FIX_VAR, InsNavigator, loose_update, tight_update
from ...receiver.deep.loose import (
    fix_range_gain,
    correlated_error_inflation,
    line_of_sight_accel,
    pv_fix,
    scalar_measurement_variances,
    scalar_measurements,
    scalar_tracking,
    select_channels,
    trailing_rate_measurement,
)
from ...receiver.deep.navigators import ClockFilter
from ...receiver.deep.strapdown import StrapdownIns
from .deep_integration_flight import Flight, body_to_ned

__all__ = ["run_deep", "run_loose", "run_tight", "ChannelOutage", "LockVerdicts", "CandidateRun", "weight_out"]


class LockVerdicts(Protocol):
    """The receiver's lock verdicts a candidate's run reads (its ``lock`` argument): the
    ideal detector of a satellite outage (`ChannelOutage`) or a lock test on the prompts
    (`gnssframework.receiver.engine.lock_detector.CN0LockDetector`). The run hands it each
    interval's correlators (``observe``) and asks which channels an update at ``t_s`` may
    use (``usable``, ``(runs, ch)`` bool; ``reach_s``: how far past ``t_s`` its
    measurements reach, which only the ideal detector can know)."""

    def observe(self, correlators: Any) -> None: ...

    def usable(self, t_s: float, reach_s: float) -> np.ndarray: ...

    @property
    def returned(self) -> np.ndarray | None: ...


@dataclass(frozen=True)
class ChannelOutage:
    """A satellite outage: the channels of ``blocked`` ``(runs, ch)`` have no signal in the
    intervals whose middle lies in ``[start_s, end_s)`` (``end_s`` None: to the end).

    In the truth the signal's amplitude is 0 there (`signal_gain`, a `CN0Fade` of infinite
    depth): the correlators hold noise only, drawn as without the outage, so the other
    channels and runs keep their random numbers. The receiver (`usable`) is an ideal lock
    detector without reacquisition: a blocked channel is dropped from the first update whose
    measurements reach into the outage, and not used again.
    """

    blocked: np.ndarray
    start_s: float
    end_s: float | None = None

    def signal_gain(self, epochs: int, coherent_time_s: float) -> np.ndarray:
        """Amplitude factor of each interval's signal, ``(epochs, runs, ch)``: 0 or 1."""
        from ...simulation.fade import CN0Fade

        duration = None if self.end_s is None else self.end_s - self.start_s
        t_mid = (np.arange(epochs) + 0.5) * coherent_time_s
        return CN0Fade(np.inf, self.start_s, duration).gains(t_mid, self.blocked)[0]

    def usable(self, t_s: float, reach_s: float) -> np.ndarray:
        """Channels the receiver uses at an update at ``t_s`` whose measurements reach
        ``reach_s`` past it: ``(runs, ch)`` bool."""
        return ~(self.blocked & (t_s + reach_s > self.start_s))

    def observe(self, correlators) -> None:
        """Each interval's correlators (not read: the schedule is known beforehand). A lock
        test that reads them is `CN0LockDetector`, which answers `usable` alike."""

    @property
    def returned(self) -> None:
        """Channels whose filters restart: none (the ideal detector never readmits)."""
        return None


#: Fewest usable channels an update needs: a loose fix 4 (position and clock), tight differences 2.
MIN_CHANNELS = {False: 4, True: 2}


def _filter_imu(p):
    """The IMU error levels the INS filter assumes: ``filter_imu``, or the truth's ``imu``."""
    return p.imu if p.filter_imu is None else p.filter_imu


def _calibrates(ekf) -> bool:
    """Whether the INS filter carries the IMU calibration states (33 INS error states)."""
    n = ekf.error_states
    if n not in (15, 33):
        raise ConfigError(f"nav_filter {ekf.name!r}", f"the strapdown INS carries 15 or 33 error states, not {n}")
    return n == 33


def _initial_cov(p) -> np.ndarray:
    """Initial covariance of the 15-state error: the scenario's initial errors and the bias levels
    (random constant plus Gauss-Markov deviation) of the IMU the filter assumes (`_filter_imu`)."""
    g = _filter_imu(p)
    std = np.concatenate(
        [
            np.full(3, np.radians(p.initial_attitude_std_deg)),
            np.full(3, p.initial_velocity_std_m_s),
            np.full(3, p.initial_position_std_m),
            np.full(3, np.hypot(g.gyro_bias_rad_s, g.gyro_markov_sigma_rad_s)),
            np.full(3, np.hypot(g.accel_bias_mps2, g.accel_markov_sigma_mps2)),
        ]
    )
    return np.diag(np.maximum(std, 1e-12) ** 2)


def _setup_ins(scenario, flight: Flight, runs: int, rng: np.random.Generator, calibration: bool = False):
    """Measured increments, the INS started from the truth plus drawn initial errors, and P0
    (``calibration``: the INS carries the IMU's scale-factor and misalignment states too)."""
    from ...inertial.error_model import apply_navigation_error
    from ...inertial.imu import simulate_imu

    p = scenario.params
    n = int(round(p.duration_s / p.imu_interval_s))
    dtheta, dv = flight.model.increments(p.imu_interval_s, n)
    dtheta_m, dv_m, _ = simulate_imu(dtheta[:, None, :], dv[:, None, :], p.imu_interval_s, p.imu, rng, (runs,))
    P0 = _initial_cov(p)
    err0 = draw.standard_normal(rng, (runs, 9), 0) * np.sqrt(np.diag(P0)[:9])
    truth0 = flight.model.evaluate(np.array([0.0])).nav_state(0)
    state0 = apply_navigation_error(truth0.broadcast((runs,)), err0)
    return StrapdownIns(state0, dtheta_m, dv_m, p.imu_interval_s, _filter_imu(p), calibration), P0


def _nav_record(flight: Flight, t_s: float, ins: StrapdownIns, cov: np.ndarray) -> dict[str, np.ndarray]:
    tr = flight.truth(t_s)
    s = ins.state
    err = np.concatenate([s.velocity_ecef_mps - tr.velocity_ecef_mps[0], s.position_ecef_m - tr.position_ecef_m[0]], -1)
    nees_vp = nees(err, cov[:, 3:9, 3:9])
    return {
        "position_m": s.position_ecef_m.copy(),
        "velocity_m_s": s.velocity_ecef_mps.copy(),
        "body_to_ned": body_to_ned(s.q_b_e, s.position_ecef_m),
        "nees": nees_vp,
        "attitude_cov_ecef": cov[:, 0:3, 0:3].copy(),
    }


def _stack(records: list[dict[str, np.ndarray]], times: list[float], extra: dict[str, np.ndarray]) -> dict:
    out = {k: np.stack([r[k] for r in records]) for k in records[0]}
    out["time_s"] = np.asarray(times)
    out.update(extra)
    return out


def run_deep(
    scenario,
    plugins: dict[str, Any],
    flight: Flight,
    truth: DeepTruth,
    runs: int,
    rng: np.random.Generator,
    lock: LockVerdicts | None = None,
) -> dict[str, np.ndarray]:
    """The ``deep`` / ``deep-no-accel`` candidates: INS-aided NCOs, prefilters, ``ins-ekf`` on differences.

    With ``lock`` verdicts (an outage's ideal detector or a lock test), an update leaves out
    the channels they exclude from the first update whose prefilter outputs reach into it (those of the interval ending at the update), as
    ``loose`` and ``tight`` do; their NCOs go on being aided by the INS."""
    p = scenario.params
    ekf = plugins["nav_filter"]
    ins, P0 = _setup_ins(scenario, flight, runs, rng, _calibrates(ekf))
    ekf.reset((runs,), RunContext(initial_cov=P0, epoch_interval_s=p.update_interval_s))
    aiding = ekf.aiding()  # an ErrorStateNavFilter's contract
    c_std = np.asarray(p.initial_clock_std_m, float)
    clock = ClockFilter(
        truth.clock_m[0] + draw.standard_normal(rng, (runs, 2), 0) * c_std, np.diag(c_std**2), aiding.clock_psd
    )
    records, times = [], []

    def record(t_s, nav):
        records.append(_nav_record(flight, t_s, nav.ins, nav.ekf.cov))
        times.append(t_s)

    usable = None if lock is None else (lambda t_s: lock.usable(t_s, 0.0))
    nav = InsNavigator(ins, ekf, clock, on_update=record, pull_in_updates=p.pull_in_updates, channel_usable=usable)
    spec = aiding.carrier_filter
    rec = run_aided_tracking(
        plugins["channel_filter"],
        nav,
        truth,
        rng,
        nco_interval_s=p.nco_interval_s,
        update_interval_s=p.update_interval_s,
        accel_aiding=aiding.accel_aiding,
        early_late_spacing_chips=p.early_late_spacing_chips,
        carrier_filter=None if spec is None else spec.create(),
        on_correlators=None if lock is None else _observer(lock, plugins["channel_filter"]),
    )
    return _stack(
        records, times, {"code_error_chips": rec.code_error_chips, "freq_error_hz": rec.freq_error_hz, **rec.extra}
    )


def _observer(lock: LockVerdicts, channel):
    """Each interval's correlators to ``lock``; the channels it marks ``returned`` (a lost
    signal back) have ``channel``'s filter restarted before it steps on them."""

    def observe(correlators) -> None:
        lock.observe(correlators)
        back = lock.returned
        if back is not None and back.any():
            channel.restart(back)

    return observe


def run_loose(
    scenario,
    plugins: dict[str, Any],
    flight: Flight,
    truth: DeepTruth,
    runs: int,
    rng: np.random.Generator,
    lock: LockVerdicts | None = None,
) -> dict[str, np.ndarray]:
    """The ``loose`` candidate: scalar loops, weighted least-squares fixes at the update rate, ``ins-ekf``.
    With fewer than 4 usable channels (``lock``) no fix can be formed: the INS coasts."""
    return _run_scalar(scenario, plugins, flight, truth, runs, rng, tight=False, lock=lock)


def run_tight(
    scenario,
    plugins: dict[str, Any],
    flight: Flight,
    truth: DeepTruth,
    runs: int,
    rng: np.random.Generator,
    lock: LockVerdicts | None = None,
) -> dict[str, np.ndarray]:
    """The ``tight`` candidate: the same scalar loops as ``loose``, their per-channel pseudoranges and
    rates single-differenced into ``ins-ekf`` (`tight_update`) at the update rate, the same
    variances, inflation and innovation gate (the gate on each update's differences together).
    With ``lock`` verdicts it updates on the usable channels while two or more remain."""
    return _run_scalar(scenario, plugins, flight, truth, runs, rng, tight=True, lock=lock)


def _run_scalar(
    scenario,
    plugins: dict[str, Any],
    flight: Flight,
    truth: DeepTruth,
    runs: int,
    rng: np.random.Generator,
    *,
    tight: bool,
    lock: LockVerdicts | None = None,
) -> dict[str, np.ndarray]:
    """Scalar loops over the whole flight, then an ``ins-ekf`` update per interval: a fix (loose) or
    the channels' measurements (tight). The two draw the same numbers in the same order.

    With ``lock`` verdicts each update uses the channels they keep (`LockVerdicts.usable`); with fewer
    than `MIN_CHANNELS` of them (4 for a fix, 2 for a difference) the filter only propagates.
    With a lock test's verdicts (`CN0LockDetector`) each run keeps its own channels, weighted
    out (`weight_out`), and a run with too few has a nil-gain update: a run's numbers do not
    depend on the other runs of its batch."""
    p = scenario.params
    T = p.coherent_time_s
    K = truth.epochs
    t_edges = np.arange(K + 1) * T
    sat_pos, sat_vel, sat_acc = truth.sat_state(t_edges)  # (K+1, ch, 3), or (K+1, runs, ch, 3) per run
    r, v, _ = flight.kinematics(t_edges)  # (K+1, 3)
    if sat_pos.ndim == 4:  # a geometry per run: the receiver against each run's satellites
        r, v = r[:, None, None, :], v[:, None, None, :]
    else:
        r, v = r[:, None, :], v[:, None, :]
    geo, los = line_of_sight(sat_pos, r)
    rate = range_rate(sat_vel, v, los)
    if sat_pos.ndim == 3:  # shared satellites: add the run axis
        geo, rate = geo[:, None, :], rate[:, None, :]
    rho = geo + truth.clock_m[..., 0:1]  # (K+1, runs, ch)
    rho_rate = rate + truth.clock_m[..., 1:2]
    carrier_rho = None
    if truth.range_error_m is not None:  # errors of the truth the receiver's model lacks
        code_m, carrier_m = truth.range_error_m(t_edges)
        carrier_rho = rho + carrier_m
        rho = rho + code_m
        rho_rate = rho_rate + np.gradient(carrier_m, T, axis=0)  # the carrier's rate is what the loops read
    rho_c = rho if carrier_rho is None else carrier_rho
    channel = plugins["channel_filter"]
    track = scalar_tracking(
        channel,
        rho,
        truth.cn0_dbhz,
        T,
        rng,
        early_late_spacing_chips=p.early_late_spacing_chips,
        carrier_range_m=carrier_rho,
        amplitude_scale=truth.signal_gain,
        on_correlators=None if lock is None else _observer(lock, channel),
    )
    cp = channel.params
    window = int(round(p.rate_window_s / T))
    var_r, var_v = scalar_measurement_variances(
        truth.cn0_dbhz,
        T,
        getattr(cp, "dll_bandwidth_hz", 1.0),
        getattr(cp, "pll_bandwidth_hz", 15.0),
        window * T,
        p.early_late_spacing_chips,
    )
    if p.loose_dll_correlation == "loop":  # correlated DLL errors between fixes (deep.loose.correlated_error_inflation)
        var_r = var_r * correlated_error_inflation(getattr(cp, "dll_bandwidth_hz", 1.0), p.update_interval_s)
    var_r = np.broadcast_to(var_r, rho.shape[1:])
    var_v = np.broadcast_to(var_v, rho.shape[1:])
    cn0 = np.broadcast_to(np.asarray(truth.cn0_dbhz, float), rho.shape[1:])
    trailing = p.loose_rate_window == "trailing"
    reach_s = (1 if trailing else window // 2 + 1) * T  # how far past the update its measurements reach
    ekf = plugins["nav_filter"]
    ins, P0 = _setup_ins(scenario, flight, runs, rng, _calibrates(ekf))
    ekf.reset((runs,), RunContext(initial_cov=P0, epoch_interval_s=p.update_interval_s))
    n_upd = int(round(p.update_interval_s / T))
    per_run = lock is not None and not isinstance(lock, ChannelOutage)  # a lock test's verdicts
    records, times = [], []
    for u, k_edge in enumerate(range(n_upd, K + 1, n_upd)):
        t_u = k_edge * T
        ins.advance(t_u)
        usable = None if lock is None else lock.usable(t_u, reach_s)
        # An outage's ideal verdicts are the same in every run: the usable channels are selected, and
        # with too few the filter only propagates. A lock test's differ by run: every run is updated
        # alike whatever its batch mates (`weight_out`), one with too few with nil gain.
        enough = per_run or usable is None or usable.sum(axis=-1).min() >= MIN_CHANNELS[tight]
        if enough and u >= p.pull_in_updates and (k_edge >= window if trailing else k_edge + window // 2 <= K):
            m_rho, m_rate = scalar_measurements(track, rho[k_edge], rho_rate[k_edge], k_edge - 1, window)
            pos0, vel0, acc0 = ins.kinematics()
            if trailing:
                m_rate = trailing_rate_measurement(
                    track, rho_c, k_edge, window, T, line_of_sight_accel(sat_pos[k_edge], sat_acc[k_edge], pos0, acc0)
                )
            s_pos = np.broadcast_to(sat_pos[k_edge], rho.shape[1:] + (3,))
            s_vel = np.broadcast_to(sat_vel[k_edge], rho.shape[1:] + (3,))
            chans = (m_rho, m_rate, var_r, var_v, s_pos, s_vel, cn0)
            refused = None
            if per_run:  # left-out channels weighted out; a run with too few refused as a whole
                chans, refused = weight_out(usable, MIN_CHANNELS[tight], *chans)
            elif usable is not None:  # each run's usable channels only
                chans = select_channels(usable, *chans)
            if tight:
                tight_update(ins, ekf, *chans, p.loose_gate_probability)
            else:
                fp, fv, fcov = pv_fix(*chans[:4], *chans[4:6], pos0, vel0)
                if refused is not None:  # no fix in those runs: the INS's own position, nil gain
                    fp, fv = np.where(refused[:, None], pos0, fp), np.where(refused[:, None], vel0, fv)
                    fcov = np.where(refused[:, None, None], fcov + REJECTED_FIX_VAR * np.eye(6), fcov)
                _, _, fix_var_r, _, fix_sat_pos, _, _ = chans  # the channels the fix used
                gain, los_fix = fix_range_gain(fix_var_r, fix_sat_pos, fp)  # a range-bias budget maps through it
                loose_update(ins, ekf, fp, fv, fcov, p.loose_gate_probability, range_gain=gain, los=los_fix)
        else:
            ekf.propagate(*ins.take_error_model())
        records.append(_nav_record(flight, t_u, ins, ekf.cov))
        times.append(t_u)
    return _stack(
        records,
        times,
        {
            "code_error_chips": track.code_error_chips,
            "freq_error_hz": track.freq_error_hz,
            "phase_error_rad": track.phase_error_rad,
        },
    )


def weight_out(usable: np.ndarray, fewest: int, m_rho, m_rate, var_r, var_v, s_pos, s_vel, cn0):
    """All channels of an update whose runs may keep different numbers of them (a lock
    detector's verdicts): a left-out channel's variances raised by `REJECTED_FIX_VAR` (its
    weight in a fix, and its difference's gain, nil) and its C/N0 -inf (never the reference
    of the differences). A run with fewer than ``fewest`` usable channels is returned as
    ``refused`` ``(runs,)``: its channels are all kept for the arithmetic (a fix needs four)
    but raised alike, so its update has nil gain."""
    refused = usable.sum(axis=-1) < fewest
    out = ~usable | refused[:, None]
    var_r = np.where(out, var_r + REJECTED_FIX_VAR, var_r)
    var_v = np.where(out, var_v + REJECTED_FIX_VAR, var_v)
    cn0 = np.where(out & ~refused[:, None], -np.inf, cn0)
    return (m_rho, m_rate, var_r, var_v, s_pos, s_vel, cn0), refused


#: What the run of every integrated candidate kind takes and gives (``run_<kind>`` of this
#: module: `run_deep`, `run_loose`, `run_tight`; ``vector`` is the scenario's own): the
#: scenario, the candidate's plugins, the flight, its truth, the runs, their streams and the
#: receiver's lock verdicts (`LockVerdicts`); the series the scenario scores (``time_s``, ``position_m``...).
CandidateRun = Callable[
    [Any, dict[str, Any], Flight, DeepTruth, int, np.random.Generator, LockVerdicts | None],
    dict[str, np.ndarray],
]
