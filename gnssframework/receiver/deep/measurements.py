"""Measurements of the deep-integration filter: between-channel differences and new information.

Two pieces of Cai and Guo 2017 (*Coherent deep GNSS/SINS integration on vector tracking*,
section 2.2, eqs. 9-11) and of the issue's rule against counting old information twice:

* **Single differences** against a reference channel k (the highest C/N0):
  $\\delta\\rho_{ik} = \\delta\\rho_i - \\delta\\rho_k$ removes the receiver clock, which
  every channel shares. With $D$ the $(n-1) \\times n$ difference operator, the
  differenced measurement $Dz$ has covariance $D R D^T$, which is *not* diagonal: the
  reference channel's noise is in every difference (Groves 2013, section 14.3.3 on
  differenced measurements' correlated noise). A diagonal $R$ on differences counts the
  reference channel n-1 times.
* **New information of a prefilter interval**: a prefilter that ran from a prior
  $(x_0, P_0)$ to a posterior $(x_1, P_1)$ carries, as one equivalent measurement of
  its state with unit measurement matrix,

  $$ R^{-1} = P_1^{-1} - P_0^{-1}, \\qquad z = R\\,(P_1^{-1} x_1 - P_0^{-1} x_0), $$

  the information form of the Kalman update (Groves 2013, section 16.3.3 on
  decorrelating prefilter outputs in federated / cascaded architectures; Carlson's
  federated filter). For a static state this is exact; with process noise it is the
  usual approximation of cascaded filters. Resetting the prefilter after each
  integration update (the other remedy) gives the same thing when $P_0^{-1} = 0$.
"""

from __future__ import annotations

import numpy as np

from ...errors import NumericalError

__all__ = [
    "reference_channel",
    "difference_operator",
    "difference",
    "linear_update",
    "LinearUpdate",
    "new_information",
    "integration_measurement",
    "clock_measurement",
    "ATTITUDE",
    "VELOCITY",
    "POSITION",
    "ACCEL_BIAS",
    "GYRO_BIAS",
]


def reference_channel(cn0_dbhz: np.ndarray) -> np.ndarray:
    """Index of the highest-C/N0 channel per run: ``(runs, ch) -> (runs,)`` (first on ties)."""
    return np.argmax(np.asarray(cn0_dbhz, float), axis=-1)


def difference_operator(n_channels: int, reference: np.ndarray) -> np.ndarray:
    """Batched single-difference operator ``D`` ``(runs, n-1, n)``: rows ``e_i - e_ref``, i != ref, in order."""
    ref = np.atleast_1d(np.asarray(reference, int))
    # Channels other than the reference, in order: i < ref stays, i >= ref shifts by one.
    idx = np.arange(n_channels - 1)[None, :]
    others = idx + (idx >= ref[:, None])  # (runs, n-1)
    rows = np.eye(n_channels)[others]  # (runs, n-1, n)
    rows[np.arange(len(ref))[:, None], idx, ref[:, None]] -= 1.0
    return rows


