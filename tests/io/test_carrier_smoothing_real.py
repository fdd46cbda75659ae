"""The reference-001 real-data example (examples/carrier_smoothing_real.py): its measures
against closed forms, and a run on the one-hour CEBR excerpt in tests/data."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from gnssframework.io.observations import SPEED_OF_LIGHT_MPS, arc_starts, read_observations

ROOT = Path(__file__).resolve().parents[2]
EXCERPT = ROOT / "tests" / "data" / "CEBR00ESP_R_20182002200_01H_30S_MO.crx.gz"


@pytest.fixture(scope="module")
def example():
    spec = importlib.util.spec_from_file_location(
        "carrier_smoothing_real", ROOT / "examples" / "carrier_smoothing_real.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_dual_frequency_measure_removes_the_ionosphere_and_keeps_the_code_error(example):
    rng = np.random.default_rng(3)
    n = 400
    r = 2.2e7 + np.cumsum(rng.normal(0, 50, n))  # any geometry
    iono_l1 = 5.0 + 3.0 * np.sin(np.linspace(0, 3, n))  # a drifting L1 delay (m)
    gamma = (1575.42 / 1227.60) ** 2
    lam1, lam2 = SPEED_OF_LIGHT_MPS / 1575.42e6, SPEED_OF_LIGHT_MPS / 1227.60e6
    code_error = rng.normal(0, 0.4, n)
    rho = r + iono_l1 + code_error
    phi1 = r - iono_l1 + 1234 * lam1  # the carrier advances by the delay (IS-GPS-200 20.3.3.3.3.3)
    phi2 = r - gamma * iono_l1 - 987 * lam2
    measured = example.iono_free_code_error(rho, phi1, phi2)
    np.testing.assert_allclose(measured - measured.mean(), code_error - code_error.mean(), atol=1e-6)
    # Code minus carrier alone would carry 2 I: a drift of 6 m peak to peak.
    assert np.ptp(rho - phi1) > 5.0


def test_a_carrier_jump_is_found_and_smooth_ionosphere_is_not(example):
    t = np.arange(300) * 30.0
    phi1 = 2e7 + 800 * t
    phi2 = phi1 - 3.0 * np.sin(t / 3000.0)  # geometry-free drift: a few mm per 30 s
    assert not example.carrier_jumps(phi1, phi2).any()
    phi2[150:] += 0.244  # one L2 cycle
    assert np.flatnonzero(example.carrier_jumps(phi1, phi2)).tolist() == [150]


def test_settle_epochs_counts_to_the_band(example):
    err = np.concatenate([np.full(10, 5.0), np.full(200, 0.1)])
    # The 5-epoch window first lies wholly in the 0.1 m part at index 10.
    assert example.settle_epochs(err) == 10


@pytest.mark.slow
def test_the_example_runs_on_the_excerpt(example, tmp_path):
    assert example.main(["--file", str(EXCERPT), "--out", str(tmp_path)]) == 0
    text = (tmp_path / "carrier_smoothing_real.md").read_text()
    obs = read_observations(EXCERPT, "G")
    arcs = int(arc_starts(obs.time_s, obs.valid, obs.lli, 1.5 * obs.interval_s).sum())
    assert f"{arcs} arcs" in text and "| adaptive-kf |" in text
    import json

    summary = json.loads((tmp_path / "carrier_smoothing_real.json").read_text())
    assert summary["lli_flags"] == int(((obs.lli & 1) != 0)[obs.valid].sum())
    assert set(summary["candidates"]) == {
        "raw",
        "hatch",
        "kf",
        "adaptive-kf",
        "hatch-slip-reset",
        "kf-slip-reset",
        "kf-tuned",
        "adaptive-kf-tuned",
    }


def test_the_pages_table_is_what_the_script_writes_from_its_summary(example):
    # CI regenerates both with --docs from the day in ../shared/data; the committed table
    # must be the script's rendering of the committed summary (never edited by hand).
    generated = ROOT / "docs" / "experiments" / "generated"
    import json

    summary = json.loads((generated / "carrier_smoothing_real.json").read_text())
    assert (generated / "carrier_smoothing_real.md").read_text() == example.markdown(summary)


def test_a_paired_difference_whose_t_interval_contains_zero_is_marked_not_significant(example):
    # 1.98 SE over 49 arcs: outside +-1.96 SE but inside the t-interval (+-2.01 SE).
    d = {
        "error_rmse_m": [0.0399, 0.0201, 49],
        "settle_epochs": [3.0, 1.0, 12],
        "significant": {"error_rmse": False, "settle_epochs": True},
    }
    assert example._paired(d, "error_rmse", 3) == "0.040 ± 0.020 (49, n.s.)"
    assert example._paired(d, "settle_epochs", 1) == "3.0 ± 1.0 (12)"


def test_the_reference_restarts_at_an_unflagged_jump_and_keeps_a_smoothers_transient(example):
    # The measure (code minus carriers) steps by the carriers' jump; the code error does not.
    rng = np.random.default_rng(11)
    n, k = 200, 120
    code_error = rng.normal(0, 0.3, n)
    step = np.where(np.arange(n) >= k, -2.5, 0.0) + 7.0  # the reference constant, stepping at the jump
    jumps = np.zeros(n, bool)
    jumps[k] = True
    reference = example.segment_reference(code_error + step, jumps)
    # Raw code: what is left is its error minus the error's mean on each segment.
    left = code_error + step - reference
    expected = code_error - np.where(np.arange(n) >= k, code_error[k:].mean(), code_error[:k].mean())
    np.testing.assert_allclose(left, expected, atol=1e-12)
    # A smoother that carried the jump and lets it decay (0.8 per epoch) keeps that transient.
    transient = np.where(np.arange(n) >= k, 1.5 * 0.8 ** np.clip(np.arange(n) - k, 0, None), 0.0)
    smoothed_left = code_error + transient + step - reference
    assert smoothed_left[k] - left[k] == pytest.approx(1.5)
    assert np.ptp(example.segment_reference(code_error, np.zeros(n, bool))) < 1e-12  # no jump: one constant
