"""Scenario ``multipath``: position-domain filtering with AR(1) colored noise (Liu et al. 2020).

A static receiver's latitude and longitude (local metres) are measured every epoch with
AR(1) colored multipath noise plus white noise, and optionally gross (NLOS-like) errors
on a fraction ``outlier_probability`` of the epochs. Candidates compose a ``nav_filter``
(``position-ca``), an ``estimator``, and optionally a ``colored-ar1`` augmentation and a
``noise_adapter``; a candidate with none of these reports the measurement itself (``raw``).
A ``colored-ar1`` without ``psi`` gets the case's true psi, or (its ``psi_estimator``)
psi estimated from a training record of ``psi_training_epochs``
(``gnssframework.estimation.ar1_estimate``). A candidate with
``scenario_options.oracle`` (an `OracleGrid`) is scored with the best fixed Q and R of
that grid, chosen against the truth on independent training runs (an oracle bound).

The nav filter is any `~gnssframework.interfaces.BatchPositionFilter`: the scenario
filters the whole sequence through it, with its model's Q and R scaled for the oracle.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field

from ... import random_streams as draw
from ... import registry
from ...errors import ConfigError
from ...estimation import LinearModel
from ...interfaces import BatchPositionFilter
from ...estimation.ar1_estimate import ar1_coefficient
from ...simulation.impairments import ar1_noise
from ..metric_components import ConvergenceEpoch, MeanAbs, Rmse, convergence_epoch, evaluate, units
from . import BatchResult, Scenario, ScenarioParams, register_scenario

__all__ = [
    "MultipathScenario",
    "OracleGrid",
    "MultipathCandidateOptions",
    "METRICS",
    "convergence_epoch",
    "BYTES_PER_EPOCH_RUN",
]

#: Peak memory of one filtered run's epoch (the measurements, the filter's means and
#: covariances, and per run and grid pair of the oracle), an upper bound:
#: tests/experiments/test_limits.py holds it above the measured peak.
BYTES_PER_EPOCH_RUN = 1536


class OracleGrid(ScenarioParams):
    r"""The best *fixed* Q and R on a grid, chosen with the truth (an oracle bound).

    The scenario runs the candidate's filter with every $(s_q Q_0, s_r R_0)$ of the grid
    on independent training runs, keeps the pair with the lowest RMS error, and reports
    that filter on the common runs. Choosing on other runs keeps the bound free of
    selection bias. Scaling Q and R together leaves the gains unchanged except through
    the initial covariance, so the grid is effectively over Q/R.
    """

    q_scales: list[float] = Field(
        [1e-8, 1e-6, 1e-4, 1e-2, 1.0],
        min_length=1,
        description="Q = s_q Q0 for each s_q (multipliers of the model's Q0)",
    )
    r_scales: list[float] = Field(
        [0.3, 1.0, 3.0, 10.0, 30.0, 100.0],
        min_length=1,
        description="R = s_r R0 for each s_r (multipliers of the model's R0)",
    )
    training_runs: int = Field(
        10,
        ge=1,
        description="independent runs the grid is scored on, drawn from a stream of the case (the same in every batch)",
    )

    def assumptions(self, context: dict[str, Any]) -> dict[str, tuple[Any, str]]:
        """What the oracle row assumes beside its nav filter's Q0 and R0: they are scaled by
        the best grid pair, chosen against the truth on training runs (the grid's range here;
        the chosen pair depends on the training runs)."""

        def span(v: list[float]) -> str:
            return f"{min(v):g} to {max(v):g} ({len(v)} values, best on {self.training_runs} training runs)"

        return {
            "Q scale s_q (Q = s_q Q0)": (span(self.q_scales), "-"),
            "R scale s_r (R = s_r R0)": (span(self.r_scales), "-"),
        }

    def passes(self) -> int:
        """Runs filtered to choose the pair: grid pairs x training runs."""
        return len(self.q_scales) * len(self.r_scales) * self.training_runs


class MultipathCandidateOptions(ScenarioParams):
    """A candidate's ``scenario_options`` in ``multipath``."""

    oracle: OracleGrid | None = Field(
        None,
        description="score this candidate's filter with the best fixed Q and R "
        "of a grid, chosen against the truth on training runs (an oracle bound)",
    )


def _oracle_runs(candidate: dict[str, Any]) -> int:
    """Runs an oracle candidate filters besides the batch (0 for the others)."""
    options = MultipathCandidateOptions.model_validate(candidate.get("scenario_options") or {})
    return 0 if options.oracle is None else options.oracle.passes()


