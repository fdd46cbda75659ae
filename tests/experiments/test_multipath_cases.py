"""Reference 004 (multipath): psi per case, raw and oracle rows, convergence_epoch."""

import numpy as np
import pytest

import gnssframework as gf
from gnssframework.experiments import get_scenario
from gnssframework.experiments.config import ComparisonConfig
from gnssframework.plugin_ref import PluginSpec
from gnssframework.experiments.scenarios.multipath import convergence_epoch
from gnssframework.random_streams import as_run_streams

BASE = {"nav_filter": {"name": "position-ca", "params": {}}, "estimator": {"name": "kf", "params": {}}}
BASE_REFS = {k: PluginSpec(k, v["name"], v["params"]) for k, v in BASE.items()}


def _run(components, case, runs=4, seed=2, epochs=120, options=None):
    scen = get_scenario({"kind": "multipath", "epochs": epochs})
    return scen.run_batch(case, scen.build(components, options), runs, np.random.default_rng(seed))


def test_convergence_epoch_against_a_hand_built_sequence():
    # err = 10 (k < 20), 3 (20 <= k < 40), 1 afterwards; window 10; second-half RMS 1, bound 2.
    # At k = 40 + j the window holds 9 - j threes and 1 + j ones: mean square (82 - 8j)/10 <= 4
    # first for j = 6, so the last epoch above the bound is 45 and the run converges at 46.
    # (A 5x bound would give 28: the tens leave the window at 20 + j with (659 - 91j)/10 <= 0.)
    err = np.concatenate([np.full(20, 10.0), np.full(20, 3.0), np.ones(60)])[:, None]
    assert convergence_epoch(err, 10)[0] == 46
    assert convergence_epoch(np.ones((50, 1)), 10)[0] == 0


def test_raw_candidate_reports_the_measurement_itself():
    scen = get_scenario({"kind": "multipath", "epochs": 120})
    zs = scen.simulate(4, as_run_streams(np.random.default_rng(2), 4), psi=0.8)  # run_batch's streams
    raw = _run({}, {"psi": 0.8}).metrics
    np.testing.assert_allclose(raw["lat_error_rmse"], np.sqrt(np.mean(zs[..., 0] ** 2, axis=0)))
    np.testing.assert_allclose(raw["horizontal_error_rmse"], np.sqrt(np.mean(np.sum(zs**2, axis=-1), axis=0)))


def test_colored_ar1_without_psi_takes_the_case_psi():
    auto = _run({**BASE, "augmentation": {"name": "colored-ar1", "params": {}}}, {"psi": 0.5}).metrics
    given = _run({**BASE, "augmentation": {"name": "colored-ar1", "params": {"psi": 0.5}}}, {"psi": 0.5}).metrics
    wrong = _run({**BASE, "augmentation": {"name": "colored-ar1", "params": {"psi": 0.9}}}, {"psi": 0.5}).metrics
    np.testing.assert_array_equal(auto["lat_error_rmse"], given["lat_error_rmse"])
    assert not np.allclose(auto["lat_error_rmse"], wrong["lat_error_rmse"])
    model = gf.registry.create("nav_filter", "position-ca").model()
    with pytest.raises(gf.ConfigError, match="colored-ar1'.psi"):
        gf.registry.create("augmentation", "colored-ar1").apply(model, np.zeros((5, 1)))


def test_oracle_with_a_one_point_grid_is_the_plain_filter_and_a_full_grid_beats_it():
    colored = {**BASE, "augmentation": {"name": "colored-ar1", "params": {}}}
    plain = _run(colored, {"psi": 0.5}).metrics["horizontal_error_rmse"]
    one = _run(colored, {"psi": 0.5}, options={"oracle": {"q_scales": [1.0], "r_scales": [1.0]}})
    np.testing.assert_array_equal(one.metrics["horizontal_error_rmse"], plain)  # same measurements, same filter
    full = _run(colored, {"psi": 0.5}, options={"oracle": {}}).metrics["horizontal_error_rmse"]
    assert np.mean(full) < 0.8 * np.mean(plain)


