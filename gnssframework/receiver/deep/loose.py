"""The loose-coupling baseline of the deep-integration experiment: scalar loops, then position/velocity fixes.

Loose coupling (Groves 2013, section 14.1.2): each channel tracks on its own (scalar
loops, no aiding), the receiver forms a position/velocity/clock solution from the loops'
pseudoranges and range rates, and that fix updates the INS's error-state filter. The
loops do not see the INS, so they run first over the whole flight
(`scalar_tracking`), then the fixes are formed at the integration rate (`pv_fix`) and fed
to ``ins-ekf`` (`ins_navigator.loose_update`).

Measurements from a scalar loop (its replica is what the receiver reads):
$\\rho_m = \\rho + \\lambda_{chip}\\,\\delta\\tau$ (the code NCO lags the true code by
$\\delta\\tau$ chips, code phase decreasing with range) and
$\\dot\\rho_m = \\dot\\rho + \\lambda_{L1}\\,\\delta f$ (the carrier NCO reads
$f - \\delta f$, range rate $-\\lambda f$).
"""

from __future__ import annotations

import numpy as np

from ... import random_streams as draw
from ...errors import ConfigError, NumericalError
from ...interfaces import ChannelFilter
from ...navigation.geometry import line_of_sight, range_rate
from ...signal.gps_l1ca import GPS_L1CA
from ...signal.spec import SignalSpec
from ..engine.loops import TrackingRecord
from ..engine.truth import SignalTruth, code_phase_of_range
from ..tracking.scalar import run_closed_loop

__all__ = [
    "scalar_tracking",
    "pv_fix",
    "fix_range_gain",
    "scalar_measurement_variances",
    "scalar_measurements",
    "trailing_rate_measurement",
    "line_of_sight_accel",
    "correlated_error_inflation",
    "fix_gate",
    "select_channels",
]


def scalar_tracking(
    channel: ChannelFilter,
    pseudorange_m: np.ndarray,
    cn0_dbhz: np.ndarray,
    coherent_time_s: float,
    rng: np.random.Generator,
    *,
    initial_doppler_error_hz: np.ndarray | float = 0.0,
    early_late_spacing_chips: float = 1.0,
    carrier_range_m: np.ndarray | None = None,
    amplitude_scale: np.ndarray | None = None,
    signal: SignalSpec = GPS_L1CA,
    on_correlators=None,
) -> TrackingRecord:
    """Track every channel with its own scalar loop.

    Parameters
    ----------
    pseudorange_m
        ``(K+1, runs, ch)`` true pseudorange at the epoch edges (clock included).
    initial_doppler_error_hz
        Acquisition's Doppler error added to the true initial Doppler.
    carrier_range_m
        ``(K+1, runs, ch)`` true range of the carrier phase when it differs from the code's
        (the ionosphere advances one and delays the other); None: ``pseudorange_m``.
    amplitude_scale
        Optional ``(K, runs, ch)`` factor on each interval's signal amplitude (0: the signal is
        gone, as in a satellite outage); the correlator noise is drawn as without it.
    signal
        The tracked signal (`GPS_L1CA`).
    on_correlators
        Optional callable given each interval's correlators (a lock detector's ``observe``).

    Returns
    -------
    The `TrackingRecord` of `run_closed_loop` (code, phase and frequency errors of the
    replicas, ``(K, runs, ch)``).
    """
    rho = np.asarray(pseudorange_m, float)
    rho0 = rho[0]
    rho_c = rho if carrier_range_m is None else np.asarray(carrier_range_m, float)
    carrier = -2 * np.pi * (rho_c - rho_c[0]) / signal.wavelength_m + draw.uniform(rng, -np.pi, np.pi, rho0.shape, 0)
    t = np.arange(rho.shape[0]).reshape((-1,) + (1,) * (rho.ndim - 1)) * coherent_time_s
    code = code_phase_of_range(signal, rho - rho0, t)
    truth = SignalTruth(
        code,
        carrier,
        np.broadcast_to(np.asarray(cn0_dbhz, float), rho0.shape),
        coherent_time_s,
        1.0 if amplitude_scale is None else amplitude_scale,
        signal=signal,
    )
    doppler0 = -(rho_c[1] - rho_c[0]) / coherent_time_s / signal.wavelength_m
    return run_closed_loop(
        channel,
        truth,
        rng,
        initial_doppler_hz=doppler0 + initial_doppler_error_hz,
        early_late_spacing_chips=early_late_spacing_chips,
        on_correlators=on_correlators,
    )


