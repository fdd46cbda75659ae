"""Reference 004's assumptions table (issue 22): what each multipath candidate assumes,
in common units, against independent closed forms."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import solve_discrete_lyapunov

from gnssframework import random_streams as draw
from gnssframework import registry
from gnssframework.estimation.ar1_estimate import ar1_coefficient
from gnssframework.experiments import get_scenario, load_config
from gnssframework.experiments.report import assumption_rows

SCENARIO = {"kind": "multipath", "epochs": 200, "psi": 0.9, "multipath_std_m": 3.0, "white_std_m": 0.5}


def _context(psi: float, epochs: int = 500) -> dict:
    return get_scenario(SCENARIO).assumption_context({"name": "c", "psi": psi, "psi_training_epochs": epochs})


def test_the_scenario_states_the_true_noise_of_its_case():
    ctx = _context(0.8, 300)
    # White + colored variance per coordinate: 3² + 0.5² = 9.25 m²; the truth is static.
    assert ctx["measurement_variance_m2"] == pytest.approx(9.25)
    assert (ctx["psi"], ctx["psi_training_epochs"], ctx["true_process_noise"]) == (0.8, 300, 0.0)
    # The scenario's psi where the case gives none.
    assert get_scenario(SCENARIO).assumption_context({"name": "c"})["psi"] == 0.9
    # The simulated noise has that variance (a long record, many runs: SE ~ 1 %).
    scen = get_scenario({**SCENARIO, "epochs": 4000})
    z = scen.simulate(50, draw.run_streams(1, (), range(50)), 0.8)
    assert np.var(z) == pytest.approx(ctx["measurement_variance_m2"], rel=0.05)


def test_position_ca_declares_its_per_epoch_process_noise_and_r0_against_the_truth():
    nav = registry.create("nav_filter", "position-ca", q0=[1.0, 0.1, 0.01], r0=1.0)
    out = nav.assumptions(_context(0.5))
    assert out["position process-noise variance per epoch"] == (1.0, "m²")
    assert out["velocity process-noise variance per epoch"] == (0.1, "m²/s²")
    assert out["acceleration process-noise variance per epoch"] == (0.01, "m²/s⁴")
    # R0 = 1 m² against the truth's 3² + 0.5² m²: about a ninth.
    assert out["R0 / true measurement variance (white + colored)"] == (pytest.approx(1.0 / (3.0**2 + 0.5**2)), "-")
    # The diagonal Q0 is the model's: it is what the filter adds every epoch.
    assert np.allclose(np.diag(nav.model().Q), [out[k][0] for k in list(out)[:3]])
    # A scenario that does not know the truth: no ratio.
    assert "R0 / true measurement variance (white + colored)" not in nav.assumptions({})


@pytest.mark.parametrize("psi", [0.3, 0.5, 0.8, 0.95])
def test_colored_ar1_gives_the_ar1_stationary_variance_factor(psi):
    aug = registry.create("augmentation", "colored-ar1", cross_covariance="paper")
    out = aug.assumptions(_context(psi))
    assert out["AR(1) psi"] == (psi, "-") and out["AR(1) psi / true psi"] == (1.0, "-")
    assert out["process/measurement cross covariance"][0].startswith("paper")
    # The stationary variance of V = psi V + xi with unit driving variance: the discrete
    # Lyapunov equation P = psi² P + 1, and the sum of the impulse response's squares.
    lyapunov = solve_discrete_lyapunov(np.array([[psi]]), np.array([[1.0]]))[0, 0]
    assert out["stationary / driving variance, 1/(1 − psi²)"][0] == pytest.approx(lyapunov, rel=1e-12)
    assert lyapunov == pytest.approx(np.sum(psi ** (2 * np.arange(2000))), rel=1e-12)
    exact = registry.create("augmentation", "colored-ar1", cross_covariance="exact").assumptions(_context(psi))
    assert exact["process/measurement cross covariance"][0].startswith("exact")


def test_a_given_psi_is_what_the_filter_assumes_whatever_the_truth():
    aug = registry.create("augmentation", "colored-ar1", psi=0.6)
    out = aug.assumptions(_context(0.8))
    assert out["AR(1) psi"][0] == 0.6 and out["AR(1) psi / true psi"][0] == pytest.approx(0.75)
    assert out["measurement-noise model"][0] == "AR(1), psi given"


def test_the_lag1_estimate_is_declared_at_its_limit_on_the_scenarios_noise():
    # The declared psi of psi_estimator = "lag1" is what the estimator converges to on the
    # scenario's measured noise; the mean of its estimates over long records of that noise
    # (two coordinates each, as filter_psi averages them) must match it within 4 SE plus
    # the record's (1 + 4 rho)/n bias.
    psi, n, m = 0.95, 20000, 100
    declared = registry.create("augmentation", "colored-ar1", psi_estimator="lag1").assumptions(_context(psi, n))
    rho = declared["AR(1) psi"][0]
    train = get_scenario(SCENARIO).simulate(m, draw.run_streams(7, (), range(m)), psi, epochs=n)  # (n, m, 2)
    est = np.mean(ar1_coefficient(train), axis=-1)
    se = np.std(est, ddof=1) / np.sqrt(m)
    assert abs(np.mean(est) - rho) < 4 * se + (1 + 4 * rho) / n
    # and it is visibly below the truth: the white share 0.25 / 9.25 biases it by 2.7 %
    assert rho / psi == pytest.approx(9.0 / 9.25) and psi - np.mean(est) > 20 * se
    ratio = registry.create("augmentation", "colored-ar1", psi_estimator="lag-ratio").assumptions(_context(psi, n))
    assert ratio["AR(1) psi / true psi"][0] == 1.0  # consistent: declared at the truth


def test_sage_husa_memory_is_its_recursions_effective_window():
    improved = registry.create("noise_adapter", "sage-husa", variant="improved", alpha_r=0.5, alpha_q=0.5)
    out = improved.assumptions({})
    assert out["adapter memory"] == (1.0, "epochs") and "adapts Q and R" in out["noise adapter"][0]
    r_only = registry.create("noise_adapter", "sage-husa", variant="improved", alpha_q=0.0)
    assert "adapts R" in r_only.assumptions({})["noise adapter"][0]
    assert "Q and" not in r_only.assumptions({})["noise adapter"][0]
    # Classic: the weight of the sample j steps back in R_k = (1 - d_k) R_{k-1} + d_k r_k,
    # d_k = (1 - b)/(1 - b^(k+1)), from the recursion itself; the weights' sum over the
    # newest one's is the effective window.
    b, K = 0.97, 3000
    d = (1 - b) / (1 - b ** (np.arange(K) + 1))
    weights = d * np.append(np.cumprod((1 - d)[::-1])[::-1][1:], 1.0)
    assert np.sum(weights) == pytest.approx(1.0)
    classic = registry.create("noise_adapter", "sage-husa", variant="classic", b=b)
    assert classic.assumptions({})["adapter memory"][0] == pytest.approx(np.sum(weights) / weights[-1], rel=1e-9)


def test_the_examples_assumptions_table_sets_the_candidates_side_by_side():
    from pathlib import Path

    rows = assumption_rows(load_config(Path(__file__).resolve().parents[2] / "examples" / "multipath.toml"))
    by = {(r["case"], r["candidate"], r["component"], r["label"]): r["value"] for r in rows}
    # The raw row assumes nothing; the plain UKF no colored noise, UKF1 the case's psi
    # (the paper's literal rows: the tuned ones' given values are the tuner's start only).
    assert not [r for r in rows if r["candidate"] == "raw"]
    assert ("psi-0.8", "UKF-paper", "augmentation", "AR(1) psi") not in by
    assert by[("psi-0.8", "UKF1-paper", "augmentation", "AR(1) psi")] == 0.8
    # UKF1's implied stationary measurement variance, R0 / (1 - psi²), against the truth's:
    # far below it at psi = 0.5, near it at 0.95 (R0 = 1 m², truth 9.25 m²).
    for case, psi in (("psi-0.5", 0.5), ("psi-0.95", 0.95)):
        implied = (
            by[(case, "UKF1-paper", "nav_filter", "R0 / true measurement variance (white + colored)")]
            * by[(case, "UKF1-paper", "augmentation", "stationary / driving variance, 1/(1 − psi²)")]
        )
        assert implied == pytest.approx(1.0 / (1 - psi**2) / 9.25)
    assert by[("psi-0.5", "AUKF1-paper", "noise_adapter", "adapter memory")] == 1.0
    assert "1e-08 to 1" in by[("psi-0.5", "oracle", "oracle", "Q scale s_q (Q = s_q Q0)")]