def test_the_oracle_is_a_scenario_option_checked_with_the_candidate():
    scen = get_scenario({"kind": "multipath", "epochs": 120})
    with pytest.raises(gf.ConfigError, match=r"^candidates\[2\]\.scenario_options\.oracle\.q_scales"):
        scen.check_candidate(BASE_REFS, "candidates[2]", {"oracle": {"q_scales": []}})
    with pytest.raises(gf.ConfigError, match=r"^candidates\[0\]\.scenario_options\.oracle: the oracle scores a filter"):
        scen.check_candidate({}, "candidates[0]", {"oracle": {}})
    with pytest.raises(gf.ConfigError, match=r"^candidates\[0\]\.scenario_options\.grid"):
        scen.check_candidate(BASE_REFS, "candidates[0]", {"grid": {}})
    other = get_scenario({"kind": "carrier-smoothing"})  # a scenario without options takes none
    with pytest.raises(gf.ConfigError, match=r"^candidates\[0\]\.scenario_options\.oracle"):
        other.candidate_options({"oracle": {}}, "candidates[0]")
    assert "oracle-grid" not in gf.registry.names("noise_adapter")  # not a plugin any more


def test_a_nav_filter_that_cannot_filter_a_sequence_is_refused_naming_the_ones_that_can():
    scen = get_scenario({"kind": "multipath", "epochs": 120})
    refs = {**BASE_REFS, "nav_filter": PluginSpec("nav_filter", "ekf-pv")}
    with pytest.raises(
        gf.ConfigError,
        match=r"candidates\[1\]\.nav_filter\.name: 'ekf-pv' cannot filter a "
        r"position sequence .*that can: position-ca",
    ):
        scen.check_candidate(refs, "candidates[1]")


def test_a_filtering_candidate_needs_both_nav_filter_and_estimator():
    with pytest.raises(gf.ConfigError, match=r"candidates\[0\]\.estimator"):
        ComparisonConfig.model_validate(
            {
                "scenario": {"kind": "multipath"},
                "cases": [{"name": "a"}],
                "candidates": [{"name": "x", "nav_filter": {"name": "position-ca"}}],
            }
        )


def test_the_papers_ukf_follows_the_measurements_with_slow_multipath():
    # Q0 = diag(1, 0.1, 0.01) against R0 = 1: steady position gain 0.77, so with slow
    # multipath the UKF's error is the raw measurement's (the paper's UKF row).
    ukf = {
        "nav_filter": {"name": "position-ca", "params": {}},
        "estimator": {"name": "ukf", "params": {"alpha": 0.01, "beta": 2.0, "kappa": 0.0}},
    }
    case = {"psi": 0.95}
    raw = _run({}, case, runs=10, epochs=300).metrics["horizontal_error_rmse"]
    filtered = _run(ukf, case, runs=10, epochs=300).metrics["horizontal_error_rmse"]
    assert np.mean(filtered) == pytest.approx(np.mean(raw), rel=0.01)
    # ... while the colored model does lower it (paired: same measurements).
    colored = _run(
        {**ukf, "augmentation": {"name": "colored-ar1", "params": {"cross_covariance": "paper"}}},
        case,
        runs=10,
        epochs=300,
    ).metrics["horizontal_error_rmse"]
    d = colored - filtered
    assert np.mean(d) < -3 * np.std(d, ddof=1) / np.sqrt(d.size)


UKF1 = {
    "nav_filter": {"name": "position-ca", "params": {}},
    "estimator": {"name": "ukf", "params": {"alpha": 0.01, "beta": 2.0, "kappa": 0.0}},
    "augmentation": {"name": "colored-ar1", "params": {"cross_covariance": "paper"}},
}


def _sage_husa(weight):
    return {
        "noise_adapter": {"name": "sage-husa", "params": {"variant": "improved", "alpha_r": weight, "alpha_q": weight}}
    }


