"""The deep-integration page's script tables (docs/deep_integration_*.py): each committed
``docs/experiments/generated/*.md`` is what its script renders from the committed ``.json``
(never edited by hand), and the scripts' new computations against independent forms."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
GENERATED = ROOT / "docs" / "experiments" / "generated"
sys.path.insert(0, str(ROOT / "docs"))

import deep_integration_carrier  # noqa: E402
import deep_integration_numbers  # noqa: E402


def _summary(name: str) -> dict:
    return json.loads((GENERATED / f"{name}.json").read_text())


@pytest.mark.parametrize("md", sorted(deep_integration_numbers.RENDER))
def test_numbers_tables_are_what_the_script_writes_from_its_summary(md):
    render = deep_integration_numbers.RENDER[md]
    assert (GENERATED / md).read_text() == render(_summary("deep_integration_numbers"))


def test_carrier_table_is_what_the_script_writes_from_its_summary():
    assert (GENERATED / "deep_integration_carrier.md").read_text() == \
        deep_integration_carrier.markdown(_summary("deep_integration_carrier"))


def test_predicted_phase_variance_is_that_of_the_simulated_error_recursion():
    # The closed form (Riccati gain, Lyapunov solution) against a simulation of the linear
    # recursion e_{k+1} = F(I-KH) e_k - F K v_k with white v of the discriminator's variance.
    from scipy.linalg import solve_discrete_are

    T, cn0 = deep_integration_carrier.T, 35.0
    F, H = np.array([[1.0, T], [0.0, 1.0]]), np.array([[1.0, T / 2]])
    r = deep_integration_carrier.R_FILTER
    P = solve_discrete_are(F.T, H.T, np.diag(deep_integration_carrier.Q_DIAG), np.array([[r]]))
    K = P @ H.T / (H @ P @ H.T + r)
    cT = 10 ** (cn0 / 10) * T
    sigma = np.sqrt(1 / (2 * cT) * (1 + 1 / (2 * cT)))
    A, B = F @ (np.eye(2) - K @ H), (F @ K)[:, 0]
    rng = np.random.default_rng(0)
    chains, steps = 400, 3000
    e = np.zeros((chains, 2))
    acc = []
    for k in range(steps):
        e = e @ A.T - np.outer(rng.normal(size=chains) * sigma, B)
        if k >= 1000:  # after the loop's transient (time constant ~ 1/B_L = 0.16 s)
            acc.append(e @ H[0])
    var = np.mean(np.square(acc))
    # 400 chains x 2000 correlated steps (~40 ms correlation): SE of the variance about 1.5 %.
    assert var == pytest.approx(deep_integration_carrier.predicted_phase_var(cn0), rel=0.08)


def test_carrier_summary_is_within_the_tests_band():
    # The same band as tests/test_deep_carrier.py (5 % SE of the measured variance).
    for row in _summary("deep_integration_carrier")["rows"]:
        assert 0.85 < row["measured_var_rad2"] / row["predicted_var_rad2"] < 1.15


def test_a_perfect_navigator_makes_the_replica_error_the_same_in_every_run_and_aiding_shrinks_it():
    s = deep_integration_numbers.first_number(seconds=0.2)
    for row in s["rows"]:
        for k in ("accel", "no_accel"):
            assert row[k]["spread_freq_hz"] == 0.0 and row[k]["spread_code_chips"] == 0.0
        assert row["accel"]["freq_hz"] < row["no_accel"]["freq_hz"]