class MultipathParams(ScenarioParams):
    epochs: int = Field(500, ge=20, le=100_000)
    dt_s: float = Field(1.0, gt=0)
    psi: float = Field(0.95, gt=-1, lt=1, description="AR(1) coefficient of the multipath noise")
    multipath_std_m: float = Field(3.0, ge=0, description="stationary std of the colored part")
    white_std_m: float = Field(0.5, ge=0, description="std of the white part")
    convergence_window: int = Field(10, ge=1, description="epochs of the running RMS in the convergence test")
    outlier_probability: float = Field(
        0.0,
        ge=0,
        lt=1,
        description="probability that an epoch's coordinate "
        "carries a gross (NLOS-like) error besides the noise (0: none; the "
        "noise draws are the same either way)",
    )
    outlier_std_m: float = Field(30.0, ge=0, description="std of the gross errors (zero-mean Gaussian)")
    outlier_from_epoch: int = Field(
        1,
        ge=0,
        description="first epoch that may carry a gross error (the filters "
        "initialise on epoch 0: 1 keeps that fix clean, as a checked first fix)",
    )


class MultipathCase(ScenarioParams):
    name: str | None = None
    psi: float | None = Field(None, gt=-1, lt=1, description="AR(1) coefficient of this case (default: the scenario's)")
    psi_training_epochs: int = Field(
        500,
        ge=20,
        le=1_000_000,
        description="length in epochs of the training record from which a colored-ar1 with psi_estimator "
        "'lag1' or 'lag-ratio' gets psi (default 500, the paper's record length): the same noise law, drawn "
        "independently of the evaluated runs",
    )


#: The scenario's metrics, each declared once as a component (name, unit, the series it
#: reduces); ``run_batch`` computes them all once with `evaluate`.
METRICS = (
    MeanAbs("lat_error_mean", "m", of="lat_error_m", description="mean absolute latitude error"),
    Rmse("lat_error_rmse", "m", of="lat_error_m", description="RMS latitude error"),
    MeanAbs("lon_error_mean", "m", of="lon_error_m", description="mean absolute longitude error"),
    Rmse("lon_error_rmse", "m", of="lon_error_m", description="RMS longitude error"),
    Rmse("horizontal_error_rmse", "m", of="horizontal_error_m", description="RMS horizontal error"),
    ConvergenceEpoch(
        "convergence_epoch",
        of="horizontal_error_m",
        window="convergence_window",
        factor=2.0,
        description="epoch after which the running RMS horizontal error stays below twice the second half's",
    ),
)