def scalar_measurement_variances(
    cn0_dbhz: np.ndarray,
    coherent_time_s: float,
    dll_bandwidth_hz: float,
    pll_bandwidth_hz: float,
    rate_window_s: float,
    early_late_spacing_chips: float = 1.0,
    signal: SignalSpec = GPS_L1CA,
) -> tuple[np.ndarray, np.ndarray]:
    """Thermal-noise variances of a scalar loop's pseudorange (m^2) and range rate (m^2/s^2).

    Code: the early-minus-late envelope DLL, $\\sigma_\\tau^2 = \\frac{B_L d}{2 c}\\left(1 +
    \\frac{2}{(2-d) T c}\\right)$ chips^2 (Kaplan and Hegarty 2017, eq. 8.44; $c = C/N_0$).
    Rate: the carrier phase advance over a window $\\Delta$ (the NCO's own frequency is
    far noisier: its proportional path passes every discriminator sample), whose two end
    points carry the PLL's thermal jitter $\\sigma_\\theta^2 = \\frac{B_L}{c}(1 +
    \\frac{1}{2Tc})$ (Kaplan and Hegarty 2017, eq. 8.35), taken as independent:
    $\\sigma_{\\dot\\rho}^2 = 2\\sigma_\\theta^2 \\lambda^2 / (2\\pi\\Delta)^2$.
    """
    c = 10.0 ** (np.asarray(cn0_dbhz, float) / 10.0)
    T, d = coherent_time_s, early_late_spacing_chips
    var_code = dll_bandwidth_hz * d / (2 * c) * (1 + 2 / ((2 - d) * T * c)) * signal.chip_length_m**2
    var_phase = pll_bandwidth_hz / c * (1 + 1 / (2 * T * c))
    var_rate = 2 * var_phase * (signal.wavelength_m / (2 * np.pi * rate_window_s)) ** 2
    return var_code, var_rate


