"""A small kit for testing a plugin against independent truths.

Each check raises ``AssertionError`` with what went wrong, so it reads as one line in a
pytest test::

    from gnssframework import testing

    def test_my_filter():
        est = MyFilter()
        testing.check_exact_on_linear(est)             # equals the Kalman filter's closed form
        testing.check_batched_equals_one_by_one(est)   # batch-first is not an approximation
    def test_my_discriminator():
        testing.check_unit_slope(MyDisc(), [-1e-3, 1e-3])
        testing.check_noise_variance(MyDisc(), cn0_dbhz=45.0, rng=np.random.default_rng(0))

The truths are independent of the code under test: the linear Kalman filter written
out below in four lines (Kalman 1960), a discriminator's slope from noise-free
correlators of the triangle autocorrelation, and its noise from a Monte Carlo draw.

Examples
--------
>>> import numpy as np
>>> from gnssframework import registry
>>> check_exact_on_linear(registry.create("estimator", "ckf"))
>>> check_covariance_psd(np.eye(2))
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .estimation import Gaussian, LinearModel
from .signal.correlator_model import amplitude_from_cn0, correlator_mean, simulate_correlators

__all__ = [
    "random_linear_problem",
    "check_covariance_psd",
    "check_exact_on_linear",
    "check_batched_equals_one_by_one",
    "check_unit_slope",
    "check_noise_variance",
    "vector_loop_series",
    "ulp_nudges",
    "relative_change",
    "assert_within_rounding",
]


def random_linear_problem(
    rng: np.random.Generator, n: int = 3, m: int = 2, batch: tuple[int, ...] = (4,)
) -> tuple[Gaussian, LinearModel, np.ndarray]:
    """A random well-conditioned linear-Gaussian problem: prior, model and a measurement."""

    def pd(k: int) -> np.ndarray:
        a = rng.standard_normal((k, k))
        return a @ a.T / k + 0.5 * np.eye(k)

    F = np.eye(n) + 0.1 * rng.standard_normal((n, n))
    H = rng.standard_normal((m, n))
    model = LinearModel(F, H, pd(n), pd(m))
    P = np.stack([pd(n) for _ in range(int(np.prod(batch)))]).reshape(batch + (n, n))
    prior = Gaussian(rng.standard_normal(batch + (n,)), P)
    z = rng.standard_normal(batch + (m,))
    return prior, model, z


def check_covariance_psd(cov: np.ndarray, name: str = "covariance", tol: float = 1e-10) -> None:
    """Every matrix of the batch is symmetric and positive semi-definite (to ``tol``)."""
    cov = np.asarray(cov, float)
    assert np.all(np.isfinite(cov)), f"{name} holds NaN or inf"
    scale = max(1.0, float(np.max(np.abs(cov))))
    asym = float(np.max(np.abs(cov - np.swapaxes(cov, -1, -2))))
    assert asym <= tol * scale, f"{name} is not symmetric (max |P - P^T| = {asym:.3g})"
    low = float(np.min(np.linalg.eigvalsh(cov)))
    assert low >= -tol * scale, f"{name} is not PSD (smallest eigenvalue {low:.3g})"


def _kalman_reference(prior: Gaussian, model: LinearModel, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Predict and update written out (Kalman 1960): the oracle of ``check_exact_on_linear``."""
    F, H, Q, R = model.F, model.H, model.Q, model.R
    x = prior.mean @ F.T
    P = F @ prior.cov @ F.T + Q
    S = H @ P @ H.T + R
    K = P @ H.T @ np.linalg.inv(S)
    x = x + np.einsum("...ij,...j->...i", K, z - x @ H.T)
    P = P - K @ S @ np.swapaxes(K, -1, -2)
    return x, P


def check_exact_on_linear(estimator: Any, rng: np.random.Generator | None = None, rtol: float = 1e-8) -> None:
    """One predict and update on a random linear-Gaussian problem equals the Kalman filter.

    Every Gaussian filter (EKF, UKF, CKF, square-root forms) is exact on a linear model;
    a filter that is not has a bug in its moments or weights.
    """
    rng = rng or np.random.default_rng(0)
    prior, model, z = random_linear_problem(rng)
    post = estimator.update(estimator.predict(prior, model), z, model).state
    x_ref, P_ref = _kalman_reference(prior, model, z)
    np.testing.assert_allclose(post.mean, x_ref, rtol=rtol, atol=rtol, err_msg="posterior mean differs from the KF")
    np.testing.assert_allclose(post.cov, P_ref, rtol=rtol, atol=rtol, err_msg="posterior cov differs from the KF")
    check_covariance_psd(post.cov, "posterior covariance")


