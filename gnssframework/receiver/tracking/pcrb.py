r"""Posterior Cramér–Rao bound (PCRB) of vector tracking.

Tichavský, Muravchik and Nehorai (IEEE Trans. Signal Processing 46(5), 1998) give the
Bayesian information matrix $J_k$ of a state sequence recursively,

$$
J_{k+1} = D_k^{22} - D_k^{21} (J_k + D_k^{11})^{-1} D_k^{12},
$$

with $D^{11} = E[-\Delta_{x_k}^{x_k} \log p(x_{k+1}|x_k)]$, $D^{12} = (D^{21})^T =
E[-\Delta_{x_k}^{x_{k+1}} \log p(x_{k+1}|x_k)]$ and $D^{22} = E[-\Delta_{x_{k+1}}^{x_{k+1}}
\log p(x_{k+1}|x_k)] + J^z_{k+1}$, where $J^z$ is the Fisher information of the
measurement. For linear-Gaussian dynamics $x_{k+1} = F x_k + w$, $w \sim N(0, Q)$,
$D^{11} = F^T Q^{-1} F$, $D^{12} = -F^T Q^{-1}$, $D^{22} = Q^{-1} + J^z$, and the matrix
inversion lemma turns the recursion into

$$
J_{k+1} = (Q + F J_k^{-1} F^T)^{-1} + J^z_{k+1},
$$

which also holds for a singular Q (a static receiver). With $J^z = H^T R^{-1} H$ (a
linear-Gaussian measurement) $J_k^{-1}$ is the Kalman filter's covariance; `pcrb_linear`
runs this form as a covariance recursion, the update written with a square root of
$J^z$ so that no ill-conditioned matrix is inverted.

Correlator measurement model (`correlator_fisher`). One coherent interval of the
prompt and of the early and late taps at offsets $o \in \{-d, 0, d\}$ has mean
$\mu_o = A R(\delta\tau - o)\, \mathrm{sinc}(\delta f T)\, e^{j\varphi}$ (the phase
$\varphi$ at mid-interval) and I and Q noise of unit variance, correlated across taps as
$C_{ij} = R(o_i - o_j)$ (`gnssframework.signal.correlator_model`). For the stacked real
vector $[I; Q]$, Gaussian with the known covariance $\mathrm{diag}(C, C)$, the Fisher
information is $J_{ab} = \mathrm{Re}(\partial_a \mu^H C^{-1} \partial_b \mu)$. At zero
tracking error,

$$
J_{\tau\tau} = A^2 g^T C^{-1} g, \quad J_{\varphi\varphi} = A^2 r^T C^{-1} r = A^2,
\quad J_{\tau\varphi} = 0, \quad J_{ff} = 0,
$$

with $r_o = R(-o)$ and $g_o = R'(-o)$ (the prompt's slope is $\mp 1$ on either side of
the peak; the two sides are averaged). The frequency enters one interval only through
$\mathrm{sinc}(\delta f T)$, flat at 0, and through the mid-interval phase: the frequency
information of a vector loop comes from the phase of successive intervals, which the
recursion accumulates. The amplitude and the data bits are taken as known, which can
only lower the bound.

Navigation model (`vector_tracking_pcrb`). The state is the nav state
$[r, v, b, d]$ (metres, m/s) and one constant carrier-phase offset $\theta_{0,i}$ per
channel (uniform on the circle: no prior information). Channel i's code delay is
$\rho_i / \lambda_{chip}$ chips and its mid-interval carrier phase
$-2\pi \rho_i / \lambda_{L1} + \theta_{0,i}$, with $\rho_i = \lVert s_i - r\rVert + b$,
so $\partial \tau_i / \partial x = [-e_i^T, 0, 1, 0] / \lambda_{chip}$ and
$\partial \varphi_i / \partial x = -2\pi [-e_i^T, 0, 1, 0] / \lambda_{L1}$. The
Jacobians are evaluated on the true trajectory (the usual approximation of the
expectation in $J^z$: the posterior spread, metres, is tiny against the satellite
distance). The dynamics are the scenario's truth: a constant-velocity receiver
(no process noise) and the clock's two-state model from its h-parameters.

Code-only bound (``measurements="code"``). Dropping the carrier phase's information
$J_{\varphi\varphi}$ leaves $J^z_k = \sum_i J_{\tau\tau,i}\, h_{i,k}^T h_{i,k}$ with
$h_{i,k} = [-e_{i,k}^T, 0, 1, 0] / \lambda_{chip}$ (and no phase offsets in the state).
For a static receiver with a known velocity and clock drift and no clock noise, the
$K$ intervals then add up to the least-squares information,
$J_K \to \sum_k G_k^T \Sigma^{-1} G_k$, $G = [-e^T, 1]$, $\Sigma = \sigma^2 I$ with
$\sigma^2 = \lambda_{chip}^2 / J_{\tau\tau}$: the snapshot covariance
$\sigma^2 (G^T G)^{-1}$ divided by $K$ (tests/receiver/test_pcrb.py checks both this limit and
the batch least-squares information of the full state).
"""