@register_scenario
class MultipathScenario(Scenario):
    """Position filtering with AR(1) colored multipath noise (Liu et al. 2020)."""

    kind = "multipath"
    Params = MultipathParams
    params: MultipathParams  # self.params, as validated
    CaseParams = MultipathCase
    components = {"nav_filter": False, "estimator": False, "augmentation": False, "noise_adapter": False}
    CandidateOptions = MultipathCandidateOptions
    metrics = units(METRICS)
    #: The raw per-epoch errors (signed, truth 0) the metrics reduce; metric components
    #: of other packages may read them too.
    outputs = {"lat_error_m": "m", "lon_error_m": "m", "horizontal_error_m": "m"}

    def batch_memory(self, case: dict, runs: int, where: str, candidates=()) -> tuple[float, str, str]:
        """One filter pass over the batch, plus an oracle's grid of passes over its
        training runs (every (Q, R) pair is a batch axis of one filter)."""
        epochs = self.params.epochs
        passes = runs + max((_oracle_runs(c) for c in candidates), default=0)
        return (
            BYTES_PER_EPOCH_RUN * epochs * passes,
            "scenario.epochs",
            f"a batch of {runs} runs of {where} ({epochs} epochs, {passes} filtered runs with an oracle's grid)",
        )

    def check_composition(self, plugins, where: str) -> None:
        if plugins and ("nav_filter" not in plugins or "estimator" not in plugins):
            missing = "nav_filter" if "nav_filter" not in plugins else "estimator"
            raise ConfigError(
                f"{where}.{missing}",
                "a filtering candidate composes a nav_filter and an estimator "
                "(a candidate with no plugins reports the raw measurement)",
            )
        if not plugins:
            return
        if not isinstance(plugins["nav_filter"], BatchPositionFilter):
            able = ", ".join(
                n
                for n in registry.names("nav_filter")
                if issubclass(registry.get("nav_filter", n), BatchPositionFilter)
            )
            raise ConfigError(
                f"{where}.nav_filter.name",
                f"{plugins['nav_filter'].name!r} cannot filter a position "
                f"sequence (not a BatchPositionFilter); nav filters that can: {able or '(none)'}",
            )

    def check_candidate(
        self, components: dict[str, Any], where: str, options: dict[str, Any] | None = None
    ) -> dict[str, Any]:
        plugins = super().check_candidate(components, where, options)
        if self.candidate_options(options, where).oracle is not None and not components:
            raise ConfigError(
                f"{where}.scenario_options.oracle",
                "the oracle scores a filter: compose a nav_filter "
                "and an estimator (a candidate with no plugins reports the raw measurement)",
            )
        return plugins

    def build(
        self, candidate: dict[str, Any], options: dict[str, Any] | None = None, case: dict[str, Any] | None = None
    ) -> dict[str, Any]:
        """The candidate's plugins, and its oracle grid under ``"oracle"`` if it has one."""
        plugins = super().build(candidate, case=case)
        oracle = self.candidate_options(options).oracle
        return plugins if oracle is None else {**plugins, "oracle": oracle}

    def simulate(
        self, runs: int, rng: np.random.Generator, psi: float | None = None, epochs: int | None = None
    ) -> np.ndarray:
        """Measured (lat, lon) errors in metres, ``(epochs, runs, 2)`` (default: the
        scenario's epochs); the truth is 0."""
        p = self.params
        psi = p.psi if psi is None else psi
        epochs = p.epochs if epochs is None else epochs
        xi_std = p.multipath_std_m * np.sqrt(1 - psi**2)
        colored = ar1_noise(psi, xi_std, epochs, rng, batch_shape=(runs, 2))
        noise = colored + p.white_std_m * draw.standard_normal(rng, (epochs, runs, 2), 1)
        if p.outlier_probability > 0:  # a stream of its own: the noise above is unchanged
            outliers = draw.child(rng, "gross-errors")
            hit = draw.random(outliers, (epochs, runs, 2), 1) < p.outlier_probability
            hit[: p.outlier_from_epoch] = False
            noise = noise + np.where(hit, p.outlier_std_m * draw.standard_normal(outliers, (epochs, runs, 2), 1), 0.0)
        return noise

    def assumption_context(self, case: dict[str, Any]) -> dict[str, Any]:
        r"""What the candidates' ``assumptions`` compare against in ``case``: the true AR(1)
        coefficient ``psi``, the true measurement-noise variance per coordinate

        $$
        \sigma_z^2 = \sigma_c^2 + \sigma_w^2
        $$

        (the AR(1) part's stationary variance $\sigma_c^2$ = ``multipath_std_m``², the white
        part's $\sigma_w^2$ = ``white_std_m``²), both parts' variances, the epoch interval
        and the training record's length. The truth is static: its process noise is 0."""
        c = self.CaseParams.model_validate(case)
        p = self.params
        return {
            "psi": p.psi if c.psi is None else c.psi,
            "dt_s": p.dt_s,
            "colored_variance_m2": p.multipath_std_m**2,
            "white_variance_m2": p.white_std_m**2,
            "measurement_variance_m2": p.multipath_std_m**2 + p.white_std_m**2,
            "psi_training_epochs": c.psi_training_epochs,
            "true_process_noise": 0.0,
        }

    #: Bound on an estimated |psi| (measurement differencing needs |psi| < 1).
    PSI_BOUND = 0.999

    def filter_psi(self, case: dict, rng: draw.RunStreams, estimator: str = "truth") -> float:
        """The psi a ``colored-ar1`` without psi is given in ``case``: the true one
        (``estimator = "truth"``), or its estimate (``"lag1"``, ``"lag-ratio"``;
        `gnssframework.estimation.ar1_estimate`) from a training record of
        ``psi_training_epochs`` drawn from the case's shared stream (the same for every
        batch and candidate, independent of the evaluated runs): the mean of the latitude
        and longitude records' estimates (the two share the noise law), clipped to
        +-``PSI_BOUND``."""
        c = self.CaseParams.model_validate(case)
        psi = self.params.psi if c.psi is None else c.psi
        if estimator == "truth":
            return psi
        train = self.simulate(1, rng.shared("psi-training"), psi, epochs=c.psi_training_epochs)[:, 0]  # (n, 2)
        est = np.mean(ar1_coefficient(train, estimator))  # both coordinates share the noise law
        return float(np.clip(est, -self.PSI_BOUND, self.PSI_BOUND))

    def case_parameters(self, kind: str, spec, case: dict) -> dict:
        """A ``colored-ar1`` without psi that takes the case's true one (``psi_estimator =
        "truth"``) is built with it (`_with_psi` would re-create it in `run_batch`); an
        estimated psi needs the task's random streams, so `_with_psi` supplies that one."""
        fields = spec.cls.Params.model_fields if kind == "augmentation" else {}
        if "psi" not in fields or "psi_estimator" not in fields:
            return {}
        own = {
            k: spec.params.get(k, fields[k].get_default(call_default_factory=True)) for k in ("psi", "psi_estimator")
        }
        if own["psi"] is not None or own["psi_estimator"] != "truth":
            return {}
        return {"psi": self.filter_psi(case, None, "truth")}

    def _with_psi(self, plugins: dict, case: dict, rng: draw.RunStreams) -> dict:
        """A ``colored-ar1`` without psi gets the case's true psi, or its estimate when the
        augmentation's ``psi_estimator`` asks for one (`filter_psi`)."""
        aug = plugins.get("augmentation")
        if aug is None or getattr(aug.params, "psi", 0.0) is not None:
            return plugins
        psi = self.filter_psi(case, rng, getattr(aug.params, "psi_estimator", "truth"))
        return {
            **plugins,
            "augmentation": registry.create("augmentation", aug.name, **{**dict(aug.params), "psi": psi}),
        }

    def _filter(self, plugins: dict, zs: np.ndarray, q_scale: float = 1.0, r_scale: float = 1.0):
        """Errors ``(K', runs, 2)`` of the candidate's filter (Q and R scaled for the oracle) and epochs."""
        if "nav_filter" not in plugins:  # raw: the measurement itself
            return zs, np.arange(zs.shape[0])
        nav = plugins["nav_filter"]
        base = nav.model()
        res = nav.filter(
            zs,
            plugins["estimator"],
            adapter=plugins.get("noise_adapter"),
            augmentation=plugins.get("augmentation"),
            model=LinearModel(base.F, base.H, base.Q * q_scale, base.R * r_scale),
        )
        return res.mean[..., nav.position_index], res.epochs  # the truth is the origin

    def _oracle(self, plugins: dict, psi: float, rng: draw.RunStreams) -> tuple[float, float]:
        """The (Q, R) scales of the grid with the lowest RMS error on independent training runs.

        The training runs come from a stream of the case, not of the batch's runs, so every
        batch picks the same scales (results do not depend on how runs were batched).
        Every grid pair runs in one batched filter: the pair is a leading batch axis of Q, R
        and the measurements (what the loop over pairs computes, test_multipath_cases.py)."""
        grid = plugins["oracle"]
        train = self.simulate(grid.training_runs, rng.shared("oracle-training"), psi)
        pairs = [(sq, sr) for sq in grid.q_scales for sr in grid.r_scales]
        nav = plugins["nav_filter"]
        base = nav.model()
        sq, sr = (np.array(v, dtype=float) for v in zip(*pairs))
        batch = (len(pairs),) + train.shape[1:]
        Q = np.broadcast_to(sq[:, None, None, None, None] * base.Q, batch + base.Q.shape[-2:]).copy()
        R = np.broadcast_to(sr[:, None, None, None, None] * base.R, batch + base.R.shape[-2:]).copy()
        zs = np.ascontiguousarray(np.broadcast_to(train[:, None], (train.shape[0],) + batch))
        res = nav.filter(
            zs, plugins["estimator"], augmentation=plugins.get("augmentation"), model=LinearModel(base.F, base.H, Q, R)
        )
        score = np.mean(res.mean[..., nav.position_index] ** 2, axis=(0, 2, 3))  # the truth is the origin
        return pairs[int(np.argmin(score))]

    def run_batch(self, case, plugins, runs, rng) -> BatchResult:
        rng = draw.as_run_streams(rng, runs)  # one stream per run: numbers independent of batching
        p = self.params
        psi = p.psi if case.get("psi") is None else case["psi"]
        zs = self.simulate(runs, rng, psi)  # first: every candidate sees the same measurements
        plugins = self._with_psi(plugins, case, rng)
        scales = self._oracle(plugins, psi, rng) if plugins.get("oracle") is not None else (1.0, 1.0)
        err, epochs = self._filter(plugins, zs, *scales)
        lat, lon = err[..., 0], err[..., 1]
        return evaluate(
            METRICS,
            {"lat_error_m": lat, "lon_error_m": lon, "horizontal_error_m": np.hypot(lat, lon)},
            epochs * p.dt_s,
            self,
        )
