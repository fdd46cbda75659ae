"""Navigators for the aided-tracking harness that need no INS.

`PvaNavigator` is GNSS-only vector tracking at the integration rate: a constant-
acceleration (white-jerk) filter of ECEF position, velocity and acceleration, updated
every integration interval with the prefilters' differenced range and rate residuals
(`measurements.integration_measurement`, correlated covariance) and correcting its
state in closed loop, plus the small clock filter that keeps the NCOs' clock terms
(`measurements.clock_measurement`). Between updates it extrapolates its state to
aid the NCOs. The ``ins-ekf`` navigator has the same structure with the INS in place of
the kinematic model (Groves 2013, sections 14.2 and 16.2).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ... import registry
from ...estimation import FilterStep, Gaussian, LinearModel
from .measurements import LinearUpdate, clock_measurement, integration_measurement, reference_channel

__all__ = ["PvaNavigator", "ClockFilter"]


def _pva_transition(dt: float, jerk_psd: float) -> tuple[np.ndarray, np.ndarray]:
    """Constant-acceleration transition and white-jerk process noise per axis (Bar-Shalom et al. 2001, 6.2.3)."""
    F1 = np.array([[1.0, dt, dt * dt / 2], [0.0, 1.0, dt], [0.0, 0.0, 1.0]])
    Q1 = jerk_psd * np.array(
        [[dt**5 / 20, dt**4 / 8, dt**3 / 6], [dt**4 / 8, dt**3 / 3, dt**2 / 2], [dt**3 / 6, dt**2 / 2, dt]]
    )
    # State order [p(3), v(3), a(3)]: kron of the per-axis model with I3.
    return np.kron(F1, np.eye(3)), np.kron(Q1, np.eye(3))


class ClockFilter:
    """Two-state receiver clock filter that keeps the NCOs' clock terms (bias m, drift m/s).

    The integration filter removes the clock by differencing (Cai and Guo 2017, section
    2.2); the NCOs still need it. After each integration update the clock error common
    to all channels is measured by generalised least squares over the channels
    (`measurements.clock_measurement`) and corrected here in closed loop. Model:
    bias driven by the drift plus white noise, drift a random walk (Groves 2013,
    section 9.4.2), PSDs ``clock_psd`` = (bias m^2/s, drift m^2/s^3).
    """

    def __init__(self, clock_m: np.ndarray, clock_cov: np.ndarray, clock_psd: tuple[float, float] = (0.1, 0.1)) -> None:
        self.c = np.asarray(clock_m, float).copy()
        runs = self.c.shape[0]
        self.Pc = np.broadcast_to(np.asarray(clock_cov, float), (runs, 2, 2)).copy()
        self.clock_psd = clock_psd
        self.t = 0.0
        self.steps = 0
        self._update = LinearUpdate("clock filter")  # the kf plugin, built once per run

    def at(self, t_s: float) -> tuple[np.ndarray, np.ndarray]:
        """Extrapolated bias (m) and drift (m/s) at ``t_s``, each ``(runs,)``."""
        dt = t_s - self.t
        return self.c[:, 0] + self.c[:, 1] * dt, self.c[:, 1]

    def predict(self, t_s: float) -> None:
        """Propagate bias and drift with their process noise to ``t_s``."""
        dt = t_s - self.t
        Fc = np.array([[1.0, dt], [0.0, 1.0]])
        qb, qd = self.clock_psd
        Qc = np.array([[qb * dt + qd * dt**3 / 3, qd * dt**2 / 2], [qd * dt**2 / 2, qd * dt]])
        self.c = self.c @ Fc.T
        self.Pc = Fc @ self.Pc @ Fc.T + Qc
        self.t = t_s

    def correct(self, residual_m, residual_cov, los, pos_error_m, vel_error_m_s) -> None:
        """Measure the clock error once the navigation error is known, and remove it."""
        runs = self.c.shape[0]
        zc, Rc = clock_measurement(residual_m, residual_cov, los, pos_error_m, vel_error_m_s)
        dc, self.Pc = self._update(
            np.zeros((runs, 2)), self.Pc, zc, np.broadcast_to(np.eye(2), (runs, 2, 2)), Rc, step=self.steps
        )
        self.c = self.c - dc
        self.steps += 1


class PvaNavigator:
    """GNSS-only navigator of the harness (vector tracking at the integration rate).

    Parameters
    ----------
    position_m, velocity_m_s, acceleration_m_s2
        Initial estimates ``(runs, 3)`` ECEF.
    cov
        Initial covariance ``(9, 9)`` of [p, v, a].
    clock_m, clock_cov
        Initial clock [bias m, drift m/s] ``(runs, 2)`` and covariance ``(2, 2)``.
    jerk_psd_m2_s5
        White-jerk power spectral density per axis.
    clock_psd
        ``(bias, drift)`` white-noise PSDs of the two-state clock (m^2/s, m^2/s^3).
    estimator
        ``None`` for the Joseph-form Kalman update, or an ``estimator`` plugin (name or
        instance: ``ekf``, ``ukf``, ``ckf`` ...) for the navigation update, run through the
        library's one filter step (`gnssframework.estimation.FilterStep`: boundary checks,
        failures naming the navigator, the run and the update); on this linear
        measurement every one of them must give the Kalman update.
    """

    def __init__(
        self,
        position_m,
        velocity_m_s,
        acceleration_m_s2,
        cov,
        clock_m,
        clock_cov,
        *,
        jerk_psd_m2_s5: float = 100.0,
        clock_psd: tuple[float, float] = (0.1, 0.1),
        estimator: Any = None,
    ) -> None:
        if isinstance(estimator, str):
            estimator = registry.create("estimator", estimator)
        self.estimator = estimator
        self.x = np.concatenate([position_m, velocity_m_s, acceleration_m_s2], axis=-1).astype(float)
        runs = self.x.shape[0]
        self.P = np.broadcast_to(np.asarray(cov, float), (runs, 9, 9)).copy()
        self.filter_step = None
        self._linear = LinearUpdate("pva-navigator") if estimator is None else None  # built once per run
        if estimator is not None:
            # The closed-loop error state restarts at zero after every correction; FilterStep checks
            # the initial covariance here and names this navigator in any numerical failure.
            self.filter_step = FilterStep(estimator, name=f"pva-navigator ({estimator.name})")
            self.filter_step.start(Gaussian(np.zeros((runs, 9)), self.P))
        self.clock = ClockFilter(clock_m, clock_cov, clock_psd)
        self.t = 0.0
        self.jerk_psd = jerk_psd_m2_s5
        self.steps = 0

    def _predicted(self, t_s: float):
        dt = t_s - self.t
        F, _ = _pva_transition(dt, 0.0)
        x = self.x @ F.T
        return (x, *self.clock.at(t_s))

    def kinematics(self, t_s: float):
        """Extrapolated position, velocity, acceleration and clock at ``t_s``."""
        x, b, d = self._predicted(t_s)
        return x[:, 0:3], x[:, 3:6], x[:, 6:9], b, d

    def update(self, t_s: float, residual_m, residual_cov, los, cn0_dbhz) -> None:
        """Predict to ``t_s``, then correct with the differenced residuals and the clock measurement."""
        dt = t_s - self.t
        F, Q = _pva_transition(dt, self.jerk_psd)
        self.x = self.x @ F.T
        self.P = F @ self.P @ F.T + Q
        self.clock.predict(t_s)
        self.t = t_s
        # Error state dx = estimate - truth; the residuals measure dx (closed loop: subtract it).
        runs = self.x.shape[0]
        z, H, R = integration_measurement(
            residual_m,
            residual_cov,
            los,
            reference_channel(cn0_dbhz),
            n_states=9,
            position=slice(0, 3),
            velocity=slice(3, 6),
        )
        if self.estimator is None:
            dx, self.P = self._linear(np.zeros((runs, 9)), self.P, z, H, R, step=self.steps)
        else:
            model = LinearModel(F=np.eye(9), H=H, Q=np.zeros((9, 9)), R=R)
            post = self.filter_step.update(Gaussian(np.zeros((runs, 9)), self.P), z, model).posterior
            dx, self.P = post.mean, post.cov
        self.x = self.x - dx
        self.clock.correct(residual_m, residual_cov, los, dx[:, 0:3], dx[:, 3:6])
        self.steps += 1
