"""[tuning]: every candidate tuned by the same procedure and budget on streams disjoint from
the evaluation's; resumable with identical results; bad specs refused at load (issue 22)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from gnssframework.errors import ConfigError
from gnssframework.experiments import load_config, run_comparison
from gnssframework.experiments import tuning as tuning_module
from gnssframework.experiments.runner import Task, plan, task_streams
from gnssframework.experiments.store import ResultStore
from gnssframework.experiments.tuning import resolve_free, trial_config

BASE = """
name = "tuned"
runs = 4
batch_size = 2
seed = 3
[executor]
workers = 1
[scenario]
kind = "multipath"
epochs = 120
psi = 0.9
[[cases]]
name = "only"
[[candidates]]
name = "kf"
nav_filter = {{ name = "position-ca" }}
estimator = {{ name = "kf" }}
[[candidates]]
name = "ar1"
nav_filter = {{ name = "position-ca" }}
estimator = {{ name = "kf" }}
augmentation = {{ name = "colored-ar1", params = {{ psi = 0.9 }} }}
[[candidates]]
name = "ar1-given"
nav_filter = {{ name = "position-ca", params = {{ r0 = 1.0 }} }}
estimator = {{ name = "kf" }}
augmentation = {{ name = "colored-ar1", params = {{ psi = 0.9 }} }}
[tuning]
trials = {trials}
runs = 3
sampler = "{sampler}"
metric = "horizontal_error_rmse"
[[tuning.free]]
path = "{path}"
low = 0.1
high = 100.0
scale = "log"
"""


def _config(tmp_path, sampler="grid", trials=4, path="candidates.*.nav_filter.params.r0", name="t.toml", text=None):
    file = tmp_path / name
    file.write_text(text or BASE.format(sampler=sampler, trials=trials, path=path))
    return load_config(file)


@pytest.mark.slow
def test_grid_tuning_picks_the_best_point_and_evaluates_it_on_the_evaluation_streams(tmp_path):
    config = _config(tmp_path)
    summary = json.loads(run_comparison(config, tmp_path / "out", progress=False).read_text())
    tuned = {t["candidate"]: t for t in summary["tuning"]}
    # '*' reached every candidate with r0, tuned independently; the same budget for both.
    assert set(tuned) == {"kf", "ar1", "ar1-given"}
    grid = [0.1, 1.0, 10.0, 100.0]  # 4 log-spaced points between 0.1 and 100
    for cand, t in tuned.items():
        assert t["trials"] == t["budget"] == 4 and t["failed_trials"] == 0
        # The tuned value is the grid point with the lowest objective, each point re-run by hand.
        store = ResultStore(tmp_path / "out" / "results.sqlite")
        scores = {}
        for r0 in grid:
            trial = trial_config(config, cand, [r0])
            v = store.values(trial.identity(), "only", cand, "horizontal_error_rmse", trial.runs)
            assert v.size == 3
            scores[r0] = float(np.mean(v))
        assert t["tuned"]["nav_filter.params.r0"] == pytest.approx(min(scores, key=scores.get))
        assert t["objective"] == pytest.approx(min(scores.values()))
    assert tuned["ar1-given"]["given"] == {"nav_filter.params.r0": 1.0}
    assert tuned["kf"]["given"] == {"nav_filter.params.r0": 1.0}  # position-ca's default
    # The evaluation: the tuned candidate at its value, the config's runs.
    rows = {(r["candidate"], r["metric"]): r for r in summary["rows"]}
    assert rows[("kf", "horizontal_error_rmse")]["runs"] == 4
    report = (tmp_path / "out" / "report.md").read_text()
    assert "## Tuning" in report and "| kf | `nav_filter.params.r0` | 1.0 |" in report
    assert (tmp_path / "out" / "tuning" / "kf.csv").read_text().count("\n") == 5
    assert (tmp_path / "out" / "plots" / "tuning-kf.png").stat().st_size > 1000


def test_tuning_streams_are_disjoint_from_the_evaluation_streams(tmp_path):
    config = _config(tmp_path)
    trial = trial_config(config, "kf", [1.0])
    assert trial.random_stream == "tuning" and trial.seed == config.seed
    for task in plan(config)[:2]:
        ev = task_streams(config, task).standard_normal((task.runs, 50))
        tu = task_streams(trial, task).standard_normal((task.runs, 50))
        assert not np.any(ev == tu)  # no run of the tuning shares a number with an evaluation run
    # The tuning streams of a run do not depend on its batch either.
    both = task_streams(trial, Task(0, 0, 0, 2)).standard_normal((2, 5))
    alone = task_streams(trial, Task(0, 0, 1, 1)).standard_normal((1, 5))
    assert np.array_equal(both[1:], alone)
    assert trial.identity() != config.identity()


@pytest.mark.slow
@pytest.mark.parametrize("sampler", ["tpe", "random"])
def test_an_interrupted_tuning_resumes_to_the_uninterrupted_result(tmp_path, monkeypatch, sampler):
    pytest.importorskip("optuna", reason="the 'tune' extra")  # installed by the test extra
    text = BASE.format(sampler=sampler, trials=6, path="candidates.ar1.nav_filter.params.r0")
    whole = json.loads(
        run_comparison(_config(tmp_path, text=text, name="w.toml"), tmp_path / "whole", progress=False).read_text()
    )
    real, calls = tuning_module._run_trial, []

    def interrupted(*args):
        if len(calls) == 4:
            raise KeyboardInterrupt  # the user's Ctrl-C in the fifth trial
        calls.append(1)
        return real(*args)

    monkeypatch.setattr(tuning_module, "_run_trial", interrupted)
    with pytest.raises(KeyboardInterrupt):
        run_comparison(_config(tmp_path, text=text, name="i.toml"), tmp_path / "cut", progress=False)
    monkeypatch.setattr(tuning_module, "_run_trial", real)
    resumed = json.loads(
        run_comparison(_config(tmp_path, text=text, name="i.toml"), tmp_path / "cut", progress=False).read_text()
    )
    assert resumed["tuning"] == whole["tuning"] and resumed["rows"] == whole["rows"]
    values = [v for v in whole["tuning"][0]["tuned"].values()]
    assert 0.1 <= values[0] <= 100.0


@pytest.mark.slow
def test_a_trial_that_fails_scores_inf_and_the_tuning_goes_on(tmp_path, monkeypatch):
    from gnssframework.errors import RunFailure

    config = _config(tmp_path, path="candidates.kf.nav_filter.params.r0")
    real = tuning_module._objective

    def objective(config, store, trial):
        if trial.candidates[0].nav_filter.params["r0"] > 50:
            raise RunFailure("candidate 'kf'", "ukf: covariance is not positive definite")
        return real(config, store, trial)

    monkeypatch.setattr(tuning_module, "_objective", objective)
    # _run_trial catches failures of the batches; here the failure comes later: wrap it too.
    real_run = tuning_module._run_trial

    def run(config, store, trial, execute):
        try:
            return real_run(config, store, trial, execute)
        except RunFailure:
            return math.inf

    monkeypatch.setattr(tuning_module, "_run_trial", run)
    summary = json.loads(run_comparison(config, tmp_path / "out", progress=False).read_text())
    (t,) = summary["tuning"]
    assert t["failed_trials"] == 1 and t["tuned"]["nav_filter.params.r0"] < 50


@pytest.mark.parametrize(
    "change, field, message",
    [
        (
            ("candidates.*.nav_filter.params.r0", "candidates.*.nav_filter.params.rr"),
            "tuning.free[0].path",
            "no candidate has this parameter",
        ),
        (
            ("candidates.*.nav_filter.params.r0", "candidates.kff.nav_filter.params.r0"),
            "tuning.free[0].path",
            "the second part must be a candidate",
        ),
        (
            ('low = 0.1\nhigh = 100.0\nscale = "log"', 'low = -5.0\nhigh = 100.0\nscale = "linear"'),
            "tuning.free",
            "candidate 'kf' at {'nav_filter.params.r0': -5.0}",
        ),
        (('metric = "horizontal_error_rmse"', 'metric = "rmse"'), "tuning.metric", "unknown metric 'rmse'"),
        (
            ('low = 0.1\nhigh = 100.0\nscale = "log"', "values = [1.0, 2.0, 3.0, 4.0, 5.0]"),
            "tuning.trials",
            "more than the budget of 4 trials",
        ),
    ],
)
def test_bad_tuning_specs_are_refused_at_load(tmp_path, change, field, message):
    text = BASE.format(sampler="grid", trials=4, path="candidates.*.nav_filter.params.r0").replace(*change)
    with pytest.raises(ConfigError) as err:
        _config(tmp_path, text=text)
    assert str(err.value).startswith(field) and message in str(err.value), str(err.value)


def test_resolve_free_expands_the_star_to_the_candidates_that_have_the_parameter(tmp_path):
    config = _config(tmp_path)
    assert sorted(resolve_free(config)) == ["ar1", "ar1-given", "kf"]


def test_a_list_parameter_is_tuned_one_element_at_a_time(tmp_path):
    text = """
