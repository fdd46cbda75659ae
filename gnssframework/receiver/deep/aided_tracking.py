"""Multi-rate aided tracking harness of deep integration (Cai and Guo 2017), batched over runs and channels.

A composition of the loop engine (`gnssframework.receiver.engine`): `Channel` NCOs steered
by range, the `AnalyticSource` and a `DeepCloser`
(`gnssframework.receiver.engine.deep_closer`, which holds the rates, the aiding, the
integration fit and the optional carrier loop). Rates (Cai and Guo 2017, section 3.1):
correlators and the code/frequency prefilter every coherent interval T (1 ms); the NCOs
re-aided every ``nco_interval_s`` from the navigator (the corrected INS at 200 Hz in deep
integration); the integration filter updated every ``update_interval_s`` (10 Hz).

Each coherent interval k the harness gives the closer what only the simulation knows:

1. the replica's true code, phase and frequency errors against the truth at the
   interval's edges (`Channel.errors`: true code phase $f_{chip} t - \\rho/\\lambda_{chip}$
   of the code pseudorange, true carrier phase $\\theta_0 - 2\\pi\\rho_c/\\lambda$ of
   the carrier range, with a uniform unknown $\\theta_0$ per channel);
2. the correlators those errors produce (`AnalyticSource`, interval k's signal and noise
   gains when the truth has them);
3. the satellites' states at the interval's end edge, for the re-aiding and the
   integration update (`DeepCloser.step`, which then commands interval k+1).

Errors are the engine's: truth minus replica code phase (chips) and Doppler (Hz)
(`gnssframework.receiver.engine.channel`). Residual sign: true minus the navigator's
prediction, so a navigator position error $\\delta r$ shows as
$\\delta\\rho_i = e_i\\cdot\\delta r - \\delta b$. With a carrier filter its tracking
error, the true carrier phase minus its replica's at mid-interval, is recorded as
``extra["phase_error_rad"]``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ... import random_streams as draw
from ...errors import ConfigError
from ...interfaces import ChannelFilter
from ...signal.correlator_model import CorrelatorSimulator, amplitude_from_cn0
from ..engine.deep_closer import DeepCloser, Navigator
from ..engine.sources import AnalyticSource
from ..engine.truth import DeepTruth, LoopTruth, code_phase_of_range

__all__ = ["DeepTruth", "Navigator", "DeepRecord", "run_aided_tracking", "loss_of_lock"]


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
    on_correlators=None,
) -> DeepRecord:
    """Run the aided tracking loop over all epochs of ``truth`` (data bits wiped off).

    Parameters
    ----------
    channel
        Code/frequency prefilter providing `gnssframework.receiver.engine.closers.CHANNEL_OUTPUTS`
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
        3.6 to 7.8 for 3 states with it; ``tests/receiver/test_deep_ins.py``).
    carrier_filter
        Optional carrier-phase prefilter (a ``channel_filter`` on ``correlators`` that
        provides ``carrier_freq_hz`` and may provide ``carrier_phase_step_rad``, e.g.
        ``kf-carrier-loop``): it closes only the carrier loop on top of the aided
        replica; its outputs are frequency and phase corrections to that replica.
    on_correlators
        Optional callable given each interval's correlators before the closer steps on them
        (a lock detector's ``observe``, whose verdict the navigator's update then reads).
    """
    closer = DeepCloser(
        channel, navigator, carrier_filter=carrier_filter, accel_aiding=accel_aiding, pull_in_updates=pull_in_updates
    )
    T = truth.coherent_time_s
    n_nco = _steps(nco_interval_s, T, "nco_interval_s")
    n_upd = _steps(update_interval_s, T, "update_interval_s")
    if n_upd % n_nco:
        raise ConfigError("update_interval_s", f"must be a multiple of nco_interval_s ({nco_interval_s} s)")
    K = truth.epochs
    runs = truth.clock_m.shape[1]
    sat_at = _EdgeStates(truth, K)
    n_ch = sat_at(0)[0].shape[-2]  # satellites (ch, 3), or (runs, ch, 3) with a geometry per run
    batch = (runs, n_ch)
    cn0 = np.broadcast_to(np.asarray(truth.cn0_dbhz, float), batch)
    # Per-run constants of the correlator draws (tap noise root, amplitude) once, not per interval.
    scale = truth.amplitude_scale
    source = AnalyticSource(
        CorrelatorSimulator(T, early_late_spacing_chips),
        amplitude_from_cn0(cn0, T),
        rng,
        amplitude_scale=None if np.ndim(scale) == 0 and scale == 1.0 else scale,
        signal_gain=truth.signal_gain,
        noise_gain=truth.noise_gain,
    )
    theta0 = draw.uniform(rng, -np.pi, np.pi, batch, 0)  # unknown initial carrier phase per channel
    closer.reset(
        batch, T, n_nco, n_upd, K, signal=truth.signal, early_late_spacing_chips=early_late_spacing_chips, cn0_dbhz=cn0
    )
    replica = closer.start(sat_at(0))
    true_at = _TrueSignal(sat_at, theta0)
    rec: dict[str, list] = {"code": [], "freq": [], "phase": []}
    edge = true_at(0)
    for k in range(K):
        nxt = true_at(k + 1)
        err = replica.errors(edge[0], nxt[0], edge[1], nxt[1], T)
        corr = source.correlate(replica, k, err)
        if on_correlators is not None:
            on_correlators(corr)
        rot_rad = closer.rotation_rad()
        if rot_rad is not None:  # the carrier loop's phase error at mid-interval (wrapped once at the end)
            rec["phase"].append(err.phase_rad + np.pi * err.freq_hz * T - rot_rad)
        closer.step(replica, corr, k, sat_at(k + 1))
        rec["code"].append(err.code_chips)
        rec["freq"].append(err.freq_hz)
        edge = nxt
    extra = {"phase_error_rad": np.angle(np.exp(1j * np.stack(rec["phase"])))} if carrier_filter is not None else {}
    updates = closer.updates  # none when the run is shorter than one integration interval
    res = np.stack([u[1] for u in updates]) if updates else np.empty((0,) + batch + (2,))
    cov = np.stack([u[2] for u in updates]) if updates else np.empty((0,) + batch + (2, 2))
    return DeepRecord(
        np.stack(rec["code"]),
        np.stack(rec["freq"]),
        (np.arange(K) + 0.5) * T,
        np.asarray([u[0] for u in updates], float),
        res,
        cov,
        extra,
    )


class _TrueSignal:
    """True code phase (chips) and carrier phase (rad) at edge k, ``(runs, ch)`` each: the
    code phase of the code pseudorange (`code_phase_of_range`) and
    :math:`\\theta_0 - 2\\pi\\rho_c/\\lambda` of the carrier range (the code range plus the
    truth's carrier-minus-code divergence, when it has range errors)."""

    def __init__(self, sat_at: _EdgeStates, theta0: np.ndarray) -> None:
        self.sat_at, self.theta0 = sat_at, theta0
        self.signal = sat_at.truth.signal
        self.T = sat_at.truth.coherent_time_s

    def __call__(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        rho = self.sat_at.pseudorange(k)
        carrier_rho = rho
        if self.sat_at.truth.range_error_m is not None:  # the carrier range differs from the code's (ionosphere)
            carrier_rho = rho + self.sat_at.carrier_minus_code(k)
        return (
            code_phase_of_range(self.signal, rho, k * self.T),
            self.theta0 - 2 * np.pi * carrier_rho / self.signal.wavelength_m,
        )


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


def loss_of_lock(code_error_chips: np.ndarray, freq_error_hz: np.ndarray, coherent_time_s: float) -> np.ndarray:
    """Loss-of-lock flags: |code error| > 0.5 chip or |frequency error| > 1/(2T).

    At 1/(2T) the coherent sum has lost 36 % of its amplitude (sinc) and half a chip
    takes the prompt halfway down the correlation triangle; both are choices, stated in
    the docs.
    """
    return (np.abs(code_error_chips) > 0.5) | (np.abs(freq_error_hz) > 0.5 / coherent_time_s)