from __future__ import annotations

from typing import Literal
from collections.abc import Callable

import numpy as np

from ... import backend
from ...errors import ConfigError
from ...estimation.compiled import loop as compiled_loop
from ...navigation.geometry import line_of_sight
from ...signal.gps_l1ca import GPS_L1CA
from ...signal.spec import SignalSpec
from ...signal.correlator_model import amplitude_from_cn0, tap_noise_cov

__all__ = ["pcrb_linear", "correlator_fisher", "vector_tracking_pcrb", "PCRB_MEASUREMENTS"]

#: What the bound's measurements are (`vector_tracking_pcrb`'s ``measurements``).
PcrbMeasurements = Literal["code-and-carrier", "code"]
PCRB_MEASUREMENTS: tuple[str, ...] = ("code-and-carrier", "code")


def pcrb_linear(
    F: np.ndarray,
    Q: np.ndarray,
    sqrt_info: Callable[[int], np.ndarray] | np.ndarray,
    P0: np.ndarray,
    steps: int,
    update_first: bool = True,
) -> np.ndarray:
    """Inverse Bayesian information $J_k^{-1}$ of linear-Gaussian dynamics (module docstring).

    Parameters
    ----------
    F, Q
        Transition and process noise per step (Q may be singular).
    sqrt_info
        ``sqrt_info(k)`` returns $L_k$ ``(m, n)`` with $J^z_k = L_k^T L_k$, the measurement
        information at step k; or all of them stacked ``(steps, m, n)``, which the
        ``numba`` backend runs in one compiled call
        (`gnssframework.estimation.compiled.loop.pcrb_stacked`; this loop is its reference).
    P0
        Prior covariance (inverse prior information) before the first measurement.
    steps
        Number of measurement steps.
    update_first
        The first step's measurement applies to the prior directly (no prediction first).

    Returns
    -------
    np.ndarray
        ``(steps, n, n)``: the bound on the error covariance after each step's measurement.
    """
    if isinstance(sqrt_info, np.ndarray):
        if sqrt_info.ndim != 3 or sqrt_info.shape[0] != steps:
            raise ValueError(f"stacked sqrt_info must be (steps={steps}, m, n), got {sqrt_info.shape}")
        if backend.compiled():
            return compiled_loop.pcrb_stacked(F, Q, sqrt_info, P0, update_first)
        sqrt_info = sqrt_info.__getitem__
    n = F.shape[0]
    P = np.array(P0, dtype=float)
    out = np.empty((steps, n, n))
    eye = np.eye(n)
    for k in range(steps):
        if k > 0 or not update_first:
            P = F @ P @ F.T + Q
        L = np.asarray(sqrt_info(k), dtype=float)
        if L.size:
            # Equivalent unit-variance measurement L x: Joseph form of the KF update.
            PHt = P @ L.T
            S = L @ PHt + np.eye(L.shape[0])
            K = np.linalg.solve(S, PHt.T).T
            A = eye - K @ L
            P = A @ P @ A.T + K @ K.T
        P = 0.5 * (P + P.T)
        out[k] = P
    return out


def correlator_fisher(
    cn0_dbhz: float, coherent_time_s: float, early_late_spacing_chips: float = 1.0, signal: SignalSpec = GPS_L1CA
) -> np.ndarray:
    """Fisher information of one interval's early, prompt and late correlators.

    Returns ``2x2`` over (code delay in chips, mid-interval carrier phase in rad) at zero
    tracking error (module docstring), for a BPSK signal (the triangle's slopes).

    Raises
    ------
    ConfigError
        For a signal with a sub-carrier (its correlation's slopes differ).
    """
    if not signal.is_bpsk:
        raise ConfigError(
            "signal",
            f"the correlator Fisher information assumes BPSK's one-chip triangle; {signal.name}'s "
            f"chip pulse is not a full-chip rectangle ({signal.subcarrier.kind} sub-carrier, "
            f"{signal.subchips_per_chip} pieces a chip)",
        )
    d = early_late_spacing_chips / 2
    if not 0 < d < 1:
        raise ConfigError("early_late_spacing_chips", f"must be in (0, 2), got {early_late_spacing_chips}")
    offsets = np.array([-d, 0.0, d])
    Cinv = np.linalg.inv(tap_noise_cov(offsets, signal=signal))
    r = np.maximum(0.0, 1.0 - np.abs(offsets))
    A2 = float(amplitude_from_cn0(cn0_dbhz, coherent_time_s)) ** 2
    # R(dtau - o) differentiated in dtau at 0: early (o=-d) falls, late rises, prompt
    # falls or rises depending on the side of the peak.
    j_tau = np.mean([g @ Cinv @ g for g in (np.array([-1.0, -1.0, 1.0]), np.array([-1.0, 1.0, 1.0]))])
    return np.diag([A2 * j_tau, A2 * (r @ Cinv @ r)])