def check_batched_equals_one_by_one(estimator: Any, rng: np.random.Generator | None = None, rtol: float = 1e-9) -> None:
    """Filtering a batch gives, element by element, what filtering each element alone gives
    (to rounding: batched and single LAPACK calls may order operations differently)."""
    rng = rng or np.random.default_rng(1)
    prior, model, z = random_linear_problem(rng, batch=(3,))
    batched = estimator.update(estimator.predict(prior, model), z, model).state
    for i in range(3):
        one = Gaussian(prior.mean[i], prior.cov[i])
        alone = estimator.update(estimator.predict(one, model), z[i], model).state
        np.testing.assert_allclose(
            batched.mean[i],
            alone.mean,
            rtol=rtol,
            atol=rtol,
            err_msg=f"batch element {i}: mean differs from a lone run",
        )
        np.testing.assert_allclose(
            batched.cov[i], alone.cov, rtol=rtol, atol=rtol, err_msg=f"batch element {i}: cov differs from a lone run"
        )


_OFFSETS = {"chips": "code_error_chips", "rad": "carrier_phase_rad", "Hz": "freq_error_hz"}


def _noise_free(disc: Any, error: np.ndarray, cn0_dbhz: float, spacing: float) -> tuple[Any, Any]:
    from .interfaces import Correlators

    T = disc.params.coherent_time_s
    taps = np.array([-spacing / 2, 0.0, spacing / 2])
    args = {"code_error_chips": 0.0, "carrier_phase_rad": 0.3, "freq_error_hz": 0.0}
    args[_OFFSETS[disc.unit]] = error
    if disc.unit == "rad":
        args["carrier_phase_rad"] = error

    def corr(phase: np.ndarray | float) -> Correlators:
        a = dict(args, carrier_phase_rad=phase)
        y = correlator_mean(
            amplitude_from_cn0(cn0_dbhz, T), a["code_error_chips"], a["carrier_phase_rad"], a["freq_error_hz"], T, taps
        )
        return Correlators(y[..., 0], y[..., 1], y[..., 2])

    previous = corr(args["carrier_phase_rad"])
    # The next interval's phase has advanced by 2 pi df T (frequency discriminators).
    current = corr(args["carrier_phase_rad"] + 2 * np.pi * np.asarray(args["freq_error_hz"]) * T)
    return current, previous


def check_unit_slope(
    disc: Any, errors: Any, rtol: float = 5e-3, cn0_dbhz: float = 45.0, early_late_spacing_chips: float = 1.0
) -> None:
    """For small true errors (in ``disc.unit``), the noise-free output equals the error."""
    e = np.asarray(errors, float)
    current, previous = _noise_free(disc, e, cn0_dbhz, early_late_spacing_chips)
    out = disc(current, previous if disc.needs_previous else None)
    np.testing.assert_allclose(out, e, rtol=rtol, err_msg=f"{disc.name}: slope is not 1 {disc.unit}/{disc.unit}")


def check_noise_variance(
    disc: Any, cn0_dbhz: float, rng: np.random.Generator, runs: int = 40_000, rtol: float = 0.25
) -> None:
    """``noise_variance(cn0)`` matches the variance of the output on simulated correlators
    (zero true error) within ``rtol``; check where the formula is meant to hold."""
    T = disc.params.coherent_time_s
    spacing = getattr(disc.params, "early_late_spacing_chips", 1.0)
    zero = np.zeros(runs)
    cur = simulate_correlators(zero, 0.0, 0.0, cn0_dbhz, T, rng, early_late_spacing_chips=spacing)
    prev = simulate_correlators(zero, 0.0, 0.0, cn0_dbhz, T, rng, early_late_spacing_chips=spacing)
    mc = float(np.var(disc(cur, prev if disc.needs_previous else None)))
    theory = float(np.asarray(disc.noise_variance(cn0_dbhz)))
    assert abs(mc - theory) <= rtol * theory, (
        f"{disc.name}: Monte Carlo variance {mc:.4g} vs noise_variance {theory:.4g} at {cn0_dbhz} dB-Hz "
        f"(tolerance {rtol:.0%}, {runs} draws)"
    )


#: The nav filter of `vector_loop_series`: the vector-tracking EKF with an OCXO clock.
VECTOR_NAV_FILTER = {"name": "ekf-pv", "params": {"clock": "ocxo"}}


