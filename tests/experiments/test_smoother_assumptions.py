"""Reference 001's assumptions (carrier-smoothed code): the smoothers' declared windows,
drift and noise, each against an independent truth (the iterated Riccati recursion, a
simulation of the plugin, the scenario's simulated code)."""

from __future__ import annotations

import numpy as np
import pytest

import gnssframework as gf
from gnssframework.experiments import get_scenario, load_config
from gnssframework.experiments.report import assumption_rows
from gnssframework.interfaces import ASSUMPTION_LABELS
from gnssframework_plugins.smoothers import random_walk_q_for_gain, steady_state_gain

ROOT = __import__("pathlib").Path(__file__).resolve().parents[2]


def _iterated_gain(q: float, r: float, epochs: int = 200_000) -> float:
    """The scalar Riccati recursion P- = P + q, K = P- / (P- + r), P = (1 - K) P-,
    iterated from P = r until it stops moving (the independent truth of the closed form)."""
    P, K = r, 0.0
    for _ in range(epochs):
        prior = P + q
        K_new = prior / (prior + r)
        P = (1.0 - K_new) * prior
        if abs(K_new - K) < 1e-15:
            break
        K = K_new
    return K_new


@pytest.mark.parametrize("q, r", [(1e-3, 1.25), (1e-6, 1.0), (0.5, 2.0), (10.0, 1.25), (1e-4, 0.09)])
def test_steady_state_gain_is_the_iterated_riccati_fixed_point(q, r):
    assert steady_state_gain(q, r) == pytest.approx(_iterated_gain(q, r), rel=1e-9)


@pytest.mark.parametrize("window, r", [(100, 1.25), (10, 1.0), (2, 4.0)])
def test_hatch_window_is_the_steady_state_gain_of_its_implied_random_walk(window, r):
    q = random_walk_q_for_gain(1.0 / window, r)
    assert q == pytest.approx(r / (window * (window - 1)), rel=1e-12)  # the closed form of the docstring
    assert _iterated_gain(q, r) == pytest.approx(1.0 / window, rel=1e-9)


def _white_noise_error(name: str, runs: int = 400, epochs: int = 800, sigma: float = 1.0, **params) -> np.ndarray:
    """Steady-state smoothed error of a plugin on a static range with white code noise and a
    noiseless carrier (the second half of the epochs)."""
    rng = np.random.default_rng(20261201)
    f = gf.registry.create("channel_filter", name, **params)
    f.reset((runs,), gf.RunContext(epoch_interval_s=1.0))
    errs = []
    for _ in range(epochs):
        noise = sigma * rng.standard_normal(runs)
        errs.append(f.step({"pseudorange_m": 2e7 + noise, "carrier_m": np.full(runs, 2e7 + 123.0)})["smoothed_m"] - 2e7)
    return np.array(errs[epochs // 2 :])


@pytest.mark.parametrize(
    "name, params",
    [("kf-smoother", {"q": 1e-3, "r": 1.25}), ("kf-smoother", {"q": 0.05, "r": 1.0}), ("hatch", {"window": 40})],
)
def test_declared_noise_equivalent_window_is_the_plugins_white_noise_variance_reduction(name, params):
    # A mean over N epochs of white noise of variance s2 has variance s2 / N: the declared
    # noise-equivalent window N (in epochs at dt = 1 s) must be what the plugin achieves.
    f = gf.registry.create("channel_filter", name, **params)
    declared = f.assumptions({"epoch_interval_s": 1.0})
    window = declared["noise-equivalent window"][0]
    err = _white_noise_error(name, **params)
    assert np.var(err) == pytest.approx(1.0 / window, rel=0.1)
    # The time constant is the decay of the response: one minus the gain per epoch, 1/K.
    assert declared["smoothing time constant"][0] == pytest.approx((window + 1) / 2, rel=1e-12)


def test_kalman_smoothers_steady_covariance_is_r_times_the_closed_form_gain():
    # The filter's own posterior variance settles at P = (1 - K) P- = K r.
    q, r = 1e-3, 1.25
    f = gf.registry.create("channel_filter", "kf-smoother", q=q, r=r)
    f.reset((1,), gf.RunContext(epoch_interval_s=1.0))
    for _ in range(2000):
        f.step({"pseudorange_m": np.zeros(1), "carrier_m": np.zeros(1)})
    assert float(f.state.cov[0, 0, 0]) == pytest.approx(steady_state_gain(q, r) * r, rel=1e-6)


def test_scenario_code_noise_variance_is_the_simulated_codes():
    scen = get_scenario({"kind": "carrier-smoothing", "slip_probability": 0.0})
    context = scen.assumption_context({"name": "x"})
    truth, code, carrier, _ = scen.simulate(400, np.random.default_rng(7))
    assert np.var(code - truth) == pytest.approx(context["code_noise_variance_m2"], rel=0.05)
    # No ionosphere: between slips, code minus carrier has no drift (its slope over the run
    # is zero within what the multipath leaves).
    cmc = (code - carrier) - (code - carrier).mean(axis=0)
    t = np.arange(len(cmc)) - (len(cmc) - 1) / 2
    slopes = (t @ cmc) / (t @ t)
    assert abs(slopes.mean()) < 4 * slopes.std() / np.sqrt(slopes.size)
    assert context["code_minus_carrier_drift_psd_m2_s"] == 0.0


def test_example_assumptions_rows():
    rows = {
        (r["case"], r["candidate"], r["label"]): r
        for r in assumption_rows(load_config(ROOT / "examples" / "carrier_smoothing.toml"))
    }
    assert {label for (_, _, label) in rows} <= set(ASSUMPTION_LABELS)
    for case in ("slips", "isolated-slips"):
        assert rows[(case, "hatch", "smoothing time constant")]["value"] == 100.0  # window 100 x 1 s
        assert rows[(case, "hatch", "noise-equivalent window")]["value"] == 199.0  # 2 tau - 1
        # R = 1.25 m^2 against 1 m^2 white + 0.25 m^2 multipath
        assert rows[(case, "kf", "pseudorange R / code noise variance")]["value"] == pytest.approx(1.0)
        assert rows[(case, "kf", "assumed code-minus-carrier drift PSD")]["value"] == pytest.approx(1e-3)
        assert rows[(case, "kf", "Q adapter")]["value"] == "none"
        assert rows[(case, "adaptive-kf", "Q adapter")]["value"].startswith("ml-q (window 10, warm-up 20")
        assert rows[(case, "kf-slip-reset", "slip reset threshold")]["value"] == 4.0
        assert rows[(case, "kf", "slip reset threshold")]["value"] == "none"
        assert (case, "raw", "Q adapter") not in rows  # raw code has no filter