def vector_tracking_pcrb(
    sat_pos: Callable[[np.ndarray], np.ndarray],
    receiver_pos: np.ndarray,
    receiver_vel: np.ndarray,
    clock_q_m: np.ndarray,
    P0: np.ndarray,
    cn0_dbhz: np.ndarray,
    coherent_time_s: float,
    epochs: int,
    early_late_spacing_chips: float = 1.0,
    measurements: PcrbMeasurements = "code-and-carrier",
    signal: SignalSpec = GPS_L1CA,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """PCRB of a vector-tracking run with a constant-velocity receiver (module docstring).

    Parameters
    ----------
    sat_pos
        ``sat_pos(t) -> (*t.shape, channels, 3)`` ECEF satellite positions at the
        times t (called once, on all mid-interval times).
    receiver_pos, receiver_vel
        ECEF position at t = 0 and the constant velocity.
    clock_q_m
        ``2x2`` clock process noise per interval of bias (m) and drift (m/s).
    P0
        ``8x8`` prior covariance of ``[r, v, b, d]`` at the first mid-interval.
    cn0_dbhz
        C/N0 per channel ``(channels,)``.
    coherent_time_s, epochs
        T and the number of intervals.
    early_late_spacing_chips
        The early-late spacing of the correlators (`correlator_fisher`).
    measurements
        ``"code-and-carrier"``: the correlators' code delay and carrier phase;
        ``"code"``: the code delay only (the carrier phase's information dropped, and
        with it the per-channel phase offsets; module docstring).
    signal
        The tracked signal (BPSK): its chip length and wavelength turn chips and radians
        into metres (GPS L1 C/A by default).

    Returns
    -------
    tuple
        Mid-interval times ``(K,)``, and the bounds on the RMS position error (m,
        $\\sqrt{\\mathrm{tr}\\, J^{-1}_{rr}}$) and RMS velocity error (m/s), each ``(K,)``.
    """
    if measurements not in PCRB_MEASUREMENTS:
        raise ConfigError("measurements", f"got {measurements!r}; allowed: {', '.join(PCRB_MEASUREMENTS)}")
    carrier = measurements == "code-and-carrier"
    T = coherent_time_s
    s0 = np.asarray(sat_pos(np.asarray(T / 2)))
    n_ch = s0.shape[0]
    cn0 = np.broadcast_to(np.asarray(cn0_dbhz, float), (n_ch,))
    sq = np.array([np.sqrt(np.diag(correlator_fisher(c, T, early_late_spacing_chips, signal))) for c in cn0])  # (ch, 2)
    n = 8 + (n_ch if carrier else 0)
    F = np.eye(n)
    F[0:3, 3:6] = T * np.eye(3)
    F[6, 7] = T
    Q = np.zeros((n, n))
    Q[6:8, 6:8] = clock_q_m
    Pfull = np.zeros((n, n))
    Pfull[:8, :8] = P0
    # Uniform initial phase: no information. A variance of 1e6 rad^2 stands for that;
    # the bound on r and v does not depend on its value once it is large.
    Pfull[8:, 8:] = 1e6 * np.eye(n - 8)
    times = np.arange(epochs) * T + T / 2
    r0, v = np.asarray(receiver_pos, float), np.asarray(receiver_vel, float)
    sats = np.asarray(sat_pos(times))  # (K, ch, 3): one orbit evaluation for all epochs

    # The measurement square roots of every epoch in one vectorised pass (issue 11).
    _, e = line_of_sight(sats.reshape(epochs, n_ch, 3), (r0 + v * times[:, None])[:, None, :])
    drho = np.zeros((epochs, n_ch, n))
    drho[..., 0:3] = -e
    drho[..., 6] = 1.0
    roots = sq[:, :1] * (drho / signal.chip_length_m)  # the code rows (K, ch, n)
    if carrier:
        phase = -2 * np.pi * drho / signal.wavelength_m
        phase[..., 8:] = np.eye(n_ch)
        roots = np.concatenate([roots, sq[:, 1:] * phase], axis=1)  # (K, 2 ch, n)

    P = pcrb_linear(F, Q, roots, Pfull, epochs)
    pos = np.sqrt(np.trace(P[:, 0:3, 0:3], axis1=1, axis2=2))
    vel = np.sqrt(np.trace(P[:, 3:6, 3:6], axis1=1, axis2=2))
    return times, pos, vel
