"""A comparison resolved once: the workers get a picklable plan and never re-validate the
config or build another candidate than their task's."""

from __future__ import annotations

import pytest
import pickle

import numpy as np

from gnssframework.experiments import load_config, run_comparison
from gnssframework.experiments.config import ComparisonConfig
from gnssframework.experiments.run_plan import resolve
from gnssframework.experiments.runner import run_task
from gnssframework.experiments.scenarios.multipath import MultipathScenario
from gnssframework.experiments.tasks import plan

CONFIG = """
name = "plan"
runs = 4
batch_size = 2
seed = 3
[executor]
workers = 1
[scenario]
kind = "multipath"
epochs = 60
[[cases]]
name = "a"
psi = 0.5
[[cases]]
name = "b"
psi = 0.9
[[candidates]]
name = "raw"
[[candidates]]
name = "kf"
nav_filter = "position-ca"
estimator = "kf"
[[candidates]]
name = "oracle"
nav_filter = "position-ca"
estimator = "kf"
scenario_options = { oracle = { q_scales = [1e-4, 1.0], r_scales = [1.0], training_runs = 2 } }
"""


def _config(tmp_path) -> ComparisonConfig:
    path = tmp_path / "plan.toml"
    path.write_text(CONFIG)
    return load_config(path)


def test_the_plan_is_the_config_resolved_and_a_pickled_plan_gives_the_same_numbers(tmp_path):
    config = _config(tmp_path)
    resolved = resolve(config)
    assert resolved.scenario is config.resolved_scenario  # validated once, the same instance
    assert [c.name for c in resolved.candidates] == ["raw", "kf", "oracle"]
    assert resolved.candidates[2].scenario_options["oracle"]["training_runs"] == 2
    assert resolved.cases[1].as_case() == {"name": "b", **config.cases[1].params()}
    copy = pickle.loads(pickle.dumps(resolved))
    for task in plan(config):
        a, b = run_task(resolved, task), run_task(copy, task)
        assert a[0] == b[0] and a[1].keys() == b[1].keys()
        for metric in a[1]:
            np.testing.assert_array_equal(a[1][metric], b[1][metric])


@pytest.mark.slow
def test_a_run_validates_the_config_once_and_builds_only_each_task_s_candidate(tmp_path, monkeypatch):
    config = _config(tmp_path)
    validations, built = [], []
    real_validate, real_build = ComparisonConfig.model_validate, MultipathScenario.build
    monkeypatch.setattr(
        ComparisonConfig,
        "model_validate",
        classmethod(lambda cls, *a, **k: validations.append(1) or real_validate.__func__(cls, *a, **k)),
    )
    monkeypatch.setattr(
        MultipathScenario,
        "build",
        lambda self, cand, options=None: built.append(sorted(cand)) or real_build(self, cand, options),
    )
    run_comparison(config, tmp_path / "out", progress=False)
    assert validations == []  # the workers got the plan, not the config to validate again
    tasks = len(plan(config))
    assert tasks == 2 * 3 * 2
    # One build per task (its own candidate), plus one per case and candidate for the
    # report's assumptions table; before, every task validated every candidate again.
    assert len(built) == tasks + 2 * 3


def test_a_candidate_is_resolved_once_at_load_into_specs_the_plan_carries(tmp_path, monkeypatch):
    import gnssframework.experiments.config as config_module
    from gnssframework.plugin_ref import PluginSpec

    calls = []
    real = config_module.resolve_candidate
    monkeypatch.setattr(config_module, "resolve_candidate", lambda *a, **k: calls.append(a[1].name) or real(*a, **k))
    config = _config(tmp_path)
    assert calls == ["raw", "kf", "oracle"]  # each candidate once, when the config is loaded
    resolved = resolve(config)
    assert resolved.candidates is config.resolved_candidates  # the plan takes them as they are
    kf = resolved.candidates[1]
    assert kf.components == {
        "nav_filter": PluginSpec("nav_filter", "position-ca"),
        "estimator": PluginSpec("estimator", "kf"),
    }
    plugins = resolved.build(1)
    assert {k: p.name for k, p in plugins.items()} == {"nav_filter": "position-ca", "estimator": "kf"}
    assert resolved.build(1)["estimator"] is not plugins["estimator"]  # fresh plugins for every batch
    assert calls == ["raw", "kf", "oracle"]


def test_a_sweep_point_and_a_tuning_trial_resolve_their_candidates_the_same_way(tmp_path):
    from gnssframework.experiments.tuning import trial_config

    path = tmp_path / "sweep.toml"
    path.write_text(
        CONFIG + '[[sweeps]]\npath = "candidates.kf.nav_filter.params.r0"\nvalues = [0.5, 2.0]\n'
        '[tuning]\ntrials = 2\nsampler = "grid"\nmetric = "lat_error_rmse"\n'
        '[[tuning.free]]\npath = "candidates.kf.nav_filter.params.r0"\nvalues = [0.25, 1.0]\n'
    )
    config = load_config(path)
    [(value, point)] = config.sweep_points(0)[1:]
    assert value == 2.0
    assert point.resolved_candidates[1].components["nav_filter"].params == {"r0": 2.0}
    trial = trial_config(config, "kf", [0.25])
    [cand] = trial.resolved_candidates
    assert cand.name == "kf" and cand.components["nav_filter"].params == {"r0": 0.25}
    assert resolve(trial).candidates == trial.resolved_candidates