runs = 2
batch_size = 2
[scenario]
kind = "vector-tracking"
duration_s = 0.5
settle_s = 0.1
channels = 5
[[cases]]
name = "c45"
cn0_dbhz = 45.0
[[candidates]]
name = "default-q"
channel_filter = { name = "iq-filter", params = { estimator = "ckf" } }
nav_filter = { name = "ekf-pv" }
[[candidates]]
name = "given-q"
channel_filter = { name = "iq-filter", params = { estimator = "ckf", q = [1.0, 2.0, 3.0, 4.0, 5.0] } }
nav_filter = { name = "ekf-pv" }
[tuning]
trials = 2
sampler = "grid"
metric = "velocity_error_rmse"
[[tuning.free]]
path = "candidates.*.channel_filter.params.q.4"
low = 0.001
high = 10.0
scale = "log"
"""
    config = _config(tmp_path, text=text)
    from gnssframework import registry

    default = list(registry.get("channel_filter", "iq-filter").Params.model_fields["q"].default)
    trial = trial_config(config, "default-q", [7.0])
    assert list(trial.candidates[0].channel_filter.params["q"]) == default[:4] + [7.0]
    trial = trial_config(config, "given-q", [7.0])
    assert list(trial.candidates[0].channel_filter.params["q"]) == [1.0, 2.0, 3.0, 4.0, 7.0]
    assert tuning_module._get(config, "given-q", resolve_free(config)["given-q"][0][1]) == 5.0
    assert tuning_module._get(config, "default-q", resolve_free(config)["default-q"][0][1]) == default[4]


def _two_cases(own: str) -> str:
    text = BASE.format(sampler="grid", trials=4, path="candidates.*.nav_filter.params.r0")
    return text.replace('[[cases]]\nname = "only"\n', '[[cases]]\nname = "only"\n[[cases]]\nname = "other"\n') + own


def test_candidate_cases_give_one_candidate_its_own_objective_cases(tmp_path):
    config = _config(tmp_path, text=_two_cases('[tuning.candidate_cases]\nkf = ["other"]\n'))
    # kf's trials run its own case only; the others the tuning's (every case), with the
    # same sampler, budget and runs.
    kf, ar1 = trial_config(config, "kf", [1.0]), trial_config(config, "ar1", [1.0])
    assert [c.name for c in kf.cases] == ["other"]
    assert [c.name for c in ar1.cases] == ["only", "other"]
    assert kf.runs == ar1.runs == 3
    from gnssframework.experiments.runner import work_estimate

    # work: 3 candidates x 2 cases x 4 runs, plus trials 4 x (1 + 2 + 2) cases x 3 runs
    assert work_estimate(config)[1] == 3 * 2 * 4 + 4 * 5 * 3


@pytest.mark.parametrize(
    "own, field, message",
    [
        ('[tuning.candidate_cases]\nkf = ["nowhere"]\n', "tuning.candidate_cases.kf[0]", "unknown case 'nowhere'"),
        ('[tuning.candidate_cases]\nghost = ["only"]\n', "tuning.candidate_cases.ghost", "not a tuned candidate"),
        ("[tuning.candidate_cases]\nkf = []\n", "tuning.candidate_cases.kf", "at least one case"),
    ],
)
def test_bad_candidate_cases_are_refused_at_load(tmp_path, own, field, message):
    with pytest.raises(ConfigError) as err:
        _config(tmp_path, text=_two_cases(own))
    assert str(err.value).startswith(field) and message in str(err.value), str(err.value)


# -- a stated composite objective (issue 42: tune on the metrics the claims use) -----------------

_COMPOSITE = 'metric = ["lat_error_rmse", "lon_error_rmse"]'


def test_a_composite_objective_is_the_geometric_mean_over_its_metrics_and_cases(tmp_path):
    text = _two_cases("").replace('metric = "horizontal_error_rmse"', _COMPOSITE)
    config = _config(tmp_path, text=text)
    assert config.tuning.metrics == ["lat_error_rmse", "lon_error_rmse"]
    trial = trial_config(config, "kf", [1.0])
    assert sorted(trial.metrics) == ["lat_error_rmse", "lon_error_rmse"]  # the trial records both
    run_comparison(trial, tmp_path / "trial", progress=False)
    store = ResultStore(tmp_path / "trial" / "results.sqlite")
    means = [
        float(np.mean(store.values(trial.identity(), case, "kf", metric, trial.runs)))
        for metric in ("lat_error_rmse", "lon_error_rmse")
        for case in ("only", "other")
    ]
    by_hand = math.exp(sum(math.log(m) for m in means) / len(means))
    assert tuning_module._objective(config, store, trial) == pytest.approx(by_hand, rel=1e-12)
    # ... and differs from either metric alone (both enter it)
    alone = [math.exp((math.log(means[2 * k]) + math.log(means[2 * k + 1])) / 2) for k in (0, 1)]
    assert all(abs(by_hand / a - 1) > 1e-6 for a in alone)


def test_a_composite_objective_names_its_unknown_metric(tmp_path):
    text = BASE.format(sampler="grid", trials=4, path="candidates.*.nav_filter.params.r0").replace(
        'metric = "horizontal_error_rmse"', 'metric = ["lat_error_rmse", "no_such_metric"]'
    )
    with pytest.raises(ConfigError) as err:
        _config(tmp_path, text=text)
    assert str(err.value).startswith("tuning.metric[1]") and "no_such_metric" in str(err.value)


def test_a_composite_tuning_reports_and_plots_its_objective(tmp_path):
    text = BASE.format(sampler="grid", trials=2, path="candidates.kf.nav_filter.params.r0").replace(
        'metric = "horizontal_error_rmse"', _COMPOSITE
    )
    summary = json.loads(run_comparison(_config(tmp_path, text=text), tmp_path / "out", progress=False).read_text())
    (kf,) = summary["tuning"]
    assert kf["candidate"] == "kf" and kf["trials"] == 2
    assert (tmp_path / "out" / "plots" / "tuning-kf.png").stat().st_size > 0
