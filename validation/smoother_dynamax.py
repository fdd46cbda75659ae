"""Our RTS smoothers against dynamax's (JAX) on the same models: PASS/FAIL to 1e-9.

dynamax (Linderman et al., probml/dynamax) is an independent implementation of the
Kalman, extended and unscented RTS smoothers. It is heavy (JAX, ~600 MB), so it is not a
test dependency: install it in a virtual environment of your own and run

    pip install dynamax==1.0.3
    python validation/smoother_dynamax.py

(CI does so in its ``oracles`` lane, `.ci/run`.)

Checks, each on a batch of runs (dynamax smooths one at a time), in float64:

- ``kf``: a linear-Gaussian model with a known input: smoothed means and covariances,
  the lag-one covariance (`SmoothedResult.lag_one_cov` against dynamax's
  ``smoothed_cross_covariances`` minus the outer product of the means) and the
  innovations log-likelihood (`gnssframework.estimation.em.log_likelihood` against
  ``marginal_loglik``);
- ``ekf``: a pendulum with analytic Jacobians against ``extended_kalman_smoother``;
- ``ukf`` (alpha, beta, kappa = sqrt(3), 2, 1, dynamax's defaults) against
  ``unscented_kalman_smoother``; ``ckf`` against the same with (1, 0, 0), the unscented
  rule that is the cubature rule;
- ``svd-ckf`` on the linear model against ``lgssm_smoother``: its points come from a
  symmetric (eigen) square root, not dynamax's Cholesky factor, so on a nonlinear model
  the two are different filters (they agree only where every square root gives the same
  moments, a linear model).

dynamax's ``psd_solve`` adds 1e-9 to the diagonal of every matrix it solves with, which
alone moves the results by ~1e-8; the script replaces it by the same Cholesky solve
without the boost (the exact problem).

dynamax's first state has the measurement directly (``p(z_1)`` is the first prior), ours
is predicted from a state before the first measurement: dynamax is given our step-0
prediction as its initial state (for the KF computed here, ``F m + u`` and ``F P F^T + Q``;
for the nonlinear engines our own prediction, the only number it takes from us).

Exit status 0 when every check passes, 1 otherwise.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

if __name__ == "__main__":  # --help works without dynamax
    argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], epilog="Needs dynamax: pip install dynamax==1.0.3"
    ).parse_args()

try:
    import jax
    import jax.numpy as jnp
    from dynamax.linear_gaussian_ssm.inference import lgssm_smoother, make_lgssm_params
    from dynamax.nonlinear_gaussian_ssm.inference_ekf import extended_kalman_smoother
    from dynamax.nonlinear_gaussian_ssm.inference_ukf import UKFHyperParams, unscented_kalman_smoother
    from dynamax.nonlinear_gaussian_ssm.models import ParamsNLGSSM
except ImportError as exc:  # pragma: no cover - an optional peer
    sys.exit(f"smoother_dynamax: needs dynamax (pip install dynamax==1.0.3): {exc}")

jax.config.update("jax_enable_x64", True)


def _exact_psd_solve(A, b, diagonal_boost=0.0):
    """dynamax's ``psd_solve`` without its default 1e-9 diagonal boost (which alone moves
    the smoothed states by ~1e-8): the exact problem, solved by Cholesky as dynamax does."""
    return _dynamax_psd_solve(A, b, diagonal_boost=0.0)


import dynamax.linear_gaussian_ssm.inference as _lin  # noqa: E402
import dynamax.nonlinear_gaussian_ssm.inference_ekf as _ekf  # noqa: E402
import dynamax.nonlinear_gaussian_ssm.inference_ukf as _ukf  # noqa: E402
from dynamax.utils.utils import psd_solve as _dynamax_psd_solve  # noqa: E402

for _module in (_lin, _ekf, _ukf):
    _module.psd_solve = _exact_psd_solve

import gnssframework as gf  # noqa: E402
from gnssframework.estimation import Gaussian, LinearModel, NonlinearModel  # noqa: E402
from gnssframework.estimation.em import log_likelihood  # noqa: E402

TOL = 1e-9
K, B = 60, 3
DT, G = 0.1, 9.81


def report(name: str, errors: dict[str, float]) -> bool:
    worst = max(errors.values())
    ok = worst <= TOL
    detail = ", ".join(f"{k} {v:.1e}" for k, v in errors.items())
    print(f"{'PASS' if ok else 'FAIL'} {name}: max abs difference {worst:.1e} (tolerance {TOL:g}): {detail}")
    return ok


def linear_check(rng, engine: str = "kf") -> bool:
    n, m = 3, 2
    F = np.eye(n) + 0.2 * rng.standard_normal((n, n))
    H = rng.standard_normal((m, n))
    A = rng.standard_normal((n, n))
    Q = 0.1 * A @ A.T / n + 0.01 * np.eye(n)
    C = rng.standard_normal((m, m))
    R = C @ C.T / m + 0.1 * np.eye(m)
    u = 0.1 * rng.standard_normal(n)
    m0, P0 = rng.standard_normal(n), np.eye(n)
    zs = rng.standard_normal((K, B, m))
    result = gf.filter_sequence(
        gf.registry.create("estimator", engine), LinearModel(F, H, Q, R, u=u), zs, Gaussian(m0, P0), store="smoother"
    )
    ours = gf.smooth(result)
    lag = ours.lag_one_cov()
    ll = log_likelihood(result.innovation, result.innovation_cov)
    params = make_lgssm_params(
        jnp.asarray(F @ m0 + u),
        jnp.asarray(F @ P0 @ F.T + Q),
        jnp.asarray(F),
        jnp.asarray(Q),
        jnp.asarray(H),
        jnp.asarray(R),
        dynamics_bias=jnp.asarray(u),
    )
    err = {"mean": 0.0, "cov": 0.0, "lag-one cov": 0.0, "log-likelihood": 0.0}
    for b in range(B):
        post = lgssm_smoother(params, jnp.asarray(zs[:, b]))
        sm, sc = np.asarray(post.smoothed_means), np.asarray(post.smoothed_covariances)
        cross = np.asarray(post.smoothed_cross_covariances) - sm[:-1, :, None] * sm[1:, None, :]
        err["mean"] = max(err["mean"], np.abs(ours.mean[:, b] - sm).max())
        err["cov"] = max(err["cov"], np.abs(ours.cov[:, b] - sc).max())
        # dynamax: E[x_t x_{t+1}^T]; ours: Cov(x_k, x_{k-1}) at k = t + 1
        err["lag-one cov"] = max(err["lag-one cov"], np.abs(np.swapaxes(lag[1:, b], -1, -2) - cross).max())
        err["log-likelihood"] = max(err["log-likelihood"], abs(float(ll[b]) - float(post.marginal_loglik)))
    return report(f"{engine} (lgssm_smoother, linear model)", err)


def pendulum():
    """x = (angle, rate); z = sin(angle); numpy (batched) and jax (single) twins."""

    def f_np(x):
        return np.stack([x[..., 0] + DT * x[..., 1], x[..., 1] - G * DT * np.sin(x[..., 0])], axis=-1)

    def h_np(x):
        return np.sin(x[..., :1])

    def fj_np(x):
        out = np.zeros(x.shape + (2,))
        out[..., 0, 0] = 1.0
        out[..., 0, 1] = DT
        out[..., 1, 0] = -G * DT * np.cos(x[..., 0])
        out[..., 1, 1] = 1.0
        return out

    def hj_np(x):
        out = np.zeros(x.shape[:-1] + (1, 2))
        out[..., 0, 0] = np.cos(x[..., 0])
        return out

    def f_jax(x):
        return jnp.array([x[0] + DT * x[1], x[1] - G * DT * jnp.sin(x[0])])

    def h_jax(x):
        return jnp.sin(x[:1])

    return f_np, h_np, fj_np, hj_np, f_jax, h_jax


def nonlinear_checks(rng) -> list[bool]:
    f_np, h_np, fj_np, hj_np, f_jax, h_jax = pendulum()
    Q = np.array([[1e-4, 0.0], [0.0, 1e-3]]) * 3
    R = np.array([[0.05]])
    model = NonlinearModel(f_np, h_np, Q, R, f_jacobian=fj_np, h_jacobian=hj_np)
    x = np.array([1.2, 0.0])
    truth = []
    for _ in range(K):
        x = f_np(x) + rng.multivariate_normal(np.zeros(2), Q)
        truth.append(x)
    zs = h_np(np.array(truth))[:, None, :] + rng.normal(0.0, np.sqrt(R[0, 0]), (K, B, 1))
    initial = Gaussian(np.array([1.0, 0.0]), np.diag([0.1, 0.1]))
    cases = [
        ("ekf", {}, None),
        (
            "ukf",
            {"alpha": float(np.sqrt(3)), "beta": 2.0, "kappa": 1.0},
            UKFHyperParams(alpha=float(np.sqrt(3)), beta=2, kappa=1),
        ),
        ("ckf", {}, UKFHyperParams(alpha=1.0, beta=0, kappa=0)),
    ]
    out = []
    for engine, params, hyper in cases:
        result = gf.filter_sequence(
            gf.registry.create("estimator", engine, **params), model, zs, initial, store="smoother"
        )
        ours = gf.smooth(result)
        err = {"mean": 0.0, "cov": 0.0}
        for b in range(B):
            prior_m = result.smoother_inputs.prior_mean[0, b]
            prior_P = result.smoother_inputs.prior_cov[0, b]
            p = ParamsNLGSSM(jnp.asarray(prior_m), jnp.asarray(prior_P), f_jax, jnp.asarray(Q), h_jax, jnp.asarray(R))
            post = (
                extended_kalman_smoother(p, jnp.asarray(zs[:, b]))
                if hyper is None
                else unscented_kalman_smoother(p, jnp.asarray(zs[:, b]), hyper)
            )
            err["mean"] = max(err["mean"], np.abs(ours.mean[:, b] - np.asarray(post.smoothed_means)).max())
            err["cov"] = max(err["cov"], np.abs(ours.cov[:, b] - np.asarray(post.smoothed_covariances)).max())
        peer = (
            "extended_kalman_smoother"
            if hyper is None
            else (f"unscented_kalman_smoother alpha={hyper.alpha:.3g} beta={hyper.beta} kappa={hyper.kappa}")
        )
        out.append(report(f"{engine} ({peer})", err))
    return out


def main() -> int:
    rng = np.random.default_rng(20261202)
    print(f"dynamax smoothers vs gnssframework, {K} steps x {B} runs, float64")
    results = [
        linear_check(np.random.default_rng(1), "kf"),
        linear_check(np.random.default_rng(1), "svd-ckf"),
        *nonlinear_checks(rng),
    ]
    print("PASS" if all(results) else "FAIL", f"({sum(results)} of {len(results)} checks)")
    return 0 if all(results) else 1


if __name__ == "__main__":
    sys.exit(main())