@pytest.mark.parametrize("cross_covariance", ["paper", "exact"])
def test_aukf1_with_the_adapters_weight_at_0_is_ukf1_in_the_multipath_scenario(cross_covariance):
    # Issue 10's check, end to end as the example builds them: before the fix the adapter
    # replaced the decorrelated noise by the raw Q0 from step 1 on (2.262 m against 2.291 m).
    case = {"psi": 0.5}
    colored = {"name": "colored-ar1", "params": {"cross_covariance": cross_covariance}}
    ukf1 = _run({**UKF1, "augmentation": colored}, case, runs=4).metrics
    aukf1_0 = _run({**UKF1, "augmentation": colored, **_sage_husa(0.0)}, case, runs=4).metrics
    for name in ("lat_error_rmse", "lon_error_rmse", "horizontal_error_rmse"):
        np.testing.assert_array_equal(aukf1_0[name], ukf1[name])


def test_the_papers_adaptive_ukf1_is_worse_than_ukf1():
    # Reference 004's AUKF1 < UKF1 does not hold here: the one-sample Q estimates keep Q at
    # or above Q0 while a static receiver needs a smaller Q (docs/experiments/multipath.md).
    # Paired over the same runs, the difference is many standard errors above 0.
    case = {"psi": 0.5}
    ukf1 = _run(UKF1, case, runs=10, epochs=300).metrics["horizontal_error_rmse"]
    aukf1 = _run({**UKF1, **_sage_husa(0.5)}, case, runs=10, epochs=300).metrics["horizontal_error_rmse"]
    d = aukf1 - ukf1
    assert np.mean(d) > 4 * np.std(d, ddof=1) / np.sqrt(d.size)


def test_the_batched_oracle_grid_chooses_what_the_loop_over_pairs_chooses():
    scen = get_scenario({"kind": "multipath", "epochs": 150})
    colored = {**BASE, "augmentation": {"name": "colored-ar1", "params": {"psi": 0.8}}}
    grid = {"q_scales": [1e-6, 1e-2, 1.0], "r_scales": [0.3, 3.0, 30.0], "training_runs": 3}
    plugins = scen.build(colored, {"oracle": grid})
    streams = as_run_streams(7, 5)
    chosen = scen._oracle(plugins, 0.8, streams)
    train = scen.simulate(3, streams.shared("oracle-training"), 0.8)  # the same training draw
    plain = scen.build(colored)
    score = {
        (sq, sr): np.mean(scen._filter(plain, train, sq, sr)[0] ** 2)
        for sq in grid["q_scales"]
        for sr in grid["r_scales"]
    }
    assert chosen == min(score, key=score.get)
    assert chosen != (1.0, 0.3)  # the grid matters: not its corner


@pytest.mark.parametrize("q_scale, sign", [(1.0, +1), (1e-2, -1)])
def test_the_papers_form_beats_the_exact_form_only_while_q_is_far_above_the_truth(q_scale, sign):
    # docs/experiments/multipath.md: keeping the process/measurement cross covariance is
    # optimal only for the true process noise. With Q0 = diag(1, 0.1, 0.01) against a static
    # truth the exact form is worse (+0.22 m at psi = 0.5 in the example); with Q = 1e-2 Q0,
    # closer to the truth, it is better (-0.0012 m). Paired over the same runs, both signs are
    # several standard errors from 0.
    q0 = [q_scale * q for q in (1.0, 0.1, 0.01)]
    forms = {}
    for form in ("paper", "exact"):
        comps = {
            **UKF1,
            "nav_filter": {"name": "position-ca", "params": {"q0": q0, "r0": 1.0}},
            "augmentation": {"name": "colored-ar1", "params": {"cross_covariance": form}},
        }
        forms[form] = _run(comps, {"psi": 0.5}, runs=20, epochs=300).metrics["horizontal_error_rmse"]
    d = forms["exact"] - forms["paper"]
    assert sign * np.mean(d) > 4 * np.std(d, ddof=1) / np.sqrt(d.size)