def difference(
    z: np.ndarray, H: np.ndarray, R: np.ndarray, reference: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Differenced measurement, model and correlated covariance.

    Parameters
    ----------
    z
        ``(runs, n)`` measurements (e.g. pseudorange errors of all channels).
    H
        ``(runs, n, m)`` their measurement matrix on the clock-free states.
    R
        ``(runs, n, n)`` (or ``(runs, n)`` diagonal) undifferenced covariance.
    reference
        ``(runs,)`` reference channel.

    Returns
    -------
    Dz ``(runs, n-1)``, DH ``(runs, n-1, m)``, D R D^T ``(runs, n-1, n-1)``.
    """
    n = z.shape[-1]
    R = np.asarray(R, float)
    if R.ndim == z.ndim:
        R = R[..., :, None] * np.eye(n)
    D = difference_operator(n, reference)
    return (np.einsum("rij,rj->ri", D, z), np.einsum("rij,rjk->rik", D, H), np.einsum("rij,rjk,rlk->ril", D, R, D))


#: The estimator of `linear_update`: the linear Kalman filter's update (Joseph form).
LINEAR_ESTIMATOR = "kf"


class LinearUpdate:
    """The Joseph-form Kalman update of `linear_update` with its ``kf`` estimator plugin and
    `FilterStep` built once (per navigator or clock filter of a run), not per update.

    Parameters
    ----------
    name
        The filter's name in its failures (e.g. ``"pva-navigator"``).
    """

    def __init__(self, name: str = "ins-ekf") -> None:
        from ... import registry
        from ...estimation import FilterStep

        self.filter_step = FilterStep(registry.create("estimator", LINEAR_ESTIMATOR), name=name)

    def __call__(
        self, x: np.ndarray, P: np.ndarray, z: np.ndarray, H: np.ndarray, R: np.ndarray, *, step: int | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Updated mean and covariance (see `linear_update`); ``step`` names the update in failures."""
        from ...estimation import Gaussian, LinearModel

        n = P.shape[-1]
        fs = self.filter_step
        fs.step_index = 0 if step is None else step
        model = LinearModel(np.eye(n), np.asarray(H, float), np.zeros((n, n)), np.asarray(R, float))
        post = fs.update(Gaussian(np.asarray(x, float), np.asarray(P, float)), z, model).posterior
        return post.mean, post.cov


def linear_update(
    x: np.ndarray,
    P: np.ndarray,
    z: np.ndarray,
    H: np.ndarray,
    R: np.ndarray,
    *,
    name: str = "ins-ekf",
    step: int | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Batched Kalman measurement update in Joseph form (Groves 2013, eqs. 3.24-3.27).

    ``x (runs, m)``, ``P (runs, m, m)``, ``z (runs, p)``, ``H (runs, p, m)``, ``R (runs, p, p)``.
    It is the update half of the library's one filter step
    (`gnssframework.estimation.FilterStep` with the ``kf`` estimator), so the navigators
    that call it fail, by name, as every other filter does. One call builds the estimator;
    a filter that updates every interval holds a `LinearUpdate` instead.

    Raises
    ------
    InvalidMeasurementError
        When a batch element's measurement holds NaN or inf.
    NotPositiveDefiniteError
        When the innovation covariance of some batch element is not positive definite.
    NumericalError
        When the posterior of some batch element is not finite or not positive definite.
    """
    return LinearUpdate(name)(x, P, z, H, R, step=step)


def new_information(
    x_prior: np.ndarray,
    P_prior: np.ndarray,
    x_post: np.ndarray,
    P_post: np.ndarray,
    *,
    name: str = "prefilter",
    step: int | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Equivalent measurement ``(z, R)`` of what a prefilter learned between prior and posterior.

    Updating ``(x_prior, P_prior)`` with ``z`` (unit measurement matrix, covariance
    ``R``) returns ``(x_post, P_post)`` exactly. ``P_prior`` may be ``inf`` on the
    diagonal (a reset filter: no prior information).

    Raises
    ------
    NumericalError
        When the interval brought no information (``P_post^{-1} - P_prior^{-1}`` not
        positive definite) for some batch element.
    """
    info_post = np.linalg.inv(P_post)
    P0 = np.asarray(P_prior, float)
    # inf on the diagonal: no prior information (a reset prefilter).
    info_prior = np.zeros_like(info_post) if np.any(np.isinf(P0)) else np.linalg.inv(P0)
    info_new = info_post - info_prior
    info_new = 0.5 * (info_new + np.swapaxes(info_new, -1, -2))
    eig = np.linalg.eigvalsh(info_new)
    if np.any(eig <= 0):
        bad = np.argwhere(np.any(eig <= 0, axis=-1).reshape(-1))
        raise NumericalError(
            name,
            [tuple(b) for b in bad],
            step,
            "the interval brought no new information (posterior information not above the prior's)",
        )
    R = np.linalg.inv(info_new)
    z = np.einsum(
        "...ij,...j->...i",
        R,
        np.einsum("...ij,...j->...i", info_post, x_post) - np.einsum("...ij,...j->...i", info_prior, x_prior),
    )
    return z, R


#: Error-state layout of the 15-state integration filter, that of `gnssframework.inertial.error_model`
#: (Groves 2013, section 14.2.1): attitude (rad), velocity (m/s), position (m), ECEF, then the
#: residual gyro and accelerometer biases of the compensated IMU output (body axes).
ATTITUDE, VELOCITY, POSITION, GYRO_BIAS, ACCEL_BIAS = (
    slice(0, 3),
    slice(3, 6),
    slice(6, 9),
    slice(9, 12),
    slice(12, 15),
)


def integration_measurement(
    residual_m: np.ndarray,
    residual_cov: np.ndarray,
    los: np.ndarray,
    reference: np.ndarray,
    *,
    n_states: int = 15,
    position: slice = POSITION,
    velocity: slice = VELOCITY,
    range_rows: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Differenced range and rate residuals as a measurement of the 15-state error.

    With the error state $\\delta x$ = estimate minus truth, channel i's residual (true
    minus predicted) is $[e_i\\cdot\\delta r - \\delta b,\\; e_i\\cdot\\delta v - \\delta d]$
    (Cai and Guo 2017, eqs. 9-11, with the attitude and sensor biases unseen by one
    update). Differencing against the reference channel removes the clock.

    Parameters
    ----------
    residual_m, residual_cov
        ``(runs, ch, 2)`` and ``(runs, ch, 2, 2)`` prefilter outputs (`aided_tracking.run_aided_tracking`).
    los
        ``(runs, ch, 3)`` unit lines of sight (ECEF).
    reference
        ``(runs,)`` reference channel.
    n_states, position, velocity
        Error-state size and where position and velocity sit (15-state layout by default).
    range_rows
        ``(runs, ch, n_b)``: range-bias states appended after the ``n_states``, entering
        channel i's range residual as $M_i b$ (`plugins.range_bias.RangeBiasBudget.rows`;
        the rates see none). Their columns of H are $D [M; 0]$: what the differences leave
        of them (a bias common to all channels cancels like the clock).

    Returns
    -------
    z ``(runs, 2(n-1))`` ordered [ranges..., rates...], H ``(runs, 2(n-1), n_states + n_b)`` and the
    correlated covariance ``(runs, 2(n-1), 2(n-1))``.
    """
    runs, n, _ = residual_m.shape
    z = np.concatenate([residual_m[..., 0], residual_m[..., 1]], axis=-1)  # (runs, 2n)
    R = np.zeros((runs, 2 * n, 2 * n))
    idx = np.arange(n)
    for a in range(2):
        for b in range(2):
            R[:, a * n + idx, b * n + idx] = residual_cov[..., a, b]
    n_b = 0 if range_rows is None else range_rows.shape[-1]
    H = np.zeros((runs, 2 * n, n_states + n_b))
    H[:, :n, position] = los
    H[:, n:, velocity] = los
    if range_rows is not None:
        H[:, :n, n_states:] = range_rows
    D1 = difference_operator(n, reference)
    D = np.zeros((runs, 2 * (n - 1), 2 * n))
    D[:, : n - 1, :n] = D1
    D[:, n - 1 :, n:] = D1
    return (np.einsum("rij,rj->ri", D, z), np.einsum("rij,rjk->rik", D, H), np.einsum("rij,rjk,rlk->ril", D, R, D))


def clock_measurement(
    residual_m: np.ndarray,
    residual_cov: np.ndarray,
    los: np.ndarray,
    pos_error_m: np.ndarray,
    vel_error_m_s: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Clock bias and drift errors seen by all channels once the navigation error is known.

    Generalised least squares over channels of $[e_i\\cdot\\delta\\hat r, e_i\\cdot\\delta\\hat v] - r_i
    = [\\delta b, \\delta d] + n_i$ with each channel's 2x2 covariance; this feeds the
    small clock filter that keeps the NCOs' clock terms (Cai and Guo 2017 remove the clock
    from the integration filter by differencing, so it is estimated beside it).

    Returns ``(z (runs, 2), R (runs, 2, 2))`` for a measurement of [bias error m, drift error m/s].
    """
    pred = np.stack([np.einsum("rcj,rj->rc", los, pos_error_m), np.einsum("rcj,rj->rc", los, vel_error_m_s)], -1)
    y = pred - residual_m
    W = np.linalg.inv(residual_cov)
    R = np.linalg.inv(W.sum(axis=1))
    z = np.einsum("rij,rj->ri", R, np.einsum("rcij,rcj->ri", W, y))
    return z, R