def pv_fix(
    range_m: np.ndarray,
    rate_m_s: np.ndarray,
    var_range: np.ndarray,
    var_rate: np.ndarray,
    sat_pos_m: np.ndarray,
    sat_vel_m_s: np.ndarray,
    pos0_m: np.ndarray,
    vel0_m_s: np.ndarray,
    *,
    iterations: int = 4,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Weighted least-squares position/velocity/clock fix (Groves 2013, sections 9.4.1-9.4.2).

    Parameters
    ----------
    range_m, rate_m_s, var_range, var_rate
        ``(runs, ch)`` pseudoranges and range rates and their variances.
    sat_pos_m, sat_vel_m_s
        ``(ch, 3)`` or ``(runs, ch, 3)``.
    pos0_m, vel0_m_s
        ``(runs, 3)`` linearisation point (the INS, or the previous fix).

    Returns
    -------
    position ``(runs, 3)``, velocity ``(runs, 3)`` and the 6x6 covariance ``(runs, 6, 6)`` of
    [position, velocity] (the clock marginalised out).
    """
    runs, n = range_m.shape
    if n < 4:  # 4 unknowns (position and clock): the normal matrix is singular, whatever rounding says
        raise NumericalError("pv-fix", [], None, f"singular geometry (fewer than 4 channels: {n})")
    r = np.asarray(pos0_m, float).copy()
    v = np.asarray(vel0_m_s, float).copy()
    b = np.zeros(runs)
    d = np.zeros(runs)
    w_r, w_v = 1.0 / var_range, 1.0 / var_rate
    for _ in range(iterations):
        rng_g, e = line_of_sight(sat_pos_m, r[:, None, :])
        pred_rho = rng_g + b[:, None]
        pred_rate = range_rate(sat_vel_m_s, v[:, None, :], e) + d[:, None]
        H = np.zeros((runs, n, 4))
        H[..., :3] = -e
        H[..., 3] = 1.0
        N_r = np.einsum("rci,rc,rcj->rij", H, w_r, H)
        N_v = np.einsum("rci,rc,rcj->rij", H, w_v, H)
        try:
            dx_r = np.linalg.solve(N_r, np.einsum("rci,rc->ri", H, w_r * (range_m - pred_rho))[..., None])[..., 0]
            dx_v = np.linalg.solve(N_v, np.einsum("rci,rc->ri", H, w_v * (rate_m_s - pred_rate))[..., None])[..., 0]
        except np.linalg.LinAlgError:
            raise NumericalError(
                "pv-fix", [], None, "singular geometry (fewer than 4 independent lines of sight)"
            ) from None
        r += dx_r[:, :3]
        b += dx_r[:, 3]
        v += dx_v[:, :3]
        d += dx_v[:, 3]
    cov = np.zeros((runs, 6, 6))
    cov[:, :3, :3] = np.linalg.inv(N_r)[:, :3, :3]
    cov[:, 3:, 3:] = np.linalg.inv(N_v)[:, :3, :3]
    return r, v, cov


def fix_range_gain(
    var_range: np.ndarray, sat_pos_m: np.ndarray, fix_pos_m: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """How each channel's range error moves a `pv_fix` position: the position rows of its
    weighted least-squares gain at the fix (Groves 2013, section 9.4.1),

    $$ K = (G^T W G)^{-1} G^T W, \\qquad G_i = [-e_i^T,\\; 1], \\quad W = \\mathrm{diag}(1/\\sigma_i^2), $$

    so that a range error $\\delta\\rho$ ``(runs, ch)`` moves the fix by $K_{0:3}\\,\\delta\\rho$.

    Parameters
    ----------
    var_range
        ``(runs, ch)`` the fix's range variances.
    sat_pos_m
        ``(ch, 3)`` or ``(runs, ch, 3)``.
    fix_pos_m
        ``(runs, 3)`` the fix.

    Returns
    -------
    The gain ``(runs, 3, ch)`` (m/m) and the unit lines of sight ``(runs, ch, 3)`` (receiver to satellite).
    """
    _, e = line_of_sight(sat_pos_m, np.asarray(fix_pos_m, float)[:, None, :])
    G = np.concatenate([-e, np.ones(e.shape[:-1] + (1,))], axis=-1)  # (runs, ch, 4)
    GtW = np.swapaxes(G, -1, -2) / np.asarray(var_range, float)[:, None, :]
    return np.linalg.solve(GtW @ G, GtW)[:, :3, :], e


def scalar_measurements(
    record: TrackingRecord,
    pseudorange_m: np.ndarray,
    rate_m_s: np.ndarray,
    k: int,
    rate_window: int,
    signal: SignalSpec = GPS_L1CA,
) -> tuple[np.ndarray, np.ndarray]:
    """Pseudorange and range rate the scalar loops read at the edge after interval ``k``.

    ``pseudorange_m`` and ``rate_m_s`` ``(runs, ch)`` are the true values there. The
    pseudorange is the code NCO's; the rate is the carrier phase advance over the
    ``rate_window`` intervals centred on the edge (the mean frequency error of those
    intervals), whose mean rate equals the rate at the centre up to $j\\Delta^2/24$.
    """
    code = 0.5 * (record.code_error_chips[k] + record.code_error_chips[min(k + 1, len(record.code_error_chips) - 1)])
    lo = max(k + 1 - rate_window // 2, 0)
    hi = min(lo + rate_window, len(record.freq_error_hz))
    return (
        pseudorange_m + signal.chip_length_m * code,
        rate_m_s + signal.wavelength_m * np.mean(record.freq_error_hz[lo:hi], axis=0),
    )


def trailing_rate_measurement(
    record: TrackingRecord,
    carrier_range_m: np.ndarray,
    k_edge: int,
    window: int,
    coherent_time_s: float,
    los_accel_m_s2: np.ndarray,
    signal: SignalSpec = GPS_L1CA,
) -> np.ndarray:
    """Range rate at edge ``k_edge`` from the carrier phase of the ``window`` intervals before it.

    The loops' carrier phase advance over the trailing window (nothing after the update
    instant) is the mean rate over it, the true mean $(\\rho_c(t_u) - \\rho_c(t_u - \\Delta))
    / \\Delta$ plus the mean replica frequency error times $\\lambda_{L1}$; it refers to the
    window's middle, so it is carried to the update instant with the receiver's own
    line-of-sight acceleration ``los_accel_m_s2`` ``(runs, ch)`` (from the INS and the
    ephemeris): $+\\ddot\\rho\\,\\Delta/2$.

    ``carrier_range_m`` ``(K+1, runs, ch)`` is the true carrier range at the epoch edges.
    """
    delta_s = window * coherent_time_s
    mean_rate = (carrier_range_m[k_edge] - carrier_range_m[k_edge - window]) / delta_s
    error = signal.wavelength_m * np.mean(record.freq_error_hz[k_edge - window : k_edge], axis=0)
    return mean_rate + error + los_accel_m_s2 * delta_s / 2


def line_of_sight_accel(
    sat_pos_m: np.ndarray, sat_acc_m_s2: np.ndarray, pos_m: np.ndarray, acc_m_s2: np.ndarray
) -> np.ndarray:
    """Range acceleration $e\\cdot(a_s - a)$ ``(runs, ch)`` of satellites ``(ch, 3)`` or ``(runs, ch, 3)``
    seen from receivers at ``pos_m`` with acceleration ``acc_m_s2`` ``(runs, 3)`` (the
    turning of the line of sight, $|v_s - v|^2_\\perp / \\rho$, below 0.1 m/s², is left out)."""
    _, e = line_of_sight(sat_pos_m, pos_m[:, None, :])
    return range_rate(sat_acc_m_s2, acc_m_s2[:, None, :], e)  # the same projection, of accelerations


def correlated_error_inflation(loop_bandwidth_hz: float | np.ndarray, interval_s: float) -> float | np.ndarray:
    """Factor on a loop's thermal variance for measurements taken every ``interval_s`` from it.

    A first-order loop (the carrier-aided DLL) with noise bandwidth $B_L$ has gain
    $\\omega = 4B_L$ and an error with autocorrelation $e^{-4B_L|t|}$ (Kaplan and Hegarty
    2017, section 8.4), so samples $\\Delta t$ apart are correlated by $\\rho =
    e^{-4B_L\\Delta t}$. The mean of many such samples has $(1+\\rho)/(1-\\rho)$ times the
    variance it would have were they white (an AR(1) sequence); a filter that takes them
    as white with the variance inflated by this factor weighs their long-run average
    correctly (it still ignores the short-term correlation).
    """
    rho = np.exp(-4.0 * np.asarray(loop_bandwidth_hz, float) * interval_s)
    return (1.0 + rho) / (1.0 - rho)


def fix_gate(innovation: np.ndarray, innovation_cov: np.ndarray, false_alarm_probability: float) -> np.ndarray:
    """Which fixes pass a chi-square innovation gate: ``(runs, m)``, ``(runs, m, m)`` -> ``(runs,)`` bool.

    A fix whose normalised innovation squared $\\nu^T S^{-1} \\nu$ exceeds the chi-square
    quantile with m degrees of freedom at ``1 - false_alarm_probability`` is rejected
    (Groves 2013, section 17.3.1): a consistent fix is refused with that probability, one
    carrying a cycle slip's or a lost loop's error far more often.
    """
    from scipy.stats import chi2

    d2 = np.einsum("ri,ri->r", innovation, np.linalg.solve(innovation_cov, innovation[..., None])[..., 0])
    return d2 <= chi2.ppf(1.0 - false_alarm_probability, innovation.shape[-1])


def select_channels(usable: np.ndarray, *arrays: np.ndarray) -> tuple[np.ndarray, ...]:
    """Each run's usable channels of ``arrays``: ``usable`` ``(runs, ch)`` bool with the same
    count m in every run, each array ``(runs, ch, ...)``; returns them ``(runs, m, ...)``,
    the channels in their order."""
    usable = np.asarray(usable, bool)
    runs = usable.shape[0]
    m = usable.sum(axis=-1)
    if np.any(m != m[0]):
        raise ConfigError("usable", f"every run must keep the same number of channels (got {sorted(set(m.tolist()))})")
    idx = np.nonzero(usable)[1].reshape(runs, int(m[0]))  # row-major: each run's channels in order
    out = []
    for a in arrays:
        a = np.asarray(a)
        out.append(np.take_along_axis(a, idx.reshape(idx.shape + (1,) * (a.ndim - 2)), axis=1))
    return tuple(out)
