"""The deep-integration page's script tables (docs/deep_integration_*.py): each committed
``docs/experiments/generated/*.md`` is what its script renders from the committed ``.json``
(never edited by hand), and the scripts' new computations against independent forms."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
GENERATED = ROOT / "docs" / "experiments" / "generated"
sys.path.insert(0, str(ROOT / "docs"))

import deep_integration_attitude  # noqa: E402
import deep_integration_carrier  # noqa: E402
import deep_integration_numbers  # noqa: E402


def _summary(name: str) -> dict:
    return json.loads((GENERATED / f"{name}.json").read_text())


@pytest.mark.parametrize("md", sorted(deep_integration_numbers.RENDER))
def test_numbers_tables_are_what_the_script_writes_from_its_summary(md):
    render = deep_integration_numbers.RENDER[md]
    assert (GENERATED / md).read_text() == render(_summary("deep_integration_numbers"))


def test_carrier_table_is_what_the_script_writes_from_its_summary():
    assert (GENERATED / "deep_integration_carrier.md").read_text() == deep_integration_carrier.markdown(
        _summary("deep_integration_carrier")
    )


def test_attitude_table_is_what_the_script_writes_from_its_summary():
    assert (GENERATED / "deep_integration_attitude.md").read_text() == deep_integration_attitude.markdown(
        _summary("deep_integration_attitude")
    )


def test_paired_difference_is_the_mean_and_standard_error_of_the_differences():
    # d = (1, 2, 3): mean 2, sample standard deviation 1, SE 1/sqrt(3).
    m, se = deep_integration_attitude.paired([1.0, 2.0, 4.0], [0.0, 0.0, 1.0])
    assert m == pytest.approx(2.0) and se == pytest.approx(1 / np.sqrt(3))


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
    # The same band as tests/receiver/test_deep_carrier.py (5 % SE of the measured variance).
    for row in _summary("deep_integration_carrier")["rows"]:
        assert 0.85 < row["measured_var_rad2"] / row["predicted_var_rad2"] < 1.15


def test_a_perfect_navigator_makes_the_replica_error_the_same_in_every_run_and_aiding_shrinks_it():
    s = deep_integration_numbers.first_number(seconds=0.2)
    for row in s["rows"]:
        for k in ("accel", "no_accel"):
            assert row[k]["spread_freq_hz"] == 0.0 and row[k]["spread_code_chips"] == 0.0
        assert row["accel"]["freq_hz"] < row["no_accel"]["freq_hz"]


def test_nees_split_table_is_what_the_script_writes_from_its_summary():
    import deep_integration_nees_split

    assert (GENERATED / "deep_integration_nees_split.md").read_text() == deep_integration_nees_split.markdown(
        _summary("deep_integration_nees_split")
    )


def test_half_normal_moments_match_a_sample():
    # |N(0, 0.5^2)|: mean 0.5 sqrt(2/pi) ~ 0.399, sd 0.5 sqrt(1 - 2/pi) ~ 0.301 (half-normal).
    m, sd = deep_integration_attitude.half_normal_mean_sd(0.5)
    x = np.abs(np.random.default_rng(1).normal(0.0, 0.5, 200_000))
    assert m == pytest.approx(x.mean(), abs=4 * 0.301 / np.sqrt(x.size))
    assert sd == pytest.approx(x.std(), rel=0.01)