def vector_loop_series(
    channel_filter: dict[str, Any],
    *,
    backend: str | None = None,
    nudge_initial_ulp: bool = False,
    duration_s: float = 5.0,
    cn0_dbhz: float = 30.0,
    runs: int = 2,
    seed: int = 5,
) -> dict[str, np.ndarray]:
    """Time series ``(K, runs)`` of a short closed vector-tracking run, for rounding checks.

    The vector-tracking scenario (8 channels, ``settle_s = 1``) with ``channel_filter``
    (``{"name": ..., "params": ...}``) and ``ekf-pv`` (OCXO). A closed loop lets any
    rounding difference grow over a run, so a compiled or reordered implementation is
    judged against how far rounding alone moves the reference: run it once as it is and
    once with ``nudge_initial_ulp`` (the initial navigation state one ulp up,
    ``np.nextafter``), and compare the change of interest with that one.

    Parameters
    ----------
    backend
        ``"numba"`` or ``"numpy"`` for this run (`gnssframework.backend.set_backend`),
        restored to the default afterwards; ``None`` leaves the current one.
    duration_s, cn0_dbhz, runs, seed
        The run: simulated seconds, C/N0 of every channel, batched runs, seed of its
        ``numpy.random.Generator``.
    """
    from . import backend as backends
    from .experiments import get_scenario

    scen = get_scenario({"kind": "vector-tracking", "duration_s": duration_s, "channels": 8, "settle_s": 1.0})
    if nudge_initial_ulp:
        truth = scen.truth

        def nudged(*args: Any, **kwargs: Any):
            t, x0, P0 = truth(*args, **kwargs)
            return t, np.nextafter(x0, np.inf), P0

        scen.truth = nudged  # this scenario object only
    if backend is not None:
        backends.set_backend(backend)
    try:
        plugins = scen.build({"channel_filter": channel_filter, "nav_filter": VECTOR_NAV_FILTER})
        return scen.run_batch({"cn0_dbhz": cn0_dbhz}, plugins, runs, np.random.default_rng(seed)).series
    finally:
        if backend is not None:
            backends.set_backend(None)


# -- holding two arithmetic paths together through a recursion ---------------------------
#
# Two implementations of the same recursion (a compiled kernel and its NumPy reference, a
# split and a fused form, a filter and an oracle) agree to rounding at each step, but the
# recursion can amplify rounding: how much depends on the problem, and which rounding each
# path commits depends on the CPU (OpenBLAS picks its kernels per processor, numba compiles
# for the host, NumPy dispatches its loops on SIMD features). A fixed tolerance such as
# 1e-12 then passes on one machine and fails on another. Instead, these helpers measure
# the amplification on the reference itself: run it again with an input one ulp away and
# allow the other path a stated multiple of that change.


def ulp_nudges(x: Any) -> tuple[np.ndarray, np.ndarray]:
    """``x`` moved one ulp up and one ulp down, elementwise (``np.nextafter``)."""
    x = np.asarray(x, dtype=float)
    return np.nextafter(x, np.inf), np.nextafter(x, -np.inf)


def _parts(value: Any) -> list[tuple[str, np.ndarray]]:
    if isinstance(value, dict):
        return [(str(k), np.asarray(v, dtype=float)) for k, v in value.items()]
    if isinstance(value, (tuple, list)):
        return [(str(i), np.asarray(v, dtype=float)) for i, v in enumerate(value)]
    return [("", np.asarray(value, dtype=float))]


def relative_change(reference: Any, other: Any) -> float:
    """``max |other - reference| / max |reference|``, the largest over the parts.

    ``reference`` and ``other`` are arrays, or tuples, lists or dicts of arrays of the same
    shapes (each part is normalised by its own largest magnitude; an all-zero part by 1).
    """
    worst = 0.0
    for (name, a), (_, b) in zip(_parts(reference), _parts(other), strict=True):
        if a.shape != b.shape:
            raise AssertionError(f"part {name!r}: shapes differ, {a.shape} vs {b.shape}")
        scale = float(np.max(np.abs(a))) if a.size else 0.0
        diff = float(np.max(np.abs(b - a))) if a.size else 0.0
        if not np.isfinite(diff):
            return float("inf")
        worst = max(worst, diff / (scale or 1.0))
    return worst


def assert_within_rounding(
    got: Any, reference: Any, nudged: Any, *, factor: float = 10.0, floor: float = 1e-12, what: str = "result"
) -> tuple[float, float]:
    """``got`` differs from ``reference`` by at most ``factor`` times what rounding moves it.

    ``nudged`` is the reference recomputed from inputs one ulp away (`ulp_nudges`), or a
    sequence of such recomputations (a tuple of arrays counts as one result: pass a list
    of results); the yardstick is the largest `relative_change` among them. ``floor`` is a
    relative allowance for a recursion that does not amplify rounding (a one-ulp nudge
    that moves nothing). Returns ``(change of got, yardstick)`` as relative numbers.
    """
    runs = nudged if isinstance(nudged, list) else [nudged]
    moved = max(relative_change(reference, n) for n in runs)
    diff = relative_change(reference, got)
    assert diff <= factor * moved + floor, (
        f"{what} differs from the reference by {diff:.3g} (relative), more than {factor:g} times "
        f"the {moved:.3g} a one-ulp change of the reference's input makes, plus {floor:.0e}"
    )
    return diff, moved
