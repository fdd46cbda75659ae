"""Reference 001's fair tuning (issue 42): every smoother of examples/carrier_smoothing.toml
has its settings free in ``[tuning]``, the only untuned candidate is marked as given, and the
plain Kalman smoother's R is left out of the free set because only Q/R acts on it (checked
here against the plugin, together with the adaptive smoother, on which R does act)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import gnssframework as gf
from gnssframework.experiments import load_config
from gnssframework.experiments.claims import untuned_candidates
from gnssframework.experiments.tuning import resolve_free

ROOT = Path(__file__).resolve().parents[2]
CONFIG = load_config(ROOT / "examples" / "carrier_smoothing.toml")


def _params(cand) -> dict:
    cf = cand.channel_filter
    return {} if cf is None else dict(cf.params)


def test_every_setting_of_every_smoother_is_free():
    free = {
        cand: {label.split("params.", 1)[1] for _, _, label in params} for cand, params in resolve_free(CONFIG).items()
    }
    for cand in CONFIG.candidates:
        if cand.channel_filter is None:  # raw code: nothing to set
            assert cand.name not in free
            continue
        given = set(_params(cand))
        expected = given - {"r", "adapter", "adapter_params"}  # r: Q/R alone acts (test below)
        if "adapter" in given:  # an adaptive smoother: R acts, and so does the adapter's window
            expected |= {"r", "adapter_params.window"}
        assert free[cand.name] == expected, cand.name


def test_the_only_untuned_candidates_are_marked_as_given():
    untuned = untuned_candidates(CONFIG)
    assert untuned == ["raw"]
    assert all(c.as_given for c in CONFIG.candidates if c.name in untuned)
    # The tuning is on the metric the error claims are about, over both cases.
    assert CONFIG.tuning.metric == "error_rmse" and CONFIG.tuning.cases is None


def _smooth(params: dict, runs: int = 8, epochs: int = 150) -> np.ndarray:
    """A kf-smoother's output on a static range with white code noise and carrier slips of
    10-30 cycles (a 0.19 m wavelength), the same random numbers for every call."""
    rng = np.random.default_rng(20261202)
    f = gf.registry.create("channel_filter", "kf-smoother", **params)
    f.reset((runs,), gf.RunContext(epoch_interval_s=1.0))
    slips = np.cumsum(np.where(rng.random((epochs, runs)) < 0.02, rng.integers(10, 30, (epochs, runs)), 0), axis=0)
    out = []
    for k in range(epochs):
        out.append(f.step({"pseudorange_m": rng.standard_normal(runs), "carrier_m": 0.19 * slips[k]})["smoothed_m"])
    return np.array(out)


@pytest.mark.parametrize("threshold", [0.0, 3.0])
def test_plain_kalman_smoother_depends_on_q_over_r_alone(threshold):
    # Q, R and P0 = R scaled together leave every gain K = P-/(P- + R) unchanged, and the slip
    # test compares |code - prediction| (metres) with the threshold: the output is the same.
    base = _smooth({"q": 0.02, "r": 1.25, "slip_threshold_m": threshold})
    scaled = _smooth({"q": 0.02 * 7.0, "r": 1.25 * 7.0, "slip_threshold_m": threshold})
    np.testing.assert_allclose(scaled, base, rtol=0, atol=1e-9)
    # ... while Q/R itself matters (the tuned parameter).
    assert np.max(np.abs(_smooth({"q": 0.2, "r": 1.25, "slip_threshold_m": threshold}) - base)) > 0.05


def test_adaptive_smoother_depends_on_r_itself():
    # ml-q estimates Q from the state corrections K v, which do not scale with R, against P
    # terms that do: scaling Q0 and R together changes the output, so R is tuned for it.
    ml = {"adapter": "ml-q", "adapter_params": {"window": 5, "warmup": 5}}
    base = _smooth({"q": 0.02, "r": 1.25, **ml})
    scaled = _smooth({"q": 0.02 * 7.0, "r": 1.25 * 7.0, **ml})
    assert np.max(np.abs(scaled - base)) > 0.05
